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
import { framesRemovedNote, hasAlarmOn, limitStem, limitsFor, resultOf } from '../lib/records.js';
import { buildHash } from '../lib/route.js';
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
   * @param {{setQuery: (q: Record<string, string>) => void, exportReport: (format: string) => Promise<void>|void, exportProfile: (format: string) => Promise<void>|void, importReference: (file: File) => Promise<void>|void, openViewer: () => void, closeViewer: () => void, addDisposition: (body: {kind: string, comment?: string}) => void}} handlers
   */
  constructor(root, handlers) {
    this.handlers = handlers;
    this.title = h('div', { class: 'titlebar' });
    this.toolbar = h('div', { class: 'toolbar' });
    this.layerNote = h('span', { class: 'note layer-note' });
    const frameRoot = h('div', { class: 'frame-root' });
    this.viewerOverlay = h('div', { class: 'viewer-overlay', hidden: true });
    this.table = h('div', { class: 'param-table' });
    this.profileCanvas = /** @type {HTMLCanvasElement} */ (
      h('canvas', { class: 'plot profile-plot', 'aria-label': 'profile plot' })
    );
    this.profileNote = h('p', { class: 'note' });
    this.comparisonRoot = h('div', { class: 'comparison' });
    this.diffCanvas = /** @type {HTMLCanvasElement} */ (
      h('canvas', { class: 'plot diff-plot', 'aria-label': 'difference plot' })
    );
    this.diffNote = h('p', { class: 'note mono' });
    this.deltaRRoot = h('div', { class: 'trend delta-r' });
    this.trendRoot = h('div', { class: 'trend' });
    this.dispositionRoot = h('div', { class: 'dispositions' });
    this.viewerRoot = h('div', { class: 'viewer' });
    // the panels that come with the second step of a wheel's load (hidden until then)
    this.panels = h(
      'div',
      { class: 'side-panels' },
      h('h2', {}, 'Disposition'),
      this.dispositionRoot,
      h('h2', {}, 'Profile vs reference'),
      this.profileCanvas,
      this.profileNote,
      h('h2', {}, 'Axle rolling-radius difference Δr(y)'),
      this.deltaRRoot,
      h('h2', {}, 'Handheld gauge'),
      this.comparisonRoot,
      h('h2', {}, 'Adaptive − Steger along the stripe'),
      this.diffCanvas,
      this.diffNote,
      h('h2', {}, 'Trend across passes'),
      this.trendRoot,
      h('h2', {}, '3D'),
      this.viewerRoot,
    );
    this.grid = h(
      'div',
      { class: 'wheel-grid' },
      h('div', { class: 'frame-panel' }, this.toolbar, frameRoot, this.viewerOverlay),
      h('div', { class: 'side-panel' }, h('h2', {}, 'Parameters'), this.table, this.panels),
    );
    this.section = h('section', { class: 'wheel' }, this.title, this.grid);
    root.replaceChildren(this.section);
    this.frame = new FrameView(frameRoot);
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
    /** @type {any} */
    this.shown = {};
    /** @type {any} */
    this.trendPlot = null;
    /** @type {any} */
    this.deltaRPlot = null;
  }

  /**
   * Bring the page up to date with the state; only parts whose data changed are redrawn.
   * @param {any} state
   */
  update(state) {
    const w = state.wheel;
    const method = state.route.query.method === 'steger' ? 'steger' : 'adaptive';
    const { passId, wheelId } = state.route.params;
    // never show another wheel's data under this wheel's address (the store may still hold it)
    if (!w || !w.layers || w.passId !== passId || w.wheelId !== wheelId) {
      const failed = w?.failed && w.passId === passId && w.wheelId === wheelId;
      this.title.replaceChildren(
        failed
          ? h(
              'p',
              { class: 'notice failed' },
              `Wheel ${wheelId} of pass ${passId} could not be shown (the reason is above). `,
              h('a', { href: buildHash(['passes', passId]) }, `Back to pass #${passId}`),
              ' · ',
              h('a', { href: '#/passes' }, 'the passes'),
            )
          : h('p', { class: 'loading' }, 'Loading wheel…'),
      );
      // a wheel that cannot be shown shows no empty panels
      this.grid.hidden = Boolean(failed);
      this.panels.classList.add('pending');
      this.frame.clear();
      this.shown = {};
      return;
    }
    this.grid.hidden = false;
    const show = LAYERS.reduce((acc, [key]) => ({ ...acc, [key]: state.layers[key] }), {});
    const changed = (/** @type {string} */ key, /** @type {any} */ value) => {
      if (this.shown[key] === value) return false;
      this.shown[key] = value;
      return true;
    };
    if (changed('titleDeps', `${w.loadMs}|${method}|${w.loading}|${state.pass?.wheels?.length}`))
      this.renderTitle(state, w, method);
    if (changed('toolbar', JSON.stringify(show))) this.renderToolbar(show);
    if (changed('layers', w.layers)) {
      // this wheel's frame data reached the canvas (the browser tests wait for it, benchmarks/browser.py times from it)
      performance.mark('frame-data', { detail: `${w.passId}/${w.wheelId}` });
      this.frame.setData({ ...w.layers, sigmaScale: w.sigmaScale, centres: w.centres });
      this.difference = pairDifference(w.centres);
      this.drawDifferencePlot(-1);
    }
    this.frame.setShow(show);
    // which wheel is fully on screen (the browser tests wait for it)
    this.section.dataset.loadedWheel = w.loading ? '' : `${w.passId}/${w.wheelId}`;
    this.layerNote.textContent = layerNote(show, w);
    if (changed('table', `${method}|${w.record?.wheel_id}|${w.loadMs}`))
      this.renderTable(w.record, state.limits, method);
    // the side panels come with the second step of the load, after the frame is drawn
    this.panels.classList.toggle('pending', !w.profiles);
    if (!w.profiles) return;
    if (changed('dispositions', `${JSON.stringify(w.dispositions)}|${state.me?.role}`))
      this.renderDispositions(w, state.me?.role);
    if (changed('profile', `${method}|${w.loadMs}`)) {
      this.profileOrder = [
        ...(method === 'steger' ? ['steger', 'adaptive'] : ['adaptive', 'steger']),
        ...(w.profiles.handheld ? ['handheld'] : []),
      ];
      this.profiles = w.profiles;
      this.drawProfilePlot(null);
      this.deltaRPlot = renderDeltaR(this.deltaRRoot, w.profiles, this.profileOrder, this.deltaRPlot);
    }
    if (changed('comparison', `${w.loadMs}|${w.comparison?.reference?.id}|${state.me?.role}`)) {
      renderComparison(
        this.comparisonRoot,
        w.comparison,
        state.me?.role !== 'viewer' ? this.handlers.importReference : null,
      );
    }
    if (changed('trend', w.trend)) {
      this.trendPlot = w.trend?.error ? null : renderTrend(this.trendRoot, w.trend, this.trendPlot);
      if (w.trend?.error)
        this.trendRoot.replaceChildren(h('p', { class: 'error' }, `trend unavailable: ${w.trend?.error}`));
    }
    if (changed('viewer', w.viewerUrl ?? null)) this.renderViewer(w.viewerUrl);
    // every panel of this wheel built (benchmarks/browser.py times the whole page to it)
    if (!w.loading && changed('complete', `${w.passId}/${w.wheelId}/${w.loadMs}`))
      performance.mark('wheel-loaded', { detail: `${w.passId}/${w.wheelId}` });
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
        : 'Dashed grey: reference. Constructions of the selected method: Sh (yellow), Sd (green), qR (pink). Hover the profile to read points.');
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
  renderTitle(state, w, method) {
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
        ? h(
            'a',
            { class: 'button', rel, href: buildHash(['passes', w.passId, 'wheels', s.wheel_id], { method }) },
            text,
          )
        : h('span', { class: 'button disabled' }, text);
    this.title.replaceChildren(
      h(
        'h1',
        {},
        h('a', { href: '#/passes' }, 'Passes'),
        ' › ',
        h('a', { href: buildHash(['passes', w.passId]) }, `Pass #${w.passId}`),
        ' › ',
        r ? `Vehicle ${r.vehicle_id} · axle ${r.axle} · ${r.side}` : `Wheel ${w.wheelId}`,
      ),
      h(
        'span',
        { class: `badge ${level}`, 'data-level': level },
        r?.reason
          ? 'not measured'
          : { ok: 'within limits', near: 'NEAR LIMIT', alarm: 'ALARM', none: r?.state ?? '–' }[level],
      ),
      h('span', { class: `disposition ${r?.disposition ? 'set' : 'open'}` }, fmtDisposition(r?.disposition)),
      disagreement
        ? h(
            'span',
            { class: 'flag disagreement', title: "adaptive and Steger differ by more than the fleet's threshold" },
            `methods differ: ${disagreement}`,
          )
        : '',
      h(
        'div',
        { class: 'segmented', role: 'group', 'aria-label': 'frame' },
        w.frames.map((/** @type {any} */ f) =>
          h(
            'button',
            {
              class: f.sensor === w.sensor && f.index === w.index ? 'on' : null,
              'data-sensor': f.sensor,
              onclick: () => this.handlers.setQuery({ sensor: f.sensor, frame: String(f.index) }),
            },
            fmtSensor(f.sensor),
            w.frames.filter((/** @type {any} */ g) => g.sensor === f.sensor).length > 1 ? ` ${f.index + 1}` : '',
          ),
        ),
      ),
      h(
        'div',
        { class: 'segmented', role: 'group', 'aria-label': 'method' },
        METHODS.map((m) =>
          h(
            'button',
            {
              class: m === method ? 'on' : null,
              'data-method': m,
              'aria-pressed': String(m === method),
              onclick: () => this.handlers.setQuery({ method: m }),
            },
            m === 'adaptive' ? 'Adaptive' : 'Steger',
          ),
        ),
      ),
      h('span', { class: 'spacer' }),
      link(siblings[at - 1], '[ prev', 'prev'),
      link(siblings[at + 1], 'next ]', 'next'),
      exportButtons(this.handlers.exportReport),
      exportButtons(this.handlers.exportProfile, 'profile'),
      h(
        'span',
        { class: 'meta', 'data-load-ms': String(Math.round(w.loadMs ?? 0)) },
        w.loading ? 'loading…' : `loaded in ${Math.round(w.loadMs ?? 0)} ms`,
      ),
    );
  }

  /** @param {Record<string, boolean>} show */
  renderToolbar(show) {
    this.toolbar.replaceChildren(
      ...LAYERS.map(([key, label, shortcut]) =>
        h(
          'label',
          { class: `toggle ${key}` },
          h('input', {
            type: 'checkbox',
            'data-layer': key,
            checked: show[key],
            onchange: (/** @type {Event} */ e) =>
              this.handlers.setQuery({ [key]: /** @type {HTMLInputElement} */ (e.target).checked ? '1' : '0' }),
          }),
          ` ${label} `,
          h('kbd', {}, shortcut),
        ),
      ),
      h(
        'button',
        { onclick: () => this.frame.fit(), title: 'fit: the stripe, then the whole frame (f)' },
        'Fit ',
        h('kbd', {}, 'f'),
      ),
      this.layerNote,
    );
  }

  /** @param {any} record @param {any} limits @param {string} method */
  renderTable(record, limits, method) {
    if (!record) {
      this.table.replaceChildren(h('p', { class: 'empty' }, 'No results for this wheel.'));
      return;
    }
    const a = resultOf(record, 'adaptive') ?? {};
    const s = resultOf(record, 'steger') ?? {};
    const limitRow = limitsFor(limits, (method === 'steger' ? s : a).reference_profile);
    // a parameter's definition, one click on its name away
    const definition = h('p', { class: 'note definition', id: 'parameter-definition', hidden: true });
    this.table.replaceChildren(
      record.reason ? h('p', { class: 'notice' }, `Not measured: ${record.reason}`) : '',
      h(
        'table',
        { class: 'grid compact' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            ['', 'Adaptive', 'Steger', 'Δ', `Limits ${limitRow?.wheel_profile ?? ''} (mm)`].map((t, i) =>
              h(
                'th',
                { class: (i === 1 && method === 'adaptive') || (i === 2 && method === 'steger') ? 'selected' : null },
                t,
              ),
            ),
          ),
        ),
        h(
          'tbody',
          {},
          PARAMETERS.map((p) =>
            h(
              'tr',
              { dataset: { parameter: p.key } },
              h(
                'th',
                { title: p.title },
                h(
                  'button',
                  {
                    class: 'definition-link',
                    'aria-controls': 'parameter-definition',
                    onclick: () => {
                      definition.hidden = definition.dataset.key === p.key && !definition.hidden;
                      definition.dataset.key = p.key;
                      definition.textContent = `${p.title}: ${p.definition}`;
                    },
                  },
                  p.label,
                  p.unit && p.unit !== 'mm' ? ` (${p.unit})` : '',
                ),
              ),
              h(
                'td',
                { class: `num ${hasAlarmOn(a, p.key, limitRow?.wheel_profile) ? 'alarm' : ''}` },
                fmtNumber(a[p.key], p.digits),
              ),
              h(
                'td',
                { class: `num ${hasAlarmOn(s, p.key, limitRow?.wheel_profile) ? 'alarm' : ''}` },
                fmtNumber(s[p.key], p.digits),
              ),
              h(
                'td',
                { class: 'num' },
                fmtSigned(a[p.key] != null && s[p.key] != null ? a[p.key] - s[p.key] : null, p.digits),
              ),
              h('td', { class: 'num' }, limitText(limitRow, p.key, p.limitMax)),
            ),
          ),
        ),
      ),
      definition,
      a.tread_reason || s.tread_reason
        ? h('p', { class: 'note tread-reason' }, `Not measured: ${a.tread_reason ?? s.tread_reason}`)
        : '',
      h('p', { class: 'note diameter-note' }, DIAMETER_NOTE),
      h(
        'table',
        { class: 'grid compact quality' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            ['Quality', 'points in / out', 'overlap RMS', 'rejected', 'σ mean (range) px'].map((t) => h('th', {}, t)),
          ),
        ),
        h(
          'tbody',
          {},
          [
            ['adaptive', a],
            ['steger', s],
          ].map(([m, r]) =>
            h(
              'tr',
              {},
              h('th', {}, m),
              h('td', { class: 'num' }, `${r.quality?.points_inner ?? '–'} / ${r.quality?.points_outer ?? '–'}`),
              h(
                'td',
                { class: 'num' },
                r.quality?.overlap_residual_mm == null ? '–' : `${fmtNumber(r.quality.overlap_residual_mm, 3)} mm`,
              ),
              h('td', { class: 'num' }, r.quality?.rejected_points ?? '–'),
              h(
                'td',
                { class: 'num' },
                `${fmtNumber(r.sigma_mean_px)} (${fmtNumber(r.sigma_min_px)}–${fmtNumber(r.sigma_max_px)})`,
              ),
            ),
          ),
        ),
      ),
      h(
        'ul',
        { class: 'alarms' },
        [
          ...(a.alarms ?? []).map((/** @type {any} */ al) => ['adaptive', al]),
          ...(s.alarms ?? []).map((/** @type {any} */ al) => ['steger', al]),
        ].map(([m, al]) => h('li', { class: 'alarm' }, `${m}: ${al.message}`)),
      ),
    );
  }

  /**
   * The disposition in force, its history (who, when) and, for operators, the form.
   * @param {any} w the wheel state
   * @param {string|undefined} role
   */
  renderDispositions(w, role) {
    const history = w.dispositions ?? [];
    const kind = /** @type {HTMLSelectElement} */ (
      h(
        'select',
        { name: 'kind' },
        DISPOSITIONS.map(([k, label]) => h('option', { value: k }, label)),
      )
    );
    const comment = /** @type {HTMLInputElement} */ (
      h('input', { name: 'comment', size: 28, maxlength: 1000, placeholder: 'reason or comment' })
    );
    const form =
      role === 'operator' || role === 'admin'
        ? h(
            'form',
            {
              class: 'disposition-form',
              onsubmit: (/** @type {Event} */ e) => {
                e.preventDefault();
                this.handlers.addDisposition({
                  kind: kind.value,
                  ...(comment.value.trim() ? { comment: comment.value.trim() } : {}),
                });
              },
            },
            kind,
            ' ',
            comment,
            ' ',
            h('button', { type: 'submit' }, 'Record'),
          )
        : h('p', { class: 'note' }, 'Recording a disposition needs an operator token.');
    this.dispositionRoot.replaceChildren(
      h(
        'p',
        { class: `current disposition ${history.length ? 'set' : 'open'}` },
        history.length ? fmtDisposition(history[0]) : 'open (no disposition yet)',
      ),
      form,
      history.length
        ? h(
            'ul',
            { class: 'disposition-history' },
            history.map((/** @type {any} */ d) =>
              h('li', {}, h('span', { class: 'mono' }, fmtTime(d.created_at)), ` ${d.actor}: `, fmtDisposition(d)),
            ),
          )
        : '',
    );
  }

  /** @param {string|null} url */
  renderViewer(url) {
    // the 3D view takes the frame's place (it needs the room); the side panel keeps the switch
    this.viewerOverlay.hidden = !url;
    this.viewerOverlay.replaceChildren(
      ...(url
        ? [
            h(
              'div',
              { class: 'viewer-bar' },
              h('strong', {}, '3D'),
              ' drag to orbit, scroll to zoom · wheel from its profile at a nominal 460 mm rolling radius (the diameter is not measured) ',
              h('a', { href: url, target: '_blank', rel: 'noopener' }, 'open full size'),
              h('span', { class: 'spacer' }),
              h(
                'button',
                { onclick: this.handlers.closeViewer, 'data-action': 'close-3d' },
                'Back to the frame ',
                h('kbd', {}, 'Esc'),
              ),
            ),
            h('iframe', { src: url, title: '3D view of the wheel', class: 'viewer-frame' }),
          ]
        : []),
    );
    this.viewerRoot.replaceChildren(
      h(
        'button',
        {
          onclick: url ? this.handlers.closeViewer : this.handlers.openViewer,
          'data-action': url ? 'close-3d' : 'open-3d',
        },
        url ? 'Back to the frame' : 'Open 3D view',
      ),
      h('span', { class: 'note' }, " the wheel, the four sensors' points, cameras and laser planes"),
    );
  }
}

/**
 * The wheel against its handheld reference: each parameter as the gauge's file gives it
 * (recomputed by the wayside code) and each method's difference from it.
 * @param {HTMLElement} root
 * @param {any} comparison a ReferenceComparison, or {error}
 * @param {((file: File) => Promise<void>|void)|null} importReference for operators and admins
 */
function renderComparison(root, comparison, importReference) {
  const reference = comparison?.reference;
  const picker = importReference
    ? h(
        'label',
        { class: 'button import-reference' },
        'Import gauge file (.whl, .prr, .csv)',
        h('input', {
          type: 'file',
          accept: '.whl,.prr,.csv',
          hidden: true,
          'data-action': 'import-reference',
          onchange: (/** @type {Event} */ e) => {
            const input = /** @type {HTMLInputElement} */ (e.target);
            if (input.files?.[0]) importReference(input.files[0]);
            input.value = '';
          },
        }),
      )
    : '';
  if (!reference) {
    root.replaceChildren(
      h(
        'p',
        { class: 'empty' },
        comparison?.error
          ? `handheld reference unavailable: ${comparison.error}`
          : 'No handheld reference for this wheel.',
      ),
      picker,
    );
    return;
  }
  const difference = (/** @type {string} */ method, /** @type {string} */ key) =>
    comparison.differences.find((/** @type {any} */ d) => d.method === method && d.parameter === key)?.difference_mm;
  const rows = PARAMETERS.filter((p) => p.key !== 'back_to_back_mm');
  root.replaceChildren(
    h(
      'table',
      { class: 'grid compact', 'data-comparison': String(reference.id) },
      h(
        'thead',
        {},
        h(
          'tr',
          {},
          ['', 'Handheld', 'Adaptive − handheld', 'Steger − handheld'].map((t) => h('th', {}, t)),
        ),
      ),
      h(
        'tbody',
        {},
        rows.map((p) =>
          h(
            'tr',
            { dataset: { parameter: p.key } },
            h('th', { title: p.title }, p.label),
            h('td', { class: 'num' }, fmtNumber(reference[p.key])),
            h('td', { class: 'num' }, fmtSigned(difference('adaptive', p.key))),
            h('td', { class: 'num' }, fmtSigned(difference('steger', p.key))),
          ),
        ),
      ),
    ),
    h(
      'p',
      { class: 'note' },
      `${reference.instrument ?? 'gauge'} · ${reference.filename} · measured ${reference.measured_on ?? fmtTime(reference.measured_at)}`,
      reference.parameter_quality === 'interpolated'
        ? ' · sparse flank: parameters interpolated between its samples'
        : '',
      ' · green curve in the profile plot, mm',
    ),
    picker,
  );
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
  const stem = limitStem(key, limits?.wheel_profile);
  if (stem === null) return '–';
  const min = limits?.[`${stem}_min_mm`];
  const max = limits?.[maxKey ?? `${stem}_max_mm`];
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
