// @ts-check
/** Axis arithmetic shared by the canvas plots. Pure. */

/**
 * Round tick positions covering [lo, hi] with about `count` steps of 1, 2 or 5 × 10^k.
 * @param {number} lo
 * @param {number} hi
 * @param {number} [count] wanted number of intervals
 * @returns {number[]} ascending ticks inside [lo, hi]
 */
export function niceTicks(lo, hi, count = 5) {
  if (!Number.isFinite(lo) || !Number.isFinite(hi) || hi <= lo) return [];
  const raw = (hi - lo) / Math.max(1, count);
  const power = 10 ** Math.floor(Math.log10(raw));
  const step = [1, 2, 5, 10].map((m) => m * power).find((s) => s >= raw) ?? 10 * power;
  const ticks = [];
  for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) {
    ticks.push(Math.abs(t) < step * 1e-9 ? 0 : Number(t.toPrecision(12)));
  }
  return ticks;
}

/**
 * Bounds [min, max] of several arrays together, skipping null and NaN; null when all empty.
 * @param {Array<ArrayLike<number|null>>} arrays
 * @returns {[number, number]|null}
 */
export function boundsOf(arrays) {
  let lo = Infinity;
  let hi = -Infinity;
  for (const array of arrays) {
    for (let i = 0; i < array.length; i += 1) {
      const v = array[i];
      if (v === null || !Number.isFinite(v)) continue;
      if (v < lo) lo = v;
      if (v > hi) hi = v;
    }
  }
  return lo <= hi ? [lo, hi] : null;
}
