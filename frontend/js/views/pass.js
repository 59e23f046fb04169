// @ts-check
/**
 * Pass: the train as vehicles → axles → left/right wheels, each with Sh, Sd, qR,
 * back-to-back and its alarm state by colour, for the adaptive method, Steger, or their
 * difference (adaptive − Steger).
 */
import {
  fmtDisposition,
  fmtNumber,
  fmtSigned,
  fmtTime,
  PARAMETERS,
  parameterOf,
  shownParameters,
} from '../lib/format.js';
import { familyOf, hasAlarmOn, marginOf, passStatus, resultOf } from '../lib/records.js';
import { buildHash } from '../lib/route.js';
import { alarmClass, definitions, h } from './dom.js';

/**
 * Render the pass page.
 * @param {HTMLElement} root
 * @param {any} state
 * @param {{setMode: (mode: string) => void, exportReport: (format: string) => Promise<void>|void}} handlers
 */
export function renderPass(root, state, handlers) {
  const pass = state.pass;
  if (!pass || pass.loading || !pass.data) {
    const text = pass?.failed
      ? `Pass ${pass.id} could not be shown (the reason is above). `
      : pass?.loading
        ? `Loading pass ${pass.id}…`
        : 'No pass loaded.';
    root.replaceChildren(
      h('p', { class: 'loading' }, text, pass?.failed ? h('a', { href: '#/passes' }, 'Back to the passes') : ''),
    );
    return;
  }
  const mode = state.route.query.mode ?? 'adaptive';
  const p = pass.data;
  const status = passStatus(p, state.liveJobs?.[p.id]);
  root.replaceChildren(
    h(
      'section',
      { class: 'pass' },
      h(
        'div',
        { class: 'titlebar' },
        h('h1', {}, h('a', { href: '#/passes' }, 'Passes'), ' › ', `Pass #${p.id}`),
        h(
          'span',
          { class: 'meta' },
          `${p.site ?? ''} · ${fmtTime(p.started_at)} · ${p.direction ?? '–'} · ${fmtNumber(p.speed_kmh, 1)} km/h`,
        ),
        h(
          'span',
          { class: `status status-${status.state}` },
          status.state,
          status.running && status.progress != null ? ` ${Math.round(status.progress * 100)} %` : null,
        ),
        h(
          'span',
          { class: 'meta' },
          `${p.wheels_measured} / ${p.wheels_total} wheels measured · ${p.wheels_not_measured} not measured · `,
          h('span', { class: p.alarm_count ? 'alarm-text' : null }, `${p.alarm_count} in alarm`),
          ' · ',
          h('span', { class: p.near_limit_count ? 'near-text' : null }, `${p.near_limit_count ?? 0} near a limit`),
        ),
        h('a', { class: 'button', href: buildHash(['review'], { pass: p.id }) }, 'Worst wheels of this pass'),
        h('span', { class: 'spacer' }),
        modeSwitch(mode, handlers.setMode),
        exportButtons(handlers.exportReport),
      ),
      (p.alarm_values ?? []).length
        ? h('p', { class: 'alarm-values' }, h('strong', {}, 'In alarm: '), p.alarm_values.join(' · '))
        : null,
      train(pass.wheels, mode, String(p.id)),
      definitions(PARAMETERS),
    ),
  );
}

/**
 * @param {string} mode
 * @param {(mode: string) => void} setMode
 * @returns {HTMLElement}
 */
function modeSwitch(mode, setMode) {
  return h(
    'div',
    { class: 'segmented', role: 'group', 'aria-label': 'method' },
    [
      ['adaptive', 'Adaptive'],
      ['steger', 'Steger'],
      ['difference', 'Δ adaptive − Steger'],
    ].map(([key, label]) =>
      h(
        'button',
        { class: mode === key ? 'on' : null, 'aria-pressed': String(mode === key), onclick: () => setMode(key) },
        label,
      ),
    ),
  );
}

/**
 * Export buttons calling back with the format; while a file is prepared (a pass PDF takes
 * a second or two) its button is disabled and a progress bar with the elapsed time shows.
 * @param {(format: string) => Promise<void>|void} exportFile
 * @param {'report'|'profile'} [kind] report (PDF, CSV, JSON) or profile (CSV, DXF, .whl) files
 * @returns {HTMLElement}
 */
export function exportButtons(exportFile, kind = 'report') {
  const formats = kind === 'report' ? ['pdf', 'csv', 'json'] : ['csv', 'dxf', 'whl'];
  const text = h('span', {});
  const status = h(
    'span',
    { class: 'export-progress', hidden: true, role: 'status' },
    h('progress', { 'aria-label': 'preparing the file' }),
    text,
  );
  const run = async (/** @type {HTMLButtonElement} */ button, /** @type {string} */ format) => {
    const started = performance.now();
    const tick = () => {
      text.textContent = ` preparing ${format.toUpperCase()}… ${((performance.now() - started) / 1000).toFixed(1)} s`;
    };
    button.disabled = true;
    status.hidden = false;
    tick();
    const timer = window.setInterval(tick, 100);
    try {
      await exportFile(format);
    } finally {
      window.clearInterval(timer);
      button.disabled = false;
      status.hidden = true;
    }
  };
  return h(
    'div',
    { class: `exports ${kind}` },
    kind === 'report' ? 'Export ' : 'Profile ',
    formats.map((f) =>
      h(
        'button',
        {
          dataset: kind === 'report' ? { export: f } : { exportProfile: f },
          title:
            kind === 'profile'
              ? `the selected method's profile as ${f === 'whl' ? 'MiniProf-style .whl' : f.toUpperCase()}`
              : null,
          onclick: (/** @type {MouseEvent} */ e) => run(/** @type {HTMLButtonElement} */ (e.currentTarget), f),
        },
        f === 'whl' ? '.whl' : f.toUpperCase(),
      ),
    ),
    status,
  );
}

/**
 * @param {any[]} wheels
 * @param {string} mode
 * @param {string} passId
 * @returns {HTMLElement}
 */
function train(wheels, mode, passId) {
  /** @type {Map<string, Map<number, any>>} */
  const vehicles = new Map();
  for (const w of wheels) {
    if (!vehicles.has(w.vehicle_id)) vehicles.set(w.vehicle_id, new Map());
    const axles = /** @type {Map<number, any>} */ (vehicles.get(w.vehicle_id));
    axles.set(w.axle, { ...(axles.get(w.axle) ?? {}), [w.side]: w });
  }
  if (vehicles.size === 0)
    return h('p', { class: 'empty' }, 'No wheels yet: frames are still arriving or being measured.');
  return h(
    'div',
    { class: 'train' },
    [...vehicles].map(([vehicleId, axles]) =>
      h(
        'div',
        { class: 'vehicle' },
        h('h2', {}, `Vehicle ${vehicleId}`),
        [...axles]
          .sort((a, b) => a[0] - b[0])
          .map(([axle, pair]) =>
            h(
              'div',
              { class: 'axle' },
              wheelCard(pair.left, 'left', mode, passId),
              h(
                'div',
                { class: 'axle-info' },
                h('div', {}, `axle ${axle}`),
                h('div', { class: 'mono', title: 'back-to-back distance' }, `B2B ${backToBack(pair, mode)}`),
              ),
              wheelCard(pair.right, 'right', mode, passId),
            ),
          ),
      ),
    ),
  );
}

/**
 * @param {any} pair {left, right}
 * @param {string} mode
 * @returns {string}
 */
function backToBack(pair, mode) {
  const value = (/** @type {string} */ m) =>
    resultOf(pair.left, m)?.back_to_back_mm ?? resultOf(pair.right, m)?.back_to_back_mm ?? null;
  if (mode === 'difference') {
    const a = value('adaptive');
    const s = value('steger');
    return a == null || s == null ? '–' : fmtSigned(a - s);
  }
  return fmtNumber(value(mode));
}

/**
 * @param {any} wheel a wheel record from the API, or undefined
 * @param {string} side
 * @param {string} mode
 * @param {string} passId
 * @returns {HTMLElement}
 */
function wheelCard(wheel, side, mode, passId) {
  if (!wheel) return h('div', { class: 'wheel-card none' }, `${side}: no wheel`);
  const adaptive = resultOf(wheel, 'adaptive');
  const steger = resultOf(wheel, 'steger');
  const shown = mode === 'steger' ? steger : adaptive;
  const cls = mode === 'steger' ? alarmClass(shown) : cardLevel(wheel, adaptive);
  const family = familyOf(adaptive ?? steger);
  const alarms = (shown?.alarms ?? []).map((/** @type {any} */ a) => a.message).join('; ');
  const reason = reasonShown(wheel, mode === 'difference' ? undefined : shown);
  const disagreement = (wheel.method_disagreement ?? [])
    .map((/** @type {any} */ d) => `${parameterOf(d.parameter).label} ${fmtSigned(d.difference_mm, 1)} mm`)
    .join(', ');
  return h(
    'a',
    {
      class: `wheel-card ${cls} state-${wheel.state}`,
      href: buildHash(['passes', passId, 'wheels', wheel.wheel_id], mode === 'difference' ? {} : { method: mode }),
      title: alarms || wheel.reason || '',
      dataset: { wheelId: String(wheel.wheel_id), side, level: cls },
    },
    h(
      'div',
      { class: 'card-head' },
      h('span', {}, side),
      h('span', { class: 'limit-set', title: `checked against the ${family} limits` }, `${family} limits`),
      h('span', { class: 'state' }, wheel.state.replace('_', ' ')),
    ),
    reason
      ? h('div', { class: 'reason' }, reason)
      : h(
          'table',
          {},
          shownParameters(family).map((p) =>
            h(
              'tr',
              { dataset: { parameter: p.key } },
              h('th', { title: `${p.title}: ${p.definition}` }, p.label),
              h(
                'td',
                { class: `num ${mode === 'difference' ? '' : valueLevel(wheel, shown, p.key, family, mode)}` },
                mode === 'difference'
                  ? fmtSigned(diff(adaptive?.[p.key], steger?.[p.key]), p.digits)
                  : fmtNumber(shown?.[p.key], p.digits),
              ),
              h('td', { class: 'unit' }, p.unit),
            ),
          ),
        ),
    disagreement
      ? h(
          'div',
          { class: 'flag disagreement', title: "adaptive − Steger beyond the fleet's threshold: check the frame" },
          `methods differ: ${disagreement}`,
        )
      : null,
    h('div', { class: `disposition ${wheel.disposition ? 'set' : 'open'}` }, fmtDisposition(wheel.disposition)),
  );
}

/**
 * The card's colour: the service's level of the adaptive result (alarm, near, ok).
 * @param {any} wheel a PassWheelRead
 * @param {any} adaptive its adaptive MethodResult or null
 * @returns {string}
 */
function cardLevel(wheel, adaptive) {
  if (alarmClass(adaptive) === 'none') return 'none';
  return wheel.level && wheel.level !== 'none' ? wheel.level : alarmClass(adaptive);
}

/**
 * Class of one value on a card: "alarm" or "near" from the margins (adaptive) or the
 * alarms (Steger, which has no margins), else none.
 * @param {any} wheel @param {any} result @param {string} key @param {string} family @param {string} mode
 * @returns {string}
 */
function valueLevel(wheel, result, key, family, mode) {
  if (mode === 'steger') return hasAlarmOn(result, key, family) ? 'alarm' : '';
  const level = marginOf(wheel, key)?.level;
  return level === 'alarm' || level === 'near' ? level : '';
}

/**
 * Why a wheel card shows no figures: the shown method's reason when it was not measured,
 * else (no result of that method, or the difference view) the wheel's own reason.
 * @param {any} wheel a wheel record from the API
 * @param {any} result the shown method's result, or undefined
 * @returns {string|null}
 */
function reasonShown(wheel, result) {
  if (result) return result.status === 'measured' ? null : (result.reason ?? wheel.reason ?? null);
  return wheel.reason ?? null;
}

/**
 * @param {number|null|undefined} a
 * @param {number|null|undefined} b
 * @returns {number|null}
 */
function diff(a, b) {
  return a == null || b == null ? null : a - b;
}
