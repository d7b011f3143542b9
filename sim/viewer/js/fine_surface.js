// A net's fine surface (docs/viewer.md "Scene message", a net's `surface`): the user's
// full-resolution organ mesh riding on the coarser simulation net, as core::add_net_surface()
// maps it (core/include/numen/core/net_surface_map.hpp). Each frame places every fine vertex
// from the net's node positions the frame carries:
//     p = Σ_m w_m x_m + F · offset,   F = [e1, e2, n] of its net triangle (x0, x1, x2):
//     e1 = (x1 − x0)/|x1 − x0|, n = (x1 − x0) × (x2 − x0) normalised, e2 = n × e1;
// the foot point alone where the triangle has collapsed (as the core). Typed arrays and one
// BufferGeometry updated in place: ~100 000 fine vertices per frame without allocating.
import * as THREE from 'three';

/// Whether net entry `n` of the scene message carries a fine surface the page can draw (its
/// embeddings sent: not above the server's kViewNetSurfaceMaxTriangles).
export function hasFineSurface(n) {
  return !!(n.surface && n.surface.triangles && n.surface.face);
}

/// The fine surface of net entry `n` (hasFineSurface(n)) as { geo, update(x, press) }: geo, its
/// BufferGeometry (positions and normals, index of the fine triangles); update(x) places its
/// vertices and normals for the frame's node positions `x` (Float32Array, 3 per node, the net's
/// nodes from index 0) and marks them for upload; with `press(pos, nor, count)` (the tools'
/// dimples, tissue_dimple.js) the placed vertices are handed to it with their normals, and the
/// normals made again where it moved any. Throws if the arrays disagree in size or index out of
/// range (the message is malformed).
export function fineSurface(n) {
  const s = n.surface, V = s.point_count, T = s.triangle_count;
  const nt = Int32Array.from(s.net_triangles), F = nt.length / 3;
  const face = Int32Array.from(s.face), tri = Uint32Array.from(s.triangles);
  const w = Float32Array.from(s.weights), off = Float32Array.from(s.offset);
  if (face.length !== V || w.length !== 3 * V || off.length !== 3 * V || tri.length !== 3 * T || nt.length % 3)
    throw new Error(`net ${n.name}: fine surface arrays disagree with point_count ${V}, triangle_count ${T}`);
  for (const k of nt) if (k < 0 || k >= n.node_count) throw new Error(`net ${n.name}: fine surface: node ${k} out of range`);
  for (const f of face) if (f < 0 || f >= F) throw new Error(`net ${n.name}: fine surface: net triangle ${f} out of range`);
  for (const k of tri) if (k >= V) throw new Error(`net ${n.name}: fine surface: vertex ${k} out of range`);
  // The weights as sent are rounded (1e-6): normalised here so that they sum to 1.
  for (let i = 0; i < V; ++i) {
    const sum = w[3 * i] + w[3 * i + 1] + w[3 * i + 2];
    if (sum > 0) for (let k = 0; k < 3; ++k) w[3 * i + k] /= sum;
  }
  const geo = new THREE.BufferGeometry();
  const pos = new Float32Array(3 * V), nor = new Float32Array(3 * V);
  geo.setAttribute('position', new THREE.BufferAttribute(pos, 3));
  geo.setAttribute('normal', new THREE.BufferAttribute(nor, 3));
  geo.setIndex(new THREE.BufferAttribute(tri, 1));
  const frame = new Float64Array(9 * F);  // per net triangle: e1, e2, n; NaN: collapsed
  const acc = new Float64Array(3 * V);    // area-weighted normal sums

  function update(x, press) {
    for (let f = 0; f < F; ++f) {
      const a = 3 * nt[3 * f], b = 3 * nt[3 * f + 1], c = 3 * nt[3 * f + 2];
      const ux = x[b] - x[a], uy = x[b + 1] - x[a + 1], uz = x[b + 2] - x[a + 2];
      const vx = x[c] - x[a], vy = x[c + 1] - x[a + 1], vz = x[c + 2] - x[a + 2];
      let nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      const lu = Math.sqrt(ux * ux + uy * uy + uz * uz), ln = Math.sqrt(nx * nx + ny * ny + nz * nz), o = 9 * f;
      if (!(lu > 0 && ln > 0 && Number.isFinite(lu) && Number.isFinite(ln))) {
        frame[o] = NaN;
        continue;
      }
      const ex = ux / lu, ey = uy / lu, ez = uz / lu;
      nx /= ln; ny /= ln; nz /= ln;
      frame[o] = ex; frame[o + 1] = ey; frame[o + 2] = ez;
      frame[o + 3] = ny * ez - nz * ey; frame[o + 4] = nz * ex - nx * ez; frame[o + 5] = nx * ey - ny * ex;
      frame[o + 6] = nx; frame[o + 7] = ny; frame[o + 8] = nz;
    }
    for (let i = 0; i < V; ++i) {
      const f = face[i], t = 3 * f, o = 9 * f, i3 = 3 * i;
      const a = 3 * nt[t], b = 3 * nt[t + 1], c = 3 * nt[t + 2];
      const w0 = w[i3], w1 = w[i3 + 1], w2 = w[i3 + 2];
      let px = w0 * x[a] + w1 * x[b] + w2 * x[c];
      let py = w0 * x[a + 1] + w1 * x[b + 1] + w2 * x[c + 1];
      let pz = w0 * x[a + 2] + w1 * x[b + 2] + w2 * x[c + 2];
      if (!Number.isNaN(frame[o])) {
        const o0 = off[i3], o1 = off[i3 + 1], o2 = off[i3 + 2];
        px += frame[o] * o0 + frame[o + 3] * o1 + frame[o + 6] * o2;
        py += frame[o + 1] * o0 + frame[o + 4] * o1 + frame[o + 7] * o2;
        pz += frame[o + 2] * o0 + frame[o + 5] * o1 + frame[o + 8] * o2;
      }
      pos[i3] = px; pos[i3 + 1] = py; pos[i3 + 2] = pz;
    }
    normals();
    if (press && press(pos, nor, V) > 0) normals();
    geo.attributes.position.needsUpdate = true;
    geo.attributes.normal.needsUpdate = true;
    geo.computeBoundingSphere();
  }

  /// Vertex normals: the sum of the incident triangles' area vectors, normalised.
  function normals() {
    acc.fill(0);
    for (let t = 0; t < tri.length; t += 3) {
      const a = 3 * tri[t], b = 3 * tri[t + 1], c = 3 * tri[t + 2];
      const ux = pos[b] - pos[a], uy = pos[b + 1] - pos[a + 1], uz = pos[b + 2] - pos[a + 2];
      const vx = pos[c] - pos[a], vy = pos[c + 1] - pos[a + 1], vz = pos[c + 2] - pos[a + 2];
      const nx = uy * vz - uz * vy, ny = uz * vx - ux * vz, nz = ux * vy - uy * vx;
      acc[a] += nx; acc[a + 1] += ny; acc[a + 2] += nz;
      acc[b] += nx; acc[b + 1] += ny; acc[b + 2] += nz;
      acc[c] += nx; acc[c + 1] += ny; acc[c + 2] += nz;
    }
    for (let k = 0; k < 3 * V; k += 3) {
      const l = Math.sqrt(acc[k] * acc[k] + acc[k + 1] * acc[k + 1] + acc[k + 2] * acc[k + 2]) || 1;
      nor[k] = acc[k] / l; nor[k + 1] = acc[k + 1] / l; nor[k + 2] = acc[k + 2] / l;
    }
  }
  return { geo, update };
}
