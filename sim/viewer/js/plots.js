// The side panel's plots (uPlot, a global of vendor/uplot/uPlot.iife.min.js): tool and hand
// penetration, feedback force, step time over a rolling window of 10 s of simulated time.

const WINDOW_S = 10;
const plotData = { t: [], tool: [], hand: [], force: [], step: [] };
function makePlot(el, title, series) {
  return new uPlot({ title, width: 318, height: 130, legend: { show: true },
                     scales: { x: { time: false } }, axes: [{ size: 30 }, { size: 44 }],
                     series: [{ label: 't (s)' }, ...series] },
                   [[], ...series.map(() => [])], document.getElementById(el));
}
const plots = {
  pen: makePlot('plot-pen', 'penetration (mm)', [{ label: 'tool', stroke: '#ff8800' }, { label: 'hand', stroke: '#00a0d0' }]),
  force: makePlot('plot-force', 'feedback force |F| (N)', [{ label: '|F|', stroke: '#c0a000' }]),
  step: makePlot('plot-step', 'step time (µs)', [{ label: 'step', stroke: '#6060c0' }]),
};
let plotDirty = false;

/// Adds frame fr (|F| = fmag, N) to the plots.
export function plotAdd(fr, fmag) {
  const d = plotData, t = fr.time_s;
  if (d.t.length && t < d.t[d.t.length - 1]) for (const k in d) d[k].length = 0;  // a seek back
  d.t.push(t); d.tool.push(1e3 * fr.penetration[0]); d.hand.push(1e3 * fr.penetration[1]);
  d.force.push(fmag); d.step.push(fr.h.step_ns * 1e-3);
  while (d.t.length && d.t[0] < t - WINDOW_S) for (const k in d) d[k].shift();
  plotDirty = true;
}
setInterval(() => {
  if (!plotDirty) return;
  plotDirty = false;
  plots.pen.setData([plotData.t, plotData.tool, plotData.hand]);
  plots.force.setData([plotData.t, plotData.force]);
  plots.step.setData([plotData.t, plotData.step]);
}, 100);
