// @ts-check
/**
 * Passes: newest first, with filters and live progress of passes still being measured.
 * j/k move the selection, Enter opens it.
 */
import { fmtNumber, fmtPercent, fmtTime } from '../lib/format.js';
import { passStatus } from '../lib/records.js';
import { buildHash } from '../lib/route.js';
import { filterButtons, h } from './dom.js';

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
  const filterKey = JSON.stringify(filter);
  const existing = /** @type {HTMLFormElement|null} */ (root.querySelector('form.filters'));
  // keep the form the user may be typing in unless the applied filter changed
  const form =
    existing && existing.dataset.filter === filterKey
      ? existing
      : /** @type {HTMLFormElement} */ (
          h(
            'form',
            {
              class: 'filters',
              dataset: { filter: filterKey },
              onsubmit: (/** @type {Event} */ e) => {
                e.preventDefault();
                const data = new FormData(/** @type {HTMLFormElement} */ (e.target));
                const next = /** @type {Record<string, string>} */ ({});
                for (const [k, v] of data.entries()) if (String(v)) next[k] = String(v);
                handlers.applyFilter(next);
              },
            },
            FILTERS.map((f) =>
              h(
                'label',
                {},
                f.label,
                ' ',
                h('input', {
                  name: f.key,
                  type: f.type,
                  size: f.size,
                  placeholder: f.placeholder,
                  value: filter[f.key] ?? '',
                }),
              ),
            ),
            h(
              'label',
              {},
              h('input', { type: 'checkbox', name: 'alarm', value: 'true', checked: filter.alarm === 'true' }),
              ' alarms only',
            ),
            ...filterButtons(filter, handlers.applyFilter),
            h('span', { class: 'count' }),
          )
        );
  /** @type {HTMLElement} */ (form.querySelector('.count')).textContent = passes.loading
    ? 'loading…'
    : `${passes.total} pass${passes.total === 1 ? '' : 'es'}`;
  const rows = passes.items.map((/** @type {any} */ p, /** @type {number} */ i) =>
    passRow(p, state.liveJobs?.[p.id], i === state.selectedRow, () => handlers.select(i)),
  );
  root.replaceChildren(
    h(
      'section',
      { class: 'passes' },
      h('h1', {}, 'Passes'),
      form,
      h(
        'table',
        { class: 'grid' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            COLUMNS.map(([t, cls]) => h('th', { class: cls }, t)),
          ),
        ),
        h(
          'tbody',
          {},
          rows.length
            ? rows
            : h(
                'tr',
                {},
                h(
                  'td',
                  { colspan: COLUMNS.length, class: 'empty' },
                  passes.loading ? 'Loading passes…' : 'No passes match. Upload one or widen the filters.',
                ),
              ),
        ),
      ),
    ),
  );
}

/**
 * @param {any} p a pass from the API
 * @param {any} live the latest job message for it, if any
 * @param {boolean} selected
 * @param {() => void} onSelect
 * @returns {HTMLElement}
 */
function passRow(p, live, selected, onSelect) {
  const { state: status, progress, running } = passStatus(p, live);
  const job = live ?? p.job;
  const href = buildHash(['passes', p.id]);
  return h(
    'tr',
    {
      class: [selected ? 'selected' : '', p.alarm_count > 0 ? 'has-alarm' : ''].join(' ').trim() || null,
      dataset: { passId: String(p.id), href },
      onclick: onSelect,
      ondblclick: () => {
        window.location.hash = href;
      },
    },
    h('td', {}, h('a', { href }, `#${p.id}`)),
    h('td', { class: 'mono' }, fmtTime(p.started_at)),
    h('td', {}, p.site ?? '–'),
    h('td', {}, p.direction ?? '–'),
    h('td', { class: 'num' }, fmtNumber(p.speed_kmh, 1)),
    h('td', { class: 'vehicles', title: (p.vehicles ?? []).join(', ') }, vehicleLinks(p.vehicles ?? [])),
    h('td', { class: 'num' }, `${running ? (job?.wheels_done ?? '–') : p.wheels_measured} / ${p.wheels_total}`),
    h('td', { class: `num ${p.wheels_not_measured > 0 ? 'warn' : ''}` }, p.wheels_not_measured ?? '–'),
    h('td', { class: `num ${p.alarm_count > 0 ? 'alarm' : ''}` }, p.alarm_count),
    h('td', { class: `num ${p.near_limit_count > 0 ? 'near' : ''}` }, p.near_limit_count ?? 0),
    h(
      'td',
      { class: 'alarm-values', title: (p.alarm_values ?? []).join('\n') },
      (p.alarm_values ?? []).slice(0, 2).join(' · ') +
        ((p.alarm_values ?? []).length > 2 ? ` (+${p.alarm_values.length - 2})` : ''),
    ),
    h(
      'td',
      { class: `status status-${status}` },
      status,
      running && progress != null
        ? h(
            'span',
            { class: 'bar', title: fmtPercent(progress) },
            h('span', { style: `width:${Math.round(progress * 100)}%` }),
          )
        : null,
      running && progress != null ? ` ${fmtPercent(progress)}` : null,
    ),
  );
}

/**
 * The vehicle ids of a pass as links to each vehicle's history, the first few only.
 * @param {string[]} vehicles
 * @returns {Array<HTMLElement|string>}
 */
function vehicleLinks(vehicles) {
  if (vehicles.length === 0) return ['–'];
  const links = vehicles
    .slice(0, VEHICLES_SHOWN)
    .flatMap((v, i) => [
      i ? ', ' : '',
      h('a', { href: buildHash(['vehicles', v]), onclick: (/** @type {Event} */ e) => e.stopPropagation() }, v),
    ]);
  return vehicles.length > VEHICLES_SHOWN ? [...links, ` +${vehicles.length - VEHICLES_SHOWN}`] : links;
}
