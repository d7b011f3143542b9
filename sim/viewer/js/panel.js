// The side panel's text (status, counters), the page's error list and the hidden #probe a test
// reads (docs/viewer.md "Page").

/// Every error the page saw (JavaScript errors, refused frames, failures it shows).
export const errors = [];
window.addEventListener('error', (e) => errors.push(String(e.message || e)));
window.addEventListener('unhandledrejection', (e) => errors.push('unhandled: ' + String(e.reason)));

/// What the page counts and shows (one object shared by the modules).
export const S = {
  scene: null,    // the scene message
  session: null,  // the session message
  last: null,     // the frame shown
  framesShown: 0, framesReceived: 0, badFrames: 0, gaps: 0, lastPeriod: -1,
};

export const statusEl = document.getElementById('status');

/// Shows `text` as the page's error (and records it).
export function fail(text) {
  errors.push(text);
  statusEl.textContent = text;
  statusEl.className = 'error';
  writeProbe();
}

/// Writes window.numenView.probe() (or the errors alone) into #probe as JSON.
export function writeProbe() {
  const probe = document.getElementById('probe');
  probe.textContent = JSON.stringify(window.numenView ? window.numenView.probe() : { errors });
}

/// Sets the status text (not an error).
export function setStatus(text) {
  statusEl.className = '';
  statusEl.textContent = text;
}

/// Rewrites the frame counters.
export function updateCounters() {
  document.getElementById('counters').textContent =
    `mode: ${S.session ? S.session.mode : '…'}\nframes received: ${S.framesReceived}   shown: ${S.framesShown}\n` +
    `bad frames: ${S.badFrames}   out of order: ${S.gaps}`;
}
