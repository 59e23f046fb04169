// @ts-check
/**
 * The wheel page's plots: profile vs reference (own canvas), adaptive − Steger difference
 * (own canvas) and the wheel's trend across passes (uPlot, x = pass time).
 */
import uPlot from '../../vendor/uPlot-1.6.32.esm.js';
import { drawDifference } from '../draw/difference.js';
import { METHOD_COLOURS } from '../draw/frame.js';
import { drawProfile } from '../draw/profile.js';
import { fmtNumber, fmtSigned, METHODS, shownParameters } from '../lib/format.js';
import { trendColumns } from '../lib/records.js';
import { definitions, fitCanvas, h, nodesOf } from './dom.js';

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
  const scale = drawProfile(
    ctx,
    {
      curves: usable.map((m) => ({
        method: m,
        x_mm: profiles[m].x_mm,
        z_mm: profiles[m].z_mm,
        outline_x_mm: profiles[m].outline_x_mm,
        outline_z_mm: profiles[m].outline_z_mm,
      })),
      reference: first.reference_x_mm?.length
        ? { name: first.reference_profile ?? 'reference', x_mm: first.reference_x_mm, z_mm: first.reference_z_mm }
        : null,
      constructions: first.construction ?? null,
      values: { sh: values.flange_height_mm, sd: values.flange_thickness_mm, qr: values.qr_mm },
    },
    { widthPx, heightPx, pixelRatio },
  );
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
 * Draw the difference plot and return its summary line and scale.
 * @param {HTMLCanvasElement} canvas
 * @param {import('../lib/method-difference.js').MethodDifference|null} diff
 * @param {number} [marker] index of the pair to ring
 * @returns {{note: string, scale: import('../lib/plot-scale.js').PlotScale|null}}
 */
export function renderDifference(canvas, diff, marker) {
  const { ctx, widthPx, heightPx, pixelRatio } = fitCanvas(canvas);
  const scale = diff ? drawDifference(ctx, diff, { widthPx, heightPx, pixelRatio, marker }) : false;
  if (!diff || !scale) {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    return { note: 'no adaptive/Steger pairs to compare', scale: null };
  }
  return {
    note: `${diff.alongPx.length} pairs · mean ${fmtNumber(diff.meanPx, 3)} px · RMS ${fmtNumber(diff.rmsPx, 3)} px (shaded: ±RMS) · max |Δ| ${fmtNumber(diff.maxAbsPx, 3)} px · ${diff.unmatched} adaptive without a Steger partner within 2 px · hover to read, click to show that point on the frame`,
    scale,
  };
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
    if (!Array.isArray(c.y_mm)) return `${m}: not computed: ${c.reason ?? 'no Δr'}`;
    const at3 = c.conicity_3mm == null ? 'not given' : fmtNumber(c.conicity_3mm, 3);
    // computed over fewer shifts than searched: the reason says which amplitudes it lacks
    return `${m}: λe(3 mm) ${at3}${c.reason ? ` (${c.reason})` : ''}`;
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
    series.push({
      label: `Δr ${method}`,
      stroke: METHOD_COLOURS[/** @type {'adaptive'|'steger'} */ (method)],
      width: 1.5,
      value: (/** @type {any} */ _u, /** @type {number|null} */ v) => fmtNumber(v, 3),
    });
    data.push(c.delta_r_mm);
  }
  // the tread's part of Δr sets the scale; flange contact (beyond ±6 mm) leaves the plot
  const tread = first.delta_r_mm.filter(
    (/** @type {number} */ _d, /** @type {number} */ i) => Math.abs(first.y_mm[i]) <= 6,
  );
  const reach = Math.max(0.5, 1.3 * Math.max(...tread.map(Math.abs)));
  const width = Math.max(280, root.clientWidth);
  const plot = new uPlot(
    {
      width,
      height: 170,
      series,
      scales: { x: { time: false }, y: { range: [-reach, reach] } },
      axes: [
        { stroke: '#c9d1db', grid: { stroke: '#262d37' }, label: 'lateral shift y (mm)' },
        { stroke: '#c9d1db', grid: { stroke: '#262d37' }, label: 'Δr (mm)', size: 48 },
      ],
      legend: { live: true },
    },
    /** @type {any} */ (data),
    root,
  );
  root.append(
    h(
      'p',
      { class: 'note' },
      `${notes.join(' · ')} · rails ${first.rail} at ${first.inclination}, gauge ${fmtNumber(first.gauge_mm, 0)} mm`,
    ),
  );
  return plot;
}

/** Height of one parameter's trend plot [CSS px]. */
const TREND_HEIGHT_PX = 130;
/** Half the x range shown when every pass is at one instant [s]. */
const SINGLE_INSTANT_HALF_RANGE_S = 12 * 3600;

/**
 * Build (or rebuild) the trend of one wheel across passes: one small plot per checked
 * parameter in its colour (adaptive solid, Steger dashed), its limit line, the amber band
 * inside it and the wear fit, with the forecast in words underneath. The x-axis spans
 * the passes (UTC); forecasts are given as dates, not drawn out to them.
 * @param {HTMLElement} root
 * @param {any} trend a WheelTrend
 * @param {{destroy: () => void}|null} previous the plots to replace
 * @returns {{destroy: () => void}|null}
 */
export function renderTrend(root, trend, previous) {
  previous?.destroy();
  root.replaceChildren();
  const family = trend?.limits?.wheel_profile ?? 'EN';
  const shown = shownParameters(family);
  const { x, km, columns } = trendColumns(
    trend,
    METHODS,
    shown.map((p) => p.key),
  );
  if (x.length < 2) {
    root.append(
      h(
        'p',
        { class: 'empty' },
        x.length
          ? 'This is the only pass of this wheel so far: the trend starts with the next one.'
          : 'No measured passes of this wheel yet.',
      ),
    );
    return null;
  }
  const plots = shown.map((p) => {
    const forecast = (trend.forecasts ?? []).find((/** @type {any} */ f) => f.parameter === p.key) ?? null;
    const box = h('div', { class: 'trend-plot', dataset: { parameter: p.key } });
    root.append(box, h('p', { class: 'note forecast', dataset: { parameter: p.key } }, forecastText(p, forecast)));
    return parameterPlot(box, p, { x, km }, columns, forecast, trend.limits);
  });
  root.append(nodesOf(definitions(shown, 'What the trended values mean')));
  return { destroy: () => plots.forEach((plot) => plot.destroy()) };
}

/**
 * @param {HTMLElement} box
 * @param {any} p a PARAMETERS entry
 * @param {{x: number[], km: Array<number|null>}} passes pass times [s] and odometer [km]
 * @param {Record<string, Array<number|null>>} columns
 * @param {any} forecast a TrendForecast or null
 * @param {any} limits the trend's WheelLimits or null
 * @returns {uPlot}
 */
function parameterPlot(box, p, { x, km }, columns, forecast, limits) {
  const fit = x.map((t, i) => (forecast ? fitValue(forecast, t, km[i]) : null));
  const lowMm = limits?.limits_mm?.[`${limitStemOf(p.key)}_min_mm`] ?? null;
  const highMm = limits?.limits_mm?.[`${limitStemOf(p.key)}_max_mm`] ?? null;
  const band = lowMm != null && highMm != null ? (highMm - lowMm) * (limits?.near_limit_fraction ?? 0.1) : null;
  // the limit lines and the amber band on the element, in mm, for whoever checks them
  Object.assign(box.dataset, { lowMm: String(lowMm ?? ''), highMm: String(highMm ?? ''), bandMm: String(band ?? '') });
  const series = [
    {},
    {
      label: `${p.label} adaptive`,
      stroke: p.colour,
      width: 1.8,
      points: { show: true, size: 5 },
      value: (/** @type {any} */ _u, /** @type {number|null} */ v) => fmtNumber(v),
    },
    {
      label: `${p.label} Steger`,
      stroke: p.colour,
      dash: [5, 4],
      width: 1,
      points: { show: true, size: 3 },
      value: (/** @type {any} */ _u, /** @type {number|null} */ v) => fmtNumber(v),
    },
    {
      label: 'fit',
      stroke: '#e5e7eb',
      dash: [2, 3],
      width: 1,
      points: { show: false },
      value: (/** @type {any} */ _u, /** @type {number|null} */ v) => fmtNumber(v),
    },
  ];
  const values = [...columns[`adaptive:${p.key}`], ...columns[`steger:${p.key}`]].filter((v) => v != null);
  const yMin = Math.min(...values, ...(lowMm != null ? [lowMm] : []));
  const yMax = Math.max(...values, ...(highMm != null ? [highMm] : []));
  const pad = Math.max(0.2, 0.08 * (yMax - yMin));
  return new uPlot(
    {
      width: Math.max(280, box.clientWidth || 420),
      height: TREND_HEIGHT_PX,
      series,
      scales: {
        x: {
          time: true,
          range: (/** @type {any} */ _u, /** @type {number} */ lo, /** @type {number} */ hi) =>
            hi - lo < 1
              ? [lo - SINGLE_INSTANT_HALF_RANGE_S, hi + SINGLE_INSTANT_HALF_RANGE_S]
              : [lo - 0.03 * (hi - lo), hi + 0.03 * (hi - lo)],
        },
        y: { range: () => [yMin - pad, yMax + pad] },
      },
      // pass times in UTC, like every other time the application shows
      tzDate: (/** @type {number} */ ts) => uPlot.tzDate(new Date(ts * 1000), 'Etc/UTC'),
      axes: [
        { stroke: '#c9d1db', grid: { stroke: '#262d37' }, space: 90, values: utcDays },
        {
          stroke: '#c9d1db',
          grid: { stroke: '#262d37' },
          label: p.unit ? `${p.label} (${p.unit})` : p.label,
          size: 50,
        },
      ],
      legend: { live: true },
      hooks: {
        drawClear: [(/** @type {uPlot} */ u) => drawLimits(u, lowMm, highMm, band)],
        // the x range on the element, in s (UTC), for whoever checks what the axis spans
        setScale: [
          (/** @type {uPlot} */ u, /** @type {string} */ key) => {
            if (key === 'x') Object.assign(box.dataset, { xMin: String(u.scales.x.min), xMax: String(u.scales.x.max) });
          },
        ],
      },
    },
    /** @type {any} */ ([x, columns[`adaptive:${p.key}`], columns[`steger:${p.key}`], fit]),
    box,
  );
}

/**
 * x-axis labels: the UTC date of each tick, with the time where ticks are less than a day apart.
 * @param {uPlot} _u
 * @param {number[]} splits tick times [s]
 * @returns {string[]}
 */
function utcDays(_u, splits) {
  const step = splits.length > 1 ? splits[1] - splits[0] : 86400;
  return splits.map((s) => {
    const iso = new Date(s * 1000).toISOString();
    return step < 86400 ? `${iso.slice(5, 10)} ${iso.slice(11, 16)}` : iso.slice(0, 10);
  });
}

/**
 * The limit stem ("flange_thickness") of a parameter key.
 * @param {string} key
 */
function limitStemOf(key) {
  return key === 'flange_thickness_10_mm' ? 'flange_thickness' : key.replace(/_mm$/, '');
}

/**
 * The wear fit's value at a pass (none without a fit): at its time t [s] for a fit per
 * day, at its odometer reading [km] for a fit per 1000 km.
 * @param {any} forecast a TrendForecast
 * @param {number} t
 * @param {number|null} km
 * @returns {number|null}
 */
function fitValue(forecast, t, km) {
  if (forecast.intercept_mm == null || !forecast.fit_from) return null;
  if (forecast.per === '1000 km')
    return km == null || forecast.fit_from_km == null
      ? null
      : forecast.intercept_mm + (forecast.rate_mm * (km - forecast.fit_from_km)) / 1000;
  return forecast.intercept_mm + (forecast.rate_mm * (t - Date.parse(forecast.fit_from) / 1000)) / 86400;
}

/**
 * Limit lines (red) and the amber band inside them, behind the series.
 * @param {uPlot} u
 * @param {number|null} lowMm @param {number|null} highMm @param {number|null} bandMm
 */
function drawLimits(u, lowMm, highMm, bandMm) {
  const { ctx } = u;
  const { left, width } = u.bbox;
  const y = (/** @type {number} */ v) => u.valToPos(v, 'y', true);
  ctx.save();
  for (const [limit, inward] of [
    [lowMm, 1],
    [highMm, -1],
  ]) {
    if (limit == null) continue;
    if (bandMm != null) {
      ctx.fillStyle = 'rgba(245, 158, 11, 0.18)';
      const a = y(limit);
      const b = y(limit + inward * bandMm);
      ctx.fillRect(left, Math.min(a, b), width, Math.abs(b - a));
    }
    ctx.strokeStyle = '#ef4444';
    ctx.lineWidth = 1.5 * devicePixelRatio;
    ctx.beginPath();
    ctx.moveTo(left, y(limit));
    ctx.lineTo(left + width, y(limit));
    ctx.stroke();
  }
  ctx.restore();
}

/**
 * The forecast of one parameter in words.
 * @param {any} p a PARAMETERS entry
 * @param {any} forecast a TrendForecast or null
 * @returns {string}
 */
function forecastText(p, forecast) {
  if (!forecast) return `${p.label}: ${p.families.length ? 'no forecast' : 'no limit, so no forecast'}`;
  if (forecast.points < 3 || forecast.limit_mm == null) return `${p.label}: ${forecast.note}`;
  const per = forecast.per === 'day' ? 'day' : '1000 km';
  const rate = `${fmtSigned(forecast.rate_mm, 3)} mm/${per} (${fmtSigned(forecast.rate_low_mm, 3)} to ${fmtSigned(forecast.rate_high_mm, 3)})`;
  const limit = `${forecast.bound === 'max' ? '≤' : '≥'} ${fmtNumber(forecast.limit_mm, 1)} mm`;
  if (forecast.per === '1000 km' && forecast.reached_km != null) {
    const odo = (/** @type {number|null} */ v) => (v == null ? 'later' : `${Math.round(v).toLocaleString('en-GB')} km`);
    const ahead =
      forecast.last_km != null ? `, ${odo(forecast.reached_km - forecast.last_km)} after the last pass` : '';
    return (
      `${p.label}: ${rate}; reaches ${limit} at ${odo(forecast.reached_km)} on the odometer${ahead} ` +
      `(90 %: ${odo(forecast.reached_km_earliest)} – ${odo(forecast.reached_km_latest)})`
    );
  }
  if (!forecast.reached_at) return `${p.label}: ${rate}; ${forecast.note}`;
  const day = (/** @type {string|null} */ iso) => (iso ? iso.slice(0, 10) : 'later');
  return `${p.label}: ${rate}; reaches ${limit} on ${day(forecast.reached_at)} UTC (90 %: ${day(forecast.reached_earliest)} – ${day(forecast.reached_latest)})`;
}
