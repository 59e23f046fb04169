// @ts-check
/** Data → screen mapping of a 2-D plot area, optionally with equal scales on both axes. Pure. */

/**
 * @typedef {object} PlotScale
 * @property {number} left plot area, CSS px
 * @property {number} top
 * @property {number} right
 * @property {number} bottom
 * @property {[number, number]} xRange data range shown on x
 * @property {[number, number]} yRange data range shown on y (up is larger)
 * @property {(x: number) => number} toX data x → screen x
 * @property {(y: number) => number} toY data y → screen y
 */

/**
 * Build a plot scale for a canvas. With `equalAspect`, one data unit is the same length on
 * both axes (a wheel profile keeps its true shape) and the ranges grow to fill the area.
 * @param {[number, number]} xRange
 * @param {[number, number]} yRange
 * @param {{widthPx: number, heightPx: number, margin: {left: number, right: number, top: number, bottom: number}, equalAspect?: boolean, padFraction?: number}} options
 * @returns {PlotScale}
 */
export function makePlotScale(xRange, yRange, options) {
  const { widthPx, heightPx, margin } = options;
  const pad = options.padFraction ?? 0.04;
  const left = margin.left;
  const top = margin.top;
  const right = widthPx - margin.right;
  const bottom = heightPx - margin.bottom;
  let [x0, x1] = padRange(xRange, pad);
  let [y0, y1] = padRange(yRange, pad);
  if (options.equalAspect) {
    const unit = Math.max((x1 - x0) / (right - left), (y1 - y0) / (bottom - top));
    const cx = (x0 + x1) / 2;
    const cy = (y0 + y1) / 2;
    x0 = cx - ((right - left) * unit) / 2;
    x1 = cx + ((right - left) * unit) / 2;
    y0 = cy - ((bottom - top) * unit) / 2;
    y1 = cy + ((bottom - top) * unit) / 2;
  }
  const sx = (right - left) / (x1 - x0);
  const sy = (bottom - top) / (y1 - y0);
  return {
    left,
    top,
    right,
    bottom,
    xRange: [x0, x1],
    yRange: [y0, y1],
    toX: (x) => left + (x - x0) * sx,
    toY: (y) => bottom - (y - y0) * sy,
  };
}

/**
 * @param {[number, number]} range
 * @param {number} fraction
 * @returns {[number, number]}
 */
function padRange([lo, hi], fraction) {
  const span = hi - lo || Math.abs(hi) || 1;
  return [lo - span * fraction, hi + span * fraction];
}

/**
 * Index of the data point drawn nearest to a screen point, within maxPx, or -1.
 * @param {PlotScale} scale
 * @param {ArrayLike<number|null>} xs
 * @param {ArrayLike<number|null>} ys
 * @param {number} sx screen x, CSS px
 * @param {number} sy screen y, CSS px
 * @param {number} maxPx search radius, CSS px
 * @returns {number}
 */
export function nearestOnScreen(scale, xs, ys, sx, sy, maxPx) {
  let best = -1;
  let bestD2 = maxPx * maxPx;
  for (let i = 0; i < xs.length; i += 1) {
    const x = xs[i];
    const y = ys[i];
    if (x === null || y === null) continue;
    const d2 = (scale.toX(x) - sx) ** 2 + (scale.toY(y) - sy) ** 2;
    if (d2 <= bestD2) {
      bestD2 = d2;
      best = i;
    }
  }
  return best;
}
