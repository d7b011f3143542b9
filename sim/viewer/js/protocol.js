// State frames (platform/include/numen/platform/state_frame.hpp) as the session message's
// frame_layout describes them (docs/viewer.md "Frames", "Server"): header fields by name, offset
// and type, then float32 arrays of `floats` per item, repeated `count` times (a header field;
// null: once). A frame decodes to { h: header fields by name, time_s, one Float32Array per array }.

const READ = {
  u8: (v, o) => v.getUint8(o), u16: (v, o) => v.getUint16(o, true),
  u32: (v, o) => v.getUint32(o, true), i32: (v, o) => v.getInt32(o, true),
  u64: (v, o) => Number(v.getBigUint64(o, true)), i64: (v, o) => Number(v.getBigInt64(o, true)),
  'char[4]': (v, o) => String.fromCharCode(v.getUint8(o), v.getUint8(o + 1), v.getUint8(o + 2), v.getUint8(o + 3)),
};
// What this page reads of a frame: a layout without one of these is refused by name.
const USED_FIELDS = ['magic', 'version', 'header_bytes', 'frame_bytes', 'num_bodies', 'num_nodes',
                     'num_contacts', 'num_axes', 'attached_body', 'period', 'time_ns', 'step_status',
                     'flags', 'step_ns', 'lifecycle', 'startup', 'fault_cause', 'num_grasps',
                     'num_extra_devices', 'num_extra_axes', 'num_threads', 'num_thread_nodes'];
const USED_ARRAYS = ['body_pose', 'target_pose', 'node_position', 'contact', 'feedback', 'penetration',
                     'device_loop', 'grasp', 'extra_device', 'extra_axis_torque', 'thread', 'thread_node'];
let frameLayout = null;  // the session message's frame_layout, checked
/// Floats per item, by array name (from the layout).
export const FLOATS = {};
/// The names of the header's fault_cause values (hal::FaultCause; the layout's fault_causes).
export const FAULT_CAUSES = [];

/// Checks and adopts the session message's frame_layout; throws naming what is missing.
export function setFrameLayout(L) {
  const where = 'the session message\'s frame_layout';
  if (!L || typeof L !== 'object')
    throw new Error(where + ' is missing: the server is older than this page (rebuild and restart numen)');
  for (const k of ['magic', 'version', 'header_bytes', 'float_bytes', 'header', 'arrays', 'fault_causes'])
    if (L[k] === undefined) throw new Error(where + ' has no "' + k + '"');
  if (L.float_bytes !== Float32Array.BYTES_PER_ELEMENT) throw new Error(where + ': float_bytes ' + L.float_bytes);
  const fields = new Set();
  for (const f of L.header) {
    if (!READ[f.type]) throw new Error(where + ': field "' + f.name + '" has unknown type "' + f.type + '"');
    fields.add(f.name);
  }
  for (const n of USED_FIELDS) if (!fields.has(n)) throw new Error(where + ' has no header field "' + n + '"');
  for (const a of L.arrays) {
    if (a.count !== null && !fields.has(a.count))
      throw new Error(where + ': array "' + a.name + '" counts by "' + a.count + '", not a header field');
    FLOATS[a.name] = a.floats;
  }
  for (const n of USED_ARRAYS) if (FLOATS[n] === undefined) throw new Error(where + ' has no array "' + n + '"');
  FAULT_CAUSES.length = 0;
  FAULT_CAUSES.push(...L.fault_causes);
  frameLayout = L;
}

/// Decodes one binary frame (an ArrayBuffer); throws naming what does not match the layout.
export function decodeFrame(buf) {
  const L = frameLayout;
  if (!L) throw new Error('a frame before the session message\'s frame_layout');
  if (buf.byteLength < L.header_bytes) throw new Error('frame shorter than its header');
  const v = new DataView(buf);
  const h = {};
  for (const f of L.header) h[f.name] = READ[f.type](v, f.offset);
  if (h.magic !== L.magic) throw new Error('not a state frame (magic ' + h.magic + ')');
  if (h.version !== L.version) throw new Error('frame version ' + h.version + ', layout ' + L.version);
  if (h.header_bytes !== L.header_bytes) throw new Error('header size ' + h.header_bytes);
  let need = L.header_bytes;
  for (const a of L.arrays) need += L.float_bytes * a.floats * (a.count === null ? 1 : h[a.count]);
  if (h.frame_bytes !== buf.byteLength || need !== buf.byteLength)
    throw new Error('frame of ' + buf.byteLength + ' bytes, header says ' + h.frame_bytes + ', counts ' + need);
  const f = new Float32Array(buf, L.header_bytes, (buf.byteLength - L.header_bytes) / L.float_bytes);  // little-endian hosts
  const fr = { h, time_s: h.time_ns * 1e-9 };
  let o = 0;
  for (const a of L.arrays) fr[a.name] = f.subarray(o, o += a.floats * (a.count === null ? 1 : h[a.count]));
  return fr;
}

/// The loop's other devices of frame fr (its extra_device items, docs/viewer.md "Frames"), each
/// { flags, lifecycle, startup, fault_cause, sample_faults, feedback: [6], torques: [its axes] }.
export function extraDevices(fr) {
  const K = FLOATS.extra_device, d = fr.extra_device, tau = fr.extra_axis_torque;
  const out = [];
  for (let i = 0, a = 0; i < fr.h.num_extra_devices; ++i) {
    const v = d.subarray(K * i, K * i + K), n = v[5];
    out.push({ flags: v[0], lifecycle: v[1], startup: v[2], fault_cause: v[3], sample_faults: v[4],
               feedback: Array.from(v.subarray(6, 12)), torques: Array.from(tau.subarray(a, a + n)) });
    a += n;
  }
  return out;
}

/// Names of the header's sample check bits (hal::SampleFault).
export const SAMPLE = ['malformed', 'non-finite', 'out of range', 'stale', 'jump', 'no data'];

/// Names of the header's enumerations and bit sets (hal::LifecycleState, hal::StartupPhase,
/// core::StepStatus, StateFrameFlag).
export const LIFECYCLE = ['unconfigured', 'inactive', 'active', 'safe stop', 'fault'];
export const STARTUP = ['reset communication', 'wait boot-up', 'start nodes', 'wait operational',
                        'operational', 'failed', 'configure'];
export const STEP = ['contact overflow', 'non-finite', 'solver not converged', 'invalid target'];
export const FLAGS = ['sample valid', 'torque', 'overrun', 'target ready', 'contacts truncated'];
/// The names of the bits set in x, comma-separated ('—': none).
export const bits = (x, names) => names.filter((_, i) => x & (1 << i)).join(', ') || '—';
