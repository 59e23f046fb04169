// @ts-check
/**
 * Worst wheels: what needs action first. Every wheel (its newest pass, or one pass) by the
 * margin to its nearest limit, smallest first, in mm and in % of the limit band; red in
 * alarm, amber near a limit; each with its disposition ("open" when none).
 */
import { fmtDisposition, fmtNumber, fmtTime, PARAMETERS, parameterOf } from '../lib/format.js';
import { REVIEW_PAGE_ROWS } from '../lib/records.js';
import { buildHash } from '../lib/route.js';
import { definitions, filterButtons, h } from './dom.js';

const FILTERS = [
  { key: 'site', label: 'Site' },
  { key: 'fleet', label: 'Fleet' },
  { key: 'vehicle', label: 'Vehicle' },
];
/** The same measurement's values shown beside its margin (the first three have no limit). */
const VALUE_KEYS = ['tread_hollow_mm', 'flange_angle_deg', 'rim_width_mm', 'equivalent_conicity'];
/** @type {Array<[string, string|null, string?]>} header, class, the parameter it shows */
const COLUMNS = [
  ['#', 'num'],
  ['Level', null],
  ['Vehicle', null],
  ['Axle', 'num'],
  ['Side', null],
  ['Parameter', null],
  ['Value', 'num'],
  ['Limit', 'num'],
  ['Margin mm', 'num'],
  ['Margin % of band', 'num'],
  ['Limits', null],
  ...VALUE_KEYS.map((key) => /** @type {[string, string, string]} */ ([parameterOf(key).label, 'num', key])),
  ['Disposition', null],
  ['Pass', null],
  ['Time', null],
  ['Site', null],
];
const LEVEL_WORDS = { alarm: 'ALARM', near: 'near limit', ok: 'ok' };

/**
 * Render the worst-wheels page.
 * @param {HTMLElement} root
 * @param {any} state
 * @param {{applyFilter: (filter: Record<string, string>) => void}} handlers applyFilter({}) clears
 */
export function renderReview(root, state, handlers) {
  const review = state.review ?? { page: null, filter: {}, loading: true };
  const filter = review.filter ?? {};
  const form = /** @type {HTMLFormElement} */ (
    h(
      'form',
      {
        class: 'filters',
        onsubmit: (/** @type {Event} */ e) => {
          e.preventDefault();
          const next = /** @type {Record<string, string>} */ ({});
          for (const [k, v] of new FormData(/** @type {HTMLFormElement} */ (e.target)).entries())
            if (String(v)) next[k] = String(v);
          handlers.applyFilter(next);
        },
      },
      FILTERS.map((f) =>
        h(
          'label',
          {},
          f.label,
          ' ',
          h('input', { name: f.key, size: 10, placeholder: 'any part', value: filter[f.key] ?? '' }),
        ),
      ),
      h(
        'label',
        {},
        'Parameter ',
        h(
          'select',
          { name: 'parameter' },
          h('option', { value: '' }, 'nearest limit'),
          PARAMETERS.filter((p) => p.families.length > 0).map((p) =>
            h(
              'option',
              { value: p.key, selected: filter.parameter === p.key ? true : null },
              `${p.label} (${p.title})`,
            ),
          ),
        ),
      ),
      h(
        'label',
        {},
        h('input', { type: 'checkbox', name: 'open', value: '1', checked: filter.open === '1' }),
        ' open only',
      ),
      h(
        'label',
        { title: 'every pass of each wheel, not only its newest' },
        h('input', { type: 'checkbox', name: 'history', value: '1', checked: filter.history === '1' }),
        ' all passes',
      ),
      filter.pass ? h('input', { type: 'hidden', name: 'pass', value: filter.pass }) : null,
      ...filterButtons(filter, handlers.applyFilter),
      h('span', { class: 'count' }, review.loading ? 'loading…' : `${review.page?.total ?? 0} wheels`),
    )
  );
  const items = review.page?.items ?? [];
  root.replaceChildren(
    h(
      'section',
      { class: 'review' },
      h(
        'h1',
        {},
        filter.pass
          ? [h('a', { href: buildHash(['passes', filter.pass]) }, `Pass #${filter.pass}`), ' › worst wheels']
          : 'Worst wheels',
      ),
      h(
        'p',
        { class: 'note' },
        'Each wheel at its nearest limit (or the chosen parameter), smallest margin first: ',
        h('span', { class: 'alarm-text' }, 'red'),
        ' beyond a limit, ',
        h('span', { class: 'near-text' }, 'amber'),
        " within the fleet's near-limit band (default the inner 10 % of each limit band). ",
        filter.pass ? '' : filter.history === '1' ? 'Every pass of each wheel.' : "Each wheel's newest pass.",
      ),
      form,
      h(
        'table',
        { class: 'grid worst' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            COLUMNS.map(([t, cls, key]) => {
              const p = key ? parameterOf(key) : null;
              return h(
                'th',
                { class: cls, title: p ? `${p.title}: ${p.definition}` : null },
                p?.unit ? `${t} ${p.unit}` : t,
              );
            }),
          ),
        ),
        h(
          'tbody',
          {},
          items.length
            ? items.map((/** @type {any} */ item, /** @type {number} */ i) =>
                row(item, (review.page?.offset ?? 0) + i + 1),
              )
            : h(
                'tr',
                {},
                h(
                  'td',
                  { colspan: COLUMNS.length, class: 'empty' },
                  review.loading ? 'Loading…' : 'No measured wheels match.',
                ),
              ),
        ),
      ),
      pager(review.page, filter, handlers.applyFilter),
      definitions(PARAMETERS),
    ),
  );
}

/**
 * @param {any} item a WorstWheelRead
 * @param {number} rank
 * @returns {HTMLElement}
 */
function row(item, rank) {
  const m = item.margin;
  const p = parameterOf(m.parameter);
  const href = buildHash(['passes', item.pass_id, 'wheels', item.wheel_id]);
  return h(
    'tr',
    {
      class: `level-${m.level}`,
      dataset: { wheelId: String(item.wheel_id), passId: String(item.pass_id), level: m.level },
      onclick: (/** @type {MouseEvent} */ e) => {
        if (!(/** @type {HTMLElement} */ (e.target).closest('a'))) window.location.hash = href;
      },
    },
    h('td', { class: 'num' }, rank),
    h('td', {}, h('span', { class: `badge ${m.level}` }, LEVEL_WORDS[/** @type {'ok'} */ (m.level)] ?? m.level)),
    h('td', {}, h('a', { href: buildHash(['vehicles', item.vehicle_id]) }, item.vehicle_id)),
    h('td', { class: 'num' }, item.axle),
    h('td', {}, item.side),
    h('td', { title: p.title }, p.label),
    h('td', { class: `num ${m.level === 'ok' ? '' : m.level}` }, `${fmtNumber(m.value_mm)} ${p.unit}`),
    h('td', { class: 'num' }, `${m.bound === 'min' ? '≥' : '≤'} ${fmtNumber(m.limit_mm, 1)}`),
    h('td', { class: 'num' }, fmtNumber(m.margin_mm)),
    h('td', { class: 'num', title: `of a ${fmtNumber(m.band_mm)} mm band` }, fmtNumber(100 * m.margin_fraction, 1)),
    h('td', {}, item.wheel_profile),
    VALUE_KEYS.map((key) =>
      h('td', { class: 'num', dataset: { parameter: key } }, fmtNumber(item[key], parameterOf(key).digits)),
    ),
    h('td', { class: `disposition ${item.disposition ? 'set' : 'open'}` }, fmtDisposition(item.disposition)),
    h('td', {}, h('a', { href }, `#${item.pass_id} wheel`)),
    h('td', { class: 'mono' }, fmtTime(item.started_at)),
    h('td', {}, item.site),
  );
}

/**
 * Previous / next page of the ranking, when there is more than one.
 * @param {any} page the Page the service returned, or null
 * @param {Record<string, string>} filter
 * @param {(filter: Record<string, string>) => void} applyFilter
 * @returns {HTMLElement|string}
 */
function pager(page, filter, applyFilter) {
  if (!page || page.total <= REVIEW_PAGE_ROWS) return '';
  const at = Math.floor(page.offset / REVIEW_PAGE_ROWS) + 1;
  const pages = Math.ceil(page.total / REVIEW_PAGE_ROWS);
  const go = (/** @type {number} */ n) => applyFilter({ ...filter, page: String(n) });
  return h(
    'div',
    { class: 'pager' },
    h('button', { disabled: at <= 1, onclick: () => go(at - 1), 'data-action': 'previous-page' }, '‹ previous'),
    ` page ${at} of ${pages} `,
    h('button', { disabled: at >= pages, onclick: () => go(at + 1), 'data-action': 'next-page' }, 'next ›'),
  );
}
