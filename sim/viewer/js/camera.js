// The camera (docs/viewer.md "Page"): an orbit camera (drag to turn, wheel to zoom towards the
// cursor, right-drag to pan) that frames the whole scene at load, follows the tool (on by
// default) and has preset views: the whole scene, front, side, along the instrument.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';
import { camera, renderer } from './stage.js';

export const controls = new OrbitControls(camera, renderer.domElement);
controls.zoomToCursor = true;  // the wheel zooms towards the point under the cursor
/// The scene's size (m): the radius the camera was fitted to; sizes of drawn marks follow it.
/// `box`: what was fitted; `follow`: the tool's last position followed (null: none yet).
export const view = { extent: 1, box: new THREE.Box3(), follow: null };
const followEl = document.getElementById('follow');

/// Looks at the centre of `box` (world, m) from direction `dir` (from the centre towards the
/// camera), far enough for the whole box to fit the view; returns the centre.
function lookAtBox(box, dir) {
  const c = box.getCenter(new THREE.Vector3());
  const r = Math.max(0.02, 0.5 * box.getSize(new THREE.Vector3()).length());
  const fov = THREE.MathUtils.degToRad(camera.fov);
  const fit = Math.min(fov, 2 * Math.atan(Math.tan(fov / 2) * camera.aspect));  // the narrower angle
  const d = 1.1 * r / Math.sin(fit / 2);
  camera.position.copy(c).addScaledVector(dir.clone().normalize(), d);
  camera.near = d / 200;
  camera.far = d * 50;
  camera.updateProjectionMatrix();
  controls.target.copy(c);
  controls.update();
  return c;
}

/// Fits the camera to `box` (world, m: the whole scene) from the front-right, above; returns
/// its centre. The box is kept for the "whole scene" preset.
export function fitCamera(box) {
  if (box.isEmpty()) box.set(new THREE.Vector3(-0.1, -0.1, -0.1), new THREE.Vector3(0.1, 0.1, 0.1));
  view.box.copy(box);
  view.extent = Math.max(0.02, 0.65 * box.getSize(new THREE.Vector3()).length());
  return lookAtBox(box, new THREE.Vector3(1.0, -1.6, 0.9));
}

/// Moves camera and orbit centre with the tool (world position `p`, m) when following is on:
/// the view keeps the offset it had, so turning and zooming still work while following.
export function followTool(p) {
  if (!followEl.checked || !p) { view.follow = p ? p.clone() : null; return; }
  if (view.follow) {
    const d = p.clone().sub(view.follow);
    camera.position.add(d);
    controls.target.add(d);
  }
  view.follow = p.clone();
}

/// Preset views. `tool`: { position, axis } of the instrument (world; axis towards its tip),
/// or null. 'scene': the whole scene; 'front': from −y; 'side': from +x; 'along': from behind
/// the instrument down its axis, centred on its tip.
export function preset(name, tool) {
  const up = new THREE.Vector3(0, 0, 1);
  if (name === 'along' && tool) {
    const r = 0.5 * view.extent;
    const c = tool.position.clone();
    camera.position.copy(c).addScaledVector(tool.axis, -r).addScaledVector(up, 0.05 * r);
    controls.target.copy(c);
    controls.update();
    view.follow = c.clone();
    return;
  }
  const dirs = { scene: new THREE.Vector3(1.0, -1.6, 0.9), front: new THREE.Vector3(0, -1, 0.05),
                 side: new THREE.Vector3(1, 0, 0.05) };
  const box = view.box.clone();
  if (tool && name !== 'scene') box.expandByPoint(tool.position);
  lookAtBox(box, dirs[name] || dirs.scene);
  if (tool) view.follow = tool.position.clone();
}
