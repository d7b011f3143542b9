// The connection to the server (docs/viewer.md "Server", "Replay"): the WebSocket on /stream,
// its messages (scene, session, frames) handed to `on`, and replay's paced frame requests.
import { S, errors, fail, statusEl, updateCounters } from './panel.js';
import { decodeFrame } from './protocol.js';

const replay = { index: 0, playing: false, speed: 1, clock: 0, pending: -1, sentAt: 0 };
let ws = null;

function request(i) {
  i = Math.max(0, Math.min(S.session.frames - 1, i));
  replay.pending = i;
  replay.sentAt = performance.now();
  ws.send(JSON.stringify({ frame: i }));
}

function setupReplay(fixedFrame) {
  const session = S.session;
  document.getElementById('replay').hidden = false;
  const slider = document.getElementById('slider');
  slider.max = String(Math.max(0, session.frames - 1));
  const play = document.getElementById('play');
  const setPlaying = (p) => { replay.playing = p; play.textContent = p ? '❚❚' : '▶'; };
  play.onclick = () => {
    if (!replay.playing && replay.index >= session.frames - 1) replay.index = 0;
    replay.clock = session.time_s[replay.index] ?? 0;
    setPlaying(!replay.playing);
  };
  document.getElementById('back').onclick = () => { setPlaying(false); request(replay.index - 1); };
  document.getElementById('fwd').onclick = () => { setPlaying(false); request(replay.index + 1); };
  document.getElementById('speed').onchange = (e) => { replay.speed = Number(e.target.value); };
  slider.oninput = () => { setPlaying(false); request(Number(slider.value)); };
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

/// Connects; on.scene(msg) builds the scene, on.frame(fr) shows a frame. `fixedFrame`: replay
/// shows that frame paused (?frame=I), null: plays from the start.
export function connect(on, fixedFrame) {
  ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/stream');
  ws.binaryType = 'arraybuffer';
  ws.onmessage = (ev) => {
    try {
      if (typeof ev.data === 'string') {
        const m = JSON.parse(ev.data);
        if (!S.scene) on.scene(m);
        else if (m.type === 'session') {
          on.session(m);
          if (m.mode === 'replay') setupReplay(fixedFrame);
          statusEl.textContent = m.mode === 'live' ? 'live: waiting for frames…' : 'replay';
          updateCounters();
        }
        return;
      }
      S.framesReceived++;
      let fr;
      try { fr = decodeFrame(ev.data); } catch (e) { S.badFrames++; errors.push(String(e)); return; }
      if (S.session && S.session.mode === 'replay') {
        replay.index = replay.pending >= 0 ? replay.pending : replay.index;
        replay.pending = -1;
        document.getElementById('slider').value = String(replay.index);
        document.getElementById('clock').textContent =
          `${fr.time_s.toFixed(3)} / ${(S.session.time_s[S.session.frames - 1] ?? 0).toFixed(3)} s`;
      }
      on.frame(fr);
    } catch (e) {
      fail('viewer error: ' + e.message);
    }
  };
  ws.onclose = () => {
    if (!errors.length) { statusEl.textContent += '\n(connection closed)'; }
    window.numenView.closed = true;
  };
  ws.onerror = () => fail('WebSocket error (is the server running?)');
}
