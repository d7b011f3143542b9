// Replay (docs/viewer.md "Replay"): the page paces, the server answers {"frame": I} requests.
// The slider, the step buttons, the plots and the timeline's marks all ask for a frame; one
// request is in flight at a time (re-sent after 1 s if lost).
import { S, fail } from './panel.js';
import { send } from './connection.js';

/// The replay's state: the frame shown, playing or not, the playback clock (s).
export const replay = { index: 0, playing: false, speed: 1, clock: 0, pending: -1, sentAt: 0, ready: false };
const listeners = [];

/// Calls fn(index) whenever the frame shown changes (the plots' cursor follows it).
export function onIndex(fn) { listeners.push(fn); }

/// Asks for frame i (clamped to the recording).
export function request(i) {
  i = Math.max(0, Math.min(S.session.frames - 1, i));
  replay.pending = i;
  replay.sentAt = performance.now();
  send({ frame: i });
}

const play = document.getElementById('play');
function setPlaying(p) { replay.playing = p; play.textContent = p ? '❚❚' : '▶'; }

/// Seeks to frame i and pauses (the slider, a plot click, a timeline mark).
export function seek(i) { setPlaying(false); request(i); }

/// Sets the controls up for the session (once); `fixedFrame`: show that frame paused.
export function setupReplay(fixedFrame) {
  const session = S.session;
  if (replay.ready) { request(replay.index); return; }  // a reconnection: the same frame again
  replay.ready = true;
  document.getElementById('replay').hidden = false;
  const slider = document.getElementById('slider');
  slider.max = String(Math.max(0, session.frames - 1));
  play.onclick = () => {
    if (!replay.playing && replay.index >= session.frames - 1) replay.index = 0;
    replay.clock = session.time_s[replay.index] ?? 0;
    setPlaying(!replay.playing);
  };
  document.getElementById('back').onclick = () => seek(replay.index - 1);
  document.getElementById('fwd').onclick = () => seek(replay.index + 1);
  document.getElementById('speed').onchange = (e) => { replay.speed = Number(e.target.value); };
  slider.oninput = () => seek(Number(slider.value));
  if (session.frames === 0) { fail('the recording has no frame'); return; }
  request(fixedFrame ?? 0);
  setPlaying(fixedFrame === null);
  let prev = performance.now();
  const tick = (now) => {
    const dt = (now - prev) * 1e-3;
    prev = now;
    if (replay.pending >= 0 && now - replay.sentAt > 1000) request(replay.pending);  // lost
    if (replay.playing && replay.pending < 0) {
      replay.clock += dt * replay.speed;
      let i = replay.index;
      while (i + 1 < session.frames && session.time_s[i + 1] <= replay.clock) ++i;
      if (i !== replay.index) request(i);
      else if (i >= session.frames - 1) setPlaying(false);
    }
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
}

/// A replayed frame arrived: it is the one asked for.
export function replayed(fr) {
  replay.index = replay.pending >= 0 ? replay.pending : replay.index;
  replay.pending = -1;
  document.getElementById('slider').value = String(replay.index);
  document.getElementById('clock').textContent =
    `${fr.time_s.toFixed(3)} / ${(S.session.time_s[S.session.frames - 1] ?? 0).toFixed(3)} s`;
  for (const fn of listeners) fn(replay.index);
}
