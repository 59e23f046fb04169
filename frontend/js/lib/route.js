// @ts-check
/**
 * The hash router's pure half: location hash ⇄ route object.
 *
 * Routes: `#/passes?site=..`, `#/passes/{id}`, `#/passes/{id}/wheels/{wheelId}?sensor=..&method=..`,
 * `#/review?site=..&parameter=..` (worst wheels), `#/vehicles/{id}`, `#/upload`, and the
 * sign-in link `#token=T` that `make run` prints.
 */

/**
 * @typedef {object} Route
 * @property {'passes'|'pass'|'wheel'|'review'|'vehicle'|'upload'|'not-found'} name
 * @property {Record<string, string>} params path parameters (passId, wheelId)
 * @property {Record<string, string>} query query parameters after `?`
 * @property {string|null} token a sign-in token carried by `#token=T`, else null
 */

const PATTERNS = [
  { name: 'passes', re: /^\/?(?:passes)?\/?$/, keys: [] },
  { name: 'pass', re: /^\/passes\/(\d+)\/?$/, keys: ['passId'] },
  { name: 'wheel', re: /^\/passes\/(\d+)\/wheels\/([^/]+)\/?$/, keys: ['passId', 'wheelId'] },
  { name: 'upload', re: /^\/upload\/?$/, keys: [] },
  { name: 'review', re: /^\/review\/?$/, keys: [] },
  { name: 'vehicle', re: /^\/vehicles\/([^/]+)\/?$/, keys: ['vehicleId'] },
];

/**
 * Parse a location hash ("#/passes/3?x=1") into a route.
 * @param {string} hash the hash, with or without its leading "#"
 * @returns {Route}
 */
export function parseHash(hash) {
  const body = hash.replace(/^#/, '');
  const tokenMatch = /^token=([^&]+)/.exec(body);
  if (tokenMatch) {
    return { name: 'passes', params: {}, query: {}, token: decodeURIComponent(tokenMatch[1]) };
  }
  const [path, search = ''] = body.split('?', 2);
  const query = Object.fromEntries(new URLSearchParams(search));
  for (const pattern of PATTERNS) {
    const match = pattern.re.exec(path);
    if (match) {
      const params = Object.fromEntries(pattern.keys.map((key, i) => [key, decodeURIComponent(match[i + 1])]));
      return { name: /** @type {Route['name']} */ (pattern.name), params, query, token: null };
    }
  }
  return { name: 'not-found', params: { path }, query, token: null };
}

/**
 * Build a hash for a route ("#/passes/3/wheels/7?method=steger"); empty query values are dropped.
 * @param {string[]} segments path segments, e.g. ['passes', '3']
 * @param {Record<string, string|number|null|undefined>} [query]
 * @returns {string}
 */
export function buildHash(segments, query = {}) {
  const path = `#/${segments.map((s) => encodeURIComponent(String(s))).join('/')}`;
  const entries = Object.entries(query).filter(([, v]) => v !== null && v !== undefined && v !== '');
  if (entries.length === 0) return path;
  return `${path}?${new URLSearchParams(entries.map(([k, v]) => [k, String(v)]))}`;
}
