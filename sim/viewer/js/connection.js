// The connection to the server (docs/viewer.md "Server", "Page"): the WebSocket on /stream and
// its messages (scene, session, frames) handed to the page; reconnection with a backoff shown
// on the page when the server goes away.
import { S, errors, fail, updateCounters } from './panel.js';
import { decodeFrame } from './protocol.js';

/// Reconnection delays (s): 0.25, 0.5, 1, 2, then every 2 s (the page resumes within 2 s of
/// the server's return, plus the time to connect).
const BACKOFF_S = [0.25, 0.5, 1, 2];
/// The connection's state, shown in #connection and read by the tests.
export const link = { state: 'connecting', attempts: 0, reconnects: 0, openedAt: 0, sceneText: null };
const connEl = document.getElementById('connection');
let ws = null, on = null, retryTimer = 0, countdown = 0;

function showLink(text, cls) {
  connEl.textContent = text;
  connEl.className = cls;
}

/// Sends a JSON message when connected (a message on a closed socket is never attempted).
export function send(obj) {
  if (ws && ws.readyState === WebSocket.OPEN) { ws.send(JSON.stringify(obj)); return true; }
  return false;
}

function open() {
  link.state = link.reconnects || link.attempts ? 'reconnecting' : 'connecting';
  ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/stream');
  ws.binaryType = 'arraybuffer';
  ws.onopen = () => {
    if (link.attempts > 0) link.reconnects++;
    link.attempts = 0;
    link.state = 'open';
    link.openedAt = performance.now();
    showLink('connected to ' + location.host, 'ok');
  };
  ws.onmessage = (ev) => {
    try {
      if (typeof ev.data === 'string') {
        const m = JSON.parse(ev.data);
        if (m.type === 'session') { on.session(m); updateCounters(); return; }
        if (S.scene) {  // a reconnection: the same scene goes on, another reloads the page
          if (ev.data !== link.sceneText) location.reload();
          return;
        }
        link.sceneText = ev.data;
        on.scene(m);
        return;
      }
      S.framesReceived++;
      let fr;
      try { fr = decodeFrame(ev.data); } catch (e) { S.badFrames++; errors.push(String(e)); return; }
      on.frame(fr);
    } catch (e) {
      fail('viewer error: ' + e.message);
    }
  };
  ws.onclose = () => {
    const was = link.state;
    link.state = 'closed';
    window.numenView.closed = true;
    const delay = BACKOFF_S[Math.min(link.attempts, BACKOFF_S.length - 1)];
    link.attempts++;
    const why = was === 'open' ? 'connection to the server lost' : 'no server at ' + location.host;
    let left = delay;
    const tickDown = () => {
      showLink(`${why}: reconnecting in ${left.toFixed(1)} s (attempt ${link.attempts})`, 'lost');
      left = Math.max(0, left - 0.25);
    };
    tickDown();
    clearInterval(countdown);
    countdown = setInterval(tickDown, 250);
    clearTimeout(retryTimer);
    retryTimer = setTimeout(() => { clearInterval(countdown); open(); }, delay * 1000);
  };
  ws.onerror = () => { /* onclose follows and says it */ };
}

/// Connects; on.scene(msg) builds the scene (once), on.session(msg) adopts the session (on
/// every connection), on.frame(fr) shows a decoded frame.
export function connect(handlers) {
  on = handlers;
  if (location.protocol === 'file:') return;  // index.html says how to serve the page
  open();
}
