// @ts-check
/** A horizontal colour bar with ticks and a unit, for data layers. Pure drawing. */
import { niceTicks } from '../lib/ticks.js';

/**
 * @typedef {object} LegendData
 * @property {Uint8ClampedArray} lut 256 RGB triplets
 * @property {number} min value at the left end
 * @property {number} max value at the right end
 * @property {string} label title with unit, e.g. "σ (px)"
 */

/**
 * Draw the colour bar filling a canvas of the given CSS size.
 * @param {CanvasRenderingContext2D} ctx
 * @param {LegendData} data
 * @param {{widthPx: number, heightPx: number, pixelRatio: number}} options
 */
export function drawColourLegend(ctx, data, options) {
  const { widthPx, heightPx, pixelRatio } = options;
  ctx.setTransform(pixelRatio, 0, 0, pixelRatio, 0, 0);
  ctx.clearRect(0, 0, widthPx, heightPx);
  const left = 8;
  const right = widthPx - 8;
  const barTop = 16;
  const barHeight = Math.max(6, heightPx - 34);
  for (let i = 0; i < 256; i += 1) {
    const x = left + ((right - left) * i) / 256;
    ctx.fillStyle = `rgb(${data.lut[3 * i]},${data.lut[3 * i + 1]},${data.lut[3 * i + 2]})`;
    ctx.fillRect(x, barTop, (right - left) / 256 + 0.5, barHeight);
  }
  ctx.strokeStyle = '#8a94a3';
  ctx.strokeRect(left, barTop, right - left, barHeight);
  ctx.fillStyle = '#d6dce4';
  ctx.font = '11px system-ui, sans-serif';
  ctx.textBaseline = 'top';
  ctx.textAlign = 'left';
  ctx.fillText(data.label, left, 2);
  ctx.textAlign = 'center';
  for (const t of niceTicks(data.min, data.max, 5)) {
    const x = left + ((right - left) * (t - data.min)) / (data.max - data.min);
    ctx.fillRect(x - 0.5, barTop + barHeight, 1, 3);
    ctx.fillText(String(t), x, barTop + barHeight + 4);
  }
}
