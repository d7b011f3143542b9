// The side panel's plots (uPlot, a global of vendor/uplot/uPlot.iife.min.js): tool and hand
// penetration, feedback force, step time. Replay: the whole recording, from the session
// message's series (read from every frame of the file, decimated as docs/viewer.md "Replay"
// says), with a cursor line at the frame shown; a click on a plot shows that frame. Live: the
// page's buffer of received frames (live.js), the same way.

const plotData = { t: [], tool: [], hand: [], intent: [], force: [], step: [] };
let cursorT = null, onPick = null;

/// Tick labels without thousands separators (uPlot's default writes 2,000: clipped to ",000").
const tick = (u, vals) => vals.map((v) => (v === null ? '' : String(+v.toPrecision(6))));
/// A y range that shows all-zero or constant data around its value, not 0–100.
function yRange(u, min, max) {
  if (min === null || max === null) return [0, 1];
  if (max - min < 1e-9) return [min - (Math.abs(min) * 0.1 || 1), max + (Math.abs(max) * 0.1 || 1)];
  const pad = 0.05 * (max - min);
  return [min - pad, max + pad];
}

/// A line at the frame shown (drawn after the series).
const cursorLine = {
  hooks: {
    draw: (u) => {
      if (cursorT === null) return;
      const x = u.valToPos(cursorT, 'x', true);
      const ctx = u.ctx;
      ctx.save();
      ctx.strokeStyle = '#d02020';
      ctx.lineWidth = 2;
      ctx.beginPath();
      ctx.moveTo(x, u.bbox.top);
      ctx.lineTo(x, u.bbox.top + u.bbox.height);
      ctx.stroke();
      ctx.restore();
    },
  },
};

function makePlot(el, title, series) {
  const u = new uPlot({ title, width: 318, height: 130, legend: { show: true },
                        scales: { x: { time: false }, y: { range: yRange } },
                        axes: [{ size: 30, values: tick }, { size: 56, values: tick }],
                        plugins: [cursorLine],
                        series: [{ label: 't (s)' }, ...series.map((s) => ({ ...s, points: { show: false } }))] },
                      [[], ...series.map(() => [])], document.getElementById(el));
  // A click shows the frame nearest the time clicked.
  u.over.addEventListener('click', () => {
    const i = u.cursor.idx;
    if (onPick && i !== null && i !== undefined) onPick(i);
  });
  return u;
}
const plots = {
  // hand: the target (the encoders' pose: the handle in a closed loop); intent: where the hand
  // pulls it (the recorded pose; the target's in replay).
  pen: makePlot('plot-pen', 'penetration (mm)', [{ label: 'tool', stroke: '#ff8800' }, { label: 'hand', stroke: '#00a0d0' },
                                                 { label: 'intent', stroke: '#7a7a7a', dash: [4, 3] }]),
  force: makePlot('plot-force', 'feedback force |F| (N)', [{ label: '|F|', stroke: '#c0a000' }]),
  step: makePlot('plot-step', 'step time (µs)', [{ label: 'step', stroke: '#6060c0' }]),
};

/// Replay: plots `series` (the session message's) once; pick(frame) is called with the frame
/// of a point clicked.
export function plotSeries(series, pick) {
  if (!series) return;
  plotData.t = series.t; plotData.tool = series.tool_mm; plotData.hand = series.hand_mm;
  plotData.intent = series.intent_mm;
  plotData.force = series.force_n; plotData.step = series.step_us;
  onPick = (i) => pick(series.frame[i]);
  redraw();
}

/// Live: plots the buffer's frames (arrays by name, as plotData), newest last; pick(i) is
/// called with the buffer index of a point clicked.
export function plotBuffer(data, pick) {
  Object.assign(plotData, data);
  onPick = pick;
  dirty = true;
}

/// Moves the cursor line to simulated time t (s) (drawn at the next redraw, at most 5 per second).
export function plotCursor(t) {
  if (t !== cursorT) dirtyCursor = true;
  cursorT = t;
}

/// Points in the penetration plot (the tests compare it with the recording's frames).
export function plotPoints() { return plots.pen.data[0].length; }

let dirty = false, dirtyCursor = false;
function redraw() {
  plots.pen.setData([plotData.t, plotData.tool, plotData.hand, plotData.intent]);
  plots.force.setData([plotData.t, plotData.force]);
  plots.step.setData([plotData.t, plotData.step]);
}
setInterval(() => {
  if (dirty) redraw();
  else if (dirtyCursor) for (const u of Object.values(plots)) u.redraw(false, false);
  dirty = dirtyCursor = false;
}, 200);
