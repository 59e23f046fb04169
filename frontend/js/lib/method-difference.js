// @ts-check
/**
 * Adaptive − Steger along the stripe: pairs each adaptive centre with the nearest Steger
 * centre and reports their signed offset along the stripe normal. Display arithmetic on the
 * two centre sets the API returns; no wheel parameter is computed here.
 */
import { buildPointIndex, nearestPoint } from './point-index.js';

/**
 * @typedef {object} CentreColumns columnar centres as the API emits them (px)
 * @property {number[]} x
 * @property {number[]} y
 * @property {number[]} nx
 * @property {number[]} ny
 * @property {number[]} [sigma]
 * @property {number[]} [strength]
 */

/**
 * @typedef {object} MethodDifference
 * @property {Float64Array} alongPx position along the stripe's main axis, px
 * @property {Float64Array} diffPx signed offset adaptive − Steger along the normal, px
 * @property {Float64Array} x adaptive centre x of each pair, px
 * @property {Float64Array} y adaptive centre y of each pair, px
 * @property {number} unmatched adaptive centres with no Steger centre within the radius
 * @property {number} meanPx mean of diffPx (NaN when empty)
 * @property {number} rmsPx root mean square of diffPx (NaN when empty)
 * @property {number} maxAbsPx largest |diffPx| (NaN when empty)
 */

/**
 * Pair adaptive with Steger centres and measure their offset along the stripe.
 * @param {CentreColumns} adaptive
 * @param {CentreColumns} steger
 * @param {number} [maxDistPx] pairing radius, px
 * @returns {MethodDifference}
 */
export function differenceAlongStripe(adaptive, steger, maxDistPx = 2) {
  const index = buildPointIndex(steger.x, steger.y, Math.max(1, maxDistPx));
  const [ux, uy] = principalAxis(adaptive.x, adaptive.y);
  const n = adaptive.x.length;
  const along = new Float64Array(n);
  const diff = new Float64Array(n);
  const px = new Float64Array(n);
  const py = new Float64Array(n);
  let k = 0;
  for (let i = 0; i < n; i += 1) {
    const j = nearestPoint(index, adaptive.x[i], adaptive.y[i], maxDistPx);
    if (j < 0) continue;
    // orient the normal consistently (towards +perpendicular of the main axis) so the
    // sign of the offset means the same thing along the whole stripe
    const flip = adaptive.nx[i] * -uy + adaptive.ny[i] * ux < 0 ? -1 : 1;
    const dx = adaptive.x[i] - steger.x[j];
    const dy = adaptive.y[i] - steger.y[j];
    diff[k] = flip * (dx * adaptive.nx[i] + dy * adaptive.ny[i]);
    along[k] = adaptive.x[i] * ux + adaptive.y[i] * uy;
    px[k] = adaptive.x[i];
    py[k] = adaptive.y[i];
    k += 1;
  }
  const d = diff.slice(0, k);
  return {
    alongPx: along.slice(0, k),
    diffPx: d,
    x: px.slice(0, k),
    y: py.slice(0, k),
    unmatched: n - k,
    ...summarise(d),
  };
}

/**
 * Unit vector of the main (largest-variance) axis of a point set; (1, 0) when degenerate.
 * @param {ArrayLike<number>} x
 * @param {ArrayLike<number>} y
 * @returns {[number, number]}
 */
export function principalAxis(x, y) {
  const n = x.length;
  if (n < 2) return [1, 0];
  let mx = 0;
  let my = 0;
  for (let i = 0; i < n; i += 1) {
    mx += x[i];
    my += y[i];
  }
  mx /= n;
  my /= n;
  let sxx = 0;
  let sxy = 0;
  let syy = 0;
  for (let i = 0; i < n; i += 1) {
    const dx = x[i] - mx;
    const dy = y[i] - my;
    sxx += dx * dx;
    sxy += dx * dy;
    syy += dy * dy;
  }
  // angle of the major axis of the 2×2 covariance matrix
  const angle = 0.5 * Math.atan2(2 * sxy, sxx - syy);
  const ux = Math.cos(angle);
  const uy = Math.sin(angle);
  // point the axis so that "along" grows with x, or with y for a vertical stripe
  return ux < -1e-9 || (Math.abs(ux) <= 1e-9 && uy < 0) ? [-ux, -uy] : [ux, uy];
}

/**
 * @param {Float64Array} d
 * @returns {{meanPx: number, rmsPx: number, maxAbsPx: number}}
 */
function summarise(d) {
  if (d.length === 0) return { meanPx: NaN, rmsPx: NaN, maxAbsPx: NaN };
  let sum = 0;
  let sumSq = 0;
  let maxAbs = 0;
  for (const v of d) {
    sum += v;
    sumSq += v * v;
    maxAbs = Math.max(maxAbs, Math.abs(v));
  }
  return { meanPx: sum / d.length, rmsPx: Math.sqrt(sumSq / d.length), maxAbsPx: maxAbs };
}
