// The numen viewer (docs/viewer.md "Page"). Connects to the WebSocket of the server that served
// it, reads the scene message (JSON), the session message (live, or replay with the frame
// index; its frame_layout says how frames are laid out) and then binary state frames
// (platform/include/numen/platform/state_frame.hpp), and draws them with three.js; plots with
// uPlot. Read-only: in live mode it sends nothing; in replay mode only {"frame": I} requests.
//
// URL parameters: ?frame=I (replay: show frame I, paused), ?w=W&h=H (the view's size in
// pixels); the browser test uses both.
// window.numenView exposes the state a test reads (also written to #probe as JSON).

const errors = [];
window.addEventListener('error', (e) => errors.push(String(e.message || e)));
window.addEventListener('unhandledrejection', (e) => errors.push('unhandled: ' + String(e.reason)));

const params = new URLSearchParams(location.search);
const statusEl = document.getElementById('status');
function fail(text) {
  errors.push(text);
  statusEl.textContent = text;
  statusEl.className = 'error';
  writeProbe();
}

function writeProbe() {
  const probe = document.getElementById('probe');
  probe.textContent = JSON.stringify(window.numenView ? window.numenView.probe() : { errors });
}

let THREE, OrbitControls;
try {
  THREE = await import('three');
  ({ OrbitControls } = await import('three/addons/controls/OrbitControls.js'));
} catch (e) {
  let why = '';
  try { why = await (await fetch('vendor/MISSING')).text(); } catch (_) { /* none */ }
  fail('three.js could not be loaded: the build did not install the page\'s libraries.\n' +
       (why || String(e)) + '\nInstall nodejs and npm, then rebuild (docs/viewer.md "Page").');
  throw e;
}

// ---- State frames (state_frame.hpp) -------------------------------------------------------
// The layout comes from the session message's frame_layout (the server writes it from
// platform::kStateFrameFields and kStateFrameArrays): header fields by name, offset and type,
// then float32 arrays of `floats` per item, repeated `count` times (a header field; null: once).
// A frame decodes to { h: header fields by name, time_s, and one Float32Array per array name }.
const READ = {
  u8: (v, o) => v.getUint8(o), u16: (v, o) => v.getUint16(o, true),
  u32: (v, o) => v.getUint32(o, true), i32: (v, o) => v.getInt32(o, true),
  u64: (v, o) => Number(v.getBigUint64(o, true)), i64: (v, o) => Number(v.getBigInt64(o, true)),
  'char[4]': (v, o) => String.fromCharCode(v.getUint8(o), v.getUint8(o + 1), v.getUint8(o + 2), v.getUint8(o + 3)),
};
// What this page reads of a frame: a layout without one of these is refused by name.
const USED_FIELDS = ['magic', 'version', 'header_bytes', 'frame_bytes', 'num_bodies', 'num_nodes',
                     'num_contacts', 'num_axes', 'attached_body', 'period', 'time_ns', 'step_status',
                     'flags', 'step_ns', 'lifecycle', 'startup'];
const USED_ARRAYS = ['body_pose', 'target_pose', 'node_position', 'contact', 'feedback', 'penetration'];
let frameLayout = null;  // the session message's frame_layout, checked
const FLOATS = {};       // floats per item, by array name

function setFrameLayout(L) {
  const where = 'the session message\'s frame_layout';
  if (!L || typeof L !== 'object')
    throw new Error(where + ' is missing: the server is older than this page (rebuild and restart numen)');
  for (const k of ['magic', 'version', 'header_bytes', 'float_bytes', 'header', 'arrays'])
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
  frameLayout = L;
}

function decodeFrame(buf) {
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

const LIFECYCLE = ['unconfigured', 'inactive', 'active', 'safe stop', 'fault'];
const STARTUP = ['reset communication', 'wait boot-up', 'start nodes', 'wait operational',
                 'operational', 'failed', 'configure'];
const STEP = ['contact overflow', 'non-finite', 'solver not converged', 'invalid target'];
const FLAGS = ['sample valid', 'torque', 'overrun', 'target ready', 'contacts truncated'];
const bits = (x, names) => names.filter((_, i) => x & (1 << i)).join(', ') || '—';

// ---- Scene -------------------------------------------------------------------------------
const COLORS = { tool: 0xff8800, body: 0x9aa4b0, ghost: 0x00c8ff, obstacle: 0xc0504d,
                 plane: 0x707a68, box: 0xb09060, net: 0x60c060 };
const container = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
container.appendChild(renderer.domElement);
const scene3 = new THREE.Scene();
scene3.background = new THREE.Color(0x20242a);
const camera = new THREE.PerspectiveCamera(40, 1, 0.001, 100);
camera.up.set(0, 0, 1);  // the shipped scenes are z up
const controls = new OrbitControls(camera, renderer.domElement);
scene3.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(1, -2, 3);
scene3.add(sun);

const q = (a) => new THREE.Quaternion(a[0], a[1], a[2], a[3]);
const v3 = (a) => new THREE.Vector3(a[0], a[1], a[2]);
const sphereGeo = new THREE.SphereGeometry(1, 24, 16);

/// One InstancedMesh of `spheres` ([x, y, z, r] in the parent's frame) in `material`.
function sphereSet(spheres, material) {
  const mesh = new THREE.InstancedMesh(sphereGeo, material, Math.max(1, spheres.length));
  mesh.count = spheres.length;
  const m = new THREE.Matrix4();
  spheres.forEach((s, i) => {
    m.compose(new THREE.Vector3(s[0], s[1], s[2]), new THREE.Quaternion(), new THREE.Vector3(s[3], s[3], s[3]));
    mesh.setMatrixAt(i, m);
  });
  return mesh;
}

let scene = null, session = null, bodies = [], ghosts = [], nets = [], jointAxes = [];
// The device's protocol (scene message): only the managed stack has a start-up to show.
let protocol = 'managed', managed = true;
let contactPoints, contactLines, forceArrow, extent = 1, obstacleBox = null, fitted = false;
const MAX_DRAWN_CONTACTS = 512;

function buildScene(msg) {
  if (msg.format !== 'numen-view') throw new Error('not a numen-view scene message');
  scene = msg;
  protocol = (msg.device && msg.device.protocol) || 'managed';
  managed = protocol === 'managed';
  document.getElementById('title').textContent = 'numen view — ' + msg.scene;
  const box = new THREE.Box3();
  for (const o of msg.obstacles) {
    let obj;
    const mat = new THREE.MeshLambertMaterial({ color: o.type === 'plane' ? COLORS.plane : o.type === 'box' ? COLORS.box : COLORS.obstacle });
    if (o.type === 'plane') continue;  // drawn once the extent is known
    if (o.type === 'box') obj = new THREE.Mesh(new THREE.BoxGeometry(2 * o.half_extents[0], 2 * o.half_extents[1], 2 * o.half_extents[2]), mat);
    else if (o.type === 'sphere') obj = new THREE.Mesh(new THREE.SphereGeometry(o.radius, 32, 20), mat);
    else if (o.type === 'capsule') {
      const g = new THREE.CapsuleGeometry(o.radius, 2 * o.half_length, 8, 24);
      g.rotateX(Math.PI / 2);  // three's capsule is along y, numen's along z
      obj = new THREE.Mesh(g, mat);
    } else if (o.type === 'sphere_set') {
      obj = sphereSet(o.spheres, mat);  // world coordinates already
      for (const s of o.spheres) box.expandByPoint(v3(s).addScalar(s[3])).expandByPoint(v3(s).addScalar(-s[3]));
    } else continue;
    if (o.type !== 'sphere_set') {
      obj.position.copy(v3(o.position));
      obj.quaternion.copy(q(o.orientation));
      obj.updateMatrixWorld();
      box.expandByObject(obj);
    }
    obj.name = o.name;
    scene3.add(obj);
  }
  msg.bodies.forEach((b, i) => {
    const tool = i === msg.attached_body;
    const solid = new THREE.MeshLambertMaterial({ color: tool ? COLORS.tool : COLORS.body, transparent: true, opacity: 1 });
    const g = sphereSet(b.spheres, solid);
    g.renderOrder = 2;  // after the ghosts: a ghost never hides its tool
    const ghostMat = new THREE.MeshBasicMaterial({ color: COLORS.ghost, transparent: true, opacity: 0.45, depthTest: false, depthWrite: false });
    const gh = sphereSet(b.spheres, ghostMat);
    gh.renderOrder = 1;
    gh.visible = false;
    scene3.add(g, gh);
    bodies.push(g);
    ghosts.push(gh);
  });
  for (const n of msg.nets) {
    const geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * n.node_count), 3));
    const mat = new THREE.MeshLambertMaterial({ color: COLORS.net, side: THREE.DoubleSide });
    let obj;
    if (n.triangles.length) {
      geo.setIndex(n.triangles.flat());
      obj = new THREE.Mesh(geo, mat);
    } else {
      obj = new THREE.Points(geo, new THREE.PointsMaterial({ color: COLORS.net, size: 2 * n.node_radius }));
    }
    obj.frustumCulled = false;
    scene3.add(obj);
    nets.push({ net: n, obj, geo });
  }
  for (const j of msg.joints) {
    const a = new THREE.AxesHelper(1);
    a.visible = false;
    a.userData = j;
    scene3.add(a);
    jointAxes.push(a);
  }
  // Contacts: points coloured by depth, normals as segments; the feedback force as an arrow.
  contactPoints = new THREE.InstancedMesh(sphereGeo, new THREE.MeshBasicMaterial(), MAX_DRAWN_CONTACTS);
  contactPoints.count = 0;
  contactPoints.frustumCulled = false;
  const lg = new THREE.BufferGeometry();
  lg.setAttribute('position', new THREE.BufferAttribute(new Float32Array(6 * MAX_DRAWN_CONTACTS), 3));
  lg.setAttribute('color', new THREE.BufferAttribute(new Float32Array(6 * MAX_DRAWN_CONTACTS), 3));
  contactLines = new THREE.LineSegments(lg, new THREE.LineBasicMaterial({ vertexColors: true }));
  contactLines.frustumCulled = false;
  forceArrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 1, 0xffee00);
  forceArrow.visible = false;
  scene3.add(contactPoints, contactLines, forceArrow);
  obstacleBox = box;  // the camera is fitted on the first frame, bodies included
}

function fitCamera(box) {
  if (box.isEmpty()) box.set(new THREE.Vector3(-0.1, -0.1, -0.1), new THREE.Vector3(0.1, 0.1, 0.1));
  const c = box.getCenter(new THREE.Vector3());
  const r = Math.max(0.02, 0.65 * box.getSize(new THREE.Vector3()).length());
  extent = r;
  for (const o of scene.obstacles) {
    if (o.type !== 'plane') continue;
    const g = new THREE.PlaneGeometry(8 * r, 8 * r);  // normal z, as numen's plane
    const mesh = new THREE.Mesh(g, new THREE.MeshLambertMaterial({ color: COLORS.plane, side: THREE.DoubleSide }));
    mesh.position.copy(v3(o.position));
    mesh.quaternion.copy(q(o.orientation));
    // Centre the square under the scene: move along the plane to the box centre's foot.
    const n = new THREE.Vector3(0, 0, 1).applyQuaternion(mesh.quaternion);
    const d = c.clone().sub(mesh.position);
    mesh.position.add(d.sub(n.clone().multiplyScalar(d.dot(n))));
    mesh.name = o.name;
    scene3.add(mesh);
  }
  const dir = new THREE.Vector3(1.0, -1.6, 0.9).normalize();
  camera.position.copy(c.clone().add(dir.multiplyScalar(2.2 * r)));
  camera.near = r / 100;
  camera.far = r * 100;
  controls.target.copy(c);
  controls.update();
  for (const a of jointAxes) a.scale.setScalar(0.15 * r);
}

// ---- Drawing a frame -----------------------------------------------------------------------
let last = null, framesShown = 0, framesReceived = 0, badFrames = 0, gaps = 0, lastPeriod = -1;
const depthColor = new THREE.Color();
const tmpM = new THREE.Matrix4(), tmpQ = new THREE.Quaternion(), tmpP = new THREE.Vector3(), tmpS = new THREE.Vector3();

function showFrame(fr) {
  const { h } = fr;
  if (h.num_bodies !== bodies.length) throw new Error('frame has ' + h.num_bodies + ' bodies, scene ' + bodies.length);
  const P = FLOATS.body_pose, T = FLOATS.target_pose, K = FLOATS.contact;
  for (let b = 0; b < h.num_bodies; ++b) {
    const p = fr.body_pose.subarray(P * b, P * b + P);
    bodies[b].position.set(p[0], p[1], p[2]);
    bodies[b].quaternion.set(p[3], p[4], p[5], p[6]);
    const t = fr.target_pose.subarray(T * b, T * b + T);
    ghosts[b].visible = t[T - 1] !== 0;  // the target flag, after the pose
    ghosts[b].position.set(t[0], t[1], t[2]);
    ghosts[b].quaternion.set(t[3], t[4], t[5], t[6]);
    const tool = b === h.attached_body;
    bodies[b].material.color.setHex(tool ? COLORS.tool : COLORS.body);
  }
  for (const { net, geo } of nets) {
    const pos = geo.attributes.position.array;
    const N = FLOATS.node_position;
    pos.set(fr.node_position.subarray(N * net.node_begin, N * (net.node_begin + net.node_count)));
    geo.attributes.position.needsUpdate = true;
    if (geo.index) geo.computeVertexNormals();
    geo.computeBoundingSphere();
  }
  if (!fitted) {  // on where the bodies, their targets and the nets are now (else the obstacles)
    fitted = true;
    const box = new THREE.Box3();
    const x = fr.node_position, N = FLOATS.node_position;
    for (let n = 0; n < h.num_nodes; ++n) box.expandByPoint(new THREE.Vector3(x[N * n], x[N * n + 1], x[N * n + 2]));
    for (let b = 0; b < h.num_bodies; ++b) {
      for (const g of ghosts[b].visible ? [bodies[b], ghosts[b]] : [bodies[b]]) {
        g.updateMatrixWorld();
        for (const sp of scene.bodies[b].spheres) {
          const c = v3(sp).applyMatrix4(g.matrixWorld);
          box.expandByPoint(c.clone().addScalar(sp[3])).expandByPoint(c.addScalar(-sp[3]));
        }
      }
    }
    fitCamera(box.isEmpty() ? obstacleBox : box);
  }
  const showContacts = document.getElementById('contacts').checked;
  const nc = showContacts ? Math.min(h.num_contacts, MAX_DRAWN_CONTACTS) : 0;
  let maxDepth = 1e-6;
  for (let c = 0; c < nc; ++c) maxDepth = Math.max(maxDepth, fr.contact[K * c + 6]);
  const lp = contactLines.geometry.attributes.position.array, lc = contactLines.geometry.attributes.color.array;
  const dot = extent * 0.01, len = extent * 0.06;
  for (let c = 0; c < nc; ++c) {
    const k = fr.contact.subarray(K * c, K * c + K);  // point, normal, depth, force
    depthColor.setHSL(0.33 * (1 - k[6] / maxDepth), 1, 0.5);  // green (shallow) to red (deepest)
    tmpM.compose(tmpP.set(k[0], k[1], k[2]), tmpQ.identity(), tmpS.setScalar(dot));
    contactPoints.setMatrixAt(c, tmpM);
    contactPoints.setColorAt(c, depthColor);
    lp.set([k[0], k[1], k[2], k[0] + len * k[3], k[1] + len * k[4], k[2] + len * k[5]], 6 * c);
    lc.set([depthColor.r, depthColor.g, depthColor.b, depthColor.r, depthColor.g, depthColor.b], 6 * c);
  }
  contactPoints.count = nc;
  contactPoints.instanceMatrix.needsUpdate = true;
  if (contactPoints.instanceColor) contactPoints.instanceColor.needsUpdate = true;
  contactLines.geometry.setDrawRange(0, 2 * nc);
  contactLines.geometry.attributes.position.needsUpdate = true;
  contactLines.geometry.attributes.color.needsUpdate = true;
  // Feedback force, drawn at the tool (world frame, N).
  const F = new THREE.Vector3(fr.feedback[0], fr.feedback[1], fr.feedback[2]);
  const fmag = F.length();
  forceArrow.visible = fmag > 1e-3 && h.attached_body >= 0;
  if (forceArrow.visible) {
    forceArrow.position.copy(bodies[h.attached_body].position);
    forceArrow.setDirection(F.clone().normalize());
    const l = Math.min(1, fmag / 10) * extent * 0.8 + extent * 0.05;  // 10 N: 0.85 of the scene
    forceArrow.setLength(l, 0.2 * l, 0.1 * l);
  }
  const axesOn = document.getElementById('axes').checked;
  for (const a of jointAxes) {
    const j = a.userData;
    a.visible = axesOn;
    if (!axesOn) continue;
    // The joint frame in the child's frame, carried by the child's pose.
    const child = bodies[j.child];
    a.position.copy(v3(j.frame_child.position)).applyQuaternion(child.quaternion).add(child.position);
    a.quaternion.copy(child.quaternion).multiply(q(j.frame_child.orientation));
  }
  if (lastPeriod >= 0 && session && session.mode === 'live' && h.period <= lastPeriod) gaps++;
  lastPeriod = h.period;
  last = fr;
  framesShown++;
  plotAdd(fr, fmag);
  statusEl.className = '';
  statusEl.textContent =
    `t = ${fr.time_s.toFixed(3)} s   period ${h.period}\n` +
    `lifecycle: ${LIFECYCLE[h.lifecycle] ?? h.lifecycle}` +
    (managed ? `   start-up: ${STARTUP[h.startup] ?? h.startup}` : `   (${protocol} protocol)`) + '\n' +
    `flags: ${bits(h.flags, FLAGS)}\nstep: ${h.step_status ? bits(h.step_status, STEP) : 'ok'}\n` +
    `contacts: ${h.num_contacts}${h.num_contacts > nc && showContacts ? ` (${nc} drawn)` : ''}   |F| = ${fmag.toFixed(2)} N`;
  updateCounters();
}

function updateCounters() {
  document.getElementById('counters').textContent =
    `mode: ${session ? session.mode : '…'}\nframes received: ${framesReceived}   shown: ${framesShown}\n` +
    `bad frames: ${badFrames}   out of order: ${gaps}`;
}

// ---- Plots (uPlot): a rolling window of 10 s of simulated time ----------------------------
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
function plotAdd(fr, fmag) {
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

// ---- Connection, live and replay -----------------------------------------------------------
const fixedFrame = params.has('frame') ? Number(params.get('frame')) : null;
const ws = new WebSocket((location.protocol === 'https:' ? 'wss://' : 'ws://') + location.host + '/stream');
ws.binaryType = 'arraybuffer';
const replay = { index: 0, playing: false, speed: 1, clock: 0, pending: -1, sentAt: 0 };

function request(i) {
  i = Math.max(0, Math.min(session.frames - 1, i));
  replay.pending = i;
  replay.sentAt = performance.now();
  ws.send(JSON.stringify({ frame: i }));
}

function setupReplay() {
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

ws.onmessage = (ev) => {
  try {
    if (typeof ev.data === 'string') {
      const m = JSON.parse(ev.data);
      if (!scene) buildScene(m);
      else if (m.type === 'session') {
        setFrameLayout(m.frame_layout);
        session = m;
        if (m.mode === 'replay') setupReplay();
        statusEl.textContent = m.mode === 'live' ? 'live: waiting for frames…' : 'replay';
        updateCounters();
      }
      return;
    }
    framesReceived++;
    let fr;
    try { fr = decodeFrame(ev.data); } catch (e) { badFrames++; errors.push(String(e)); return; }
    if (session && session.mode === 'replay') {
      replay.index = replay.pending >= 0 ? replay.pending : replay.index;
      replay.pending = -1;
      document.getElementById('slider').value = String(replay.index);
      document.getElementById('clock').textContent =
        `${fr.time_s.toFixed(3)} / ${(session.time_s[session.frames - 1] ?? 0).toFixed(3)} s`;
    }
    showFrame(fr);
  } catch (e) {
    fail('viewer error: ' + e.message);
  }
};
ws.onclose = () => {
  if (!errors.length) { statusEl.textContent += '\n(connection closed)'; }
  window.numenView.closed = true;
};
ws.onerror = () => fail('WebSocket error (is the server running?)');

// ---- Render loop and what a test reads -----------------------------------------------------
// ?w=W&h=H fixes the view's size in pixels (the browser test: the same projection in every
// Chromium run, whatever its window).
const fixedSize = params.has('w') && params.has('h');
if (fixedSize) {
  container.style.right = 'auto';
  container.style.bottom = 'auto';
  container.style.width = Number(params.get('w')) + 'px';
  container.style.height = Number(params.get('h')) + 'px';
}
function resize() {
  const w = container.clientWidth, h = container.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();

/// Sphere centres of body b (or of its ghost) projected to page pixels, with radii in pixels.
function project(group, b) {
  const out = [];
  const rect = renderer.domElement.getBoundingClientRect();
  for (const s of scene.bodies[b].spheres) {
    const c = new THREE.Vector3(s[0], s[1], s[2]).applyMatrix4(group.matrixWorld);
    const edge = c.clone().add(new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0).multiplyScalar(s[3]));
    const pc = c.clone().project(camera), pe = edge.project(camera);
    const px = (p) => [rect.left + (p.x + 1) / 2 * rect.width, rect.top + (1 - p.y) / 2 * rect.height];
    const [x, y] = px(pc), [ex, ey] = px(pe);
    out.push({ x, y, r: Math.hypot(ex - x, ey - y), inside: Math.abs(pc.x) < 1 && Math.abs(pc.y) < 1 && pc.z < 1 });
  }
  return out;
}

window.numenView = {
  errors, closed: false,
  get framesShown() { return framesShown; },
  probe() {
    const p = { errors, framesShown, framesReceived, mode: session?.mode ?? null,
                period: last?.h.period ?? null, colors: { tool: COLORS.tool, ghost: COLORS.ghost } };
    if (last && last.h.attached_body >= 0) {
      const b = last.h.attached_body;
      p.tool = project(bodies[b], b);
      p.ghost = ghosts[b].visible ? project(ghosts[b], b) : [];
      p.toolName = scene.bodies[b].name;
    }
    return p;
  },
};

renderer.setAnimationLoop(() => {
  controls.update();
  renderer.render(scene3, camera);
  if (last) {
    if (!document.title.endsWith('ready')) document.title = 'numen view: ready';
    writeProbe();
  }
});
