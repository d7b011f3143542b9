// A live run in the view (docs/viewer.md "Page"): every frame received is kept in a buffer of
// the last LIVE_BUFFER_FRAMES; the view shows the newest, or — paused — any frame of the buffer
// (slider, step buttons, a click on a plot), while numen keeps running and frames keep arriving.
import { S } from './panel.js';

/// Frames kept: 2 minutes at 60 Hz, and at most LIVE_BUFFER_BYTES of frames.
export const LIVE_BUFFER_FRAMES = 7200;
export const LIVE_BUFFER_BYTES = 64e6;
/// The buffer (oldest first) and the view's state: paused, the frame shown when paused.
export const live = { frames: [], paused: false, shown: null };
let show = null;
const slider = document.getElementById('slider'), play = document.getElementById('play');
const cols = { t: [], tool: [], hand: [], intent: [], force: [], step: [] };

function setPaused(p) {
  live.paused = p;
  play.textContent = p ? '▶' : '❚❚';
  play.title = p ? 'Back to live' : 'Pause the view (numen keeps running)';
  if (!p && live.frames.length) showAt(live.frames.length - 1);
}

function showAt(i) {
  i = Math.max(0, Math.min(live.frames.length - 1, i));
  live.shown = live.frames[i];
  slider.value = String(i);
  show(live.shown);
  clock();
}

function clock() {
  const n = live.frames.length;
  if (!n) return;
  const t0 = live.frames[0].time_s, t1 = live.frames[n - 1].time_s;
  document.getElementById('clock').textContent = live.paused
    ? `paused at ${live.shown.time_s.toFixed(3)} s (buffer ${t0.toFixed(1)}–${t1.toFixed(1)} s)`
    : `live ${t1.toFixed(3)} s`;
}

/// Sets the controls up for a live session (once). `showFrame(fr)` draws a frame.
export function setupLive(showFrame) {
  if (show) return;
  show = showFrame;
  document.getElementById('replay').hidden = false;
  document.getElementById('speed').hidden = true;
  setPaused(false);
  play.onclick = () => setPaused(!live.paused);
  const index = () => live.frames.indexOf(live.shown);
  document.getElementById('back').onclick = () => { setPaused(true); showAt(index() - 1); };
  document.getElementById('fwd').onclick = () => { setPaused(true); showAt(index() + 1); };
  slider.oninput = () => { setPaused(true); showAt(Number(slider.value)); };
}

/// Empties the buffer (a new live session: another run's periods start again at 0).
export function liveReset() {
  live.frames.length = 0;
  live.shown = null;
  for (const k in cols) cols[k].length = 0;
  setPaused(false);
}

/// Pauses the view on buffer frame i (a plot click).
export function pauseAt(i) { setPaused(true); showAt(i); }

/// A live frame arrived: buffered, and shown unless paused. Returns the plot columns of the
/// buffer.
export function liveFrame(fr) {
  const fmag = Math.hypot(fr.feedback[0], fr.feedback[1], fr.feedback[2]);
  const n = live.frames.length;
  if (n && fr.h.period <= live.frames[n - 1].h.period) S.gaps++;
  live.frames.push(fr);
  cols.t.push(fr.time_s); cols.tool.push(1e3 * fr.penetration[0]); cols.hand.push(1e3 * fr.penetration[1]);
  cols.intent.push(1e3 * fr.device_loop[0]);
  cols.force.push(fmag); cols.step.push(fr.h.step_ns * 1e-3);
  if (live.frames.length > Math.min(LIVE_BUFFER_FRAMES, Math.max(60, Math.floor(LIVE_BUFFER_BYTES / fr.h.frame_bytes)))) {
    live.frames.shift();
    for (const k in cols) cols[k].shift();
  }
  slider.max = String(live.frames.length - 1);
  if (!live.paused) showAt(live.frames.length - 1);
  else { slider.value = String(live.frames.indexOf(live.shown)); clock(); }
  return cols;
}
