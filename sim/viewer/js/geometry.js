// The scene's geometry from the scene message (docs/viewer.md "Scene message"): obstacles,
// bodies and their ghosts (the target pose), deformable nets, joint axes; and each frame's poses.
import * as THREE from 'three';
import { scene3, v3, q } from './stage.js';
import { FLOATS } from './protocol.js';
import { hasFineSurface, fineSurface } from './fine_surface.js';
import { needleGeometry, needleOf } from './suture.js';
import { pressDimples } from './tissue_dimple.js';

/// Colours of what is drawn (the legend's too).
export const COLORS = { tool: 0xff8800, body: 0x9aa4b0, held: 0xd040d0, ghost: 0x00c8ff, obstacle: 0xc0504d,
                        plane: 0x707a68, box: 0xb09060, net: 0x60c060, coarseNet: 0x1e5a1e,
                        spheres: 0xf0f0a0 };
export const sphereGeo = new THREE.SphereGeometry(1, 24, 16);
/// Spheres of a set of many (an organ of hundreds): 10 × 7 facets each, a fifth of the triangles
/// (software rendering draws every one; docs/viewer.md "What it costs").
const coarseSphereGeo = new THREE.SphereGeometry(1, 10, 7);

/// One InstancedMesh of `spheres` ([x, y, z, r] in the parent's frame) in `material`.
function sphereSet(spheres, material) {
  const geo = spheres.length > 32 ? coarseSphereGeo : sphereGeo;
  const mesh = new THREE.InstancedMesh(geo, material, Math.max(1, spheres.length));
  mesh.count = spheres.length;
  const m = new THREE.Matrix4();
  spheres.forEach((s, i) => {
    m.compose(new THREE.Vector3(s[0], s[1], s[2]), new THREE.Quaternion(), new THREE.Vector3(s[3], s[3], s[3]));
    mesh.setMatrixAt(i, m);
  });
  return mesh;
}

/// A capsule from a to b (THREE.Vector3, m) of radius r, as a geometry.
function capsuleBetween(a, b, r) {
  const d = b.clone().sub(a), L = d.length();
  const g = new THREE.CapsuleGeometry(r, Math.max(1e-6, L), 6, 20);  // along y, centred
  g.applyQuaternion(new THREE.Quaternion().setFromUnitVectors(new THREE.Vector3(0, 1, 0), L > 0 ? d.normalize() : new THREE.Vector3(0, 0, 1)));
  g.translate((a.x + b.x) / 2, (a.y + b.y) / 2, (a.z + b.z) / 2);
  return g;
}

/// A mesh's surface from the scene message (flat `vertices` and `triangles` in its own frame)
/// as a geometry, or its bounds as box edges (userData.wire) when the server sent only its
/// `aabb` (a mesh too large to send).
function meshGeometry(m) {
  if (m.vertices) {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(m.vertices, 3));
    g.setIndex(m.triangles);
    g.computeVertexNormals();
    return g;
  }
  const [lo, hi] = m.aabb;
  const box = new THREE.BoxGeometry(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  box.translate((hi[0] + lo[0]) / 2, (hi[1] + lo[1]) / 2, (hi[2] + lo[2]) / 2);
  const g = new THREE.EdgesGeometry(box);
  g.userData.wire = true;
  return g;
}

/// Geometry g drawn in `material`: as lines of its colour (the same Color object: a colour
/// change shows on both) when g is a wire box, else as a mesh.
function drawable(g, material) {
  if (!g.userData.wire) return new THREE.Mesh(g, material);
  const { transparent, opacity, depthTest, depthWrite } = material;
  const lines = new THREE.LineBasicMaterial({ transparent, opacity, depthTest, depthWrite });
  lines.color = material.color;
  return new THREE.LineSegments(g, lines);
}

/// Body i's visual shape in its own frame (a geometry), or null when its spheres are its look:
///  - a mesh (the scene message's `mesh` of the body): its surface placed by the mesh's pose in
///    the body frame (userData.surface);
///  - a needle's body (the scene message's `needles`): its arc, a tube of the wire's radius
///    (suture.js);
///  - spheres on one line (a shaft, a jaw): a capsule from the first centre to the last, of
///    the largest radius;
///  - no spheres, a deformable net on it (the hidden rigid core): a 1.5 mm shaft along its z
///    through the net's extent (sized by sizeCores() on the first frame);
///  - no spheres, a joint to the world (the trocar sleeve): a 4 mm sleeve along its z, from
///    8 cm behind the joint's frame to 1 cm ahead;
///  - no spheres otherwise: a 3 mm ball at its origin.
function visualShape(msg, i) {
  const mesh = msg.bodies[i].mesh;
  if (mesh) {
    const g = meshGeometry(mesh).applyQuaternion(q(mesh.orientation)).translate(...mesh.position);
    g.userData.surface = true;
    return g;
  }
  const needle = needleOf(msg, i);
  if (needle) return needleGeometry(needle);
  const sp = msg.bodies[i].spheres;
  if (sp.length >= 2) {
    const a = v3(sp[0]), b = v3(sp[sp.length - 1]), ab = b.clone().sub(a);
    const L = ab.length();
    if (L === 0) return null;
    let r = 0;
    for (const s of sp) {
      const p = v3(s).sub(a);
      const off = p.clone().sub(ab.clone().multiplyScalar(p.dot(ab) / (L * L))).length();
      if (off > 0.1 * s[3]) return null;  // not one line
      r = Math.max(r, s[3]);
    }
    return capsuleBetween(a, b, r);
  }
  if (sp.length === 1) return null;
  if (msg.nets.some((n) => n.body === i)) {
    const g = new THREE.CylinderGeometry(0.0015, 0.0015, 1, 16).rotateX(Math.PI / 2);  // along z, length 1
    g.userData = { core: true };
    return g;
  }
  const j = msg.joints.find((j) => (j.child === i && j.parent === -1) || (j.parent === i && j.child === -1));
  if (j) {
    const f = v3((j.child === i ? j.frame_child : j.frame_parent).position);
    const z = new THREE.Vector3(0, 0, 1).applyQuaternion(q((j.child === i ? j.frame_child : j.frame_parent).orientation));
    return capsuleBetween(f.clone().addScaledVector(z, -0.08), f.clone().addScaledVector(z, 0.01), 0.004);
  }
  return new THREE.SphereGeometry(0.003, 16, 12);
}

/// Sizes the hidden cores' shafts to their nets' extent along their z at frame fr (once).
export function sizeCores(msg, fr) {
  const N = FLOATS.node_position, x = fr.node_position;
  G.bodies.forEach((g, i) => {
    const mesh = g.children.find((c) => c.geometry?.userData?.core);
    if (!mesh) return;
    g.updateMatrixWorld();
    const inv = g.matrixWorld.clone().invert();
    let lo = Infinity, hi = -Infinity;
    for (const n of msg.nets) {
      if (n.body !== i) continue;
      for (let k = n.node_begin; k < n.node_begin + n.node_count; ++k) {
        const z = new THREE.Vector3(x[N * k], x[N * k + 1], x[N * k + 2]).applyMatrix4(inv).z;
        lo = Math.min(lo, z);
        hi = Math.max(hi, z);
      }
    }
    if (!(hi > lo)) return;
    for (const m of [mesh, G.ghosts[i].children.find((c) => c.geometry === mesh.geometry)]) {
      m.scale.set(1, 1, hi - lo);
      m.position.set(0, 0, (hi + lo) / 2);
    }
  });
}

/// Shows or hides the collision spheres of the bodies that have another shape.
export function showCollisionSpheres(on) {
  for (const g of [...G.bodies, ...G.ghosts])
    for (const c of g.children) if (c.userData.collision) c.visible = on;
}

/// Shows or hides the coarse nets under the fine surfaces (wireframes; a net without a fine
/// surface is always drawn as its own triangles).
export function showCoarseNets(on) {
  for (const { fine, obj } of G.nets) if (fine) obj.visible = on;
}

/// What buildScene() made: one entry per body (its group and its ghost), net and joint; a net's
/// entry { net, obj, geo, fine, fineObj, moves, dimpleMove }: its node geometry and what draws
/// it (obj: its triangles, or points without any; a wireframe under a fine surface), its fine
/// surface (fine_surface.js, null without one) and that surface's mesh, and for an organ given
/// by its material (the entry's `tissue`) the dimples' scratch (tissue_dimple.js; null
/// otherwise) and the largest move they made in the frame drawn (m); bodySpheres, each body's
/// spheres ([x, y, z, r] in its frame).
export const G = { bodies: [], ghosts: [], nets: [], jointAxes: [], obstacleBox: new THREE.Box3(), bodySpheres: [] };

/// Builds the static world of the scene message `msg`.
export function buildScene(msg) {
  if (msg.format !== 'numen-view') throw new Error('not a numen-view scene message');
  G.bodySpheres = msg.bodies.map((b) => b.spheres);
  const box = G.obstacleBox;
  for (const o of msg.obstacles) {
    let obj;
    const mat = new THREE.MeshLambertMaterial({ color: o.type === 'plane' ? COLORS.plane : o.type === 'box' ? COLORS.box : COLORS.obstacle });
    if (o.type === 'plane') continue;  // drawn once the extent is known (addPlanes)
    if (o.type === 'box') obj = new THREE.Mesh(new THREE.BoxGeometry(2 * o.half_extents[0], 2 * o.half_extents[1], 2 * o.half_extents[2]), mat);
    else if (o.type === 'sphere') obj = new THREE.Mesh(new THREE.SphereGeometry(o.radius, 32, 20), mat);
    else if (o.type === 'capsule') {
      const g = new THREE.CapsuleGeometry(o.radius, 2 * o.half_length, 8, 24);
      g.rotateX(Math.PI / 2);  // three's capsule is along y, numen's along z
      obj = new THREE.Mesh(g, mat);
    } else if (o.type === 'mesh') obj = drawable(meshGeometry(o), mat);  // in the obstacle's frame
    else if (o.type === 'sphere_set') {
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
    // transparent (opacity 1): drawn in the same pass as the ghosts, after them (renderOrder)
    const solid = new THREE.MeshLambertMaterial({ color: tool ? COLORS.tool : COLORS.body, transparent: true, opacity: 1 });
    const ghostMat = new THREE.MeshBasicMaterial({ color: COLORS.ghost, transparent: true, opacity: 0.45, depthTest: false, depthWrite: false });
    const shape = visualShape(msg, i);
    const g = new THREE.Group(), gh = new THREE.Group();
    g.name = gh.name = b.name;
    g.userData = { body: i, material: solid };
    // The collision spheres: the body's look where it has no other shape, else a toggle.
    const spheres = sphereSet(b.spheres, shape ? new THREE.MeshLambertMaterial({ color: COLORS.spheres, transparent: true, opacity: 0.5 }) : solid);
    const ghostSpheres = sphereSet(b.spheres, ghostMat);
    spheres.userData.collision = ghostSpheres.userData.collision = !!shape;
    g.add(spheres);
    gh.add(ghostSpheres);
    if (shape) {
      g.add(drawable(shape, solid));
      gh.add(drawable(shape, ghostMat));
    }
    for (const o of [g, ...g.children]) o.renderOrder = 2;  // after the ghosts: a ghost never hides its tool
    for (const o of [gh, ...gh.children]) o.renderOrder = 1;
    gh.visible = false;
    scene3.add(g, gh);
    G.bodies.push(g);
    G.ghosts.push(gh);
  });
  for (const n of msg.nets) {
    const geo = new THREE.BufferGeometry();
    geo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(3 * n.node_count), 3));
    const mat = new THREE.MeshLambertMaterial({ color: COLORS.net, side: THREE.DoubleSide });
    let obj, fine = null, fineObj = null;
    if (hasFineSurface(n)) {
      // The organ is its fine surface, in the net's material; the net a wireframe under it.
      fine = fineSurface(n);
      fineObj = new THREE.Mesh(fine.geo, mat);
      fineObj.frustumCulled = false;
      fineObj.name = n.name;
      scene3.add(fineObj);
      geo.setIndex(n.surface.net_triangles);
      obj = new THREE.Mesh(geo, new THREE.MeshBasicMaterial({ color: COLORS.coarseNet, wireframe: true }));
      obj.visible = false;
    } else if (n.triangles.length) {
      if (n.surface) console.warn(`net ${n.name}: its fine surface of ${n.surface.triangle_count} triangles was too large to send: the net is drawn`);
      geo.setIndex(n.triangles.flat());
      obj = new THREE.Mesh(geo, mat);
    } else {
      obj = new THREE.Points(geo, new THREE.PointsMaterial({ color: COLORS.net, size: 2 * n.node_radius }));
    }
    obj.frustumCulled = false;
    scene3.add(obj);
    // An organ given by its material: the tools' dimples drawn on it (tissue_dimple.js).
    const moves = n.tissue ? new Float64Array(fine ? n.surface.point_count : n.node_count) : null;
    G.nets.push({ net: n, obj, geo, fine, fineObj, moves });
  }
  for (const j of msg.joints) {
    const a = new THREE.AxesHelper(1);
    a.visible = false;
    a.userData = j;
    scene3.add(a);
    G.jointAxes.push(a);
  }
}

/// Draws the scene's planes as squares of side 8 r centred under `c` (world, m), and sizes the
/// joint axes to the scene (r: the scene's radius, m).
export function addPlanes(msg, c, r) {
  for (const o of msg.obstacles) {
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
  for (const a of G.jointAxes) a.scale.setScalar(0.15 * r);
}

/// Box (world, m) around the frame's bodies (their spheres and mesh surfaces), their targets and
/// the nets (empty if none).
export function frameBox(msg, fr) {
  const box = new THREE.Box3();
  const x = fr.node_position, N = FLOATS.node_position;
  for (let n = 0; n < fr.h.num_nodes; ++n) box.expandByPoint(new THREE.Vector3(x[N * n], x[N * n + 1], x[N * n + 2]));
  for (let b = 0; b < fr.h.num_bodies; ++b) {
    for (const g of G.ghosts[b].visible ? [G.bodies[b], G.ghosts[b]] : [G.bodies[b]]) {
      g.updateMatrixWorld();
      for (const sp of msg.bodies[b].spheres) {
        const c = v3(sp).applyMatrix4(g.matrixWorld);
        box.expandByPoint(c.clone().addScalar(sp[3])).expandByPoint(c.addScalar(-sp[3]));
      }
      for (const c of g.children) if (c.geometry?.userData?.surface) box.expandByObject(c);
    }
  }
  return box;
}

/// Moves the bodies, their ghosts and the nets to frame `fr`.
export function showBodies(fr) {
  const { h } = fr;
  if (h.num_bodies !== G.bodies.length) throw new Error('frame has ' + h.num_bodies + ' bodies, scene ' + G.bodies.length);
  const P = FLOATS.body_pose, T = FLOATS.target_pose;
  const held = heldBodies(fr);
  for (let b = 0; b < h.num_bodies; ++b) {
    const p = fr.body_pose.subarray(P * b, P * b + P);
    G.bodies[b].position.set(p[0], p[1], p[2]);
    G.bodies[b].quaternion.set(p[3], p[4], p[5], p[6]);
    const t = fr.target_pose.subarray(T * b, T * b + T);
    G.ghosts[b].visible = t[T - 1] !== 0;  // the target flag, after the pose
    G.ghosts[b].position.set(t[0], t[1], t[2]);
    G.ghosts[b].quaternion.set(t[3], t[4], t[5], t[6]);
    G.bodies[b].userData.material.color.setHex(b === h.attached_body ? COLORS.tool : held.has(b) ? COLORS.held : COLORS.body);
  }
  let spheres = null;  // the bodies' spheres in the world, for the organs given by their material
  for (const entry of G.nets) {
    const { net, geo, fine, moves } = entry;
    const pos = geo.attributes.position.array;
    const N = FLOATS.node_position;
    pos.set(fr.node_position.subarray(N * net.node_begin, N * (net.node_begin + net.node_count)));
    geo.attributes.position.needsUpdate = true;
    if (moves) spheres ??= worldSpheres(fr);
    const others = moves ? spheres.filter((s) => s.body !== net.body) : null;
    const press = moves ? (p, n, count) => (entry.dimpleMove = pressDimples(p, n, count, others, moves)) : null;
    if (fine) {
      fine.update(pos, press);  // the net is then a wireframe: no normals
    } else if (geo.index) {
      geo.computeVertexNormals();
      if (press && press(pos, geo.attributes.normal.array, net.node_count) > 0) geo.computeVertexNormals();
    }
    geo.computeBoundingSphere();
  }
}

/// Every body's spheres at frame `fr` as { c: [x, y, z] (world, m), r (m), body }.
export function worldSpheres(fr) {
  const out = [], P = FLOATS.body_pose;
  const v = new THREE.Vector3(), rot = new THREE.Quaternion();
  for (let b = 0; b < fr.h.num_bodies; ++b) {
    const p = fr.body_pose.subarray(P * b, P * b + P);
    rot.set(p[3], p[4], p[5], p[6]);
    for (const s of G.bodySpheres[b]) {
      v.set(s[0], s[1], s[2]).applyQuaternion(rot);
      out.push({ c: [v.x + p[0], v.y + p[1], v.z + p[2]], r: s[3], body: b });
    }
  }
  return out;
}

/// The bodies the frame's graspers hold (its grasp array: the held body first of each item).
export function heldBodies(fr) {
  const out = new Set(), K = FLOATS.grasp, g = fr.grasp;
  for (let i = 0; g && i < fr.h.num_grasps; ++i) if (g[K * i] >= 0) out.add(g[K * i]);
  return out;
}

/// Shows the joint axes (each joint's frame on its child) or hides them.
export function showJointAxes(on) {
  for (const a of G.jointAxes) {
    const j = a.userData;
    a.visible = on;
    if (!on) continue;
    const child = G.bodies[j.child];
    a.position.copy(v3(j.frame_child.position)).applyQuaternion(child.quaternion).add(child.position);
    a.quaternion.copy(child.quaternion).multiply(q(j.frame_child.orientation));
  }
}
