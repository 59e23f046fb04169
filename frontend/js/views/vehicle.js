// @ts-check
/**
 * A vehicle's history: its wheels (axle × side) across its passes, newest first, each cell
 * coloured by the wheel's level and showing its nearest margin and disposition; a search
 * result list when the id matches no vehicle exactly.
 */
import { fmtDisposition, fmtNumber, fmtTime, parameterOf } from '../lib/format.js';
import { buildHash } from '../lib/route.js';
import { html, render } from '../../vendor/lit-html-3.3.3.js';

/**
 * Render the vehicle page.
 * @param {HTMLElement} root
 * @param {any} state
 */
export function renderVehicle(root, state) {
  const v = state.vehicle;
  const title = html`<h1><a href="#/passes">Passes</a> › Vehicle ${state.route.params.vehicleId}</h1>`;
  const page = (/** @type {unknown} */ body) => html`<section class="vehicle-page">${title}${body}</section>`;
  if (!v || v.loading) {
    render(page(html`<p class="loading">Loading the vehicle…</p>`), root);
    return;
  }
  if (!v.history) {
    const found = v.matches?.length
      ? html`<p>No vehicle is called "${v.id}"; these contain it:</p>
          <ul class="matches">
            ${v.matches.map((/** @type {string} */ m) => html`<li><a href=${buildHash(['vehicles', m])}>${m}</a></li>`)}
          </ul>`
      : html`<p class="empty">No vehicle id contains "${v.id}". <a href="#/passes">Back to the passes</a></p>`;
    render(page(found), root);
    return;
  }
  const passes = v.history.passes;
  /** @type {Map<string, {axle: number, side: string}>} */
  const positions = new Map();
  for (const p of passes)
    for (const w of p.wheels) positions.set(`${w.axle}/${w.side}`, { axle: w.axle, side: w.side });
  const columns = [...positions.values()].sort((a, b) => a.axle - b.axle || a.side.localeCompare(b.side));
  const history = html`<p class="note">
      ${passes.length} pass${passes.length === 1 ? '' : 'es'}, newest first; each cell: the wheel's nearest limit margin
      (adaptive) and its disposition.
      <a href=${buildHash(['review'], { vehicle: v.history.vehicle_id })}>Worst wheels of this vehicle</a>
    </p>
    <div class="table-scroll">
      <table class="grid vehicle-history">
        <thead>
          <tr>
            <th>Pass</th>
            <th>Time</th>
            <th>Site</th>
            ${columns.map((c) => html`<th>axle ${c.axle} ${c.side}</th>`)}
          </tr>
        </thead>
        <tbody>
          ${passes.map(
            (/** @type {any} */ p) =>
              html`<tr data-pass-id=${String(p.pass_id)}>
                <td><a href=${buildHash(['passes', p.pass_id])}>#${p.pass_id}</a></td>
                <td class="mono">${fmtTime(p.started_at)}</td>
                <td>${p.site}</td>
                ${columns.map((c) =>
                  cell(
                    p,
                    p.wheels.find((/** @type {any} */ w) => w.axle === c.axle && w.side === c.side),
                  ),
                )}
              </tr>`,
          )}
        </tbody>
      </table>
    </div>`;
  render(page(history), root);
}

/**
 * @param {any} p a VehiclePass
 * @param {any} wheel a PassWheelRead or undefined
 * @returns {import('../../vendor/lit-html-3.3.3.js').TemplateResult}
 */
function cell(p, wheel) {
  if (!wheel) return html`<td class="empty">–</td>`;
  const nearest = [...(wheel.margins ?? [])].sort((a, b) => a.margin_fraction - b.margin_fraction)[0];
  const label = nearest
    ? `${parameterOf(nearest.parameter).label} ${fmtNumber(nearest.value_mm)} mm`
    : wheel.state.replace('_', ' ');
  const margin = nearest ? `${fmtNumber(100 * nearest.margin_fraction, 0)} % margin · ` : '';
  return html`<td class="cell level-${wheel.level}" data-level=${wheel.level}>
    <a href=${buildHash(['passes', p.pass_id, 'wheels', wheel.wheel_id])}>${label}</a>
    <div class="disposition ${wheel.disposition ? 'set' : 'open'}">${margin}${fmtDisposition(wheel.disposition)}</div>
  </td>`;
}
