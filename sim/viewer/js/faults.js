// Faults and safe states (docs/viewer.md "Page"): a banner over the view with what the frame
// says caused them, and marks on the replay timeline at every change of the device's lifecycle
// or the step's status (the replay session message's series.events, read from the whole file).
import { LIFECYCLE, STARTUP, STEP, FLAGS, FAULT_CAUSES, bits, extraDevices } from './protocol.js';

const banner = document.getElementById('banner');
let since = null;  // { t, period } of the first frame of the fault shown
let events = [];   // the replay's series.events (empty live)

/// The fault or safe state of a frame header as { level: 'fault' | 'safe' | 'step', text }, or
/// null when it has none. Its cause: what the frame carries (the safety supervisor's cause of
/// the latched safe state, the step's status bits, a failed start-up, the flags).
export function faultOf(h, managed) {
  const causes = [];
  if (h.fault_cause) causes.push(FAULT_CAUSES[h.fault_cause] ?? 'cause ' + h.fault_cause);
  if (h.step_status) causes.push('step: ' + bits(h.step_status, STEP));
  if (managed && h.startup === 5) causes.push('start-up: ' + STARTUP[5]);
  if (h.flags & (1 << 2)) causes.push('overrun');
  if (!(h.flags & 1)) causes.push('no valid sample');
  if (h.flags & (1 << 4)) causes.push(bits(h.flags & (1 << 4), FLAGS));
  if (h.lifecycle === 4 || h.lifecycle === 3) {
    return { level: h.lifecycle === 4 ? 'fault' : 'safe',
             text: (h.lifecycle === 4 ? 'FAULT' : 'SAFE STOP') + ': device lifecycle "' + LIFECYCLE[h.lifecycle] + '"' +
                   (causes.length ? ' — ' + causes.join('; ') : '') };
  }
  if (h.step_status) return { level: 'step', text: 'STEP STATUS: ' + bits(h.step_status, STEP) };
  return null;
}

/// The loop's other devices in a safe state in frame fr, as one line ('' when none);
/// `deviceName(i)` names device i.
function extraFaults(fr, deviceName) {
  if (!fr.extra_device) return '';
  const out = [];
  extraDevices(fr).forEach((d, i) => {
    if (d.lifecycle !== 3 && d.lifecycle !== 4) return;
    out.push(deviceName(i + 1) + ': ' + (d.lifecycle === 4 ? 'FAULT' : 'SAFE STOP') +
             (d.fault_cause ? ' — ' + (FAULT_CAUSES[d.fault_cause] ?? 'cause ' + d.fault_cause) : ''));
  });
  return out.join('; ');
}

/// Shows or hides the banner for frame fr (time_s, h, the other devices); returns the banner's
/// text or ''. `deviceName(i)` names the loop's device i (the other devices' faults are shown
/// after device 0's).
export function showFault(fr, managed, deviceName = (i) => 'device ' + i) {
  const own = faultOf(fr.h, managed), others = extraFaults(fr, deviceName);
  const f = own && others ? { level: own.level, text: own.text + ' | ' + others }
          : own ?? (others ? { level: 'fault', text: others } : null);
  if (!f) {
    banner.hidden = true;
    since = null;
    return '';
  }
  // Since when: replay, the last change of state at or before this frame (the whole file's
  // events); live, the first frame seen in this state.
  let from = null;
  for (const e of events) if (e.t <= fr.time_s + 1e-9 && e.lifecycle === fr.h.lifecycle) from = e.t;
  if (from !== null) since = { t: from };
  else if (!since || fr.time_s < since.t) since = { t: fr.time_s };
  banner.hidden = false;
  banner.className = f.level;
  banner.textContent = f.text + `   (since t = ${since.t.toFixed(3)} s)`;
  return banner.textContent;
}

/// Marks the replay timeline (#marks, under the slider) at the series' events and its grasp
/// events (`grasperName(i)`, `objectName(body, net, thread)` name them in the mark's tooltip);
/// a click on a mark calls seek(frame). Returns the marks drawn.
export function markTimeline(series, frames, seek, grasperName = (i) => 'grasper ' + i,
                             objectName = (b, n, t = -1) =>
                               (b >= 0 ? 'body ' + b : n >= 0 ? 'net ' + n : t >= 0 ? 'thread ' + t : '?')) {
  const el = document.getElementById('marks');
  el.textContent = '';
  if (!series || !frames) return 0;
  events = series.events;
  let n = 0;
  for (const e of series.events) {
    const level = e.lifecycle === 4 ? 'fault' : e.lifecycle === 3 ? 'safe' : e.step_status ? 'step' : null;
    if (!level) continue;
    const m = document.createElement('span');
    m.className = 'mark ' + level;
    m.style.left = (100 * e.frame / Math.max(1, frames - 1)) + '%';
    m.title = `t = ${e.t.toFixed(3)} s: ${LIFECYCLE[e.lifecycle] ?? e.lifecycle}` +
              (e.fault_cause ? ' (' + (FAULT_CAUSES[e.fault_cause] ?? e.fault_cause) + ')' : '') +
              (e.step_status ? ', step: ' + bits(e.step_status, STEP) : '');
    m.onclick = () => seek(e.frame);
    el.appendChild(m);
    ++n;
  }
  for (const e of series.grasp_events ?? []) {
    const m = document.createElement('span');
    m.className = 'mark ' + e.event;  // grasp, release, slip
    m.style.left = (100 * e.frame / Math.max(1, frames - 1)) + '%';
    m.title = `t = ${e.t.toFixed(3)} s: ${e.event} ${grasperName(e.grasper)}: ${objectName(e.body, e.net, e.thread ?? -1)}`;
    m.onclick = () => seek(e.frame);
    el.appendChild(m);
    ++n;
  }
  return n;
}
