// @ts-check
/**
 * Pan/zoom arithmetic for the frame canvas. Pure: a viewport is a plain object, every
 * function returns a new one.
 *
 * Screen position (CSS px) = image position (px) × scale + offset. Image pixel [r, c] has its
 * centre at (x = c, y = r) (docs/coordinate-frames.md), so it covers x ∈ [c − 0.5, c + 0.5].
 */

/** @typedef {{scale: number, offsetX: number, offsetY: number}} Viewport */

/** Zoom limits: from a quarter-size overview to 64 screen px per image px. */
export const MIN_SCALE = 0.02;
export const MAX_SCALE = 64;

/**
 * Viewport showing a whole image centred in a canvas.
 * @param {number} imageWidthPx
 * @param {number} imageHeightPx
 * @param {number} canvasWidthPx CSS px
 * @param {number} canvasHeightPx CSS px
 * @returns {Viewport}
 */
export function fitViewport(imageWidthPx, imageHeightPx, canvasWidthPx, canvasHeightPx) {
  const scale = clampScale(Math.min(canvasWidthPx / imageWidthPx, canvasHeightPx / imageHeightPx));
  return {
    scale,
    // the image spans x ∈ [-0.5, W - 0.5]: centre that span
    offsetX: (canvasWidthPx - imageWidthPx * scale) / 2 + 0.5 * scale,
    offsetY: (canvasHeightPx - imageHeightPx * scale) / 2 + 0.5 * scale,
  };
}

/**
 * Viewport showing an image region [xMin, xMax] × [yMin, yMax] (px) centred in a canvas.
 * @param {number} xMin
 * @param {number} yMin
 * @param {number} xMax
 * @param {number} yMax
 * @param {number} canvasWidthPx CSS px
 * @param {number} canvasHeightPx CSS px
 * @returns {Viewport}
 */
export function fitRegion(xMin, yMin, xMax, yMax, canvasWidthPx, canvasHeightPx) {
  const width = Math.max(1, xMax - xMin);
  const height = Math.max(1, yMax - yMin);
  const scale = clampScale(Math.min(canvasWidthPx / width, canvasHeightPx / height));
  return {
    scale,
    offsetX: canvasWidthPx / 2 - ((xMin + xMax) / 2) * scale,
    offsetY: canvasHeightPx / 2 - ((yMin + yMax) / 2) * scale,
  };
}

/**
 * Zoom by a factor keeping the image point under the screen point (sx, sy) fixed.
 * @param {Viewport} vp
 * @param {number} factor > 1 zooms in
 * @param {number} sx screen x, CSS px
 * @param {number} sy screen y, CSS px
 * @returns {Viewport}
 */
export function zoomAt(vp, factor, sx, sy) {
  const scale = clampScale(vp.scale * factor);
  const [ix, iy] = screenToImage(vp, sx, sy);
  return { scale, offsetX: sx - ix * scale, offsetY: sy - iy * scale };
}

/**
 * Move the view by a screen displacement.
 * @param {Viewport} vp
 * @param {number} dxPx CSS px
 * @param {number} dyPx CSS px
 * @returns {Viewport}
 */
export function panBy(vp, dxPx, dyPx) {
  return { scale: vp.scale, offsetX: vp.offsetX + dxPx, offsetY: vp.offsetY + dyPx };
}

/**
 * Image coordinates (px) of a screen point.
 * @param {Viewport} vp
 * @param {number} sx
 * @param {number} sy
 * @returns {[number, number]}
 */
export function screenToImage(vp, sx, sy) {
  return [(sx - vp.offsetX) / vp.scale, (sy - vp.offsetY) / vp.scale];
}

/**
 * Screen coordinates (CSS px) of an image point.
 * @param {Viewport} vp
 * @param {number} ix
 * @param {number} iy
 * @returns {[number, number]}
 */
export function imageToScreen(vp, ix, iy) {
  return [ix * vp.scale + vp.offsetX, iy * vp.scale + vp.offsetY];
}

/**
 * The image rectangle visible in a canvas, as [xMin, yMin, xMax, yMax] in image px.
 * @param {Viewport} vp
 * @param {number} canvasWidthPx
 * @param {number} canvasHeightPx
 * @returns {[number, number, number, number]}
 */
export function visibleImageRect(vp, canvasWidthPx, canvasHeightPx) {
  const [x0, y0] = screenToImage(vp, 0, 0);
  const [x1, y1] = screenToImage(vp, canvasWidthPx, canvasHeightPx);
  return [x0, y0, x1, y1];
}

/**
 * @param {number} scale
 * @returns {number}
 */
function clampScale(scale) {
  return Math.max(MIN_SCALE, Math.min(MAX_SCALE, scale));
}
