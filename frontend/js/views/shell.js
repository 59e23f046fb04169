// @ts-check
/**
 * The frame around every page: header with navigation, role, live-link state, the error
 * banner (every failure in words) and the keyboard help.
 */
import { html, nothing, render } from '../../vendor/lit-html-3.3.3.js';

/** Keyboard shortcuts shown by "?" (the wheel page's are listed there too). */
export const SHORTCUTS = [
  ['g p', 'passes'],
  ['g w', 'worst wheels'],
  ['g u', 'upload'],
  ['j / k', 'next / previous row'],
  ['Enter', 'open row'],
  ['a / s', 'adaptive / Steger centres'],
  ['m / o', 'stripe mask / σ map'],
  ['x', 'camera frame on / off'],
  ['f', 'fit stripe / whole frame'],
  ['+ / −', 'zoom'],
  ['scroll', 'zoom at the pointer'],
  ['double-click', 'zoom in there (with ⇧: out)'],
  ['drag', 'pan the frame'],
  ['← ↑ → ↓', 'pan'],
  ['[ / ]', 'previous / next wheel'],
  ['i', 'next sensor'],
  ['Esc', 'close 3D or help, else up one level'],
  ['?', 'this help (a click outside closes it)'],
];

/**
 * Render the header, banner and help from state into their containers.
 * @param {{header: HTMLElement, banner: HTMLElement, help: HTMLElement}} els
 * @param {any} state
 * @param {{dismissError: () => void, signOut: () => void, closeHelp: () => void, findVehicle: (text: string) => void}} handlers
 */
export function renderShell(els, state, handlers) {
  const role = state.me?.role ?? null;
  const name = state.route?.name;
  const active = (/** @type {boolean} */ on) => (on ? 'active' : nothing);
  render(
    html`<a class="brand" href="#/passes">wheelscan</a>
      <nav>
        <a href="#/passes" class=${active(name === 'passes' || name === 'pass' || name === 'wheel')}>Passes</a
        ><a href="#/review" class=${active(name === 'review')}>Worst wheels</a
        >${role && role !== 'viewer' ? html`<a href="#/upload" class=${active(name === 'upload')}>Upload</a>` : nothing}
      </nav>
      ${role ? vehicleSearch(state, handlers.findVehicle) : nothing}
      <span class="spacer"></span>
      <span class="live ${state.socketOpen ? 'on' : 'off'}" title="live updates (WebSocket)"
        >${state.socketOpen ? '● live' : '○ offline'}</span
      >
      ${
        role
          ? html`<span class="role role-${role}" title=${state.me?.name ?? ''}>${role}</span>
              <button class="link" @click=${handlers.signOut}>sign out</button>`
          : nothing
      }
      <span class="hint">press ? for keys</span>`,
    els.header,
  );
  render(
    state.error
      ? html`<div class="error" role="alert">
          <strong>Error. </strong>${state.error}<button
            class="link"
            @click=${handlers.dismissError}
            aria-label="dismiss"
          >
            dismiss
          </button>
        </div>`
      : nothing,
    els.banner,
  );
  els.help.hidden = !state.helpOpen;
  render(
    state.helpOpen
      ? html`<button class="link close" @click=${handlers.closeHelp} aria-label="close help">×</button>
          <h2>Keyboard and mouse</h2>
          <table>
            ${SHORTCUTS.map(
              ([key, what]) =>
                html`<tr>
                  <td><kbd>${key}</kbd></td>
                  <td>${what}</td>
                </tr>`,
            )}
          </table>`
      : nothing,
    els.help,
  );
}

/**
 * The vehicle search of the header (every page): Enter opens the vehicle's history, or the
 * vehicles whose id contains the text. What is typed stays while the page updates.
 * @param {any} state
 * @param {(text: string) => void} findVehicle
 * @returns {import('../../vendor/lit-html-3.3.3.js').TemplateResult}
 */
function vehicleSearch(state, findVehicle) {
  const onSubmit = (/** @type {Event} */ e) => {
    e.preventDefault();
    const input = /** @type {HTMLFormElement} */ (e.target).elements.namedItem('vehicle');
    const text = /** @type {HTMLInputElement} */ (input).value.trim();
    if (text) findVehicle(text);
  };
  return html`<form class="vehicle-search" role="search" @submit=${onSubmit}>
    <input
      type="search"
      name="vehicle"
      placeholder="vehicle id…"
      size="14"
      aria-label="find a vehicle"
      .value=${state.route?.name === 'vehicle' ? state.route.params.vehicleId : ''}
    />
  </form>`;
}

/**
 * The sign-in form shown when there is no valid token; its field has the focus when shown.
 * @param {HTMLElement} root
 * @param {(token: string) => void} onSubmit
 */
export function renderSignIn(root, onSubmit) {
  const submit = (/** @type {Event} */ e) => {
    e.preventDefault();
    const input = /** @type {HTMLFormElement} */ (e.target).elements.namedItem('token');
    const token = /** @type {HTMLInputElement} */ (input).value.trim();
    if (token) onSubmit(token);
  };
  const shown = root.querySelector('section.sign-in') !== null;
  render(
    html`<section class="sign-in">
      <h1>Sign in</h1>
      <p>
        Open the link that <code>make run</code> printed, or paste an API token (<code
          >wheelscan token create --role viewer</code
        >).
      </p>
      <form @submit=${submit}>
        <input type="password" name="token" placeholder="wst_…" autocomplete="off" size="48" />
        <button type="submit">Sign in</button>
      </form>
    </section>`,
    root,
  );
  if (!shown) /** @type {HTMLInputElement} */ (root.querySelector('input[name=token]')).focus();
}
