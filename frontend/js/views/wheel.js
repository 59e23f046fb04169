// @ts-check
/**
 * Wheel review: the camera frame with adaptive/Steger centres, stripe mask and σ map; the
 * parameter table with limits; the profile vs reference with its constructions; the handheld
 * gauge's reference against both methods; adaptive − Steger along the stripe; the trend
 * across passes; report and profile exports and the 3D view.
 */
import { differenceAlongStripe } from '../lib/method-difference.js';
import { nearestOnScreen } from '../lib/plot-scale.js';
import {
  DIAMETER_NOTE,
  DISPOSITIONS,
  fmtDisposition,
  fmtNumber,
  fmtSensor,
  fmtSigned,
  fmtTime,
  METHODS,
  PARAMETERS,
  parameterOf,
} from '../lib/format.js';
import {
  framesRemovedNote,
  hasAlarmOn,
  limitBounds,
  limitsFor,
  missingValuesReason,
  resultOf,
  uncheckedLimits,
} from '../lib/records.js';
import { buildHash } from '../lib/route.js';
import { html, nothing, render } from '../../vendor/lit-html-3.3.3.js';
import { alarmClass, h } from './dom.js';
import { FrameView } from './frame-view.js';
import { exportButtons } from './pass.js';
import { renderDeltaR, renderDifference, renderProfile, renderTrend } from './plots.js';

/** Layer toggles: key, label, keyboard shortcut. */
export const LAYERS = [
  ['adaptive', 'Adaptive centres', 'a'],
  ['steger', 'Steger centres', 's'],
  ['mask', 'Stripe mask', 'm'],
  ['sigma', 'σ map', 'o'],
  ['image', 'Frame', 'x'],
];

export class WheelView {
  /**
   * @param {HTMLElement} root
   * @param {{setQuery: (q: Record<string, string>) => void, exportReport: (format: string) => Promise<void>|void, exportProfile: (format: string) => Promise<void>|void, importReference: (file: File) => Promise<void>|void, openViewer: () => void, closeViewer: () => void, addDisposition: (body: {kind: string, comment?: string}) => Promise<boolean>|void}} handlers
   */
  constructor(root, handlers) {
    this.root = root;
    this.handlers = handlers;
    // what the canvases and plots draw into: made once, placed by the template, drawn below
    this.frameRoot = h('div', { class: 'frame-root' });
    this.profileCanvas = /** @type {HTMLCanvasElement} */ (
      h('canvas', { class: 'plot profile-plot', 'aria-label': 'profile plot' })
    );
    this.profileNote = h('p', { class: 'note' });
    this.diffCanvas = /** @type {HTMLCanvasElement} */ (
      h('canvas', { class: 'plot diff-plot', 'aria-label': 'difference plot' })
    );
    this.diffNote = h('p', { class: 'note mono' });
    this.deltaRRoot = h('div', { class: 'trend delta-r' });
    this.trendRoot = h('div', { class: 'trend' });
    this.frame = new FrameView(this.frameRoot);
    /** @type {Record<string, any>} */
    this.profiles = {};
    this.profileOrder = ['adaptive', 'steger'];
    /** @type {import('../lib/plot-scale.js').PlotScale|null} */
    this.profileScale = null;
    this.profileCanvas.addEventListener('pointermove', (e) => this.hoverProfile(e.offsetX, e.offsetY));
    this.profileCanvas.addEventListener('pointerleave', () => this.drawProfilePlot(null));
    /** @type {import('../lib/method-difference.js').MethodDifference|null} */
    this.difference = null;
    /** @type {import('../lib/plot-scale.js').PlotScale|null} */
    this.diffScale = null;
    this.diffCanvas.addEventListener('pointermove', (e) => this.drawDifferencePlot(this.pairAt(e.offsetX, e.offsetY)));
    this.diffCanvas.addEventListener('pointerleave', () => this.drawDifferencePlot(-1));
    this.diffCanvas.addEventListener('click', (e) => {
      const i = this.pairAt(e.offsetX, e.offsetY);
      if (i >= 0 && this.difference) this.frame.centreOn(this.difference.x[i], this.difference.y[i]);
    });
    /** What the canvases and plots last drew (they redraw only when it changes). @type {any} */
    this.drawn = {};
    /** @type {any} */
    this.trendPlot = null;
    /** @type {any} */
    this.deltaRPlot = null;
  }

  /**
   * Bring the page up to date with the state: the template patches the DOM where it
   * changed; the frame, the profile and difference canvases and the uPlot plots redraw
   * only when their data changed.
   * @param {any} state
   */
  update(state) {
    const w = state.wheel;
    const method = state.route.query.method === 'steger' ? 'steger' : 'adaptive';
    const { passId, wheelId } = state.route.params;
    const show = LAYERS.reduce((acc, [key]) => ({ ...acc, [key]: state.layers[key] }), {});
    // never show another wheel's data under this wheel's address (the store may still hold it)
    const ready = Boolean(w?.layers && w.passId === passId && w.wheelId === wheelId);
    const failed = !ready && w?.failed && w.passId === passId && w.wheelId === wheelId;
    render(this.page(state, ready ? w : null, method, show, Boolean(failed)), this.root);
    if (!ready) {
      this.frame.clear();
      this.drawn = {};
      return;
    }
    const changed = (/** @type {string} */ key, /** @type {any} */ value) => {
      if (this.drawn[key] === value) return false;
      this.drawn[key] = value;
      return true;
    };
    if (changed('layers', w.layers)) {
      // this wheel's frame data reached the canvas (the browser tests wait for it, benchmarks/browser.py times from it)
      performance.mark('frame-data', { detail: `${w.passId}/${w.wheelId}` });
      this.frame.setData({ ...w.layers, sigmaScale: w.sigmaScale, centres: w.centres });
      this.difference = pairDifference(w.centres);
      this.drawDifferencePlot(-1);
    }
    this.frame.setShow(show);
    // the side panels come with the second step of the load, after the frame is drawn
    if (!w.profiles) return;
    if (changed('profile', `${method}|${w.loadMs}`)) {
      this.profileOrder = [
        ...(method === 'steger' ? ['steger', 'adaptive'] : ['adaptive', 'steger']),
        ...(w.profiles.handheld ? ['handheld'] : []),
      ];
      this.profiles = w.profiles;
      this.drawProfilePlot(null);
      this.deltaRPlot = renderDeltaR(this.deltaRRoot, w.profiles, this.profileOrder, this.deltaRPlot);
    }
    if (changed('trend', w.trend)) {
      this.trendPlot = w.trend?.error ? null : renderTrend(this.trendRoot, w.trend, this.trendPlot);
      if (w.trend?.error)
        this.trendRoot.replaceChildren(h('p', { class: 'error' }, `trend unavailable: ${w.trend?.error}`));
    }
    // every panel of this wheel built (benchmarks/browser.py times the whole page to it)
    if (!w.loading && changed('complete', `${w.passId}/${w.wheelId}/${w.loadMs}`))
      performance.mark('wheel-loaded', { detail: `${w.passId}/${w.wheelId}` });
  }

  /**
   * The page: title, layer toolbar, frame (or the 3D view over it), parameter table and,
   * once the second step of the load is in, the side panels.
   * @param {any} state
   * @param {any} w the wheel state when it is this address's wheel, else null
   * @param {string} method
   * @param {Record<string, boolean>} show
   * @param {boolean} failed the wheel could not be loaded
   */
  page(state, w, method, show, failed) {
    const { passId, wheelId } = state.route.params;
    const role = state.me?.role;
    const title = w
      ? this.title(state, w, method)
      : failed
        ? html`<p class="notice failed">
            Wheel ${wheelId} of pass ${passId} could not be shown (the reason is above).
            <a href=${buildHash(['passes', passId])}>Back to pass #${passId}</a> ·
            <a href="#/passes">the passes</a>
          </p>`
        : html`<p class="loading">Loading wheel…</p>`;
    // the panels' frame is always there (the difference plot is drawn with the frame's
    // data, before the rest); what they show comes with the second step of the load
    const more = Boolean(w?.profiles);
    const panels = html`<h2>Disposition</h2>
      <div class="dispositions">${more ? this.dispositions(w, role) : nothing}</div>
      <h2>Profile vs reference</h2>
      ${this.profileCanvas}${this.profileNote}
      <h2>Axle rolling-radius difference Δr(y)</h2>
      ${this.deltaRRoot}
      <h2>Handheld gauge</h2>
      <div class="comparison">
        ${more ? comparisonTable(w.comparison, role !== 'viewer' ? this.handlers.importReference : null) : nothing}
      </div>
      <h2>Adaptive − Steger along the stripe</h2>
      ${this.diffCanvas}${this.diffNote}
      <h2>Trend across passes</h2>
      ${this.trendRoot}
      <h2>3D</h2>
      <div class="viewer">${more ? this.viewerSwitch(w.viewerUrl ?? null) : nothing}</div>`;
    // which wheel is fully on screen (the browser tests wait for it)
    const loaded = w && !w.loading ? `${w.passId}/${w.wheelId}` : '';
    return html`<section class="wheel" data-loaded-wheel=${loaded}>
      <div class="titlebar">${title}</div>
      <div class="wheel-grid" ?hidden=${failed}>
        <div class="frame-panel">
          <div class="toolbar">${this.toolbar(show, w ? layerNote(show, w) : '')}</div>
          ${this.frameRoot}${this.viewerOverlay(w?.viewerUrl ?? null)}
        </div>
        <div class="side-panel">
          <h2>Parameters</h2>
          <div class="param-table">${w ? parameterTables(w.record, state.limits, method) : nothing}</div>
          <div class="side-panels ${more ? '' : 'pending'}">${panels}</div>
        </div>
      </div>
    </section>`;
  }

  /**
   * Draw the profile plot, ringing a hovered point and reading it out.
   * @param {{method: string, x: number, z: number}|null} hovered
   */
  drawProfilePlot(hovered) {
    const { note, scale } = renderProfile(this.profileCanvas, this.profiles, this.profileOrder, hovered);
    this.profileScale = scale;
    this.profileNote.textContent =
      note ??
      (hovered
        ? `${hovered.method}: x ${fmtNumber(hovered.x, 2)} mm · z ${fmtNumber(hovered.z, 2)} mm`
        : 'Points: every frame of both sensors, as fused; the line through them: their outline (as exported). Dashed grey: reference. Constructions of the selected method: Sh (yellow), Sd (green), qR (pink). Hover the profile to read points.');
  }

  /**
   * Draw the difference plot, ringing and reading out pair `i` (none when -1).
   * @param {number} i
   */
  drawDifferencePlot(i) {
    const { note, scale } = renderDifference(this.diffCanvas, this.difference, i);
    this.diffScale = scale;
    const d = this.difference;
    this.diffNote.textContent =
      i >= 0 && d
        ? `Δ ${fmtSigned(d.diffPx[i], 3)} px at ${fmtNumber(d.alongPx[i], 0)} px along the stripe (frame x ${fmtNumber(d.x[i], 1)}, y ${fmtNumber(d.y[i], 1)} px): click to show it on the frame`
        : note;
    // what the plot spans and holds, for checks that nothing is clipped
    Object.assign(this.diffCanvas.dataset, {
      hovered: String(i),
      deltaTopPx: String(scale?.yRange[1] ?? ''),
      maxAbsPx: String(d?.maxAbsPx ?? ''),
      zeroY: String(scale ? scale.toY(0) : ''),
      left: String(scale?.left ?? ''),
      right: String(scale?.right ?? ''),
    });
  }

  /**
   * The pair under a point of the difference plot (within 8 CSS px), or -1.
   * @param {number} sx
   * @param {number} sy
   * @returns {number}
   */
  pairAt(sx, sy) {
    const d = this.difference;
    if (!d || !this.diffScale) return -1;
    return nearestOnScreen(this.diffScale, d.alongPx, d.diffPx, sx, sy, 8);
  }

  /**
   * @param {number} sx
   * @param {number} sy
   */
  hoverProfile(sx, sy) {
    const scale = this.profileScale;
    if (!scale) return;
    for (const method of this.profileOrder) {
      const p = this.profiles[method];
      if (!p || !Array.isArray(p.x_mm)) continue;
      const i = nearestOnScreen(scale, p.x_mm, p.z_mm, sx, sy, 10);
      if (i >= 0) return this.drawProfilePlot({ method, x: p.x_mm[i], z: p.z_mm[i] });
    }
    return this.drawProfilePlot(null);
  }

  destroy() {
    this.frame.destroy();
    this.trendPlot?.destroy();
  }

  /** @param {any} state @param {any} w @param {string} method */
  title(state, w, method) {
    const r = w.record;
    const siblings = state.pass?.wheels ?? [];
    const level =
      alarmClass(resultOf(r, method)) === 'none'
        ? 'none'
        : method === 'adaptive' && r?.level && r.level !== 'none'
          ? r.level
          : alarmClass(resultOf(r, method));
    const disagreement = (r?.method_disagreement ?? [])
      .map((/** @type {any} */ d) => `${parameterOf(d.parameter).label} ${fmtSigned(d.difference_mm, 1)} mm`)
      .join(', ');
    const at = siblings.findIndex((/** @type {any} */ s) => String(s.wheel_id) === String(w.wheelId));
    const link = (/** @type {any} */ s, /** @type {string} */ text, /** @type {string} */ rel) =>
      s
        ? html`<a class="button" rel=${rel} href=${buildHash(['passes', w.passId, 'wheels', s.wheel_id], { method })}
            >${text}</a
          >`
        : html`<span class="button disabled">${text}</span>`;
    const shown = resultOf(r, method);
    const unchecked = uncheckedLimits(shown, limitsFor(state.limits, shown?.reference_profile), PARAMETERS);
    const badge = r?.reason
      ? 'not measured'
      : { ok: 'within limits', near: 'NEAR LIMIT', alarm: 'ALARM', none: r?.state ?? '–' }[level] +
        ((level === 'ok' || level === 'near') && unchecked.length ? ` · ${unchecked.join(', ')} not checked` : '');
    const frameButton = (/** @type {any} */ f) =>
      html`<button
        class=${f.sensor === w.sensor && f.index === w.index ? 'on' : nothing}
        data-sensor=${f.sensor}
        @click=${() => this.handlers.setQuery({ sensor: f.sensor, frame: String(f.index) })}
      >
        ${fmtSensor(f.sensor)}${
          w.frames.filter((/** @type {any} */ g) => g.sensor === f.sensor).length > 1 ? ` ${f.index + 1}` : ''
        }
      </button>`;
    return html`<h1>
        <a href="#/passes">Passes</a> › <a href=${buildHash(['passes', w.passId])}>Pass #${w.passId}</a> ›
        ${r ? `Vehicle ${r.vehicle_id} · axle ${r.axle} · ${r.side}` : `Wheel ${w.wheelId}`}
      </h1>
      <span class="badge ${level}" data-level=${level}>${badge}</span>
      <span class="disposition ${r?.disposition ? 'set' : 'open'}">${fmtDisposition(r?.disposition)}</span>
      ${
        disagreement
          ? html`<span class="flag disagreement" title="adaptive and Steger differ by more than the fleet's threshold"
              >methods differ: ${disagreement}</span
            >`
          : nothing
      }
      <div class="segmented" role="group" aria-label="frame">${w.frames.map(frameButton)}</div>
      <div class="segmented" role="group" aria-label="method">
        ${METHODS.map(
          (m) =>
            html`<button
              class=${m === method ? 'on' : nothing}
              data-method=${m}
              aria-pressed=${String(m === method)}
              @click=${() => this.handlers.setQuery({ method: m })}
            >
              ${m === 'adaptive' ? 'Adaptive' : 'Steger'}
            </button>`,
        )}
      </div>
      <span class="spacer"></span>
      ${link(siblings[at - 1], '[ prev', 'prev')} ${link(siblings[at + 1], 'next ]', 'next')}
      ${exportButtons(this.handlers.exportReport)} ${exportButtons(this.handlers.exportProfile, 'profile')}
      <span class="meta" data-load-ms=${String(Math.round(w.loadMs ?? 0))}
        >${w.loading ? 'loading…' : `loaded in ${Math.round(w.loadMs ?? 0)} ms`}</span
      >`;
  }

  /**
   * The layer switches, the fit button and why a layer that is on is not drawn yet.
   * @param {Record<string, boolean>} show
   * @param {string} note
   */
  toolbar(show, note) {
    return html`${LAYERS.map(
        ([key, label, shortcut]) =>
          html`<label class="toggle ${key}"
            ><input
              type="checkbox"
              data-layer=${key}
              .checked=${show[key]}
              @change=${(/** @type {Event} */ e) =>
                this.handlers.setQuery({ [key]: /** @type {HTMLInputElement} */ (e.target).checked ? '1' : '0' })}
            />
            ${label} <kbd>${shortcut}</kbd></label
          >`,
      )}<button @click=${() => this.frame.fit()} title="fit: the stripe, then the whole frame (f)">
        Fit <kbd>f</kbd></button
      ><span class="note layer-note">${note}</span>`;
  }

  /**
   * The disposition in force, its history (who, when) and, for operators, the form (cleared
   * once a disposition is recorded).
   * @param {any} w the wheel state
   * @param {string|undefined} role
   */
  dispositions(w, role) {
    const history = w.dispositions ?? [];
    const onSubmit = async (/** @type {Event} */ e) => {
      e.preventDefault();
      const form = /** @type {HTMLFormElement} */ (e.target);
      const kind = /** @type {HTMLSelectElement} */ (form.elements.namedItem('kind')).value;
      const comment = /** @type {HTMLInputElement} */ (form.elements.namedItem('comment')).value.trim();
      if (await this.handlers.addDisposition({ kind, ...(comment ? { comment } : {}) })) form.reset();
    };
    const form =
      role === 'operator' || role === 'admin'
        ? html`<form class="disposition-form" @submit=${onSubmit}>
            <select name="kind">
              ${DISPOSITIONS.map(([k, label]) => html`<option value=${k}>${label}</option>`)}
            </select>
            <input name="comment" size="28" maxlength="1000" placeholder="reason or comment" />
            <button type="submit">Record</button>
          </form>`
        : html`<p class="note">Recording a disposition needs an operator token.</p>`;
    return html`<p class="current disposition ${history.length ? 'set' : 'open'}">
        ${history.length ? fmtDisposition(history[0]) : 'open (no disposition yet)'}
      </p>
      ${form}
      ${
        history.length
          ? html`<ul class="disposition-history">
              ${history.map(
                (/** @type {any} */ d) =>
                  html`<li><span class="mono">${fmtTime(d.created_at)}</span> ${d.actor}: ${fmtDisposition(d)}</li>`,
              )}
            </ul>`
          : nothing
      }`;
  }

  /**
   * The side panel's switch between the frame and the 3D view.
   * @param {string|null} url the 3D view's, when it is open
   */
  viewerSwitch(url) {
    return html`<button
        @click=${url ? this.handlers.closeViewer : this.handlers.openViewer}
        data-action=${url ? 'close-3d' : 'open-3d'}
      >
        ${url ? 'Back to the frame' : 'Open 3D view'}</button
      ><span class="note"> the wheel, the four sensors' points, cameras and laser planes</span>`;
  }

  /**
   * The 3D view in the frame's place (it needs the room), hidden without a URL.
   * @param {string|null} url
   */
  viewerOverlay(url) {
    return html`<div class="viewer-overlay" ?hidden=${!url}>
      ${
        url
          ? html`<div class="viewer-bar">
                <strong>3D</strong> drag to orbit, scroll to zoom · wheel from its profile at a nominal 460 mm rolling
                radius (the diameter is not measured) <a href=${url} target="_blank" rel="noopener">open full size</a
                ><span class="spacer"></span
                ><button @click=${this.handlers.closeViewer} data-action="close-3d">
                  Back to the frame <kbd>Esc</kbd>
                </button>
              </div>
              <iframe src=${url} title="3D view of the wheel" class="viewer-frame"></iframe>`
          : nothing
      }
    </div>`;
  }
}

/**
 * The parameter table (both methods, their difference and the limits; a parameter's name
 * shows its definition), the quality table and the alarms.
 * @param {any} record
 * @param {any} limits
 * @param {string} method
 */
function parameterTables(record, limits, method) {
  if (!record) return html`<p class="empty">No results for this wheel.</p>`;
  const a = resultOf(record, 'adaptive') ?? {};
  const s = resultOf(record, 'steger') ?? {};
  const limitRow = limitsFor(limits, (method === 'steger' ? s : a).reference_profile);
  const define = (/** @type {Event} */ e, /** @type {any} */ p) => {
    const definition = /** @type {HTMLElement} */ (
      /** @type {HTMLElement} */ (e.currentTarget).closest('.param-table')?.querySelector('#parameter-definition')
    );
    definition.hidden = definition.dataset.key === p.key && !definition.hidden;
    definition.dataset.key = p.key;
    definition.textContent = `${p.title}: ${p.definition}`;
  };
  const headings = ['', 'Adaptive', 'Steger', 'Δ', `Limits ${limitRow?.wheel_profile ?? ''} (mm)`];
  const selected = (/** @type {number} */ i) =>
    (i === 1 && method === 'adaptive') || (i === 2 && method === 'steger') ? 'selected' : nothing;
  const alarmOn = (/** @type {any} */ r, /** @type {string} */ key) =>
    hasAlarmOn(r, key, limitRow?.wheel_profile) ? 'alarm' : '';
  const alarms = [
    ...(a.alarms ?? []).map((/** @type {any} */ al) => ['adaptive', al]),
    ...(s.alarms ?? []).map((/** @type {any} */ al) => ['steger', al]),
  ];
  // the definition paragraph has no bindings: the buttons set it, updates leave it alone
  return html`${record.reason ? html`<p class="notice">Not measured: ${record.reason}</p>` : nothing}
    <table class="grid compact">
      <thead>
        <tr>
          ${headings.map((t, i) => html`<th class=${selected(i)}>${t}</th>`)}
        </tr>
      </thead>
      <tbody>
        ${PARAMETERS.map(
          (p) =>
            html`<tr data-parameter=${p.key}>
              <th title=${p.title}>
                <button
                  class="definition-link"
                  aria-controls="parameter-definition"
                  @click=${(/** @type {Event} */ e) => define(e, p)}
                >
                  ${p.label}${p.unit && p.unit !== 'mm' ? ` (${p.unit})` : ''}
                </button>
              </th>
              <td class="num ${alarmOn(a, p.key)}">${fmtNumber(a[p.key], p.digits)}</td>
              <td class="num ${alarmOn(s, p.key)}">${fmtNumber(s[p.key], p.digits)}</td>
              <td class="num">
                ${fmtSigned(a[p.key] != null && s[p.key] != null ? a[p.key] - s[p.key] : null, p.digits)}
              </td>
              <td class="num">${limitText(limitRow, p.key, p.limitMax)}</td>
            </tr>`,
        )}
      </tbody>
    </table>
    <p class="note definition" id="parameter-definition" hidden></p>
    ${[
      ['Adaptive', a],
      ['Steger', s],
    ].map(([name, r]) => {
      const why = missingValuesReason(r);
      return why
        ? html`<p class="note missing-reason" data-method=${name.toLowerCase()}>${name}, not measured: ${why}</p>`
        : nothing;
    })}
    ${
      a.tread_reason || s.tread_reason
        ? html`<p class="note tread-reason">Not measured: ${a.tread_reason ?? s.tread_reason}</p>`
        : nothing
    }
    <p class="note diameter-note">${DIAMETER_NOTE}</p>
    <table class="grid compact quality">
      <thead>
        <tr>
          ${['Quality', 'points in / out', 'overlap RMS', 'rejected', 'σ mean (range) px'].map((t) => html`<th>${t}</th>`)}
        </tr>
      </thead>
      <tbody>
        ${[
          ['adaptive', a],
          ['steger', s],
        ].map(
          ([m, r]) =>
            html`<tr>
              <th>${m}</th>
              <td class="num">${r.quality?.points_inner ?? '–'} / ${r.quality?.points_outer ?? '–'}</td>
              <td class="num">
                ${r.quality?.overlap_residual_mm == null ? '–' : `${fmtNumber(r.quality.overlap_residual_mm, 3)} mm`}
              </td>
              <td class="num">${r.quality?.rejected_points ?? '–'}</td>
              <td class="num">
                ${fmtNumber(r.sigma_mean_px)} (${fmtNumber(r.sigma_min_px)}–${fmtNumber(r.sigma_max_px)})
              </td>
            </tr>`,
        )}
      </tbody>
    </table>
    <ul class="alarms">
      ${alarms.map(([m, al]) => html`<li class="alarm">${m}: ${al.message}</li>`)}
    </ul>`;
}

/**
 * The wheel against its handheld reference: each parameter as the gauge's file gives it
 * (recomputed by the wayside code) and each method's difference from it.
 * @param {any} comparison a ReferenceComparison, or {error}
 * @param {((file: File) => Promise<void>|void)|null} importReference for operators and admins
 */
function comparisonTable(comparison, importReference) {
  const reference = comparison?.reference;
  const onPicked = (/** @type {Event} */ e) => {
    const input = /** @type {HTMLInputElement} */ (e.target);
    if (input.files?.[0]) importReference?.(input.files[0]);
    input.value = '';
  };
  const picker = importReference
    ? html`<label class="button import-reference"
        >Import gauge file (.whl, .prr, .csv)<input
          type="file"
          accept=".whl,.prr,.csv"
          hidden
          data-action="import-reference"
          @change=${onPicked}
      /></label>`
    : nothing;
  if (!reference) {
    return html`<p class="empty">
        ${
          comparison?.error
            ? `handheld reference unavailable: ${comparison.error}`
            : 'No handheld reference for this wheel.'
        }
      </p>
      ${picker}`;
  }
  const difference = (/** @type {string} */ method, /** @type {string} */ key) =>
    comparison.differences.find((/** @type {any} */ d) => d.method === method && d.parameter === key)?.difference_mm;
  const rows = PARAMETERS.filter((p) => p.key !== 'back_to_back_mm');
  return html`<table class="grid compact" data-comparison=${String(reference.id)}>
      <thead>
        <tr>
          ${['', 'Handheld', 'Adaptive − handheld', 'Steger − handheld'].map((t) => html`<th>${t}</th>`)}
        </tr>
      </thead>
      <tbody>
        ${rows.map(
          (p) =>
            html`<tr data-parameter=${p.key}>
              <th title=${p.title}>${p.label}</th>
              <td class="num">${fmtNumber(reference[p.key])}</td>
              <td class="num">${fmtSigned(difference('adaptive', p.key))}</td>
              <td class="num">${fmtSigned(difference('steger', p.key))}</td>
            </tr>`,
        )}
      </tbody>
    </table>
    <p class="note">
      ${reference.instrument ?? 'gauge'} · ${reference.filename} · measured
      ${reference.measured_on ?? fmtTime(reference.measured_at)}${
        reference.parameter_quality === 'interpolated'
          ? ' · sparse flank: parameters interpolated between its samples'
          : ''
      }
      · green curve in the profile plot, mm
    </p>
    ${picker}`;
}

/**
 * Why a layer that is switched on is not drawn yet: still loading, or the service's words;
 * first, that the camera frame itself was removed by retention.
 * @param {Record<string, boolean>} show
 * @param {any} w the wheel state
 * @returns {string}
 */
function layerNote(show, w) {
  const removed = framesRemovedNote(w.record);
  const notes = removed ? [removed] : [];
  for (const [key, label] of [
    ['mask', 'stripe mask'],
    ['sigma', 'σ map'],
  ]) {
    if (!show[key] || w.layers?.[key]) continue;
    const error = w.layerErrors?.[key];
    notes.push(error ? `${label} unavailable: ${error}` : `${label} loading…`);
  }
  return notes.join(' · ');
}

/**
 * Limits of one parameter as "min – max", "≥ min" or "≤ max" from a LimitsRead row.
 * @param {any} limits
 * @param {string} key parameter key such as "flange_height_mm"
 * @param {string} [maxKey] the limit field bounding it from above, when not `<stem>_max_mm`
 * @returns {string}
 */
function limitText(limits, key, maxKey) {
  const bounds = limitBounds(limits, key, maxKey);
  if (bounds === null) return '–';
  const { min, max } = bounds;
  if (min != null && max != null) return `${fmtNumber(min, 1)} – ${fmtNumber(max, 1)}`;
  if (min != null) return `≥ ${fmtNumber(min, 1)}`;
  if (max != null) return `≤ ${fmtNumber(max, 1)}`;
  return '–';
}

/**
 * @param {Record<string, any>} centres
 * @returns {import('../lib/method-difference.js').MethodDifference|null}
 */
function pairDifference(centres) {
  const { adaptive, steger } = centres;
  if (!adaptive || !steger || !Array.isArray(adaptive.x) || !Array.isArray(steger.x)) return null;
  return differenceAlongStripe(adaptive, steger, 2);
}
