// A stand-in for CanvasRenderingContext2D that records every call, for drawing-module tests.

/**
 * @returns {{ctx: any, calls: Array<[string, any[]]>}}
 */
export function recordingContext() {
  const calls = [];
  const target = { canvas: { width: 800, height: 600 } };
  const ctx = new Proxy(target, {
    get(obj, key) {
      if (key in obj) return obj[key];
      return (...args) => {
        calls.push([String(key), args]);
      };
    },
    set(obj, key, value) {
      obj[key] = value;
      calls.push([`set:${String(key)}`, [value]]);
      return true;
    },
  });
  return { ctx, calls };
}
