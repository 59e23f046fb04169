// @ts-check
/**
 * Pixel recipes for image layers, on RGBA typed arrays (ImageData.data). Pure: no DOM.
 */

/**
 * Turn a decoded mask image (RGBA: the mask where red > 127, rejected candidate centres
 * where 64 < red ≤ 127) into a translucent tint layer.
 * @param {Uint8ClampedArray} maskRgba decoded mask pixels, 4 bytes per pixel
 * @param {[number, number, number, number]} tintRgba colour and alpha (0..255) inside the mask
 * @param {[number, number, number, number]} rejectedRgba colour and alpha of rejected centres
 * @returns {Uint8ClampedArray<ArrayBuffer>} RGBA pixels, transparent elsewhere
 */
export function tintMask(maskRgba, tintRgba, rejectedRgba) {
  const out = new Uint8ClampedArray(maskRgba.length);
  for (let p = 0; p < maskRgba.length; p += 4) {
    const value = maskRgba[p];
    const tint = value > 127 ? tintRgba : value > 64 ? rejectedRgba : null;
    if (tint) out.set(tint, p);
  }
  return out;
}
