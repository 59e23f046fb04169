// @ts-check
/**
 * The fused wheel profile against the reference profile, with the Sh, Sd and qR
 * constructions the service computed. Pure drawing on our own canvas; both axes share one
 * mm scale. A measured profile is drawn as its points: it pools every frame of both
 * sensors, whose points interleave along x (frame-to-frame offsets of 0.1–0.4 mm), so a
 * line through them in the API's order would zigzag between frames and join a stray piece
 * to the tread. Over them runs the profile's outline the service computed (medians in
 * 0.25 mm steps along the profile, what the exports hold). The outline and the reference
 * are stroked in their order (never sorted by x, so the multi-valued flange keeps its
 * shape).
 */
import { boundsOf } from '../lib/ticks.js';
import { makePlotScale } from '../lib/plot-scale.js';
import { drawAxes, fillPoints, strokePolyline } from './axes.js';
import { METHOD_COLOURS } from './frame.js';

/** Side of a measured profile point's square, CSS px. */
const POINT_SIZE_PX = 2;
/** Opacity of the points under the outline. */
const POINT_ALPHA = 0.45;

/**
 * @typedef {object} ProfileCurve
 * @property {string} method "adaptive" or "steger"
 * @property {Array<number|null>} x_mm
 * @property {Array<number|null>} z_mm
 * @property {Array<number|null>} [outline_x_mm] the profile's outline, null between pieces
 * @property {Array<number|null>} [outline_z_mm]
 */

/**
 * @typedef {object} Constructions points in the profile frame, mm, as the API returns them
 * @property {{flange_top: number[], tread_point: number[]}} [sh]
 * @property {{back_face_x_mm: number, flank_point: number[]}} [sd]
 * @property {{upper_point: number[], lower_point: number[]}} [qr]
 */

/**
 * @typedef {object} ProfileData
 * @property {ProfileCurve[]} curves measured profiles to draw
 * @property {{name: string, x_mm: Array<number|null>, z_mm: Array<number|null>}|null} reference
 * @property {Constructions|null} constructions of the first curve's method
 * @property {{sh?: number|null, sd?: number|null, qr?: number|null}} values labels, mm
 */

/**
 * Draw the profile plot filling a canvas of the given CSS size; returns the plot scale.
 * @param {CanvasRenderingContext2D} ctx
 * @param {ProfileData} data
 * @param {{widthPx: number, heightPx: number, pixelRatio: number}} options
 * @returns {import('../lib/plot-scale.js').PlotScale|null} null when there is nothing to draw
 */
export function drawProfile(ctx, data, options) {
  const xs = data.curves.map((c) => c.x_mm);
  const zs = data.curves.map((c) => c.z_mm);
  if (data.reference) {
    xs.push(data.reference.x_mm);
    zs.push(data.reference.z_mm);
  }
  const xRange = boundsOf(xs);
  const zRange = boundsOf(zs);
  if (!xRange || !zRange) return null;
  const scale = makePlotScale(xRange, zRange, {
    ...options,
    margin: { left: 44, right: 12, top: 10, bottom: 34 },
    equalAspect: true,
  });
  drawAxes(ctx, scale, { ...options, xLabel: 'x from back face (mm)', yLabel: 'z (mm)' });
  ctx.save();
  ctx.beginPath();
  ctx.rect(scale.left, scale.top, scale.right - scale.left, scale.bottom - scale.top);
  ctx.clip();
  if (data.reference) {
    ctx.strokeStyle = '#9aa5b1';
    ctx.setLineDash([5, 4]);
    ctx.lineWidth = 1.5;
    strokePolyline(ctx, scale, data.reference.x_mm, data.reference.z_mm);
    ctx.setLineDash([]);
  }
  // the first curve is the selected method: draw it last, on top
  for (const curve of [...data.curves].reverse()) {
    ctx.fillStyle = METHOD_COLOURS[/** @type {'adaptive'|'steger'} */ (curve.method)] ?? '#fff';
    ctx.globalAlpha = POINT_ALPHA;
    fillPoints(ctx, scale, curve.x_mm, curve.z_mm, POINT_SIZE_PX);
    ctx.globalAlpha = 1;
    if (curve.outline_x_mm && curve.outline_z_mm) {
      ctx.strokeStyle = ctx.fillStyle;
      ctx.lineWidth = 1.5;
      strokePolyline(ctx, scale, curve.outline_x_mm, curve.outline_z_mm);
    }
  }
  if (data.constructions) drawConstructions(ctx, scale, data.constructions, data.values);
  ctx.restore();
  drawKey(ctx, scale, data);
  return scale;
}

/**
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} s
 * @param {Constructions} c
 * @param {ProfileData['values']} values
 */
function drawConstructions(ctx, s, c, values) {
  ctx.lineWidth = 1.2;
  ctx.font = 'bold 11px system-ui, sans-serif';
  ctx.textBaseline = 'middle';
  if (c.sh) {
    const [tx, tz] = c.sh.tread_point;
    const [fx, fz] = c.sh.flange_top;
    ctx.strokeStyle = '#f5d90a';
    ctx.setLineDash([3, 3]);
    line(ctx, s, s.xRange[0], tz, s.xRange[1], tz);
    line(ctx, s, s.xRange[0], fz, fx, fz);
    ctx.setLineDash([]);
    arrow(ctx, s, tx, tz, tx, fz);
    label(ctx, s, tx, (tz + fz) / 2, `Sh ${fmt(values.sh)}`, '#f5d90a', 6);
  }
  if (c.sd) {
    const [px, pz] = c.sd.flank_point;
    ctx.strokeStyle = '#4ade80';
    arrow(ctx, s, c.sd.back_face_x_mm, pz, px, pz);
    label(ctx, s, (c.sd.back_face_x_mm + px) / 2, pz, `Sd ${fmt(values.sd)}`, '#4ade80', -14, true);
  }
  if (c.qr) {
    const [ux, uz] = c.qr.upper_point;
    const [lx, lz] = c.qr.lower_point;
    ctx.strokeStyle = '#f472b6';
    line(ctx, s, ux, uz, lx, lz);
    line(ctx, s, lx, lz, ux, lz);
    for (const [x, z] of [c.qr.upper_point, c.qr.lower_point]) dot(ctx, s, x, z, '#f472b6');
    label(ctx, s, Math.max(ux, lx), (uz + lz) / 2, `qR ${fmt(values.qr)}`, '#f472b6', 8);
  }
}

/**
 * @param {number|null|undefined} v
 * @returns {string}
 */
function fmt(v) {
  return v === null || v === undefined || !Number.isFinite(v) ? '–' : `${v.toFixed(2)} mm`;
}

/**
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} s
 * @param {number} x0
 * @param {number} y0
 * @param {number} x1
 * @param {number} y1
 */
function line(ctx, s, x0, y0, x1, y1) {
  ctx.beginPath();
  ctx.moveTo(s.toX(x0), s.toY(y0));
  ctx.lineTo(s.toX(x1), s.toY(y1));
  ctx.stroke();
}

/**
 * A double-headed dimension arrow between two data points.
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} s
 * @param {number} x0
 * @param {number} y0
 * @param {number} x1
 * @param {number} y1
 */
function arrow(ctx, s, x0, y0, x1, y1) {
  const ax = s.toX(x0);
  const ay = s.toY(y0);
  const bx = s.toX(x1);
  const by = s.toY(y1);
  const angle = Math.atan2(by - ay, bx - ax);
  ctx.beginPath();
  ctx.moveTo(ax, ay);
  ctx.lineTo(bx, by);
  for (const [px, py, a] of [
    [ax, ay, angle],
    [bx, by, angle + Math.PI],
  ]) {
    ctx.moveTo(px + 7 * Math.cos(a - 0.4), py + 7 * Math.sin(a - 0.4));
    ctx.lineTo(px, py);
    ctx.lineTo(px + 7 * Math.cos(a + 0.4), py + 7 * Math.sin(a + 0.4));
  }
  ctx.stroke();
}

/**
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} s
 * @param {number} x
 * @param {number} y
 * @param {string} colour
 */
function dot(ctx, s, x, y, colour) {
  ctx.fillStyle = colour;
  ctx.beginPath();
  ctx.arc(s.toX(x), s.toY(y), 3, 0, 2 * Math.PI);
  ctx.fill();
}

/**
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} s
 * @param {number} x
 * @param {number} y
 * @param {string} text
 * @param {string} colour
 * @param {number} dxPx horizontal offset of the label, CSS px
 * @param {boolean} [centred] centre the text on x (offset then applies vertically)
 */
function label(ctx, s, x, y, text, colour, dxPx, centred = false) {
  ctx.fillStyle = colour;
  ctx.textAlign = centred ? 'center' : 'left';
  ctx.fillText(text, s.toX(x) + (centred ? 0 : dxPx), s.toY(y) + (centred ? dxPx : 0));
}

/**
 * @param {CanvasRenderingContext2D} ctx
 * @param {import('../lib/plot-scale.js').PlotScale} s
 * @param {ProfileData} data
 */
function drawKey(ctx, s, data) {
  /** @type {Array<[string, string, boolean]>} name, colour, a method (points) or not */
  const entries = data.curves.map((c) => [c.method, METHOD_COLOURS[/** @type {'adaptive'} */ (c.method)], true]);
  if (data.reference) entries.push([`reference ${data.reference.name}`, '#9aa5b1', false]);
  ctx.font = '11px system-ui, sans-serif';
  ctx.textAlign = 'left';
  ctx.textBaseline = 'middle';
  let y = s.bottom - 10 - 14 * (entries.length - 1);
  for (const [name, colour, points] of entries) {
    ctx.fillStyle = colour;
    // a method: its points (faint) with the outline through them; the reference: a line
    if (points) {
      ctx.globalAlpha = POINT_ALPHA;
      for (let dx = 0; dx < 16; dx += 5) ctx.fillRect(s.right - 130 + dx, y - 4, 3, 3);
      ctx.globalAlpha = 1;
      ctx.fillRect(s.right - 130, y, 16, 1.5);
    } else ctx.fillRect(s.right - 130, y - 1, 16, 3);
    ctx.fillStyle = '#c9d1db';
    ctx.fillText(name, s.right - 108, y);
    y += 14;
  }
}
