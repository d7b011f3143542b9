// The camera: an orbit camera (drag to turn, wheel to zoom, right-drag to pan) fitted to a box.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { camera, renderer } from './stage.js';

export const controls = new OrbitControls(camera, renderer.domElement);
/// The scene's size (m): the radius the camera was fitted to; sizes of drawn marks follow it.
export const view = { extent: 1 };

/// Points the camera at `box` (world, m) from the front-right, above; returns its centre.
export function fitCamera(box) {
  if (box.isEmpty()) box.set(new THREE.Vector3(-0.1, -0.1, -0.1), new THREE.Vector3(0.1, 0.1, 0.1));
  const c = box.getCenter(new THREE.Vector3());
  const r = Math.max(0.02, 0.65 * box.getSize(new THREE.Vector3()).length());
  view.extent = r;
  const dir = new THREE.Vector3(1.0, -1.6, 0.9).normalize();
  camera.position.copy(c.clone().add(dir.multiplyScalar(2.2 * r)));
  camera.near = r / 100;
  camera.far = r * 100;
  camera.updateProjectionMatrix();
  controls.target.copy(c);
  controls.update();
  return c;
}
