// @ts-check
/** A horizontal colour bar with ticks and a unit, for data layers. Pure drawing. */
import { niceTicks } from '../lib/ticks.js';

/**
 * @typedef {object} LegendData
 * @property {Uint8ClampedArray} lut 256 RGB triplets
 * @property {number} min value at the left end
 * @property {number} max value at the right end
 * @property {string} label title with unit, e.g. "σ (px)"
 * @property {number[]} [marks] values marked on the bar (the configured scales σ1..σ3),
 *   labelled in place of round ticks
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
  const marks = data.marks?.length ? data.marks : niceTicks(data.min, data.max, 5);
  for (const [i, t] of marks.entries()) {
    const x = left + ((right - left) * (t - data.min)) / (data.max - data.min);
    ctx.fillRect(x - 0.5, barTop + barHeight, 1, 3);
    // labels at the bar's ends stay inside the canvas
    ctx.textAlign = i === 0 && x - left < 12 ? 'left' : i === marks.length - 1 && right - x < 12 ? 'right' : 'center';
    ctx.fillText(data.marks?.length ? t.toFixed(2) : String(t), x, barTop + barHeight + 4);
  }
}
