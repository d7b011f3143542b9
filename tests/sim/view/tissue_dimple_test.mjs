// Tests of sim/viewer/js/tissue_dimple.js (docs/viewer.md, "Tissue given by its material"): the
// dimple the page draws where a tool's sphere presses an organ given by its material. Run by
// CTest as viewer_tissue_dimple (`node --test`; skipped where node is missing).
import { test } from 'node:test';
import assert from 'node:assert/strict';
import { copyFileSync, mkdtempSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { fileURLToPath, pathToFileURL } from 'node:url';

// The page's module is an ES module in a .js file of a package without "type": "module" (the
// browser does not ask): imported here as a .mjs copy, which every node takes as one.
const source = fileURLToPath(new URL('../../../sim/viewer/js/tissue_dimple.js', import.meta.url));
const copy = join(mkdtempSync(join(tmpdir(), 'numen-dimple-')), 'tissue_dimple.mjs');
copyFileSync(source, copy);
const { hertzDisplacement, kReachRadii, pressDimples } = await import(pathToFileURL(copy).href);

/// A flat square grid of (2n + 1)² vertices `h` apart in z = 0, normals +z.
function flatGrid(n, h) {
  const count = (2 * n + 1) ** 2, pos = new Float64Array(3 * count), nor = new Float64Array(3 * count);
  let k = 0;
  for (let j = -n; j <= n; ++j)
    for (let i = -n; i <= n; ++i, ++k) {
      pos[3 * k] = i * h;
      pos[3 * k + 1] = j * h;
      nor[3 * k + 2] = 1;
    }
  return { count, pos, nor };
}

test("Hertz's surface: delta under the centre, delta / 2 at the rim, continuous, falling as 1 / rho", () => {
  const R = 0.0025, delta = 0.001, a = Math.sqrt(R * delta);
  assert.ok(Math.abs(hertzDisplacement(0, R, delta) - delta) < 1e-15);
  assert.ok(Math.abs(hertzDisplacement(a, R, delta) - delta / 2) < 1e-12);
  assert.ok(Math.abs(hertzDisplacement(a * (1 + 1e-9), R, delta) - delta / 2) < 1e-9 * delta);
  // Far out: (4 / 3π) δ a / ρ.
  const far = 100 * a;
  assert.ok(Math.abs(hertzDisplacement(far, R, delta) / ((4 / (3 * Math.PI)) * delta * a / far) - 1) < 1e-3);
  let last = Infinity;
  for (let rho = 0; rho < 10 * a; rho += a / 50) {
    const u = hertzDisplacement(rho, R, delta);
    assert.ok(u < last && u > 0, `decreasing and positive at ${rho}`);
    last = u;
  }
  assert.equal(hertzDisplacement(a, R, 0), 0);
});

test('a sphere pressed 1 mm into a flat surface: the dimple under it, no vertex inside it, the far surface left', () => {
  const R = 0.0025, delta = 0.001, h = 0.0002;
  const g = flatGrid(60, h);  // 24 mm square
  const before = Float64Array.from(g.pos);
  const c = [0, 0, R - delta];
  const moves = new Float64Array(g.count);
  const largest = pressDimples(g.pos, g.nor, g.count, [{ c, r: R }], moves);
  assert.ok(Math.abs(largest - delta) < 1e-12, `the largest move is the depth: ${largest}`);
  const a = Math.sqrt(R * delta), reach = kReachRadii * a, floor = hertzDisplacement(reach, R, delta);
  for (let k = 0; k < g.count; ++k) {
    const x = g.pos[3 * k], y = g.pos[3 * k + 1], z = g.pos[3 * k + 2];
    assert.equal(x, before[3 * k]);  // moved along the normal only
    assert.equal(y, before[3 * k + 1]);
    const rho = Math.hypot(x, y);
    const inside = Math.hypot(x - c[0], y - c[1], z - c[2]) < R - 1e-12;
    assert.ok(!inside, `vertex ${k} at rho ${rho} is inside the sphere`);
    if (rho >= reach) assert.equal(z, 0, `beyond the reach at ${rho}`);
    else if (rho > 1.05 * a) assert.ok(Math.abs(-z - (hertzDisplacement(rho, R, delta) - floor)) < 1e-15, `Hertz at ${rho}`);
  }
  // Continuous: no step between neighbours larger than the slope allows.
  const n = 121;
  for (let i = 0; i + 1 < n; ++i) {
    const k = 60 * n + i;  // the row through the centre
    assert.ok(Math.abs(g.pos[3 * (k + 1) + 2] - g.pos[3 * k + 2]) < 0.2 * delta, `step at column ${i}`);
  }
});

test('the surface facing away and a sphere that does not reach the surface are left alone', () => {
  const R = 0.0025, h = 0.0005;
  const g = flatGrid(10, h);
  for (let k = 0; k < g.count; ++k) g.nor[3 * k + 2] = -1;  // the surface's underside
  const moves = new Float64Array(g.count);
  // Pressing from below into an underside means n · n₀ > 0 again: a sphere above it, pressing
  // from the wrong side, meets the underside from within: it is put on the sphere only where a
  // vertex is inside it.
  const above = Float64Array.from(g.pos);
  assert.equal(pressDimples(g.pos, g.nor, g.count, [{ c: [0, 0, R + 1e-4], r: R }], moves), 0);
  assert.deepEqual(g.pos, above);
  assert.equal(pressDimples(g.pos, g.nor, g.count, [], moves), 0);
  assert.deepEqual(g.pos, above);
});

test('two spheres side by side: each vertex takes the deeper dimple, none is inside either', () => {
  const R = 0.0015, delta = 0.0006, h = 0.0001;
  const g = flatGrid(80, h);
  const spheres = [{ c: [-0.001, 0, R - delta], r: R }, { c: [0.001, 0, R - delta], r: R }];
  const moves = new Float64Array(g.count);
  pressDimples(g.pos, g.nor, g.count, spheres, moves);
  for (let k = 0; k < g.count; ++k) {
    const p = [g.pos[3 * k], g.pos[3 * k + 1], g.pos[3 * k + 2]];
    for (const { c, r } of spheres) assert.ok(Math.hypot(p[0] - c[0], p[1] - c[1], p[2] - c[2]) >= r - 1e-12);
    assert.ok(-p[2] <= delta + 1e-12, 'no deeper than a sphere');
  }
});
