// @ts-check
/**
 * The wheel review canvas: camera frame, stripe mask, σ map and the centre points of both
 * methods, under a pan/zoom viewport. Pure drawing: (ctx, data, options), no DOM lookups.
 */
import { visibleImageRect } from '../lib/viewport.js';

/** Point colours: adaptive orange, Steger cyan (distinct for common colour blindness);
 * Steger's dots are drawn smaller on top of the adaptive ones. */
export const METHOD_COLOURS = { adaptive: '#ff7a1a', steger: '#22c3ee', handheld: '#a3e635' };
/** Candidates a method rejected (where the extraction stores them): rose, never a centre colour. */
export const REJECTED_COLOUR = '#f43f5e';

/**
 * @typedef {object} FrameLayers
 * @property {CanvasImageSource|null} image the camera frame (full resolution)
 * @property {CanvasImageSource|null} mask tinted stripe mask, same size as the frame
 * @property {CanvasImageSource|null} sigma coloured σ map (RGBA), same size as the frame
 * @property {Array<{method: string, x: ArrayLike<number>, y: ArrayLike<number>}>} centres
 * @property {{x: number, y: number}|null} highlight the hovered centre, image px
 * @property {Array<{method: string, x: ArrayLike<number>, y: ArrayLike<number>}>} [rejected]
 *   candidate points each method rejected, drawn under its centres while they are shown
 */

/**
 * @typedef {object} FrameOptions
 * @property {import('../lib/viewport.js').Viewport} viewport
 * @property {number} widthPx canvas width, CSS px
 * @property {number} heightPx canvas height, CSS px
 * @property {number} pixelRatio device pixels per CSS px
 * @property {{image: boolean, mask: boolean, sigma: boolean, adaptive: boolean, steger: boolean}} show
 * @property {number} [sigmaAlpha] opacity of the σ map, 0..1
 */

/**
 * Draw every visible layer; returns the number of centre points drawn (after culling).
 * @param {CanvasRenderingContext2D} ctx
 * @param {FrameLayers} layers
 * @param {FrameOptions} options
 * @returns {number}
 */
export function drawFrame(ctx, layers, options) {
  const { viewport: vp, widthPx, heightPx, pixelRatio, show } = options;
  ctx.setTransform(pixelRatio, 0, 0, pixelRatio, 0, 0);
  ctx.fillStyle = '#111418';
  ctx.fillRect(0, 0, widthPx, heightPx);
  // image pixel [r, c] covers x ∈ [c − 0.5, c + 0.5]: draw images shifted by half a pixel
  ctx.save();
  ctx.setTransform(
    pixelRatio * vp.scale,
    0,
    0,
    pixelRatio * vp.scale,
    pixelRatio * (vp.offsetX - 0.5 * vp.scale),
    pixelRatio * (vp.offsetY - 0.5 * vp.scale),
  );
  ctx.imageSmoothingEnabled = vp.scale < 2;
  if (show.image && layers.image) ctx.drawImage(layers.image, 0, 0);
  if (show.mask && layers.mask) ctx.drawImage(layers.mask, 0, 0);
  // σ is defined inside the mask only: on top, so its colours read true against the legend
  if (show.sigma && layers.sigma) {
    ctx.globalAlpha = options.sigmaAlpha ?? 0.85;
    ctx.drawImage(layers.sigma, 0, 0);
    ctx.globalAlpha = 1;
  }
  ctx.restore();
  for (const set of layers.rejected ?? []) {
    if (show[/** @type {'adaptive'|'steger'} */ (set.method)])
      drawPoints(ctx, set.x, set.y, REJECTED_COLOUR, 0.8, options);
  }
  let drawn = 0;
  for (const set of layers.centres) {
    if (!show[/** @type {'adaptive'|'steger'} */ (set.method)]) continue;
    // Steger's dots are smaller, so where both methods agree both stay visible
    const dotScale = set.method === 'steger' ? 0.55 : 1;
    drawn += drawPoints(ctx, set.x, set.y, METHOD_COLOURS[set.method] ?? '#fff', dotScale, options);
  }
  if (layers.highlight) drawHighlight(ctx, layers.highlight, vp);
  return drawn;
}

/**
 * @param {CanvasRenderingContext2D} ctx
 * @param {ArrayLike<number>} x
 * @param {ArrayLike<number>} y
 * @param {string} colour
 * @param {number} dotScale size relative to the default dot
 * @param {FrameOptions} options
 * @returns {number} points drawn
 */
function drawPoints(ctx, x, y, colour, dotScale, options) {
  const { viewport: vp, widthPx, heightPx } = options;
  const [x0, y0, x1, y1] = visibleImageRect(vp, widthPx, heightPx);
  // a dot grows with zoom up to a third of an image pixel, never below 1.5 CSS px
  const size = dotScale * Math.max(2, Math.min(vp.scale / 3, 8));
  const half = size / 2;
  ctx.fillStyle = colour;
  ctx.beginPath();
  let drawn = 0;
  for (let i = 0; i < x.length; i += 1) {
    const xi = x[i];
    const yi = y[i];
    if (xi < x0 || xi > x1 || yi < y0 || yi > y1) continue;
    ctx.rect(xi * vp.scale + vp.offsetX - half, yi * vp.scale + vp.offsetY - half, size, size);
    drawn += 1;
  }
  ctx.fill();
  return drawn;
}

/**
 * @param {CanvasRenderingContext2D} ctx
 * @param {{x: number, y: number}} point
 * @param {import('../lib/viewport.js').Viewport} vp
 */
function drawHighlight(ctx, point, vp) {
  const sx = point.x * vp.scale + vp.offsetX;
  const sy = point.y * vp.scale + vp.offsetY;
  ctx.strokeStyle = '#ffffff';
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  ctx.arc(sx, sy, 7, 0, 2 * Math.PI);
  ctx.moveTo(sx - 11, sy);
  ctx.lineTo(sx - 4, sy);
  ctx.moveTo(sx + 4, sy);
  ctx.lineTo(sx + 11, sy);
  ctx.stroke();
}
