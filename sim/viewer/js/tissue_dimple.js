// The dimple a tool's sphere presses into an organ given by its material, drawn (docs/viewer.md,
// "Tissue given by its material"; docs/tissue.md, "The contact"). The organ's net carries the
// tissue's deformation on the scale of the contact's load patch; under the patch, the two-scale
// law takes the half-space's own approach, which no node shows: the sphere sinks into the drawn
// surface by it (2.75 mm at 4.4 N on the default scene's organ). The page draws that part as a
// Hertzian sphere's dimple (Johnson 1985, "Contact Mechanics", §3.4: the surface of a half-space
// pressed a depth δ by a rigid sphere of radius R): u(ρ) = δ − ρ² / (2R) inside the contact
// radius a = √(R δ), u(ρ) = (δ / π) [(2 − ρ²/a²) asin(a/ρ) + (ρ/a) √(1 − a²/ρ²)] outside it (δ/2 at
// the rim, falling as 1/ρ), cut off at kReachRadii contact radii (less its value there, so that it
// is continuous); then any drawn vertex still inside a sphere is put on the sphere's surface
// along the surface's inward normal. A view of the simulation only: nothing of it goes back.
// The OpenIGTLink surfaces draw the same (sim/src/view/tissue_dimple.hpp, its C++ twin: keep the
// two alike). Pure functions on typed arrays (no three.js), so that node can test them.

/// How far a dimple reaches, in contact radii (beyond it the surface is left as the net puts it).
export const kReachRadii = 6;

/// Hertz's surface displacement (m) at distance `rho` (m) from the axis of a sphere of radius `R`
/// (m) pressed `delta` (m, > 0) into a half-space: δ − ρ²/(2R) within a = √(R δ), the exterior
/// field beyond it (Johnson 1985, eq. 3.42).
export function hertzDisplacement(rho, R, delta) {
  if (!(delta > 0)) return 0;
  const a = Math.sqrt(R * delta);
  if (rho <= a) return delta - (rho * rho) / (2 * R);
  const s = a / rho;
  return (delta / Math.PI) * ((2 - 1 / (s * s)) * Math.asin(s) + Math.sqrt(1 - s * s) / s);
}

/// Moves the `count` vertices `pos` (Float32Array or Float64Array, 3 per vertex, world m) of an
/// organ's drawn surface into the dimples the spheres `spheres` ([{ c: [x, y, z], r }], world m)
/// press into it; `nor` their unit outward normals before (3 per vertex); `moves` a
/// Float64Array of at least `count` entries (scratch: nothing is allocated). Per sphere: the
/// vertex nearest its centre within its radius gives the axis (its normal n₀) and the depth δ
/// (the sphere's reach below that vertex's tangent plane); each vertex facing the same way
/// (n · n₀ > 0), within kReachRadii contact radii of the axis and of that vertex's level along
/// it, is moved along −n by the largest displacement any sphere gives it; then any vertex still
/// inside a sphere is put on its surface. Returns the largest move (m).
export function pressDimples(pos, nor, count, spheres, moves) {
  moves.fill(0, 0, count);
  let largest = 0;
  // The surface's bounds: a sphere that does not reach them presses nothing (one pass, instead
  // of one per sphere).
  let lx = Infinity, ly = Infinity, lz = Infinity, hx = -Infinity, hy = -Infinity, hz = -Infinity;
  for (let k = 0; k < 3 * count; k += 3) {
    if (pos[k] < lx) lx = pos[k];
    if (pos[k] > hx) hx = pos[k];
    if (pos[k + 1] < ly) ly = pos[k + 1];
    if (pos[k + 1] > hy) hy = pos[k + 1];
    if (pos[k + 2] < lz) lz = pos[k + 2];
    if (pos[k + 2] > hz) hz = pos[k + 2];
  }
  const reaches = ({ c, r }) => r > 0 && c[0] > lx - r && c[0] < hx + r && c[1] > ly - r && c[1] < hy + r &&
                                c[2] > lz - r && c[2] < hz + r;
  spheres = spheres.filter(reaches);
  for (const { c, r } of spheres) {
    // The vertex nearest the sphere's centre within its radius: the axis and the depth there.
    let best = -1, bestD2 = r * r;
    for (let i = 0; i < count; ++i) {
      const i3 = 3 * i;
      const dx = pos[i3] - c[0], dy = pos[i3 + 1] - c[1], dz = pos[i3 + 2] - c[2];
      const d2 = dx * dx + dy * dy + dz * dz;
      if (d2 < bestD2) bestD2 = d2, best = i;
    }
    if (best < 0) continue;
    const b3 = 3 * best;
    const nx = nor[b3], ny = nor[b3 + 1], nz = nor[b3 + 2];
    // Depth: the sphere's reach below the vertex's tangent plane.
    const delta = r - ((c[0] - pos[b3]) * nx + (c[1] - pos[b3 + 1]) * ny + (c[2] - pos[b3 + 2]) * nz);
    if (!(delta > 0)) continue;
    const a = Math.sqrt(r * delta);
    const reach = kReachRadii * a, floor = hertzDisplacement(reach, r, delta);
    const level = delta - r;  // the nearest vertex's place along the axis from the centre
    for (let i = 0; i < count; ++i) {
      const i3 = 3 * i;
      if (nor[i3] * nx + nor[i3 + 1] * ny + nor[i3 + 2] * nz <= 0) continue;
      const ex = pos[i3] - c[0], ey = pos[i3 + 1] - c[1], ez = pos[i3 + 2] - c[2];
      const along = ex * nx + ey * ny + ez * nz;
      if (!(Math.abs(along - level) < reach)) continue;
      const lx = ex - along * nx, ly = ey - along * ny, lz = ez - along * nz;
      const rho = Math.sqrt(lx * lx + ly * ly + lz * lz);
      if (!(rho < reach)) continue;
      const u = hertzDisplacement(rho, r, delta) - floor;
      if (u > moves[i]) moves[i] = u;
    }
  }
  for (let i = 0; i < count; ++i) {
    const u = moves[i];
    if (!(u > 0)) continue;
    const i3 = 3 * i;
    pos[i3] -= u * nor[i3];
    pos[i3 + 1] -= u * nor[i3 + 1];
    pos[i3 + 2] -= u * nor[i3 + 2];
    if (u > largest) largest = u;
  }
  // What is still inside a sphere (a curved surface, or spheres side by side) onto its surface,
  // along the vertex's inward normal: the exit of the line p − t n from the sphere.
  for (const { c, r } of spheres) {
    for (let i = 0; i < count; ++i) {
      const i3 = 3 * i;
      const ex = pos[i3] - c[0], ey = pos[i3 + 1] - c[1], ez = pos[i3 + 2] - c[2];
      const e2 = ex * ex + ey * ey + ez * ez;
      if (!(e2 < r * r)) continue;
      const en = ex * nor[i3] + ey * nor[i3 + 1] + ez * nor[i3 + 2];
      const t = en + Math.sqrt(en * en - e2 + r * r);
      pos[i3] -= t * nor[i3];
      pos[i3 + 1] -= t * nor[i3 + 1];
      pos[i3 + 2] -= t * nor[i3 + 2];
      const moved = moves[i] + t;
      if (moved > largest) largest = moved;
    }
  }
  return largest;
}
