// Contacts and forces: each contact's point and normal coloured by depth, and the feedback
// force sent to the device as an arrow at the tool (docs/viewer.md "Page").
import * as THREE from 'three';
import { scene3 } from './stage.js';
import { FLOATS } from './protocol.js';
import { sphereGeo, G } from './geometry.js';
import { view } from './camera.js';

/// Contacts drawn at most per frame (the count is shown).
export const MAX_DRAWN_CONTACTS = 512;
let contactPoints, contactLines, forceArrow;

/// Makes the contact marks and the force arrow (once, after the scene).
export function buildContacts() {
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
}

const depthColor = new THREE.Color();
const tmpM = new THREE.Matrix4(), tmpQ = new THREE.Quaternion(), tmpP = new THREE.Vector3(), tmpS = new THREE.Vector3();

/// Draws frame fr's contacts (none when `show` is false) and its feedback force; returns
/// { drawn: contacts drawn, fmag: |F| (N) }.
export function showContacts(fr, show) {
  const { h } = fr;
  const K = FLOATS.contact;
  const nc = show ? Math.min(h.num_contacts, MAX_DRAWN_CONTACTS) : 0;
  let maxDepth = 1e-6;
  for (let c = 0; c < nc; ++c) maxDepth = Math.max(maxDepth, fr.contact[K * c + 6]);
  const lp = contactLines.geometry.attributes.position.array, lc = contactLines.geometry.attributes.color.array;
  const dot = view.extent * 0.01, len = view.extent * 0.06;
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
    forceArrow.position.copy(G.bodies[h.attached_body].position);
    forceArrow.setDirection(F.clone().normalize());
    const l = Math.min(1, fmag / 10) * view.extent * 0.8 + view.extent * 0.05;  // 10 N: 0.85 of the scene
    forceArrow.setLength(l, 0.2 * l, 0.1 * l);
  }
  return { drawn: nc, fmag };
}
