// @ts-check
/**
 * Adaptive − Steger along the stripe: a scatter of the signed offset (px) against the
 * position along the stripe, with the zero line and the ±RMS band. The Δ axis spans the bulk
 * of the offsets; larger ones are drawn on its edge. Pure drawing.
 */
import { boundsOf } from '../lib/ticks.js';
import { makePlotScale } from '../lib/plot-scale.js';
import { drawAxes } from './axes.js';

/**
 * Draw the difference plot filling a canvas of the given CSS size.
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/method-difference.js').MethodDifference} diff
 * @param {{widthPx: number, heightPx: number, pixelRatio: number}} options
 * @returns {boolean} false when there were no pairs to draw
 */
export function drawDifference(ctx, diff, options) {
  const xRange = boundsOf([diff.alongPx]);
  if (!xRange) return false;
  // scale to the bulk (98th percentile of |Δ|), not to a few outliers; those sit on the edge
  const sortedAbs = Float64Array.from(diff.diffPx, Math.abs).sort();
  const p98 = sortedAbs[Math.floor(0.98 * (sortedAbs.length - 1))];
  const limit = Math.max(0.25, Math.min(3, 1.25 * p98));
  const scale = makePlotScale(xRange, [-limit, limit], {
    ...options,
    margin: { left: 44, right: 12, top: 8, bottom: 32 },
    padFraction: 0.02,
  });
  drawAxes(ctx, scale, { ...options, xLabel: 'along stripe (px)', yLabel: 'Δ (px)' });
  ctx.fillStyle = 'rgba(255,255,255,0.07)';
  const top = scale.toY(diff.rmsPx);
  ctx.fillRect(scale.left, top, scale.right - scale.left, scale.toY(-diff.rmsPx) - top);
  ctx.strokeStyle = '#9aa5b1';
  ctx.beginPath();
  ctx.moveTo(scale.left, Math.round(scale.toY(0)) + 0.5);
  ctx.lineTo(scale.right, Math.round(scale.toY(0)) + 0.5);
  ctx.stroke();
  ctx.fillStyle = '#e8b04a';
  ctx.beginPath();
  for (let i = 0; i < diff.alongPx.length; i += 1) {
    const d = Math.max(-limit, Math.min(limit, diff.diffPx[i]));
    ctx.rect(scale.toX(diff.alongPx[i]) - 1, scale.toY(d) - 1, 2, 2);
  }
  ctx.fill();
  return true;
}
