// @ts-check
/**
 * The wheel page's plots: profile vs reference (own canvas), adaptive − Steger difference
 * (own canvas) and the wheel's trend across passes (uPlot, x = pass time).
 */
import uPlot from '../../vendor/uPlot-1.6.32.esm.js';
import { drawDifference } from '../draw/difference.js';
import { METHOD_COLOURS } from '../draw/frame.js';
import { drawProfile } from '../draw/profile.js';
import { fmtNumber, METHODS } from '../lib/format.js';
import { trendColumns } from '../lib/records.js';
import { fitCanvas, h } from './dom.js';

/**
 * Draw the profile plot of the methods shown.
 * @param {HTMLCanvasElement} canvas
 * @param {Record<string, any>} profiles method → ProfileRead from the API (or {error})
 * @param {string[]} methods methods to draw, first one gets its constructions drawn
 * @param {{x: number, z: number}|null} [marker] a profile point to ring (the hovered one), mm
 * @returns {{note: string|null, scale: import('../lib/plot-scale.js').PlotScale|null}} a note
 *   when there is nothing to draw; the plot's scale otherwise
 */
export function renderProfile(canvas, profiles, methods, marker = null) {
  const usable = methods.filter((m) => profiles[m] && Array.isArray(profiles[m].x_mm));
  const { ctx, widthPx, heightPx, pixelRatio } = fitCanvas(canvas);
  if (usable.length === 0) {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    return { note: methods.map((m) => `${m}: ${profiles[m]?.error ?? 'no profile'}`).join('; '), scale: null };
  }
  const first = profiles[usable[0]];
  const values = first.parameters ?? {};
  const scale = drawProfile(ctx, {
    curves: usable.map((m) => ({ method: m, x_mm: profiles[m].x_mm, z_mm: profiles[m].z_mm })),
    reference: first.reference_x_mm?.length
      ? { name: first.reference_profile ?? 'reference', x_mm: first.reference_x_mm, z_mm: first.reference_z_mm }
      : null,
    constructions: first.construction ?? null,
    values: { sh: values.flange_height_mm, sd: values.flange_thickness_mm, qr: values.qr_mm },
  }, { widthPx, heightPx, pixelRatio });
  if (scale && marker) {
    ctx.strokeStyle = '#ffffff';
    ctx.lineWidth = 1.5;
    ctx.beginPath();
    ctx.arc(scale.toX(marker.x), scale.toY(marker.z), 6, 0, 2 * Math.PI);
    ctx.stroke();
  }
  return { note: null, scale };
}

/**
 * Draw the difference plot and return its summary line.
 * @param {HTMLCanvasElement} canvas
 * @param {import('../lib/method-difference.js').MethodDifference|null} diff
 * @returns {string}
 */
export function renderDifference(canvas, diff) {
  const { ctx, widthPx, heightPx, pixelRatio } = fitCanvas(canvas);
  if (!diff || !drawDifference(ctx, diff, { widthPx, heightPx, pixelRatio })) {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    return 'no adaptive/Steger pairs to compare';
  }
  return `${diff.alongPx.length} pairs · mean ${fmtNumber(diff.meanPx, 3)} px · RMS ${fmtNumber(diff.rmsPx, 3)} px · max |Δ| ${fmtNumber(diff.maxAbsPx, 3)} px · ${diff.unmatched} adaptive without a Steger partner within 2 px`;
}

/**
 * Build (or rebuild) the plot of the axle's rolling-radius difference Δr(y) per method, from
 * the `conicity` the profile carries (y ascending, as the API emits it).
 * @param {HTMLElement} root
 * @param {Record<string, any>} profiles method → ProfileRead
 * @param {string[]} methods methods in drawing order (the selected first)
 * @param {uPlot|null} previous the plot to replace
 * @returns {uPlot|null}
 */
export function renderDeltaR(root, profiles, methods, previous) {
  previous?.destroy();
  root.replaceChildren();
  const usable = methods.filter((m) => Array.isArray(profiles[m]?.conicity?.y_mm));
  const notes = methods.map((m) => {
    const c = profiles[m]?.conicity;
    if (!c) return `${m}: not computed yet (both wheels of the axle are needed)`;
    if (c.reason) return `${m}: not computed: ${c.reason}`;
    return `${m}: λe(3 mm) ${fmtNumber(c.conicity_3mm, 3)}`;
  });
  if (usable.length === 0) {
    root.append(h('p', { class: 'empty' }, notes.join(' · ')));
    return null;
  }
  const first = profiles[usable[0]].conicity;
  const series = [{ label: 'y mm' }];
  const data = [first.y_mm];
  for (const method of [...usable].reverse()) {
    const c = profiles[method].conicity;
    if (c.y_mm.length !== first.y_mm.length) continue;
    series.push({ label: `Δr ${method}`, stroke: METHOD_COLOURS[/** @type {'adaptive'|'steger'} */ (method)], width: 1.5,
      value: (/** @type {any} */ _u, /** @type {number|null} */ v) => fmtNumber(v, 3) });
    data.push(c.delta_r_mm);
  }
  // the tread's part of Δr sets the scale; flange contact (beyond ±6 mm) leaves the plot
  const tread = first.delta_r_mm.filter((/** @type {number} */ _d, /** @type {number} */ i) => Math.abs(first.y_mm[i]) <= 6);
  const reach = Math.max(0.5, 1.3 * Math.max(...tread.map(Math.abs)));
  const width = Math.max(280, root.clientWidth);
  const plot = new uPlot({
    width, height: 170, series,
    scales: { x: { time: false }, y: { range: [-reach, reach] } },
    axes: [{ stroke: '#c9d1db', grid: { stroke: '#262d37' }, label: 'lateral shift y (mm)' },
      { stroke: '#c9d1db', grid: { stroke: '#262d37' }, label: 'Δr (mm)', size: 48 }],
    legend: { live: true },
  }, /** @type {any} */ (data), root);
  root.append(h('p', { class: 'note' },
    `${notes.join(' · ')} · rails ${first.rail} at ${first.inclination}, gauge ${fmtNumber(first.gauge_mm, 0)} mm`));
  return plot;
}

const TREND_SERIES = [
  { key: 'flange_height_mm', label: 'Sh', dash: [] },
  { key: 'flange_thickness_mm', label: 'Sd', dash: [6, 3] },
  { key: 'qr_mm', label: 'qR', dash: [2, 3] },
];

/**
 * Build (or rebuild) the trend plot of one wheel across passes.
 * @param {HTMLElement} root
 * @param {any} trend a WheelTrend
 * @param {uPlot|null} previous the plot to replace
 * @returns {uPlot|null}
 */
export function renderTrend(root, trend, previous) {
  previous?.destroy();
  root.replaceChildren();
  const { x, columns } = trendColumns(trend, METHODS, TREND_SERIES.map((s) => s.key));
  if (x.length < 2) {
    root.append(h('p', { class: 'empty' },
      x.length ? 'This is the only pass of this wheel so far: the trend starts with the next one.'
        : 'No measured passes of this wheel yet.'));
    return null;
  }
  const series = [{}];
  const data = [x];
  // Steger first, so the adaptive lines (the product's method) are drawn on top
  for (const method of [...METHODS].reverse()) {
    for (const s of TREND_SERIES) {
      series.push({
        label: `${s.label} ${method}`,
        stroke: METHOD_COLOURS[/** @type {'adaptive'|'steger'} */ (method)],
        dash: s.dash,
        width: 1.5,
        points: { show: true, size: 5 },
        value: (/** @type {any} */ _u, /** @type {number|null} */ v) => fmtNumber(v),
      });
      data.push(columns[`${method}:${s.key}`]);
    }
  }
  const width = Math.max(280, root.clientWidth);
  return new uPlot({
    width, height: 190, series,
    scales: { x: { time: true } },
    // pass times in UTC, like every other time the application shows
    tzDate: (/** @type {number} */ ts) => uPlot.tzDate(new Date(ts * 1000), 'Etc/UTC'),
    axes: [{ stroke: '#c9d1db', grid: { stroke: '#262d37' } },
      { stroke: '#c9d1db', grid: { stroke: '#262d37' }, label: 'mm', size: 44 }],
    legend: { live: true },
  }, /** @type {any} */ (data), root);
}
