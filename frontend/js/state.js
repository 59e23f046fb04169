// @ts-check
/**
 * The one store of the application: a plain object replaced (never mutated) on each change,
 * and the subscribers told after every change. Views read it; actions write it.
 */

/**
 * @template T
 * @typedef {object} Store
 * @property {() => T} get the current state
 * @property {(patch: Partial<T> | ((state: T) => Partial<T>)) => void} set merge a patch
 * @property {(listener: (state: T, previous: T) => void) => () => void} subscribe returns unsubscribe
 */

/**
 * Create a store.
 * @template T
 * @param {T} initial
 * @returns {Store<T>}
 */
export function createStore(initial) {
  let state = Object.freeze({ ...initial });
  /** @type {Set<(state: T, previous: T) => void>} */
  const listeners = new Set();
  return {
    get: () => state,
    set(patch) {
      const previous = state;
      const delta = typeof patch === 'function' ? patch(state) : patch;
      state = Object.freeze({ ...state, ...delta });
      for (const listener of listeners) listener(state, previous);
    },
    subscribe(listener) {
      listeners.add(listener);
      return () => listeners.delete(listener);
    },
  };
}
