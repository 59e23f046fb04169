// @ts-check
/** Axes, grid and labels for the canvas plots. Pure drawing. */
import { niceTicks } from '../lib/ticks.js';

/** Plot colours shared by the canvas plots (dark theme). */
export const PLOT_COLOURS = {
  background: '#161a20',
  grid: '#262d37',
  axis: '#6b7685',
  text: '#c9d1db',
};

/**
 * Clear the canvas and draw a framed grid with tick labels and axis titles.
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} scale
 * @param {{widthPx: number, heightPx: number, pixelRatio: number, xLabel: string, yLabel: string}} options
 */
export function drawAxes(ctx, scale, options) {
  const { widthPx, heightPx, pixelRatio } = options;
  ctx.setTransform(pixelRatio, 0, 0, pixelRatio, 0, 0);
  ctx.fillStyle = PLOT_COLOURS.background;
  ctx.fillRect(0, 0, widthPx, heightPx);
  ctx.font = '11px system-ui, sans-serif';
  ctx.lineWidth = 1;
  ctx.strokeStyle = PLOT_COLOURS.grid;
  ctx.fillStyle = PLOT_COLOURS.text;
  const xTicks = niceTicks(scale.xRange[0], scale.xRange[1], Math.max(4, Math.round((scale.right - scale.left) / 70)));
  const yTicks = niceTicks(scale.yRange[0], scale.yRange[1], Math.max(4, Math.round((scale.bottom - scale.top) / 40)));
  ctx.beginPath();
  for (const t of xTicks) {
    const x = Math.round(scale.toX(t)) + 0.5;
    ctx.moveTo(x, scale.top);
    ctx.lineTo(x, scale.bottom);
  }
  for (const t of yTicks) {
    const y = Math.round(scale.toY(t)) + 0.5;
    ctx.moveTo(scale.left, y);
    ctx.lineTo(scale.right, y);
  }
  ctx.stroke();
  ctx.textAlign = 'center';
  ctx.textBaseline = 'top';
  for (const t of xTicks) ctx.fillText(String(t), scale.toX(t), scale.bottom + 4);
  ctx.textAlign = 'right';
  ctx.textBaseline = 'middle';
  for (const t of yTicks) ctx.fillText(String(t), scale.left - 5, scale.toY(t));
  ctx.strokeStyle = PLOT_COLOURS.axis;
  ctx.strokeRect(scale.left + 0.5, scale.top + 0.5, scale.right - scale.left, scale.bottom - scale.top);
  ctx.textAlign = 'center';
  ctx.textBaseline = 'bottom';
  ctx.fillText(options.xLabel, (scale.left + scale.right) / 2, heightPx - 2);
  ctx.save();
  ctx.translate(12, (scale.top + scale.bottom) / 2);
  ctx.rotate(-Math.PI / 2);
  ctx.textBaseline = 'middle';
  ctx.fillText(options.yLabel, 0, 0);
  ctx.restore();
}

/**
 * Stroke a polyline in the order given, breaking at null/NaN — never sorted, so a
 * multi-valued curve (the flange) keeps its true shape.
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} scale
 * @param {ArrayLike<number|null>} xs
 * @param {ArrayLike<number|null>} ys
 */
export function strokePolyline(ctx, scale, xs, ys) {
  ctx.beginPath();
  let pen = false;
  for (let i = 0; i < xs.length; i += 1) {
    const x = xs[i];
    const y = ys[i];
    if (x === null || y === null || !Number.isFinite(x) || !Number.isFinite(y)) {
      pen = false;
      continue;
    }
    if (pen) ctx.lineTo(scale.toX(x), scale.toY(y));
    else ctx.moveTo(scale.toX(x), scale.toY(y));
    pen = true;
  }
  ctx.stroke();
}

/**
 * Fill a square of `sizePx` CSS px at each finite point, in one path (the fill style is
 * the caller's); points without a value are skipped.
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} scale
 * @param {ArrayLike<number|null>} xs
 * @param {ArrayLike<number|null>} ys
 * @param {number} sizePx
 * @returns {number} points drawn
 */
export function fillPoints(ctx, scale, xs, ys, sizePx) {
  const half = sizePx / 2;
  let drawn = 0;
  ctx.beginPath();
  for (let i = 0; i < xs.length; i += 1) {
    const x = xs[i];
    const y = ys[i];
    if (x === null || y === null || !Number.isFinite(x) || !Number.isFinite(y)) continue;
    ctx.rect(scale.toX(x) - half, scale.toY(y) - half, sizePx, sizePx);
    drawn += 1;
  }
  ctx.fill();
  return drawn;
}
