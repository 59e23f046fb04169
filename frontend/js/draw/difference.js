// @ts-check
/**
 * Adaptive − Steger along the stripe: a scatter of the signed offset (px) against the
 * position along the stripe, with the zero line and the ±RMS band (shaded). The Δ axis spans
 * every offset (at most the pairing radius, so none is clipped). Pure drawing.
 */
import { boundsOf } from '../lib/ticks.js';
import { makePlotScale } from '../lib/plot-scale.js';
import { drawAxes } from './axes.js';

/**
 * Draw the difference plot filling a canvas of the given CSS size.
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/method-difference.js').MethodDifference} diff
 * @param {{widthPx: number, heightPx: number, pixelRatio: number, marker?: number}} options
 *   marker: index of a pair to ring (the hovered one)
 * @returns {import('../lib/plot-scale.js').PlotScale|false} the plot's scale (for hit tests),
 *   false when there were no pairs to draw
 */
export function drawDifference(ctx, diff, options) {
  const xRange = boundsOf([diff.alongPx]);
  if (!xRange) return false;
  // every offset on the plot: pairs are at most the pairing radius apart (2 px), so the
  // largest |Δ| with a little room bounds the axis
  const limit = Math.max(0.25, 1.08 * diff.maxAbsPx);
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
    ctx.rect(scale.toX(diff.alongPx[i]) - 1, scale.toY(diff.diffPx[i]) - 1, 2, 2);
  }
  ctx.fill();
  const m = options.marker;
  if (m !== undefined && m >= 0 && m < diff.alongPx.length) {
    ctx.strokeStyle = '#ffffff';
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    ctx.arc(scale.toX(diff.alongPx[m]), scale.toY(diff.diffPx[m]), 5, 0, 2 * Math.PI);
    ctx.stroke();
  }
  return scale;
}
