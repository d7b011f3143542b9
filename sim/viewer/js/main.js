// The page put together (docs/viewer.md "Page"): the scene message builds the world, each
// frame moves it and fills the panel; window.numenView exposes what a test reads.
import * as THREE from 'three';
import { S, errors, setStatus, updateCounters, writeProbe } from './panel.js';
import { FLOATS, setFrameLayout, LIFECYCLE, STARTUP, STEP, FLAGS, bits } from './protocol.js';
import { params, renderer, scene3, camera } from './stage.js';
import { controls, fitCamera, view } from './camera.js';
import { COLORS, G, buildScene, addPlanes, frameBox, showBodies, showJointAxes } from './geometry.js';
import { buildContacts, showContacts } from './contacts.js';
import { plotAdd } from './plots.js';
import { connect } from './connection.js';

// The device's protocol (scene message): only the managed stack has a start-up to show.
let protocol = 'managed', managed = true, fitted = false;

function onScene(msg) {
  buildScene(msg);
  S.scene = msg;
  protocol = (msg.device && msg.device.protocol) || 'managed';
  managed = protocol === 'managed';
  document.getElementById('title').textContent = 'numen view — ' + msg.scene;
  buildContacts();
}

function onSession(m) {
  setFrameLayout(m.frame_layout);
  S.session = m;
}

function showFrame(fr) {
  const { h } = fr;
  showBodies(fr);
  if (!fitted) {  // on where the bodies, their targets and the nets are now (else the obstacles)
    fitted = true;
    const box = frameBox(S.scene, fr);
    const c = fitCamera(box.isEmpty() ? G.obstacleBox : box);
    addPlanes(S.scene, c, view.extent);
  }
  const contactsOn = document.getElementById('contacts').checked;
  const { drawn, fmag } = showContacts(fr, contactsOn);
  showJointAxes(document.getElementById('axes').checked);
  if (S.lastPeriod >= 0 && S.session && S.session.mode === 'live' && h.period <= S.lastPeriod) S.gaps++;
  S.lastPeriod = h.period;
  S.last = fr;
  S.framesShown++;
  plotAdd(fr, fmag);
  setStatus(
    `t = ${fr.time_s.toFixed(3)} s   period ${h.period}\n` +
    `lifecycle: ${LIFECYCLE[h.lifecycle] ?? h.lifecycle}` +
    (managed ? `   start-up: ${STARTUP[h.startup] ?? h.startup}` : `   (${protocol} protocol)`) + '\n' +
    `flags: ${bits(h.flags, FLAGS)}\nstep: ${h.step_status ? bits(h.step_status, STEP) : 'ok'}\n` +
    `contacts: ${h.num_contacts}${h.num_contacts > drawn && contactsOn ? ` (${drawn} drawn)` : ''}   |F| = ${fmag.toFixed(2)} N`);
  updateCounters();
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
                period: last?.h.period ?? null, colors: { tool: COLORS.tool, ghost: COLORS.ghost } };
    if (last && last.h.attached_body >= 0) {
      const b = last.h.attached_body;
      p.tool = project(G.bodies[b], b);
      p.ghost = G.ghosts[b].visible ? project(G.ghosts[b], b) : [];
      p.toolName = S.scene.bodies[b].name;
    }
    return p;
  },
};

connect({ scene: onScene, session: onSession, frame: showFrame },
        params.has('frame') ? Number(params.get('frame')) : null);

renderer.setAnimationLoop(() => {
  controls.update();
  renderer.render(scene3, camera);
  if (S.last) {
    if (!document.title.endsWith('ready')) document.title = 'numen view: ready';
    writeProbe();
  }
});
