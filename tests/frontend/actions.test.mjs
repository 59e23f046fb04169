// The list loaders apply only the latest request's answer (node --test).
import assert from 'node:assert/strict';
import { test } from 'node:test';

import { createActions } from '../../frontend/js/actions.js';
import { createStore } from '../../frontend/js/state.js';

/** An API whose list calls answer only when the test says so, in any order. */
function deferredApi() {
  /** @type {{query: any, answer: (page: any) => void}[]} */
  const calls = [];
  const later = (query) =>
    new Promise((resolve) => {
      calls.push({ query, answer: resolve });
    });
  return { calls, api: { listPasses: later, worstWheels: later } };
}

for (const [load, list, answer] of [
  ['loadPasses', 'passes', (filter) => ({ items: [{ id: filter.site ?? 'all' }], total: 1 })],
  ['loadReview', 'review', (filter) => ({ items: [], total: 0, site: filter.site ?? 'all' })],
]) {
  test(`${load}: a cleared filter stays cleared when the earlier filter answers last`, async () => {
    const { calls, api } = deferredApi();
    const store = createStore({ passes: { items: [], filter: {}, loading: false }, review: null });
    const actions = createActions(/** @type {any} */ (api), store);
    const filtered = actions[load]({ site: 'IM-' });
    const cleared = actions[load]({});
    calls[1].answer(answer({}));
    await cleared;
    calls[0].answer(answer({ site: 'IM-' }));
    await filtered;
    assert.deepEqual(store.get()[list].filter, {});
    assert.equal(store.get()[list].loading, false);
    assert.equal(store.get().error ?? null, null);
  });
}
