// @ts-check
/**
 * Pixel recipes for image layers, on RGBA typed arrays (ImageData.data). Pure: no DOM.
 */

/**
 * Turn a decoded mask image (RGBA, mask where red > 127) into a translucent tint layer.
 * @param {Uint8ClampedArray} maskRgba decoded mask pixels, 4 bytes per pixel
 * @param {[number, number, number, number]} tintRgba colour and alpha (0..255) inside the mask
 * @returns {Uint8ClampedArray<ArrayBuffer>} RGBA pixels, transparent outside the mask
 */
export function tintMask(maskRgba, tintRgba) {
  const out = new Uint8ClampedArray(maskRgba.length);
  const [r, g, b, a] = tintRgba;
  for (let p = 0; p < maskRgba.length; p += 4) {
    if (maskRgba[p] > 127) {
      out[p] = r;
      out[p + 1] = g;
      out[p + 2] = b;
      out[p + 3] = a;
    }
  }
  return out;
}
