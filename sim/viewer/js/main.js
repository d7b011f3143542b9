// The page put together (docs/viewer.md "Page"): the scene message builds the world, each
// frame moves it and fills the panel; window.numenView exposes what a test reads.
import * as THREE from 'three';
import { S, errors, setStatus, updateCounters, writeProbe } from './panel.js';
import { FLOATS, setFrameLayout, LIFECYCLE, STARTUP, STEP, FLAGS, SAMPLE, FAULT_CAUSES, bits, extraDevices } from './protocol.js';
import { params, renderer, scene3, camera, render, requestRender } from './stage.js';
import { controls, fitCamera, followTool, preset, view } from './camera.js';
import { COLORS, G, buildScene, addPlanes, frameBox, showBodies, showJointAxes, showCollisionSpheres, showCoarseNets, sizeCores, worldSpheres } from './geometry.js';
import { buildContacts, showContacts, forceScale } from './contacts.js';
import { showLegend } from './legend.js';
import { showPick, pick } from './pick.js';
import { plotSeries, plotBuffer, plotCursor, plotPoints } from './plots.js';
import { setupLive, liveFrame, liveReset, pauseAt, live } from './live.js';
import { connect, link } from './connection.js';
import { setupReplay, replayed, seek, replay } from './replay.js';
import { showFault, markTimeline } from './faults.js';
import { buildThreads, showThreads, threadProbe } from './suture.js';

// The device's protocol (scene message): only the managed stack has a start-up to show.
let protocol = 'managed', managed = true, fitted = false;

function onScene(msg) {
  buildScene(msg);
  buildThreads(msg);
  S.scene = msg;
  protocol = (msg.device && msg.device.protocol) || 'managed';
  managed = protocol === 'managed';
  document.getElementById('title').textContent = 'numen view — ' + msg.scene;
  buildContacts(msg.bodies.length);
}

let marks = 0;
function onSession(m) {
  setFrameLayout(m.frame_layout);
  S.session = m;
  if (m.mode === 'replay') {
    setupReplay(params.has('frame') ? Number(params.get('frame')) : null);
    marks = markTimeline(m.series, m.frames, seek, grasperName, objectName);
    plotSeries(m.series, seek);
  } else {
    liveReset();  // a new connection is a new run: its frames start again
    setupLive(showFrame);
  }
  if (!S.last) setStatus(m.mode === 'live' ? 'live: waiting for frames…' : 'replay');
}

let banner = '', contactText = '', graspText = '', deviceText = '';

/// The scene's name of the loop's device i (0: the scene message's device, then extra_devices).
const deviceName = (i) => {
  const d = i === 0 ? S.scene?.device : S.scene?.extra_devices?.[i - 1];
  return 'device ' + i + (d ? ` '${d.name}'` : '');
};

/// One line per other device of the loop in frame fr (device 0's state is the lines above):
/// its lifecycle, samples, latched fault, feedback force and the torques sent; '' for one device.
function deviceLines(fr) {
  let out = '';
  extraDevices(fr).forEach((d, i) => {
    const f = Math.hypot(d.feedback[0], d.feedback[1], d.feedback[2]);
    out += `\n${deviceName(i + 1)}: ${LIFECYCLE[d.lifecycle] ?? d.lifecycle}` +
           (d.fault_cause ? ` (${FAULT_CAUSES[d.fault_cause] ?? 'cause ' + d.fault_cause})` : '') +
           `, samples ${d.flags & 1 ? 'valid' : 'rejected' + (d.sample_faults ? ' (' + bits(d.sample_faults, SAMPLE) + ')' : '')}` +
           `, |F| = ${f.toFixed(2)} N, τ = [${d.torques.map((x) => x.toFixed(3)).join(', ')}]`;
  });
  return out;
}

/// The scene's name of grasper i, of what a grasp holds (a body, a net's tissue or a thread).
const grasperName = (i) => S.scene?.grasps?.[i]?.name ?? 'grasper ' + i;
const objectName = (b, n, t = -1) => (b >= 0 ? S.scene.bodies[b]?.name ?? 'body ' + b
                              : n >= 0 ? (S.scene.nets[n]?.name ?? 'net ' + n) + ' (tissue)'
                              : t >= 0 ? 'thread ' + (S.scene.threads?.[t]?.name ?? t) : 'something');

/// One line per grasper of frame fr: what it holds (a body: the grip's springs; tissue or a
/// thread: the held nodes; its pull) or that it is open, with its jaws' opening; '' without
/// graspers.
function graspLines(fr) {
  const K = FLOATS.grasp, g = fr.grasp;
  let out = '';
  for (let i = 0; i < fr.h.num_grasps; ++i) {
    const [body, net, held, opening, pull] = g.subarray(K * i, K * i + 5);
    const thread = g[K * i + 8];  // the held thread (frame version 6), −1: none
    const deg = (opening * 180 / Math.PI).toFixed(1);
    const what = body >= 0 || net >= 0 || thread >= 0 ? objectName(body, net, thread) : '';
    out += `\ngrasp ${grasperName(i)}: ` + (what
      ? `holds ${what} (${held} ${body >= 0 ? 'springs' : 'nodes'}, pull ${pull.toFixed(2)} N)`
      : 'empty') + `, jaws ${deg}°`;
  }
  return out;
}
/// Draws frame fr (the view, the banner, the status); the toggles redraw the frame shown.
function draw(fr) {
  const { h } = fr;
  showBodies(fr);
  showThreads(fr);
  if (!fitted) {  // the whole scene: obstacles, and where the bodies, targets and nets are now
    fitted = true;
    sizeCores(S.scene, fr);
    const box = frameBox(S.scene, fr).union(G.obstacleBox);
    const c = fitCamera(box);
    addPlanes(S.scene, c, view.extent);
  }
  const tool = toolInfo(fr);
  followTool(tool ? tool.position : null);
  const contactsOn = toggles.contacts.checked;
  const { drawn, arrows, fmag } = showContacts(fr, contactsOn, toggles.springs.checked);
  showJointAxes(toggles.axes.checked);
  showCollisionSpheres(toggles.spheres.checked);
  showCoarseNets(toggles.net.checked);
  showLegend(forceScale);
  banner = showFault(fr, managed, deviceName);
  contactText = `contacts: ${h.num_contacts}${h.num_contacts > drawn && contactsOn ? ` (${drawn} drawn)` : ''}` +
                `${contactsOn ? `, ${arrows} force arrows` : ''}   |F| = ${fmag.toFixed(2)} N`;
  graspText = graspLines(fr);
  deviceText = deviceLines(fr);
  setStatus(
    `t = ${fr.time_s.toFixed(3)} s   period ${h.period}\n` +
    `lifecycle: ${LIFECYCLE[h.lifecycle] ?? h.lifecycle}` +
    (managed ? `   start-up: ${STARTUP[h.startup] ?? h.startup}` : `   (${protocol} protocol)`) + '\n' +
    `flags: ${bits(h.flags, FLAGS)}\nstep: ${h.step_status ? bits(h.step_status, STEP) : 'ok'}\n` + contactText + graspText +
    deviceText);
  showPick(fr);
  requestRender();
  return fmag;
}

/// The page's cost (tests/sim/view/viewer_perf.py): frames drawn and rendered, the time in
/// draw() and in renderer.render() (with ?perf=1 the render waits for the GPU: gl.finish()).
const perf = { drawn: 0, drawMs: 0, rendered: 0, renderMs: 0, contacts: 0, nodes: 0, finish: params.has('perf') };

/// Shows a frame that arrived (replay: the one asked for; live: the newest, or one of the
/// buffer when the view is paused).

function showFrame(fr) {
  if (S.session && S.session.mode === 'replay') replayed(fr);
  const t0 = performance.now();
  draw(fr);
  perf.drawMs += performance.now() - t0;
  perf.drawn++;
  perf.contacts += fr.h.num_contacts;
  perf.nodes += fr.h.num_nodes;
  S.last = fr;
  S.framesShown++;
  plotCursor(fr.time_s);
  updateCounters();
}

/// A frame arrived: replay shows it (it was asked for); live buffers it (live.js shows it).
function onFrame(fr) {
  if (S.session && S.session.mode === 'replay') return showFrame(fr);
  plotBuffer(liveFrame(fr), pauseAt);
}

const toggles = {};
for (const id of ['contacts', 'axes', 'spheres', 'springs', 'net']) {
  toggles[id] = document.getElementById(id);
  toggles[id].onchange = () => { if (S.last) draw(S.last); };  // at once, paused or not
}

/// The instrument: { position: the held body's origin, tip: its farthest sphere along its
/// spheres' line (else the origin), axis: towards the tip (world) } or null without one.
function toolInfo(fr = S.last) {
  const b = fr ? fr.h.attached_body : -1;
  if (b < 0) return null;
  const body = G.bodies[b], sp = S.scene.bodies[b].spheres;
  body.updateMatrixWorld();
  const axis = new THREE.Vector3(0, 0, 1);
  let tip = new THREE.Vector3();
  if (sp.length >= 2) {
    axis.set(sp[sp.length - 1][0] - sp[0][0], sp[sp.length - 1][1] - sp[0][1], sp[sp.length - 1][2] - sp[0][2]).normalize();
    tip.set(sp[sp.length - 1][0], sp[sp.length - 1][1], sp[sp.length - 1][2]);
  }
  tip.applyMatrix4(body.matrixWorld);
  axis.applyQuaternion(body.quaternion);
  return { position: body.position.clone(), tip, axis };
}

for (const el of document.querySelectorAll('#views button'))
  el.onclick = () => {
    const t = toolInfo();
    preset(el.dataset.view, t && { position: t.tip, axis: t.axis });
  };

/// A world point projected to page pixels; inside: within the canvas and in front.
function projectPoint(p) {
  const rect = renderer.domElement.getBoundingClientRect();
  const pc = p.clone().project(camera);
  return { x: rect.left + (pc.x + 1) / 2 * rect.width, y: rect.top + (1 - pc.y) / 2 * rect.height,
           inside: Math.abs(pc.x) < 1 && Math.abs(pc.y) < 1 && pc.z < 1 };
}

/// Sphere centres of body b (or of its ghost) projected to page pixels, with radii in pixels.
function project(group, b) {
  const out = [];
  const rect = renderer.domElement.getBoundingClientRect();
  for (const s of S.scene.bodies[b].spheres) {
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
  get framesShown() { return S.framesShown; },
  probe() {
    const last = S.last;
    const p = { errors, framesShown: S.framesShown, framesReceived: S.framesReceived, mode: S.session?.mode ?? null,
                period: last?.h.period ?? null, colors: { tool: COLORS.tool, ghost: COLORS.ghost, held: COLORS.held },
                link: { state: link.state, reconnects: link.reconnects, attempts: link.attempts },
                banner, marks, grasps: graspText.trim(), devices: deviceText.trim() };
    if (last && last.h.attached_body >= 0) {
      const b = last.h.attached_body;
      p.tool = project(G.bodies[b], b);
      p.ghost = G.ghosts[b].visible ? project(G.ghosts[b], b) : [];
      p.toolName = S.scene.bodies[b].name;
      camera.updateMatrixWorld();
      p.toolPx = projectPoint(toolInfo().position);
    }
    if (S.session?.mode === 'replay') p.index = replay.index;
    else p.live = { buffered: live.frames.length, paused: live.paused, firstPeriod: live.frames[0]?.h.period ?? null };
    p.plotPoints = plotPoints();
    p.graspEvents = S.session?.series?.grasp_events ?? [];
    p.series = S.session?.series ? { frames: S.session.series.frames, stride: S.session.series.stride } : null;
    p.pick = pick;
    p.scale = { ...forceScale };
    p.shapes = S.scene ? S.scene.bodies.filter((b, i) => G.bodies[i].children.length > 1).map((b) => b.name) : [];
    // The needles (drawn as their arcs: a shape, so in p.shapes too) and the threads.
    p.needles = (S.scene?.needles ?? []).map((n) => ({ name: n.name, body: n.body, shape: G.bodies[n.body]?.children.length > 1 }));
    p.threads = threadProbe();
    // The bodies with a mesh: the triangles drawn, the body's position in the frame shown (m,
    // world) and the middle of the drawn surface's world box (it moves with the body's pose).
    p.meshBodies = [];
    S.scene?.bodies.forEach((b, i) => {
      if (!b.mesh || !last) return;
      const surface = G.bodies[i].children.find((c) => c.geometry?.userData?.surface);
      const index = surface?.geometry.index;
      G.bodies[i].updateMatrixWorld();
      const middle = surface ? new THREE.Box3().setFromObject(surface).getCenter(new THREE.Vector3()) : null;
      const P = FLOATS.body_pose;
      p.meshBodies.push({ name: b.name, sent: b.mesh.triangle_count, drawn: index ? index.count / 3 : 0,
                          position: Array.from(last.body_pose.subarray(P * i, P * i + 3)),
                          middle: middle?.toArray() ?? null, middlePx: middle ? projectPoint(middle) : null });
    });
    // The organs given by their material: the largest dimple drawn, and how far any drawn vertex
    // is inside another body's sphere (0: none).
    if (last)
      p.tissueNets = G.nets.filter((e) => e.moves).map(({ net, geo, fineObj, dimpleMove }) => {
        const g = (fineObj ?? { geometry: geo }).geometry, pos = g.attributes.position.array;
        const drawn = new Set(g.index.array);  // the vertices of its triangles (a net's interior nodes are not)
        let inside = 0;
        for (const { c, r, body } of worldSpheres(last)) {
          if (body === net.body) continue;
          for (const v of drawn) {
            const k = 3 * v, d = Math.hypot(pos[k] - c[0], pos[k + 1] - c[1], pos[k + 2] - c[2]);
            if (r - d > inside) inside = r - d;
          }
        }
        return { name: net.name, dimpleMove: dimpleMove ?? 0, inside };
      });
    // The nets with a fine surface: its vertices and triangles sent and drawn, a few of its
    // vertices in the frame shown (m, world: indices 0, V/3, 2V/3, V − 1), the middle of its box
    // and whether the coarse net is shown.
    p.netSurfaces = G.nets.filter((e) => e.fine).map(({ net, geo, fineObj }) => {
      const V = net.surface.point_count, pos = fineObj.geometry.attributes.position.array;
      const sample = [0, Math.floor(V / 3), Math.floor(2 * V / 3), V - 1];
      const middle = new THREE.Box3().setFromBufferAttribute(fineObj.geometry.attributes.position).getCenter(new THREE.Vector3());
      return { name: net.name, points: V, sent: net.surface.triangle_count, drawn: fineObj.geometry.index.count / 3,
               sample, samplePositions: sample.map((i) => Array.from(pos.subarray(3 * i, 3 * i + 3))),
               middle: middle.toArray(), middlePx: projectPoint(middle), coarseShown: G.nets.find((e) => e.geo === geo).obj.visible };
    });
    if (last) {
      // The force arrows of the first contacts: from the contact point to the arrow's tip (px).
      const K = FLOATS.contact, c = last.contact;
      p.arrows = [];
      for (let k = 0; k < Math.min(8, last.h.num_contacts); ++k) {
        const o = new THREE.Vector3(c[K * k], c[K * k + 1], c[K * k + 2]);
        const f = new THREE.Vector3(c[K * k + 7], c[K * k + 8], c[K * k + 9]);
        if (f.length() < 1e-6) continue;
        p.arrows.push({ from: projectPoint(o), to: projectPoint(o.clone().addScaledVector(f, forceScale.m_per_n)), n: f.length() });
      }
      if (last.h.attached_body >= 0 && G.ghosts[last.h.attached_body].visible)
        p.ghostPx = projectPoint(G.ghosts[last.h.attached_body].position);
    }
    return p;
  },
  perf,
  /// Replay: shows frame i, paused.
  seek: (i) => seek(i),
  /// The scene message, and body i's group in the view (its pose of the frame shown), for tests.
  scene: () => S.scene,
  body: (i) => G.bodies[i],
  /// A preset view by name (the buttons' names).
  view: (name) => document.querySelector(`#views button[data-view="${name}"]`).click(),
};

connect({ scene: onScene, session: onSession, frame: onFrame });

controls.addEventListener('change', requestRender);
renderer.setAnimationLoop(() => {
  controls.update();
  if (!render.needed) return;
  render.needed = false;
  const t0 = performance.now();
  renderer.render(scene3, camera);
  if (perf.finish) renderer.getContext().finish();
  perf.renderMs += performance.now() - t0;
  perf.rendered++;
  if (S.last) {
    if (!document.title.endsWith('ready')) document.title = 'numen view: ready';
    writeProbe();
  }
});
