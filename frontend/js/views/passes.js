// @ts-check
/**
 * Passes: newest first, with filters and live progress of passes still being measured.
 * j/k move the selection, Enter opens it.
 */
import { fmtNumber, fmtPercent, fmtTime } from '../lib/format.js';
import { passStatus } from '../lib/records.js';
import { buildHash } from '../lib/route.js';
import { html, nothing, render } from '../../vendor/lit-html-3.3.3.js';
import { emptyRow, filterButtons } from './dom.js';

/** Table columns: title and class (numbers align right under their heading). */
const COLUMNS = [
  ['Pass', null],
  ['Time', null],
  ['Site', null],
  ['Dir.', null],
  ['km/h', 'num'],
  ['Vehicles', null],
  ['Measured', 'num'],
  ['Not measured', 'num'],
  ['Alarms', 'num'],
  ['Wheels near limit', 'num'],
  ['Values in alarm', null],
  ['Status', null],
];
/** Vehicle ids listed in a row before "+ n more". */
const VEHICLES_SHOWN = 4;

const FILTERS = [
  { key: 'site', label: 'Site', type: 'text', size: 10, placeholder: 'any part' },
  { key: 'vehicle', label: 'Vehicle', type: 'text', size: 10, placeholder: 'any part' },
  { key: 'since', label: 'From', type: 'date' },
  { key: 'until', label: 'To', type: 'date' },
];

/**
 * Render the passes page.
 * @param {HTMLElement} root
 * @param {any} state
 * @param {{applyFilter: (filter: Record<string, string>) => void, select: (index: number) => void}} handlers
 *   applyFilter({}) clears every filter
 */
export function renderPasses(root, state, handlers) {
  const passes = state.passes ?? { items: [], filter: {} };
  const filter = passes.filter ?? {};
  const onSubmit = (/** @type {Event} */ e) => {
    e.preventDefault();
    const data = new FormData(/** @type {HTMLFormElement} */ (e.target));
    const next = /** @type {Record<string, string>} */ ({});
    for (const [k, v] of data.entries()) if (String(v)) next[k] = String(v);
    handlers.applyFilter(next);
  };
  const rows = passes.items.map((/** @type {any} */ p, /** @type {number} */ i) =>
    passRow(p, state.liveJobs?.[p.id], i === state.selectedRow, () => handlers.select(i)),
  );
  // the inputs' values are set only when the applied filter changes them: typing survives updates
  render(
    html`<section class="passes">
      <h1>Passes</h1>
      <form class="filters" @submit=${onSubmit}>
        ${FILTERS.map(
          (f) =>
            html`<label
              >${f.label}
              <input
                name=${f.key}
                type=${f.type}
                size=${f.size ?? nothing}
                placeholder=${f.placeholder ?? nothing}
                .value=${filter[f.key] ?? ''}
            /></label>`,
        )}
        <label
          ><input type="checkbox" name="alarm" value="true" .checked=${filter.alarm === 'true'} /> alarms only</label
        >
        ${filterButtons(filter, handlers.applyFilter)}
        <span class="count"
          >${passes.loading ? 'loading…' : `${passes.total} pass${passes.total === 1 ? '' : 'es'}`}</span
        >
      </form>
      <table class="grid">
        <thead>
          <tr>
            ${COLUMNS.map(([t, cls]) => html`<th class=${cls ?? nothing}>${t}</th>`)}
          </tr>
        </thead>
        <tbody>
          ${
            rows.length
              ? rows
              : emptyRow(
                  COLUMNS.length,
                  passes.loading ? 'Loading passes…' : 'No passes match. Upload one or widen the filters.',
                )
          }
        </tbody>
      </table>
    </section>`,
    root,
  );
}

/**
 * @param {any} p a pass from the API
 * @param {any} live the latest job message for it, if any
 * @param {boolean} selected
 * @param {() => void} onSelect
 * @returns {import('../../vendor/lit-html-3.3.3.js').TemplateResult}
 */
function passRow(p, live, selected, onSelect) {
  const { state: status, progress, running } = passStatus(p, live);
  const job = live ?? p.job;
  const href = buildHash(['passes', p.id]);
  const alarmValues = p.alarm_values ?? [];
  const classes = [selected ? 'selected' : '', p.alarm_count > 0 ? 'has-alarm' : ''].join(' ').trim();
  const bar = running && progress != null;
  return html`<tr
    class=${classes || nothing}
    data-pass-id=${String(p.id)}
    data-href=${href}
    @click=${onSelect}
    @dblclick=${() => {
      window.location.hash = href;
    }}
  >
    <td><a href=${href}>#${p.id}</a></td>
    <td class="mono">${fmtTime(p.started_at)}</td>
    <td>${p.site ?? '–'}</td>
    <td>${p.direction ?? '–'}</td>
    <td class="num">${fmtNumber(p.speed_kmh, 1)}</td>
    <td class="vehicles" title=${(p.vehicles ?? []).join(', ')}>${vehicleLinks(p.vehicles ?? [])}</td>
    <td class="num">${running ? (job?.wheels_done ?? '–') : p.wheels_measured} / ${p.wheels_total}</td>
    <td class="num ${p.wheels_not_measured > 0 ? 'warn' : ''}">${p.wheels_not_measured ?? '–'}</td>
    <td class="num ${p.alarm_count > 0 ? 'alarm' : ''}">${p.alarm_count}</td>
    <td class="num ${p.near_limit_count > 0 ? 'near' : ''}">${p.near_limit_count ?? 0}</td>
    <td class="alarm-values" title=${alarmValues.join('\n')}>
      ${alarmValues.slice(0, 2).join(' · ') + (alarmValues.length > 2 ? ` (+${alarmValues.length - 2})` : '')}
    </td>
    <td class="status status-${status}">
      ${status}${
        bar
          ? html`<span class="bar" title=${fmtPercent(progress)}
                ><span style="width:${Math.round(progress * 100)}%"></span
              ></span>
              ${fmtPercent(progress)}`
          : nothing
      }
    </td>
  </tr>`;
}

/**
 * The vehicle ids of a pass as links to each vehicle's history, the first few only.
 * @param {string[]} vehicles
 * @returns {unknown[]}
 */
function vehicleLinks(vehicles) {
  if (vehicles.length === 0) return ['–'];
  const links = vehicles
    .slice(0, VEHICLES_SHOWN)
    .flatMap((v, i) => [
      i ? ', ' : '',
      html`<a href=${buildHash(['vehicles', v])} @click=${(/** @type {Event} */ e) => e.stopPropagation()}>${v}</a>`,
    ]);
  return vehicles.length > VEHICLES_SHOWN ? [...links, ` +${vehicles.length - VEHICLES_SHOWN}`] : links;
}
