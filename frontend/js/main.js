// @ts-check
/**
 * Entry point: wires the API client, the store, the hash router, the views and the keyboard.
 * The only module with page-wide state (the store instance and the current view).
 */
import { createActions } from './actions.js';
import { createApi } from './api.js';
import { buildHash, parseHash } from './lib/route.js';
import { html, render } from '../vendor/lit-html-3.3.3.js';
import { createStore } from './state.js';
import { renderPass } from './views/pass.js';
import { renderPasses } from './views/passes.js';
import { renderReview } from './views/review.js';
import { renderShell, renderSignIn } from './views/shell.js';
import { renderUpload } from './views/upload.js';
import { renderVehicle } from './views/vehicle.js';
import { LAYERS, WheelView } from './views/wheel.js';

const TOKEN_KEY = 'wheelscan.token';
/** Layers shown when the URL does not say otherwise. */
const DEFAULT_LAYERS = { image: true, adaptive: true, steger: true, mask: false, sigma: false };

const els = {
  header: /** @type {HTMLElement} */ (document.getElementById('header')),
  banner: /** @type {HTMLElement} */ (document.getElementById('banner')),
  view: /** @type {HTMLElement} */ (document.getElementById('view')),
  help: /** @type {HTMLElement} */ (document.getElementById('help')),
};
// the shell renders the header from here on (index.html's brand shows until this script runs)
els.header.replaceChildren();

const store = createStore({
  token: window.localStorage.getItem(TOKEN_KEY),
  me: null,
  signingIn: false,
  route: parseHash(''),
  error: null,
  helpOpen: false,
  passes: { items: [], filter: {}, loading: false },
  selectedRow: 0,
  liveJobs: {},
  socketOpen: false,
  pass: null,
  wheel: null,
  upload: null,
  limits: null,
  layers: DEFAULT_LAYERS,
  review: null,
  vehicle: null,
});
const api = createApi(() => store.get().token);
const actions = createActions(api, store);
/** @type {WheelView|null} */
let wheelView = null;
/** @type {(() => void)|null} */
let stopWatching = null;
let lastLoadKey = '';
/** The element the page on screen renders into, and which page that is. */
let page = { name: '', root: document.createElement('div') };

/**
 * The element page `name` renders into: a new one whenever the page changes, so the views
 * (lit-html templates, patched in place) never patch another page's DOM.
 * @param {string} name
 * @returns {HTMLElement}
 */
function pageRoot(name) {
  if (page.name !== name) {
    const root = document.createElement('div');
    root.className = 'page';
    els.view.replaceChildren(root);
    page = { name, root };
  }
  return page.root;
}

window.addEventListener('error', (e) => store.set({ error: `the page hit a bug: ${e.message}` }));
window.addEventListener('unhandledrejection', (e) =>
  store.set({ error: `the page hit a bug: ${String(e.reason?.message ?? e.reason)}` }),
);

/** Follow the location hash: sign in from `#token=`, then load what the route shows. */
async function onHashChange() {
  const route = parseHash(window.location.hash);
  if (route.token) {
    window.localStorage.setItem(TOKEN_KEY, route.token);
    window.history.replaceState(null, '', `${window.location.pathname}#/passes`);
    await actions.signIn(route.token);
    if (store.get().me) startWatching();
    else stopWatching?.();
  }
  const layers = /** @type {typeof DEFAULT_LAYERS} */ (
    Object.fromEntries(
      LAYERS.map(([key]) => [
        key,
        route.query[key] === undefined
          ? DEFAULT_LAYERS[/** @type {keyof typeof DEFAULT_LAYERS} */ (key)]
          : route.query[key] === '1',
      ]),
    )
  );
  if (!store.get().me) {
    store.set({ route, layers });
    return;
  }
  const loadKey = loadKeyOf(route);
  // a new page starts without the last page's error (restyling the same page keeps it)
  store.set(loadKey === lastLoadKey ? { route, layers } : { route, layers, error: null });
  if (loadKey === lastLoadKey) return;
  lastLoadKey = loadKey;
  if (route.name === 'passes') await actions.loadPasses(route.query);
  else if (route.name === 'pass') {
    await actions.loadPass(route.params.passId);
    followPassJob();
  } else if (route.name === 'wheel') {
    await actions.loadWheel(
      route.params.passId,
      route.params.wheelId,
      route.query.sensor,
      Number(route.query.frame ?? 0),
    );
  } else if (route.name === 'review') await actions.loadReview(route.query);
  else if (route.name === 'vehicle') await actions.loadVehicle(route.params.vehicleId);
}

/**
 * What must be fetched for a route; query changes that only restyle (method, layers) keep it.
 * @param {import('./lib/route.js').Route} route
 * @returns {string}
 */
function loadKeyOf(route) {
  if (route.name === 'wheel') {
    return `wheel/${route.params.passId}/${route.params.wheelId}/${route.query.sensor ?? ''}/${route.query.frame ?? 0}`;
  }
  if (route.name === 'passes' || route.name === 'review') return `${route.name}?${new URLSearchParams(route.query)}`;
  if (route.name === 'vehicle') return `vehicle/${route.params.vehicleId}`;
  return `${route.name}/${route.params.passId ?? route.params.path ?? ''}`;
}

/** Listen for job progress of every pass; a finished job refreshes what is on screen. */
function startWatching() {
  stopWatching?.();
  stopWatching = api.watch(
    'passes',
    (msg) => {
      const before = store.get().liveJobs[msg.pass_id];
      actions.jobUpdate(msg);
      const finished = msg.wheels_done !== before?.wheels_done || msg.state !== before?.state;
      if (finished) refreshOnProgress(msg);
    },
    (open) => store.set({ socketOpen: open }),
  );
}

/** @type {(() => void)|null} */
let stopFollowing = null;

/**
 * While the pass on screen is still measured, follow its job's own socket (which reports
 * every step to the end) so the train fills in wheel by wheel.
 */
function followPassJob() {
  stopFollowing?.();
  stopFollowing = null;
  const job = store.get().pass?.data?.job;
  if (!job || job.state === 'done' || job.state === 'failed') return;
  const stop = api.watch(
    `jobs/${job.job_id}`,
    (msg) => {
      actions.jobUpdate(msg);
      refreshOnProgress(msg);
      if (msg.state === 'done' || msg.state === 'failed') stop();
    },
    () => {},
  );
  stopFollowing = stop;
}

let refreshTimer = 0;
/**
 * Reload the list or the pass on screen when a job made progress (at most twice a second).
 * @param {any} msg
 */
function refreshOnProgress(msg) {
  if (refreshTimer) return;
  refreshTimer = window.setTimeout(() => {
    refreshTimer = 0;
    const { route } = store.get();
    if (route.name === 'passes') actions.loadPasses(route.query);
    else if (route.name === 'pass' && route.params.passId === String(msg.pass_id))
      actions.loadPass(route.params.passId);
  }, 500);
}

/**
 * Merge query parameters into the current route's hash (method, sensor, layer toggles).
 * @param {Record<string, string>} patch
 */
function setQuery(patch) {
  const { route } = store.get();
  const segments = window.location.hash.replace(/^#\//, '').split('?')[0].split('/');
  window.location.hash = buildHash(segments, { ...route.query, ...patch });
}

/** Render the shell and the page of the current route from the state. */
function renderApp() {
  const state = store.get();
  renderShell(els, state, {
    dismissError: () => store.set({ error: null }),
    closeHelp: () => store.set({ helpOpen: false }),
    findVehicle: (text) => {
      window.location.hash = buildHash(['vehicles', text]);
    },
    signOut: () => {
      window.localStorage.removeItem(TOKEN_KEY);
      stopWatching?.();
      store.set({ token: null, me: null });
    },
  });
  if (state.route.name !== 'pass' && stopFollowing) {
    stopFollowing();
    stopFollowing = null;
  }
  if (state.route.name !== 'wheel' && wheelView) {
    wheelView.destroy();
    wheelView = null;
  }
  if (!state.me) {
    if (!state.signingIn) {
      renderSignIn(pageRoot('sign-in'), async (token) => {
        window.localStorage.setItem(TOKEN_KEY, token);
        await actions.signIn(token);
        if (!store.get().me) return;
        startWatching();
        lastLoadKey = '';
        onHashChange();
      });
    } else pageRoot('signing-in').replaceChildren('Signing in…');
    return;
  }
  const { route } = state;
  if (route.name === 'passes') {
    renderPasses(pageRoot('passes'), state, {
      applyFilter: (filter) => {
        window.location.hash = buildHash(['passes'], filter);
      },
      select: (index) => store.set({ selectedRow: index }),
    });
  } else if (route.name === 'pass') {
    renderPass(pageRoot('pass'), state, {
      setMode: (mode) => setQuery({ mode }),
      exportReport: (format) => actions.exportReport(route.params.passId, null, format),
    });
  } else if (route.name === 'review') {
    renderReview(pageRoot('review'), state, {
      applyFilter: (filter) => {
        window.location.hash = buildHash(['review'], filter);
      },
    });
  } else if (route.name === 'vehicle') {
    renderVehicle(pageRoot('vehicle'), state);
  } else if (route.name === 'wheel') {
    wheelView ??= new WheelView(pageRoot('wheel'), {
      setQuery,
      exportReport: (format) =>
        actions.exportReport(store.get().route.params.passId, store.get().route.params.wheelId, format),
      importReference: (file) => {
        const { params } = store.get().route;
        return actions.importReference(params.passId, params.wheelId, file);
      },
      exportProfile: (format) => {
        const { params, query } = store.get().route;
        return actions.exportProfile(
          params.passId,
          params.wheelId,
          query.method === 'steger' ? 'steger' : 'adaptive',
          format,
        );
      },
      openViewer: () => actions.openViewer(store.get().route.params.passId, store.get().route.params.wheelId),
      closeViewer: () => actions.patchWheel({ viewerUrl: null }),
      addDisposition: (body) =>
        actions.addDisposition(store.get().route.params.passId, store.get().route.params.wheelId, body),
    });
    wheelView.update(state);
  } else if (route.name === 'upload') {
    renderUpload(pageRoot('upload'), state, { upload: actions.upload });
  } else {
    render(
      html`<p class="not-found">
        Nothing lives at "${route.params.path}". <a href="#/passes">Go back to the passes list</a>.
      </p>`,
      pageRoot('not-found'),
    );
  }
}

/**
 * Keyboard: global navigation, list movement, and the frame canvas on the wheel page.
 * @param {KeyboardEvent} e
 */
function onKey(e) {
  const target = /** @type {HTMLElement} */ (e.target);
  if (target.closest('input, textarea, select') || e.ctrlKey || e.metaKey || e.altKey) return;
  const state = store.get();
  if (e.key === '?') store.set({ helpOpen: !state.helpOpen });
  else if (e.key === 'Escape') escape(state);
  else if (state.route.name === 'passes') passesKey(e, state);
  else if (state.route.name === 'wheel') wheelKey(e, state);
  const jumps = /** @type {Record<string, string>} */ ({ p: '#/passes', u: '#/upload', w: '#/review' });
  if (pendingG && jumps[e.key]) window.location.hash = jumps[e.key];
  pendingG = e.key === 'g';
}
let pendingG = false;

/** @param {any} state */
function escape(state) {
  if (state.helpOpen) store.set({ helpOpen: false });
  else if (state.route.name === 'wheel' && state.wheel?.viewerUrl) actions.patchWheel({ viewerUrl: null });
  else if (state.route.name === 'wheel') window.location.hash = buildHash(['passes', state.route.params.passId]);
  else if (state.route.name === 'pass' || state.route.name === 'review' || state.route.name === 'vehicle')
    window.location.hash = '#/passes';
}

/** @param {KeyboardEvent} e @param {any} state */
function passesKey(e, state) {
  const n = state.passes.items.length;
  if (e.key === 'j' || e.key === 'ArrowDown') store.set({ selectedRow: Math.min(n - 1, state.selectedRow + 1) });
  else if (e.key === 'k' || e.key === 'ArrowUp') store.set({ selectedRow: Math.max(0, state.selectedRow - 1) });
  else if (e.key === 'Enter' && n > 0)
    window.location.hash = buildHash(['passes', state.passes.items[state.selectedRow].id]);
}

/** @param {KeyboardEvent} e @param {any} state */
function wheelKey(e, state) {
  const layer = LAYERS.find(([, , key]) => key === e.key);
  if (layer) return setQuery({ [layer[0]]: state.layers[layer[0]] ? '0' : '1' });
  const frame = wheelView?.frame;
  const step = 60;
  /** @type {Record<string, () => void>} */
  const moves = {
    f: () => frame?.fit(),
    '+': () => frame?.zoom(1.5),
    '=': () => frame?.zoom(1.5),
    '-': () => frame?.zoom(1 / 1.5),
    ArrowLeft: () => frame?.pan(step, 0),
    ArrowRight: () => frame?.pan(-step, 0),
    ArrowUp: () => frame?.pan(0, step),
    ArrowDown: () => frame?.pan(0, -step),
    '[': () => /** @type {HTMLElement|null} */ (document.querySelector('a[rel=prev]'))?.click(),
    ']': () => /** @type {HTMLElement|null} */ (document.querySelector('a[rel=next]'))?.click(),
    i: () => {
      const frames = state.wheel?.frames ?? [];
      const at = frames.findIndex(
        (/** @type {any} */ f) => f.sensor === state.wheel.sensor && f.index === state.wheel.index,
      );
      const next = frames[(at + 1) % frames.length];
      if (frames.length > 1) setQuery({ sensor: next.sensor, frame: String(next.index) });
    },
  };
  if (moves[e.key]) {
    e.preventDefault();
    moves[e.key]();
  }
}

store.subscribe(renderApp);
window.addEventListener('hashchange', onHashChange);
window.addEventListener('keydown', onKey);
// the help closes on a click anywhere outside it
window.addEventListener('pointerdown', (e) => {
  if (store.get().helpOpen && !els.help.contains(/** @type {Node} */ (e.target))) store.set({ helpOpen: false });
});
(async () => {
  const { token } = store.get();
  if (token && !parseHash(window.location.hash).token) {
    await actions.signIn(token);
    if (store.get().me) startWatching();
  }
  await onHashChange();
  renderApp();
})();
