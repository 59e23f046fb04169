// @ts-check
/**
 * A uniform grid over 2-D points for nearest-point queries (hover read-out, method pairing).
 * Pure: built from arrays, never mutated after construction.
 */

/**
 * @typedef {object} PointIndex
 * @property {number} cellPx grid cell size, px
 * @property {Map<number, number[]>} cells cell key → indices of the points in it
 * @property {ArrayLike<number>} x
 * @property {ArrayLike<number>} y
 */

/**
 * Index points by grid cell.
 * @param {ArrayLike<number>} x x coordinates, px
 * @param {ArrayLike<number>} y y coordinates, px (same length)
 * @param {number} [cellPx] grid cell size, px
 * @returns {PointIndex}
 */
export function buildPointIndex(x, y, cellPx = 8) {
  if (x.length !== y.length) {
    throw new RangeError(`x and y must have equal length, got ${x.length} and ${y.length}`);
  }
  const cells = new Map();
  for (let i = 0; i < x.length; i += 1) {
    const key = cellKey(Math.floor(x[i] / cellPx), Math.floor(y[i] / cellPx));
    const bucket = cells.get(key);
    if (bucket) bucket.push(i);
    else cells.set(key, [i]);
  }
  return { cellPx, cells, x, y };
}

/**
 * Index of the point nearest to (qx, qy) within maxDistPx, or -1 when none is that close.
 * @param {PointIndex} index
 * @param {number} qx px
 * @param {number} qy px
 * @param {number} maxDistPx search radius, px
 * @returns {number}
 */
export function nearestPoint(index, qx, qy, maxDistPx) {
  const { cellPx, cells, x, y } = index;
  const reach = Math.ceil(maxDistPx / cellPx);
  const cx = Math.floor(qx / cellPx);
  const cy = Math.floor(qy / cellPx);
  let best = -1;
  let bestD2 = maxDistPx * maxDistPx;
  for (let gy = cy - reach; gy <= cy + reach; gy += 1) {
    for (let gx = cx - reach; gx <= cx + reach; gx += 1) {
      const bucket = cells.get(cellKey(gx, gy));
      if (!bucket) continue;
      for (const i of bucket) {
        const d2 = (x[i] - qx) ** 2 + (y[i] - qy) ** 2;
        if (d2 <= bestD2) {
          bestD2 = d2;
          best = i;
        }
      }
    }
  }
  return best;
}

/**
 * @param {number} gx
 * @param {number} gy
 * @returns {number}
 */
function cellKey(gx, gy) {
  // frames are < 2^15 cells wide; shift y into the high bits, keep negatives distinct
  return (gy + 32768) * 65536 + (gx + 32768);
}
