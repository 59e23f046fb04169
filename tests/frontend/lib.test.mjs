// Unit tests of the pure front-end helpers (node --test).
import assert from 'node:assert/strict';
import { test } from 'node:test';

import { VIRIDIS, lutIndex } from '../../frontend/js/lib/colormap.js';
import { fmtNumber, fmtSigned, fmtTime } from '../../frontend/js/lib/format.js';
import { tintMask } from '../../frontend/js/lib/layer-pixels.js';
import { differenceAlongStripe } from '../../frontend/js/lib/method-difference.js';
import { makePlotScale, nearestOnScreen } from '../../frontend/js/lib/plot-scale.js';
import { buildPointIndex, nearestPoint } from '../../frontend/js/lib/point-index.js';
import { buildHash, parseHash } from '../../frontend/js/lib/route.js';
import { boundsOf, niceTicks } from '../../frontend/js/lib/ticks.js';
import { fitRegion, fitViewport, imageToScreen, screenToImage, zoomAt } from '../../frontend/js/lib/viewport.js';

/** Deterministic pseudo-random numbers in [0, 1) (fixed seed). */
function lcg(seed) {
  let s = seed >>> 0;
  return () => (s = (1664525 * s + 1013904223) >>> 0) / 2 ** 32;
}

test('parseHash reads the sign-in token make run prints', () => {
  assert.deepEqual(parseHash('#token=wst_ab%2Bc').token, 'wst_ab+c');
});

test('parseHash reads pass and wheel routes with their query', () => {
  assert.deepEqual(parseHash('#/passes/12').params, { passId: '12' });
  const route = parseHash('#/passes/3/wheels/7?method=steger&mask=1');
  assert.equal(route.name, 'wheel');
  assert.deepEqual(route.params, { passId: '3', wheelId: '7' });
  assert.deepEqual(route.query, { method: 'steger', mask: '1' });
  assert.equal(parseHash('').name, 'passes');
  assert.equal(parseHash('#/nowhere').name, 'not-found');
});

test('buildHash round-trips through parseHash and drops empty values', () => {
  const hash = buildHash(['passes', 3, 'wheels', 'w 1'], { method: 'steger', site: '', x: null });
  const route = parseHash(hash);
  assert.deepEqual(route.params, { passId: '3', wheelId: 'w 1' });
  assert.deepEqual(route.query, { method: 'steger' });
});

test('zoomAt keeps the image point under the cursor fixed', () => {
  const vp = fitViewport(1600, 1200, 800, 600);
  const [ix, iy] = screenToImage(vp, 123, 456);
  const zoomed = zoomAt(vp, 3.7, 123, 456);
  const [sx, sy] = imageToScreen(zoomed, ix, iy);
  assert.ok(Math.abs(sx - 123) < 1e-9 && Math.abs(sy - 456) < 1e-9);
  assert.ok(Math.abs(zoomed.scale - 3.7 * vp.scale) < 1e-12);
});

test('fitViewport shows the whole frame edge to edge, centred', () => {
  const vp = fitViewport(1600, 1200, 800, 700);
  assert.equal(vp.scale, 0.5);
  const [left] = imageToScreen(vp, -0.5, 0);
  const [right] = imageToScreen(vp, 1599.5, 0);
  const [, top] = imageToScreen(vp, 0, -0.5);
  const [, bottom] = imageToScreen(vp, 0, 1199.5);
  assert.deepEqual([left, right], [0, 800]);
  assert.deepEqual([top, 700 - bottom], [50, 50]);
});

test('nearestPoint agrees with a brute-force search', () => {
  const rand = lcg(7);
  const x = Array.from({ length: 3000 }, () => rand() * 1600);
  const y = Array.from({ length: 3000 }, () => rand() * 1200);
  const index = buildPointIndex(x, y, 8);
  for (let q = 0; q < 200; q += 1) {
    const qx = rand() * 1600;
    const qy = rand() * 1200;
    let best = -1;
    let bestD2 = 25 * 25;
    for (let i = 0; i < x.length; i += 1) {
      const d2 = (x[i] - qx) ** 2 + (y[i] - qy) ** 2;
      if (d2 <= bestD2) {
        bestD2 = d2;
        best = i;
      }
    }
    const found = nearestPoint(index, qx, qy, 25);
    if (best < 0) assert.equal(found, -1);
    else assert.equal((x[found] - qx) ** 2 + (y[found] - qy) ** 2, bestD2);
  }
});

test('differenceAlongStripe measures a known offset with one sign despite flipped normals', () => {
  // a stripe along 30°, Steger centres shifted by −0.3 px along the normal
  const angle = Math.PI / 6;
  const [ux, uy] = [Math.cos(angle), Math.sin(angle)];
  const [nx, ny] = [-uy, ux];
  const adaptive = { x: [], y: [], nx: [], ny: [] };
  const steger = { x: [], y: [], nx: [], ny: [] };
  for (let i = 0; i < 400; i += 1) {
    const t = i * 0.8;
    const flip = i % 2 ? -1 : 1;
    adaptive.x.push(100 + t * ux);
    adaptive.y.push(50 + t * uy);
    adaptive.nx.push(flip * nx);
    adaptive.ny.push(flip * ny);
    steger.x.push(100 + t * ux - 0.3 * nx);
    steger.y.push(50 + t * uy - 0.3 * ny);
    steger.nx.push(nx);
    steger.ny.push(ny);
  }
  const diff = differenceAlongStripe(adaptive, steger, 2);
  assert.equal(diff.diffPx.length, 400);
  assert.equal(diff.unmatched, 0);
  for (const d of diff.diffPx) assert.ok(Math.abs(Math.abs(d) - 0.3) < 1e-9);
  assert.ok(Math.abs(Math.abs(diff.meanPx) - 0.3) < 1e-9, 'all offsets carry the same sign');
  // the position along the stripe is the path length: 0.8 px per centre here
  for (let i = 1; i < diff.alongPx.length; i += 1)
    assert.ok(Math.abs(diff.alongPx[i] - diff.alongPx[i - 1] - 0.8) < 1e-9);
});

test('differenceAlongStripe keeps its sign around a bend of the stripe', () => {
  // an L: down a vertical line, then right along a horizontal one; Steger 0.25 px to the left of travel
  const a = { x: [], y: [], nx: [], ny: [] };
  const s = { x: [], y: [], nx: [], ny: [] };
  // left of travel (cross(t, n) > 0): going down it is −x, going right it is +y
  const add = (x, y, nx, ny, leftX, leftY) => {
    a.x.push(x);
    a.y.push(y);
    a.nx.push(nx);
    a.ny.push(ny);
    s.x.push(x - 0.25 * leftX);
    s.y.push(y - 0.25 * leftY);
    s.nx.push(nx);
    s.ny.push(ny);
  };
  for (let i = 0; i < 100; i += 1) add(10, i, i % 2 ? -1 : 1, 0, -1, 0);
  for (let i = 1; i < 100; i += 1) add(10 + i, 99, 0, i % 2 ? -1 : 1, 0, 1);
  const diff = differenceAlongStripe(a, s, 2);
  const away = [...diff.diffPx].filter((_, i) => i < 97 || i > 101);
  for (const d of away) assert.ok(Math.abs(d - 0.25) < 1e-9, `offset +0.25 px on both legs, got ${d}`);
});

test('differenceAlongStripe leaves centres without a partner unmatched', () => {
  const a = { x: [0, 10, 20], y: [0, 0, 0], nx: [0, 0, 0], ny: [1, 1, 1] };
  const s = { x: [0.1, 20.2], y: [0.5, 0], nx: [0, 0], ny: [1, 1] };
  const diff = differenceAlongStripe(a, s, 2);
  assert.equal(diff.unmatched, 1);
  assert.equal(diff.diffPx.length, 2);
});

test('niceTicks picks round steps inside the range', () => {
  assert.deepEqual(niceTicks(0, 10, 5), [0, 2, 4, 6, 8, 10]);
  assert.deepEqual(niceTicks(-0.27, 0.27, 6), [-0.2, -0.1, 0, 0.1, 0.2]);
  assert.deepEqual(niceTicks(3, 3, 5), []);
});

test('boundsOf skips null and NaN', () => {
  assert.deepEqual(boundsOf([[3, null, NaN, -1], [7]]), [-1, 7]);
  assert.equal(boundsOf([[null]]), null);
});

test('makePlotScale with equalAspect gives one mm the same length on both axes', () => {
  const s = makePlotScale([0, 140], [-5, 35], {
    widthPx: 460,
    heightPx: 300,
    margin: { left: 44, right: 12, top: 10, bottom: 34 },
    equalAspect: true,
  });
  const xUnit = s.toX(1) - s.toX(0);
  const yUnit = s.toY(0) - s.toY(1);
  assert.ok(Math.abs(xUnit - yUnit) < 1e-9);
  assert.ok(s.toX(0) >= s.left && s.toX(140) <= s.right);
  assert.ok(s.toY(35) >= s.top && s.toY(-5) <= s.bottom);
});

test('VIRIDIS matches matplotlib at both ends and lutIndex clamps', () => {
  assert.deepEqual([...VIRIDIS.slice(0, 3)], [68, 1, 84]);
  assert.deepEqual([...VIRIDIS.slice(765, 768)], [253, 231, 37]);
  assert.equal(lutIndex(-5, 0, 10), 0);
  assert.equal(lutIndex(50, 0, 10), 255);
  assert.equal(lutIndex(NaN, 0, 10), 0);
});

test('tintMask colours mask pixels and rejected centres, and leaves the rest transparent', () => {
  const mask = new Uint8ClampedArray([255, 255, 255, 255, 0, 0, 0, 255, 96, 96, 96, 255]);
  assert.deepEqual([...tintMask(mask, [1, 2, 3, 4], [5, 6, 7, 8])], [1, 2, 3, 4, 0, 0, 0, 0, 5, 6, 7, 8]);
});

test('formatters show missing values as a dash and times in UTC', () => {
  assert.equal(fmtNumber(null), '–');
  assert.equal(fmtNumber(28.456), '28.46');
  assert.equal(fmtSigned(0.1), '+0.10');
  assert.equal(fmtSigned(-0.001), '0.00', 'no negative zero');
  assert.equal(fmtSigned(-0.5), '−0.50');
  assert.equal(fmtTime('2026-11-23T10:00:00+01:00'), '2026-11-23 09:00:00 UTC');
});

test('fitRegion centres a region and fits its larger side', () => {
  const vp = fitRegion(100, 200, 500, 400, 800, 600);
  assert.equal(vp.scale, 2);
  assert.deepEqual(imageToScreen(vp, 300, 300), [400, 300]);
});

test('nearestOnScreen finds the drawn point under the pointer and skips gaps', () => {
  const s = makePlotScale([0, 100], [0, 50], {
    widthPx: 200,
    heightPx: 100,
    margin: { left: 0, right: 0, top: 0, bottom: 0 },
    padFraction: 0,
  });
  const xs = [0, 50, null, 100];
  const zs = [0, 25, null, 50];
  assert.equal(nearestOnScreen(s, xs, zs, s.toX(50) + 3, s.toY(25), 5), 1);
  assert.equal(nearestOnScreen(s, xs, zs, 150, 90, 5), -1);
});
