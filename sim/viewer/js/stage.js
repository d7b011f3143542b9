// The three.js stage: renderer, scene graph, lights and the view's size (?w=W&h=H fixes it in
// pixels: the browser test's projection is then the same in every Chromium run).
import * as THREE from 'three';

export const params = new URLSearchParams(location.search);
export const container = document.getElementById('view');
/// The WebGL renderer's name (e.g. "ANGLE (Google, Vulkan 1.3.0 (SwiftShader Device ...))").
export const glRenderer = (() => {
  const gl = document.createElement('canvas').getContext('webgl2');
  const ext = gl && gl.getExtension('WEBGL_debug_renderer_info');
  return ext ? String(gl.getParameter(ext.UNMASKED_RENDERER_WEBGL)) : 'unknown';
})();
/// Software rendering (SwiftShader) draws without multisampling: it costs a third of the frame
/// rate there (docs/viewer.md "What it costs"); ?aa=1 / ?aa=0 force it on or off.
const software = /SwiftShader|llvmpipe|software/i.test(glRenderer);
const antialias = params.has('aa') ? params.get('aa') !== '0' : !software;
export const renderer = new THREE.WebGLRenderer({ antialias, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
container.appendChild(renderer.domElement);
export const scene3 = new THREE.Scene();
scene3.background = new THREE.Color(0x20242a);
export const camera = new THREE.PerspectiveCamera(40, 1, 0.001, 100);
camera.up.set(0, 0, 1);  // the shipped scenes are z up
scene3.add(new THREE.HemisphereLight(0xffffff, 0x404050, 1.6));
const sun = new THREE.DirectionalLight(0xffffff, 1.6);
sun.position.set(1, -2, 3);
scene3.add(sun);

if (params.has('w') && params.has('h')) {
  container.style.right = 'auto';
  container.style.bottom = 'auto';
  container.style.width = Number(params.get('w')) + 'px';
  container.style.height = Number(params.get('h')) + 'px';
}
/// Whether the view must be rendered again (a frame drawn, the camera moved, a resize): the
/// page renders only then, so a paused view costs nothing.
export const render = { needed: true };
export const requestRender = () => { render.needed = true; };

function resize() {
  render.needed = true;
  const w = container.clientWidth, h = container.clientHeight;
  renderer.setSize(w, h);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
}
window.addEventListener('resize', resize);
resize();

/// [x, y, z] or [x, y, z, w] arrays as three.js vectors and quaternions.
export const v3 = (a) => new THREE.Vector3(a[0], a[1], a[2]);
export const q = (a) => new THREE.Quaternion(a[0], a[1], a[2], a[3]);
