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
 * @property {Float64Array} alongPx path length along the stripe (adaptive centres in API order), px
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
 *
 * The API emits centres in chain order, so the position along the stripe is the running
 * path length over the adaptive centres (a jump between chains adds its length, keeping the
 * position monotonic). The offset's sign is taken on the left of the direction of travel,
 * so it means the same thing along a curved stripe whatever sign each normal carries.
 * @param {CentreColumns} adaptive
 * @param {CentreColumns} steger
 * @param {number} [maxDistPx] pairing radius, px
 * @returns {MethodDifference}
 */
export function differenceAlongStripe(adaptive, steger, maxDistPx = 2) {
  const index = buildPointIndex(steger.x, steger.y, Math.max(1, maxDistPx));
  const n = adaptive.x.length;
  const along = new Float64Array(n);
  const diff = new Float64Array(n);
  const px = new Float64Array(n);
  const py = new Float64Array(n);
  let k = 0;
  let path = 0;
  for (let i = 0; i < n; i += 1) {
    if (i > 0) path += Math.hypot(adaptive.x[i] - adaptive.x[i - 1], adaptive.y[i] - adaptive.y[i - 1]);
    const j = nearestPoint(index, adaptive.x[i], adaptive.y[i], maxDistPx);
    if (j < 0) continue;
    const [tx, ty] = tangentAt(adaptive, i);
    // left of travel: cross(t, n) > 0
    const flip = tx * adaptive.ny[i] - ty * adaptive.nx[i] < 0 ? -1 : 1;
    const dx = adaptive.x[i] - steger.x[j];
    const dy = adaptive.y[i] - steger.y[j];
    diff[k] = flip * (dx * adaptive.nx[i] + dy * adaptive.ny[i]);
    along[k] = path;
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
 * Direction of travel at centre i: the chord between its neighbours (one-sided at the ends).
 * @param {CentreColumns} c
 * @param {number} i
 * @returns {[number, number]}
 */
function tangentAt(c, i) {
  const a = Math.max(0, i - 1);
  const b = Math.min(c.x.length - 1, i + 1);
  return [c.x[b] - c.x[a], c.y[b] - c.y[a]];
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
