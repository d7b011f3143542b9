// Picking (docs/viewer.md "Page"): a click on a body (without dragging) shows its name, pose,
// velocity and contacts in the panel, for every frame shown until another click.
import * as THREE from 'three';
import { camera, renderer } from './stage.js';
import { FLOATS } from './protocol.js';
import { G } from './geometry.js';
import { S } from './panel.js';

const el = document.getElementById('pick');
const ray = new THREE.Raycaster();
let picked = -1, down = null, prev = null, before = null;  // the frames shown last and before it
/// What the panel shows of the picked body (read by the tests).
export const pick = { body: -1, text: '' };

renderer.domElement.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
renderer.domElement.addEventListener('pointerup', (e) => {
  if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4) return;  // a drag turns
  pickAt(e.clientX, e.clientY);
});

/// Picks the body under page pixel (x, y); returns its index or -1.
export function pickAt(x, y) {
  const r = renderer.domElement.getBoundingClientRect();
  ray.setFromCamera(new THREE.Vector2((x - r.left) / r.width * 2 - 1, -(y - r.top) / r.height * 2 + 1), camera);
  const hits = ray.intersectObjects(G.bodies.filter((g) => g.visible), true);
  picked = -1;
  for (const h of hits) {
    let o = h.object;
    while (o && o.userData.body === undefined) o = o.parent;
    if (o) { picked = o.userData.body; break; }
  }
  if (S.last) showPick(S.last);
  return picked;
}

const mm = (v) => (1e3 * v).toFixed(1);

/// Writes the picked body's figures at frame fr: position (mm) and orientation (quaternion),
/// velocity by finite difference from the frame shown before (the frame carries no velocity),
/// and the contacts whose point lies on its spheres (within radius + 1 mm: a contact does not
/// name its body).
export function showPick(fr) {
  if (fr !== prev) { before = prev; prev = fr; }  // a redraw of the same frame keeps its velocity
  pick.body = picked;
  if (picked < 0 || !S.scene) { el.hidden = true; pick.text = ''; return; }
  const P = FLOATS.body_pose, K = FLOATS.contact, b = picked;
  const p = fr.body_pose.subarray(P * b, P * b + P);
  let vel = 'needs two frames';
  if (before && fr.time_s > before.time_s && fr.time_s - before.time_s < 0.2) {
    const q = before.body_pose.subarray(P * b, P * b + P), dt = fr.time_s - before.time_s;
    const v = [0, 1, 2].map((k) => (p[k] - q[k]) / dt);
    vel = `(${v.map(mm).join(', ')}) mm/s, |v| = ${mm(Math.hypot(...v))} mm/s`;
  }
  const g = G.bodies[b];
  g.updateMatrixWorld();
  const spheres = S.scene.bodies[b].spheres.map((s) => [new THREE.Vector3(s[0], s[1], s[2]).applyMatrix4(g.matrixWorld), s[3]]);
  let n = 0, deepest = 0, force = new THREE.Vector3();
  for (let c = 0; c < fr.h.num_contacts; ++c) {
    const k = fr.contact.subarray(K * c, K * c + K);
    const x = new THREE.Vector3(k[0], k[1], k[2]);
    if (!spheres.some(([o, r]) => o.distanceTo(x) <= r + k[6] + 1e-3)) continue;
    ++n;
    deepest = Math.max(deepest, k[6]);
    force.add(new THREE.Vector3(k[7], k[8], k[9]));
  }
  pick.text = `${S.scene.bodies[b].name} (body ${b}${b === fr.h.attached_body ? ', the tool' : ''})\n` +
    `position (${mm(p[0])}, ${mm(p[1])}, ${mm(p[2])}) mm\n` +
    `orientation (x y z w) (${[3, 4, 5, 6].map((k) => p[k].toFixed(3)).join(', ')})\n` +
    `velocity ${vel}\n` +
    `contacts ${n}` + (n ? `, deepest ${mm(deepest)} mm, force (${[force.x, force.y, force.z].map((f) => f.toFixed(2)).join(', ')}) N` : '');
  el.hidden = false;
  el.textContent = pick.text;
}
