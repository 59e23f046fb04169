// @ts-check
/**
 * DOM helpers of the views: the templates they share (lit-html: rendered again, the DOM is
 * patched where a value changed), `h` for the few elements made once by hand (canvases, plot
 * boxes) and canvas sizing.
 */
import { html, render } from '../../vendor/lit-html-3.3.3.js';

/**
 * Create an element with properties, attributes, listeners and children.
 * Keys starting with "on" become listeners; `class`, `dataset`, `style` and other strings
 * become attributes; null/false children are skipped; strings become text.
 * @param {string} tag
 * @param {Record<string, any>} [props]
 * @param {...any} children
 * @returns {HTMLElement}
 */
export function h(tag, props = {}, ...children) {
  const el = document.createElement(tag);
  for (const [key, value] of Object.entries(props)) {
    if (value === null || value === undefined || value === false) continue;
    if (key.startsWith('on') && typeof value === 'function') el.addEventListener(key.slice(2), value);
    else if (key === 'dataset') Object.assign(el.dataset, value);
    else if (key === 'value' || key === 'checked' || key === 'disabled') /** @type {any} */ (el)[key] = value;
    else el.setAttribute(key, value === true ? '' : String(value));
  }
  for (const child of children.flat(Infinity)) {
    if (child === null || child === undefined || child === false) continue;
    el.append(child instanceof Node ? child : document.createTextNode(String(child)));
  }
  return el;
}

/**
 * A canvas sized to its CSS box at the device pixel ratio; returns its context and CSS size.
 * @param {HTMLCanvasElement} canvas
 * @returns {{ctx: CanvasRenderingContext2D, widthPx: number, heightPx: number, pixelRatio: number}}
 */
export function fitCanvas(canvas) {
  const pixelRatio = window.devicePixelRatio || 1;
  const widthPx = Math.max(1, canvas.clientWidth);
  const heightPx = Math.max(1, canvas.clientHeight);
  const w = Math.round(widthPx * pixelRatio);
  const hgt = Math.round(heightPx * pixelRatio);
  if (canvas.width !== w || canvas.height !== hgt) {
    canvas.width = w;
    canvas.height = hgt;
  }
  const ctx = /** @type {CanvasRenderingContext2D} */ (canvas.getContext('2d'));
  return { ctx, widthPx, heightPx, pixelRatio };
}

/**
 * Alarm class of a result: "alarm" when it has alarms, "ok" when measured, else "none".
 * @param {any} result a method's result object from the API, or null
 * @returns {'alarm'|'ok'|'none'}
 */
export function alarmClass(result) {
  if (!result || result.status === 'not_measured' || result.flange_height_mm == null) return 'none';
  return result.alarms && result.alarms.length > 0 ? 'alarm' : 'ok';
}

/**
 * The Apply and Clear-filters buttons of a filter form (the pass list's and the worst
 * wheels'); clearing applies the empty filter.
 * @param {Record<string, string>} filter the filter in force
 * @param {(filter: Record<string, string>) => void} applyFilter
 */
export function filterButtons(filter, applyFilter) {
  return html`<button type="submit">Apply</button
    ><button
      type="button"
      data-action="clear-filters"
      ?disabled=${Object.keys(filter).length === 0}
      @click=${() => applyFilter({})}
    >
      Clear filters
    </button>`;
}

/**
 * The one row of a table with nothing to list: `text` across its `columns`.
 * @param {number} columns
 * @param {string} text
 */
export function emptyRow(columns, text) {
  return html`<tr>
    <td colspan=${columns} class="empty">${text}</td>
  </tr>`;
}

/**
 * The definitions of `parameters`, one click away: a closed disclosure listing each one's
 * label, title, unit and definition (the pass page's cards, the worst wheels, the trend).
 * @param {any[]} parameters PARAMETERS entries
 * @param {string} [summary] the disclosure's text
 */
export function definitions(parameters, summary = 'What the values mean') {
  return html`<details class="definitions">
    <summary>${summary}</summary>
    <dl>
      ${parameters.map(
        (p) =>
          html`<dt data-parameter=${p.key}>${p.label}: ${p.title}${p.unit ? ` [${p.unit}]` : ''}</dt>
            <dd data-parameter=${p.key}>${p.definition}</dd>`,
      )}
    </dl>
  </details>`;
}

/**
 * A template's DOM, made once, for areas built by hand around a plot (`views/plots.js`).
 * @param {unknown} template
 * @returns {DocumentFragment}
 */
export function nodesOf(template) {
  const fragment = document.createDocumentFragment();
  render(template, fragment);
  return fragment;
}
