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
import {
  checkedFamily,
  familyOf,
  hasAlarmOn,
  marginOf,
  missingValuesReason,
  passStatus,
  resultOf,
} from '../lib/records.js';
import { buildHash } from '../lib/route.js';
import { html, nothing, render } from '../../vendor/lit-html-3.3.3.js';
import { alarmClass, definitions } from './dom.js';

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
    render(
      html`<p class="loading">${text}${pass?.failed ? html`<a href="#/passes">Back to the passes</a>` : nothing}</p>`,
      root,
    );
    return;
  }
  const mode = state.route.query.mode ?? 'adaptive';
  const p = pass.data;
  const status = passStatus(p, state.liveJobs?.[p.id]);
  const highlight = (/** @type {boolean} */ on, /** @type {string} */ cls) => (on ? cls : nothing);
  render(
    html`<section class="pass">
      <div class="titlebar">
        <h1><a href="#/passes">Passes</a> › Pass #${p.id}</h1>
        <span class="meta"
          >${p.site ?? ''} · ${fmtTime(p.started_at)} · ${p.direction ?? '–'} · ${fmtNumber(p.speed_kmh, 1)} km/h</span
        >
        <span class="status status-${status.state}"
          >${status.state}${
            status.running && status.progress != null ? ` ${Math.round(status.progress * 100)} %` : nothing
          }</span
        >
        <span class="meta"
          >${p.wheels_measured} / ${p.wheels_total} wheels measured · ${p.wheels_not_measured} not measured ·
          <span class=${highlight(p.alarm_count, 'alarm-text')}>${p.alarm_count} in alarm</span> ·
          <span class=${highlight(p.near_limit_count, 'near-text')}>${p.near_limit_count ?? 0} near a limit</span></span
        >
        <a class="button" href=${buildHash(['review'], { pass: p.id })}>Worst wheels of this pass</a>
        <span class="spacer"></span>
        ${modeSwitch(mode, handlers.setMode)} ${exportButtons(handlers.exportReport)}
      </div>
      ${
        (p.alarm_values ?? []).length
          ? html`<p class="alarm-values"><strong>In alarm: </strong>${p.alarm_values.join(' · ')}</p>`
          : nothing
      }
      ${train(pass.wheels, mode, String(p.id))} ${definitions(PARAMETERS)}
    </section>`,
    root,
  );
}

/**
 * @param {string} mode
 * @param {(mode: string) => void} setMode
 */
function modeSwitch(mode, setMode) {
  return html`<div class="segmented" role="group" aria-label="method">
    ${[
      ['adaptive', 'Adaptive'],
      ['steger', 'Steger'],
      ['difference', 'Δ adaptive − Steger'],
    ].map(
      ([key, label]) =>
        html`<button
          class=${mode === key ? 'on' : nothing}
          aria-pressed=${String(mode === key)}
          @click=${() => setMode(key)}
        >
          ${label}
        </button>`,
    )}
  </div>`;
}

/**
 * Export buttons calling back with the format; while a file is prepared (a pass PDF takes
 * a second or two) its button is disabled and a progress bar with the elapsed time shows.
 * The progress is set by the click, on elements with no bindings: updates leave it alone.
 * @param {(format: string) => Promise<void>|void} exportFile
 * @param {'report'|'profile'} [kind] report (PDF, CSV, JSON) or profile (CSV, DXF, .whl) files
 */
export function exportButtons(exportFile, kind = 'report') {
  const formats = kind === 'report' ? ['pdf', 'csv', 'json'] : ['csv', 'dxf', 'whl'];
  const run = async (/** @type {MouseEvent} */ e, /** @type {string} */ format) => {
    const button = /** @type {HTMLButtonElement} */ (e.currentTarget);
    const status = /** @type {HTMLElement} */ (button.parentElement?.querySelector('.export-progress'));
    const text = /** @type {HTMLElement} */ (status.querySelector('.export-time'));
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
  const title = (/** @type {string} */ f) =>
    kind === 'profile'
      ? `the selected method's profile as ${f === 'whl' ? 'MiniProf-style .whl' : f.toUpperCase()}`
      : nothing;
  return html`<div class="exports ${kind}">
    ${kind === 'report' ? 'Export ' : 'Profile '}${formats.map(
      (f) =>
        html`<button
          data-export=${kind === 'report' ? f : nothing}
          data-export-profile=${kind === 'report' ? nothing : f}
          title=${title(f)}
          @click=${(/** @type {MouseEvent} */ e) => run(e, f)}
        >
          ${f === 'whl' ? '.whl' : f.toUpperCase()}
        </button>`,
    )}<span class="export-progress" hidden role="status"
      ><progress aria-label="preparing the file"></progress><span class="export-time"></span
    ></span>
  </div>`;
}

/**
 * @param {any[]} wheels
 * @param {string} mode
 * @param {string} passId
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
    return html`<p class="empty">No wheels yet: frames are still arriving or being measured.</p>`;
  return html`<div class="train">
    ${[...vehicles].map(
      ([vehicleId, axles]) =>
        html`<div class="vehicle">
          <h2>Vehicle ${vehicleId}</h2>
          ${[...axles]
            .sort((a, b) => a[0] - b[0])
            .map(
              ([axle, pair]) =>
                html`<div class="axle">
                  ${wheelCard(pair.left, 'left', mode, passId)}
                  <div class="axle-info">
                    <div>axle ${axle}</div>
                    <div class="mono" title="back-to-back distance">B2B ${backToBack(pair, mode)}</div>
                  </div>
                  ${wheelCard(pair.right, 'right', mode, passId)}
                </div>`,
            )}
        </div>`,
    )}
  </div>`;
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
 */
function wheelCard(wheel, side, mode, passId) {
  if (!wheel) return html`<div class="wheel-card none">${side}: no wheel</div>`;
  const adaptive = resultOf(wheel, 'adaptive');
  const steger = resultOf(wheel, 'steger');
  const shown = mode === 'steger' ? steger : adaptive;
  const cls = mode === 'steger' ? alarmClass(shown) : cardLevel(wheel, adaptive);
  // A wheel neither method measured was checked against no limits: no badge.
  const checked = checkedFamily([adaptive, steger]);
  const family = checked ?? familyOf(adaptive ?? steger);
  const alarms = (shown?.alarms ?? []).map((/** @type {any} */ a) => a.message).join('; ');
  const reason = reasonShown(wheel, mode === 'difference' ? undefined : shown);
  const missing = missingValuesReason(shown);
  const disagreement = (wheel.method_disagreement ?? [])
    .map((/** @type {any} */ d) => `${parameterOf(d.parameter).label} ${fmtSigned(d.difference_mm, 1)} mm`)
    .join(', ');
  const value = (/** @type {any} */ p) =>
    mode === 'difference'
      ? fmtSigned(diff(adaptive?.[p.key], steger?.[p.key]), p.digits)
      : fmtNumber(shown?.[p.key], p.digits);
  const href = buildHash(['passes', passId, 'wheels', wheel.wheel_id], mode === 'difference' ? {} : { method: mode });
  return html`<a
    class="wheel-card ${cls} state-${wheel.state}"
    href=${href}
    title=${[alarms || wheel.reason, missing && `not measured: ${missing}`].filter(Boolean).join('; ')}
    data-wheel-id=${String(wheel.wheel_id)}
    data-side=${side}
    data-level=${cls}
  >
    <div class="card-head">
      <span>${side}</span>
      ${checked ? html`<span class="limit-set" title="checked against the ${family} limits">${family} limits</span>` : html`<span></span>`}
      <span class="state">${wheel.state.replace('_', ' ')}</span>
    </div>
    ${
      reason
        ? html`<div class="reason">${reason}</div>`
        : html`<table>
            ${shownParameters(family).map(
              (p) =>
                html`<tr data-parameter=${p.key}>
                  <th title="${p.title}: ${p.definition}">${p.label}</th>
                  <td class="num ${mode === 'difference' ? '' : valueLevel(wheel, shown, p.key, family, mode)}">
                    ${value(p)}
                  </td>
                  <td class="unit">${p.unit}</td>
                </tr>`,
            )}
          </table>`
    }
    ${
      disagreement
        ? html`<div class="flag disagreement" title="adaptive − Steger beyond the fleet's threshold: check the frame">
            methods differ: ${disagreement}
          </div>`
        : nothing
    }
    <div class="disposition ${wheel.disposition ? 'set' : 'open'}">${fmtDisposition(wheel.disposition)}</div>
  </a>`;
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
