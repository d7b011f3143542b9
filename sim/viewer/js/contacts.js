// Forces where they act (docs/viewer.md "Page"): each contact's point (a dot of fixed size on
// screen), its force on the first body as an arrow (length ∝ |f|, the scale in the legend), both
// coloured by depth; the coupling spring from each ghost to its body; the feedback force sent
// to the device as an arrow at the tool. All drawn over the scene (not hidden behind obstacles).
import * as THREE from 'three';
import { scene3 } from './stage.js';
import { FLOATS } from './protocol.js';
import { G } from './geometry.js';
import { view } from './camera.js';

/// Contacts drawn at most per frame (the count is shown).
export const MAX_DRAWN_CONTACTS = 512;
/// Contact dots' size, screen pixels.
const DOT_PX = 9;
/// Coils of a drawn coupling spring (segments: 2 per coil, plus its two ends).
const COILS = 8;
let dots, arrows, heads, springs, forceArrow;
/// The arrows' scale: metres per newton (grows with the largest contact force seen, so the
/// longest arrow is at most 0.35 of the scene) and the depth of the deepest colour (m).
export const forceScale = { m_per_n: 0, max_n: 0, depth_m: 0 };

function overlay(obj, order) {
  obj.renderOrder = order;
  obj.frustumCulled = false;
  obj.material.depthTest = false;
  obj.material.depthWrite = false;
  obj.material.transparent = true;
  return obj;
}

/// Makes the contact marks, the springs and the force arrow (once, after the scene).
export function buildContacts(numBodies) {
  const pg = new THREE.BufferGeometry();
  pg.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * MAX_DRAWN_CONTACTS), 3));
  pg.setAttribute('color', new THREE.BufferAttribute(new Float32Array(3 * MAX_DRAWN_CONTACTS), 3));
  dots = overlay(new THREE.Points(pg, new THREE.PointsMaterial({ size: DOT_PX, sizeAttenuation: false, vertexColors: true })), 5);
  const lg = new THREE.BufferGeometry();
  lg.setAttribute('position', new THREE.BufferAttribute(new Float32Array(6 * MAX_DRAWN_CONTACTS), 3));
  lg.setAttribute('color', new THREE.BufferAttribute(new Float32Array(6 * MAX_DRAWN_CONTACTS), 3));
  arrows = overlay(new THREE.LineSegments(lg, new THREE.LineBasicMaterial({ vertexColors: true })), 5);
  const cone = new THREE.ConeGeometry(0.35, 1, 12).translate(0, -0.5, 0);  // tip at the origin, along +y
  heads = overlay(new THREE.InstancedMesh(cone, new THREE.MeshBasicMaterial(), MAX_DRAWN_CONTACTS), 5);
  heads.count = 0;
  const sg = new THREE.BufferGeometry();
  const perSpring = 2 * COILS + 2;
  sg.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * 2 * perSpring * Math.max(1, numBodies)), 3));
  springs = overlay(new THREE.LineSegments(sg, new THREE.LineBasicMaterial({ color: 0xe0f4ff, opacity: 0.9 })), 4);
  forceArrow = new THREE.ArrowHelper(new THREE.Vector3(0, 0, 1), new THREE.Vector3(), 1, 0xffee00);
  forceArrow.visible = false;
  scene3.add(dots, arrows, heads, springs, forceArrow);
}

const color = new THREE.Color();
const tmpM = new THREE.Matrix4(), tmpQ = new THREE.Quaternion(), tmpS = new THREE.Vector3();
const Y = new THREE.Vector3(0, 1, 0), dir = new THREE.Vector3(), tip = new THREE.Vector3();

/// Colour of a depth d (m): yellow (0) through green and blue to purple (≥ deepest), a
/// viridis-like map that never takes the tool's orange or the ghost's hue at its ends.
function depthColor(d, deepest) {
  return color.setHSL((60 + 220 * Math.min(1, d / deepest)) / 360, 1, 0.55);
}

/// Draws frame fr's contacts (none when `show` is false), its springs (when `springsOn`) and
/// its feedback force; returns { drawn: contacts drawn, fmag: |F| (N) }.
export function showContacts(fr, show, springsOn) {
  const { h } = fr;
  const K = FLOATS.contact;
  const nc = show ? Math.min(h.num_contacts, MAX_DRAWN_CONTACTS) : 0;
  let deepest = 1e-6, fmax = 0;
  for (let c = 0; c < nc; ++c) {
    deepest = Math.max(deepest, fr.contact[K * c + 6]);
    fmax = Math.max(fmax, Math.hypot(fr.contact[K * c + 7], fr.contact[K * c + 8], fr.contact[K * c + 9]));
  }
  forceScale.max_n = Math.max(forceScale.max_n, fmax, 0.5);
  forceScale.m_per_n = 0.35 * view.extent / forceScale.max_n;
  forceScale.depth_m = deepest;
  const pp = dots.geometry.attributes.position.array, pc = dots.geometry.attributes.color.array;
  const lp = arrows.geometry.attributes.position.array, lc = arrows.geometry.attributes.color.array;
  let na = 0;
  for (let c = 0; c < nc; ++c) {
    const k = fr.contact.subarray(K * c, K * c + K);  // point, normal, depth, force
    depthColor(k[6], deepest);
    pp.set([k[0], k[1], k[2]], 3 * c);
    pc.set([color.r, color.g, color.b], 3 * c);
    const f = Math.hypot(k[7], k[8], k[9]);
    if (f < 1e-6) continue;
    const len = f * forceScale.m_per_n;
    dir.set(k[7] / f, k[8] / f, k[9] / f);
    tip.set(k[0], k[1], k[2]).addScaledVector(dir, len);
    lp.set([k[0], k[1], k[2], tip.x, tip.y, tip.z], 6 * na);
    lc.set([color.r, color.g, color.b, color.r, color.g, color.b], 6 * na);
    const head = Math.min(0.25 * len, 0.03 * view.extent);
    tmpM.compose(tip, tmpQ.setFromUnitVectors(Y, dir), tmpS.set(head, head, head));
    heads.setMatrixAt(na, tmpM);
    heads.setColorAt(na, color);
    ++na;
  }
  dots.geometry.setDrawRange(0, nc);
  dots.geometry.attributes.position.needsUpdate = true;
  dots.geometry.attributes.color.needsUpdate = true;
  arrows.geometry.setDrawRange(0, 2 * na);
  arrows.geometry.attributes.position.needsUpdate = true;
  arrows.geometry.attributes.color.needsUpdate = true;
  heads.count = na;
  heads.instanceMatrix.needsUpdate = true;
  if (heads.instanceColor) heads.instanceColor.needsUpdate = true;
  drawSprings(springsOn);
  // Feedback force sent to the device, drawn at the tool (world frame, N).
  const F = new THREE.Vector3(fr.feedback[0], fr.feedback[1], fr.feedback[2]);
  const fmag = F.length();
  forceArrow.visible = fmag > 1e-3 && h.attached_body >= 0;
  if (forceArrow.visible) {
    forceArrow.position.copy(G.bodies[h.attached_body].position);
    forceArrow.setDirection(F.clone().normalize());
    const l = Math.min(1, fmag / 10) * view.extent * 0.8 + view.extent * 0.05;  // 10 N: 0.85 of the scene
    forceArrow.setLength(l, 0.2 * l, 0.1 * l);
  }
  return { drawn: nc, arrows: na, fmag };
}

/// The coupling springs: a zigzag from each visible ghost's origin to its body's origin.
function drawSprings(on) {
  const p = springs.geometry.attributes.position.array;
  let v = 0;
  const a = new THREE.Vector3(), b = new THREE.Vector3(), d = new THREE.Vector3(), n = new THREE.Vector3();
  const push = (x) => { p.set([x.x, x.y, x.z], 3 * v); ++v; };
  for (let i = 0; on && i < G.bodies.length; ++i) {
    if (!G.ghosts[i].visible) continue;
    a.copy(G.ghosts[i].position);
    b.copy(G.bodies[i].position);
    d.subVectors(b, a);
    const L = d.length();
    if (L < 1e-5) continue;
    n.set(0, 0, 1).cross(d);
    if (n.lengthSq() < 1e-12) n.set(1, 0, 0);
    n.normalize().multiplyScalar(Math.min(0.25 * L, 0.01 * view.extent) + 0.002 * view.extent);
    let prev = a.clone();
    for (let s = 1; s <= 2 * COILS + 1; ++s) {
      const q = a.clone().addScaledVector(d, s / (2 * COILS + 1));
      if (s < 2 * COILS + 1) q.addScaledVector(n, s % 2 ? 1 : -1);
      push(prev); push(q);
      prev = q;
    }
  }
  springs.geometry.setDrawRange(0, v);
  springs.geometry.attributes.position.needsUpdate = true;
}
