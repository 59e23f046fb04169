// @ts-check
/**
 * A vehicle's history: its wheels (axle × side) across its passes, newest first, each cell
 * coloured by the wheel's level and showing its nearest margin and disposition; a search
 * result list when the id matches no vehicle exactly.
 */
import { fmtDisposition, fmtNumber, fmtTime, parameterOf } from '../lib/format.js';
import { buildHash } from '../lib/route.js';
import { h } from './dom.js';

/**
 * Render the vehicle page.
 * @param {HTMLElement} root
 * @param {any} state
 */
export function renderVehicle(root, state) {
  const v = state.vehicle;
  const title = h('h1', {}, h('a', { href: '#/passes' }, 'Passes'), ' › ', `Vehicle ${state.route.params.vehicleId}`);
  if (!v || v.loading) {
    root.replaceChildren(
      h('section', { class: 'vehicle-page' }, title, h('p', { class: 'loading' }, 'Loading the vehicle…')),
    );
    return;
  }
  if (!v.history) {
    root.replaceChildren(
      h(
        'section',
        { class: 'vehicle-page' },
        title,
        v.matches?.length
          ? [
              h('p', {}, `No vehicle is called "${v.id}"; these contain it:`),
              h(
                'ul',
                { class: 'matches' },
                v.matches.map((/** @type {string} */ m) =>
                  h('li', {}, h('a', { href: buildHash(['vehicles', m]) }, m)),
                ),
              ),
            ]
          : h(
              'p',
              { class: 'empty' },
              `No vehicle id contains "${v.id}". `,
              h('a', { href: '#/passes' }, 'Back to the passes'),
            ),
      ),
    );
    return;
  }
  const passes = v.history.passes;
  /** @type {Map<string, {axle: number, side: string}>} */
  const positions = new Map();
  for (const p of passes)
    for (const w of p.wheels) positions.set(`${w.axle}/${w.side}`, { axle: w.axle, side: w.side });
  const columns = [...positions.values()].sort((a, b) => a.axle - b.axle || a.side.localeCompare(b.side));
  root.replaceChildren(
    h(
      'section',
      { class: 'vehicle-page' },
      title,
      h(
        'p',
        { class: 'note' },
        `${passes.length} pass${passes.length === 1 ? '' : 'es'}, newest first; each cell: the wheel's nearest limit margin (adaptive) and its disposition. `,
        h('a', { href: buildHash(['review'], { vehicle: v.history.vehicle_id }) }, 'Worst wheels of this vehicle'),
      ),
      h(
        'table',
        { class: 'grid vehicle-history' },
        h(
          'thead',
          {},
          h(
            'tr',
            {},
            h('th', {}, 'Pass'),
            h('th', {}, 'Time'),
            h('th', {}, 'Site'),
            columns.map((c) => h('th', {}, `axle ${c.axle} ${c.side}`)),
          ),
        ),
        h(
          'tbody',
          {},
          passes.map((/** @type {any} */ p) =>
            h(
              'tr',
              { dataset: { passId: String(p.pass_id) } },
              h('td', {}, h('a', { href: buildHash(['passes', p.pass_id]) }, `#${p.pass_id}`)),
              h('td', { class: 'mono' }, fmtTime(p.started_at)),
              h('td', {}, p.site),
              columns.map((c) =>
                cell(
                  p,
                  p.wheels.find((/** @type {any} */ w) => w.axle === c.axle && w.side === c.side),
                ),
              ),
            ),
          ),
        ),
      ),
    ),
  );
}

/**
 * @param {any} p a VehiclePass
 * @param {any} wheel a PassWheelRead or undefined
 * @returns {HTMLElement}
 */
function cell(p, wheel) {
  if (!wheel) return h('td', { class: 'empty' }, '–');
  const nearest = [...(wheel.margins ?? [])].sort((a, b) => a.margin_fraction - b.margin_fraction)[0];
  const label = nearest
    ? `${parameterOf(nearest.parameter).label} ${fmtNumber(nearest.value_mm)} mm (${fmtNumber(100 * nearest.margin_fraction, 0)} %)`
    : wheel.state.replace('_', ' ');
  return h(
    'td',
    { class: `cell level-${wheel.level}`, dataset: { level: wheel.level } },
    h('a', { href: buildHash(['passes', p.pass_id, 'wheels', wheel.wheel_id]) }, label),
    h('div', { class: `disposition ${wheel.disposition ? 'set' : 'open'}` }, fmtDisposition(wheel.disposition)),
  );
}
