// @ts-check
/**
 * Worst wheels: what needs action first. Every wheel (its newest pass, or one pass) by the
 * margin to its nearest limit, smallest first, in mm and in % of the limit band; red in
 * alarm, amber near a limit; each with its disposition ("open" when none) and the values its
 * measurement lacks (a limit without a value is not checked).
 */
import { fmtDisposition, fmtNumber, fmtTime, PARAMETERS, parameterOf } from '../lib/format.js';
import { missingValueNames, REVIEW_PAGE_ROWS } from '../lib/records.js';
import { buildHash } from '../lib/route.js';
import { html, nothing, render } from '../../vendor/lit-html-3.3.3.js';
import { definitions, emptyRow, filterButtons } from './dom.js';

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
  const onSubmit = (/** @type {Event} */ e) => {
    e.preventDefault();
    const next = /** @type {Record<string, string>} */ ({});
    for (const [k, v] of new FormData(/** @type {HTMLFormElement} */ (e.target)).entries())
      if (String(v)) next[k] = String(v);
    handlers.applyFilter(next);
  };
  const items = review.page?.items ?? [];
  const scope = filter.pass ? '' : filter.history === '1' ? 'Every pass of each wheel.' : "Each wheel's newest pass.";
  render(
    html`<section class="review">
      <h1>
        ${filter.pass ? html`<a href=${buildHash(['passes', filter.pass])}>Pass #${filter.pass}</a> › worst wheels` : 'Worst wheels'}
      </h1>
      <p class="note">
        Each wheel at its nearest limit (or the chosen parameter), smallest margin first:
        <span class="alarm-text">red</span> beyond a limit, <span class="near-text">amber</span> within the fleet's
        near-limit band (default the inner 10 % of each limit band). ${scope}
      </p>
      <form class="filters" @submit=${onSubmit}>
        ${FILTERS.map(
          (f) =>
            html`<label
              >${f.label} <input name=${f.key} size="10" placeholder="any part" .value=${filter[f.key] ?? ''}
            /></label>`,
        )}
        <label
          >Parameter
          <select name="parameter" .value=${filter.parameter ?? ''}>
            <option value="">nearest limit</option>
            ${PARAMETERS.filter((p) => p.families.length > 0).map(
              (p) =>
                html`<option value=${p.key} ?selected=${filter.parameter === p.key}>${p.label} (${p.title})</option>`,
            )}
          </select></label
        >
        <label><input type="checkbox" name="open" value="1" .checked=${filter.open === '1'} /> open only</label>
        <label
          title="wheels whose Sd (LM), Sd EN (EN) or qR was not measured: that limit is not checked, gauge them by hand"
          ><input type="checkbox" name="unchecked" value="1" .checked=${filter.unchecked === '1'} /> limits not
          checked</label
        >
        <label title="every pass of each wheel, not only its newest"
          ><input type="checkbox" name="history" value="1" .checked=${filter.history === '1'} /> all passes</label
        >
        ${filter.pass ? html`<input type="hidden" name="pass" .value=${filter.pass} />` : nothing}
        ${filterButtons(filter, handlers.applyFilter)}
        <span class="count">${review.loading ? 'loading…' : `${review.page?.total ?? 0} wheels`}</span>
      </form>
      <div class="table-scroll">
        <table class="grid worst">
          <thead>
            <tr>
              ${COLUMNS.map(([t, cls, key]) => {
                const p = key ? parameterOf(key) : null;
                return html`<th class=${cls ?? nothing} title=${p ? `${p.title}: ${p.definition}` : nothing}>
                  ${p?.unit ? `${t} ${p.unit}` : t}
                </th>`;
              })}
            </tr>
          </thead>
          <tbody>
            ${
              items.length
                ? items.map((/** @type {any} */ item, /** @type {number} */ i) =>
                    row(item, (review.page?.offset ?? 0) + i + 1),
                  )
                : emptyRow(COLUMNS.length, review.loading ? 'Loading…' : 'No measured wheels match.')
            }
          </tbody>
        </table>
      </div>
      ${pager(review.page, filter, handlers.applyFilter)} ${definitions(PARAMETERS)}
    </section>`,
    root,
  );
}

/**
 * @param {any} item a WorstWheelRead
 * @param {number} rank
 * @returns {import('../../vendor/lit-html-3.3.3.js').TemplateResult}
 */
function row(item, rank) {
  const m = item.margin;
  const p = parameterOf(m.parameter);
  const href = buildHash(['passes', item.pass_id, 'wheels', item.wheel_id]);
  const onClick = (/** @type {MouseEvent} */ e) => {
    if (!(/** @type {HTMLElement} */ (e.target).closest('a'))) window.location.hash = href;
  };
  const level = LEVEL_WORDS[/** @type {'ok'} */ (m.level)] ?? m.level;
  return html`<tr
    class="level-${m.level}"
    data-wheel-id=${String(item.wheel_id)}
    data-pass-id=${String(item.pass_id)}
    data-level=${m.level}
    @click=${onClick}
  >
    <td class="num">${rank}</td>
    <td><span class="badge ${m.level}">${level}</span>${missingNote(item.values_not_measured)}</td>
    <td><a href=${buildHash(['vehicles', item.vehicle_id])}>${item.vehicle_id}</a></td>
    <td class="num">${item.axle}</td>
    <td>${item.side}</td>
    <td title=${p.title}>${p.label}</td>
    <td class="num ${m.level === 'ok' ? '' : m.level}">${fmtNumber(m.value_mm)} ${p.unit}</td>
    <td class="num">${m.bound === 'min' ? '≥' : '≤'} ${fmtNumber(m.limit_mm, 1)}</td>
    <td class="num">${fmtNumber(m.margin_mm)}</td>
    <td class="num" title="of a ${fmtNumber(m.band_mm)} mm band">${fmtNumber(100 * m.margin_fraction, 1)}</td>
    <td>${item.wheel_profile}</td>
    ${VALUE_KEYS.map((key) => html`<td class="num" data-parameter=${key}>${fmtNumber(item[key], parameterOf(key).digits)}</td>`)}
    <td class="disposition ${item.disposition ? 'set' : 'open'}">${fmtDisposition(item.disposition)}</td>
    <td><a href=${href}>#${item.pass_id} wheel</a></td>
    <td class="mono">${fmtTime(item.started_at)}</td>
    <td>${item.site}</td>
  </tr>`;
}

/**
 * "Sd not measured" under a row's level when the measurement lacks values (a limit without a
 * value is not checked: gauge it by hand), the service's reason as its title.
 * @param {string|null|undefined} reason the row's `values_not_measured`
 * @returns {import('../../vendor/lit-html-3.3.3.js').TemplateResult|typeof nothing}
 */
function missingNote(reason) {
  const names = missingValueNames(reason);
  if (!names.length) return nothing;
  return html`<span class="missing-values" title=${reason ?? ''}>${names.join(', ')} not measured</span>`;
}

/**
 * Previous / next page of the ranking, when there is more than one.
 * @param {any} page the Page the service returned, or null
 * @param {Record<string, string>} filter
 * @param {(filter: Record<string, string>) => void} applyFilter
 * @returns {import('../../vendor/lit-html-3.3.3.js').TemplateResult|typeof nothing}
 */
function pager(page, filter, applyFilter) {
  if (!page || page.total <= REVIEW_PAGE_ROWS) return nothing;
  const at = Math.floor(page.offset / REVIEW_PAGE_ROWS) + 1;
  const pages = Math.ceil(page.total / REVIEW_PAGE_ROWS);
  const go = (/** @type {number} */ n) => applyFilter({ ...filter, page: String(n) });
  return html`<div class="pager">
    <button ?disabled=${at <= 1} @click=${() => go(at - 1)} data-action="previous-page">‹ previous</button>
    page ${at} of ${pages}
    <button ?disabled=${at >= pages} @click=${() => go(at + 1)} data-action="next-page">next ›</button>
  </div>`;
}
