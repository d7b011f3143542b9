// Suturing (docs/suturing.md, docs/viewer.md "What it draws"): the needles' arcs as the shapes of
// their bodies, and the suture threads as polylines through their nodes of each frame (the
// frame's thread and thread_node arrays; the scene message's needles and threads).
import * as THREE from 'three';
import { scene3 } from './stage.js';
import { FLOATS } from './protocol.js';

/// The threads' colour (the legend's too).
export const THREAD_COLOR = 0x3050ff;

/// Needle n of the scene message (radius R, arc_angle φ, wire_radius, centre and tail_angle in
/// its body's frame) as a tube of the wire's radius along its arc, in the body's frame: a torus
/// segment about `centre` in the x–y plane from tail_angle to tail_angle + φ.
export function needleGeometry(n) {
  const g = new THREE.TorusGeometry(n.radius, n.wire_radius, 8, 48, n.arc_angle);  // from +x about +z
  g.rotateZ(n.tail_angle);
  g.translate(n.centre[0], n.centre[1], n.centre[2]);
  return g;
}

/// The needle of body i in the scene message `msg`, or undefined.
export const needleOf = (msg, i) => (msg.needles ?? []).find((n) => n.body === i);

/// What buildThreads() made: per thread { thread, geo, obj, broken }, its node geometry, the
/// line segments that draw it and the segment it is drawn broken at (−1: whole).
export const threads = [];

/// The segments of a thread of `count` nodes as line pairs, leaving out segment `broken` (−1:
/// none): a broken thread is drawn in two pieces.
function segmentIndex(count, broken) {
  const index = [];
  for (let s = 0; s + 1 < count; ++s) if (s !== broken) index.push(s, s + 1);
  return index;
}

/// Builds the threads of the scene message `msg` (its "threads"; none in a scene without).
export function buildThreads(msg) {
  threads.length = 0;
  for (const t of msg.threads ?? []) {
    const geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * t.node_count), 3));
    geo.setIndex(segmentIndex(t.node_count, -1));
    const obj = new THREE.LineSegments(geo, new THREE.LineBasicMaterial({ color: THREAD_COLOR }));
    obj.frustumCulled = false;
    obj.name = t.name;
    obj.renderOrder = 2;
    scene3.add(obj);
    threads.push({ thread: t, geo, obj, broken: -1 });
  }
}

/// Moves the threads to frame `fr`: their nodes from thread_node, and a thread that broke drawn
/// without its broken segment.
export function showThreads(fr) {
  if (!threads.length) return;
  if (fr.h.num_threads !== threads.length) throw new Error('frame has ' + fr.h.num_threads + ' threads, scene ' + threads.length);
  const N = FLOATS.thread_node, K = FLOATS.thread;
  threads.forEach((e, i) => {
    const { thread: t, geo } = e;
    geo.attributes.position.array.set(fr.thread_node.subarray(N * t.node_begin, N * (t.node_begin + t.node_count)));
    geo.attributes.position.needsUpdate = true;
    geo.computeBoundingSphere();
    const broken = fr.thread[K * i];
    if (broken !== e.broken) {
      e.broken = broken;
      geo.setIndex(segmentIndex(t.node_count, broken));
    }
  });
}

/// The threads as a test reads them: name, nodes, segments drawn, the broken segment (−1: none)
/// and its first and last node (m, world) in the frame shown.
export function threadProbe() {
  return threads.map(({ thread: t, geo, broken }) => {
    const x = geo.attributes.position.array, n = t.node_count;
    return { name: t.name, nodes: n, segmentsDrawn: geo.index.count / 2, broken,
             first: Array.from(x.subarray(0, 3)), last: Array.from(x.subarray(3 * n - 3, 3 * n)) };
  });
}
