// @ts-check
/**
 * The frame around every page: header with navigation, role, live-link state, the error
 * banner (every failure in words) and the keyboard help.
 */
import { h } from './dom.js';

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
 * Render the header and banner from state into their containers.
 * @param {{header: HTMLElement, banner: HTMLElement, help: HTMLElement}} els
 * @param {any} state
 * @param {{dismissError: () => void, signOut: () => void, closeHelp: () => void, findVehicle: (text: string) => void}} handlers
 */
export function renderShell(els, state, handlers) {
  const role = state.me?.role ?? null;
  const name = state.route?.name;
  const parts = [
    h('a', { class: 'brand', href: '#/passes' }, 'wheelscan'),
    h(
      'nav',
      {},
      h(
        'a',
        { href: '#/passes', class: name === 'passes' || name === 'pass' || name === 'wheel' ? 'active' : null },
        'Passes',
      ),
      h('a', { href: '#/review', class: name === 'review' ? 'active' : null }, 'Worst wheels'),
      role && role !== 'viewer'
        ? h('a', { href: '#/upload', class: name === 'upload' ? 'active' : null }, 'Upload')
        : null,
    ),
    role ? vehicleSearch(state, handlers.findVehicle) : null,
    h('span', { class: 'spacer' }),
    h(
      'span',
      { class: `live ${state.socketOpen ? 'on' : 'off'}`, title: 'live updates (WebSocket)' },
      state.socketOpen ? '● live' : '○ offline',
    ),
    role ? h('span', { class: `role role-${role}`, title: state.me?.name ?? '' }, role) : null,
    role ? h('button', { class: 'link', onclick: handlers.signOut }, 'sign out') : null,
    h('span', { class: 'hint' }, 'press ? for keys'),
  ];
  els.header.replaceChildren(...parts.filter((part) => part !== null));
  els.banner.replaceChildren(
    ...(state.error
      ? [
          h(
            'div',
            { class: 'error', role: 'alert' },
            h('strong', {}, 'Error. '),
            state.error,
            h('button', { class: 'link', onclick: handlers.dismissError, 'aria-label': 'dismiss' }, 'dismiss'),
          ),
        ]
      : []),
  );
  els.help.hidden = !state.helpOpen;
  if (state.helpOpen && !els.help.firstChild) {
    els.help.append(
      h('button', { class: 'link close', onclick: handlers.closeHelp, 'aria-label': 'close help' }, '×'),
      h('h2', {}, 'Keyboard and mouse'),
      h(
        'table',
        {},
        SHORTCUTS.map(([key, what]) => h('tr', {}, h('td', {}, h('kbd', {}, key)), h('td', {}, what))),
      ),
    );
  }
}

/**
 * The vehicle search of the header (every page): Enter opens the vehicle's history, or the
 * vehicles whose id contains the text.
 * @param {any} state
 * @param {(text: string) => void} findVehicle
 * @returns {HTMLElement}
 */
function vehicleSearch(state, findVehicle) {
  const existing = /** @type {HTMLFormElement|null} */ (document.querySelector('header form.vehicle-search'));
  if (existing) return existing;
  const input = /** @type {HTMLInputElement} */ (
    h('input', {
      type: 'search',
      name: 'vehicle',
      placeholder: 'vehicle id…',
      size: 14,
      'aria-label': 'find a vehicle',
      value: state.route?.name === 'vehicle' ? state.route.params.vehicleId : '',
    })
  );
  return h(
    'form',
    {
      class: 'vehicle-search',
      role: 'search',
      onsubmit: (/** @type {Event} */ e) => {
        e.preventDefault();
        if (input.value.trim()) findVehicle(input.value.trim());
      },
    },
    input,
  );
}

/**
 * The sign-in form shown when there is no valid token.
 * @param {HTMLElement} root
 * @param {(token: string) => void} onSubmit
 */
export function renderSignIn(root, onSubmit) {
  const input = /** @type {HTMLInputElement} */ (
    h('input', {
      type: 'password',
      name: 'token',
      placeholder: 'wst_…',
      autocomplete: 'off',
      size: 48,
    })
  );
  root.replaceChildren(
    h(
      'section',
      { class: 'sign-in' },
      h('h1', {}, 'Sign in'),
      h(
        'p',
        {},
        'Open the link that ',
        h('code', {}, 'make run'),
        ' printed, or paste an API token (',
        h('code', {}, 'wheelscan token create --role viewer'),
        ').',
      ),
      h(
        'form',
        {
          onsubmit: (/** @type {Event} */ e) => {
            e.preventDefault();
            if (input.value.trim()) onSubmit(input.value.trim());
          },
        },
        input,
        ' ',
        h('button', { type: 'submit' }, 'Sign in'),
      ),
    ),
  );
  input.focus();
}
