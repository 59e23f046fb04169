// @ts-check
/**
 * The only module that talks to the service: HTTP JSON, images, downloads, uploads and
 * WebSockets. Every call returns parsed data or throws ApiError with words a person can act
 * on. Paths live in one table so a renamed route is a one-line change.
 */

/** An API failure with the service's {"detail", "code"} (or our own words when it gave none). */
export class ApiError extends Error {
  /**
   * @param {string} message what went wrong, in words
   * @param {number} status HTTP status (0 when the service could not be reached)
   * @param {string} code the service's error code, or a local one
   */
  constructor(message, status, code) {
    super(message);
    this.name = 'ApiError';
    this.status = status;
    this.code = code;
  }
}

/** @param {number|string} passId @param {number|string} wheelId */
const wheelPath = (passId, wheelId) => `/api/passes/${passId}/wheels/${wheelId}`;
/**
 * Path and query of one layer of a wheel's frame: the sensor's position (inner/outer) in
 * the path, the frame's index among that sensor's frames of the wheel in the query.
 * @param {number|string} p @param {number|string} w @param {string} layer "frames", "mask", "sigma", "centres"
 * @param {string} sensor e.g. "left_inner" @param {number} index @param {string} suffix @param {string} [method]
 */
const layerPath = (p, w, layer, sensor, index, suffix, method) =>
  `${wheelPath(p, w)}/${layer}/${sensor.split('_')[1]}${suffix}?${new URLSearchParams({ index: String(index), ...(method ? { method } : {}) })}`;

/**
 * A frame and its centres: what the wheel page draws first. The browser keeps six
 * connections to the service; its queue serves high before low.
 * @type {RequestInit}
 */
const FIRST = { priority: 'high' };
/**
 * The side panels' requests, after the frame's, dropped when the page moves on.
 * @param {AbortSignal} [signal]
 * @returns {RequestInit}
 */
const after = (signal) => ({ priority: 'low', signal });

/**
 * @typedef {object} Api
 * @property {() => Promise<import('./api-types').Me>} me
 * @property {(filter: Record<string, string>) => Promise<import('./api-types').Page_PassSummary_>} listPasses
 * @property {(passId: number|string) => Promise<import('./api-types').PassSummary>} getPass
 * @property {(passId: number|string) => Promise<import('./api-types').PassWheelRead[]>} listWheels
 * @property {() => Promise<import('./api-types').LimitsRead[]>} getLimits
 * @property {(p: number|string, w: number|string, sensor: string, index: number) => Promise<ImageBitmap>} frameImage
 * @property {(p: number|string, w: number|string, sensor: string, index: number, method: string, signal?: AbortSignal) => Promise<ImageBitmap>} maskImage
 * @property {(p: number|string, w: number|string, sensor: string, index: number, method: string, signal?: AbortSignal) => Promise<{bitmap: ImageBitmap, sigma_min_px: number, sigma_max_px: number, scales_px: number[], colormap: string}>} sigmaImage
 * @property {(p: number|string, w: number|string, sensor: string, index: number, method: string) => Promise<import('./api-types').CentresRead>} centres
 * @property {(passId: number|string, wheelId: number|string, method: string, signal?: AbortSignal) => Promise<import('./api-types').ProfileRead>} profile
 * @property {(wheelId: number|string, signal?: AbortSignal) => Promise<import('./api-types').WheelTrend>} trend
 * @property {(passId: number|string, wheelId: number|string|null, format: string) => Promise<{blob: Blob, filename: string}>} report
 * @property {(passId: number|string, wheelId: number|string, method: string, format: string) => Promise<{blob: Blob, filename: string}>} profileFile
 * @property {(passId: number|string, wheelId: number|string, signal?: AbortSignal) => Promise<import('./api-types').ReferenceComparison>} referenceComparison
 * @property {(wheelId: number|string, file: File) => Promise<import('./api-types').ReferenceRead>} importReference
 * @property {(passId: number|string, wheelId: number|string) => Promise<import('./api-types').ViewerRead>} viewer
 * @property {(passId: number|string, wheelId: number|string, signal?: AbortSignal) => Promise<import('./api-types').PassWheelRead>} getWheel
 * @property {(query: Record<string, string>) => Promise<import('./api-types').Page_WorstWheelRead_>} worstWheels
 * @property {(text: string) => Promise<string[]>} searchVehicles
 * @property {(vehicleId: string) => Promise<import('./api-types').VehicleHistory>} vehicle
 * @property {(passId: number|string, wheelId: number|string, signal?: AbortSignal) => Promise<import('./api-types').DispositionRead[]>} dispositions
 * @property {(passId: number|string, wheelId: number|string, body: {kind: string, comment?: string}) => Promise<import('./api-types').DispositionRead>} addDisposition
 * @property {(jobId: number|string) => Promise<import('./api-types').JobRead>} getJob
 * @property {(file: File, onProgress: (fraction: number) => void) => Promise<{pass_id: number, job_id: number}>} uploadPass
 * @property {(path: 'passes'|string, onMessage: (msg: any) => void, onState: (open: boolean) => void) => () => void} watch
 */

/**
 * Create the API client.
 * @param {() => string|null} getToken the current bearer token
 * @param {string} [base] origin of the service; default the page's own
 * @returns {Api}
 */
export function createApi(getToken, base = '') {
  /** @param {string} path @param {RequestInit} [init] */
  const request = async (path, init = {}) => {
    const headers = new Headers(init.headers);
    const token = getToken();
    if (token) headers.set('Authorization', `Bearer ${token}`);
    let response;
    try {
      response = await fetch(base + path, { ...init, headers });
    } catch (err) {
      if (init.signal?.aborted) throw err; // the caller moved on: not a failure to report
      throw new ApiError(`cannot reach the service (${String(err)}); is it running?`, 0, 'network');
    }
    if (!response.ok) throw await errorFrom(response, path);
    return response;
  };
  /** @param {string} path @param {RequestInit} [init] */
  const json = async (path, init) => (await request(path, init)).json();
  /** @param {Response} response @param {string} path */
  const decode = async (response, path) => {
    try {
      return await createImageBitmap(await response.blob());
    } catch {
      throw new ApiError(`the service sent an image the browser cannot decode (${path})`, 200, 'decode');
    }
  };
  /** A file attachment: its bytes and the name the service gave it. @param {string} path @param {string} fallback */
  const download = async (path, fallback) => {
    const response = await request(path);
    const match = /filename="?([^";]+)"?/.exec(response.headers.get('Content-Disposition') ?? '');
    return { blob: await response.blob(), filename: match ? match[1] : fallback };
  };
  /** @param {string} path @param {RequestInit} [init] */
  const bitmap = async (path, init) => decode(await request(path, init), path);
  return {
    me: () => json('/api/me'),
    listPasses: (filter) => json(`/api/passes?${new URLSearchParams(filter)}`),
    getPass: (passId) => json(`/api/passes/${passId}`),
    listWheels: (passId) => json(`/api/passes/${passId}/wheels`),
    getLimits: () => json('/api/limits'),
    frameImage: (p, w, sensor, index) => bitmap(layerPath(p, w, 'frames', sensor, index, '.png'), FIRST),
    maskImage: (p, w, sensor, index, method, signal) =>
      bitmap(layerPath(p, w, 'mask', sensor, index, '.png', method), { signal }),
    sigmaImage: async (p, w, sensor, index, method, signal) => {
      const path = layerPath(p, w, 'sigma', sensor, index, '.png', method);
      const response = await request(path, { signal });
      return {
        sigma_min_px: Number(response.headers.get('X-Sigma-Min-Px')),
        sigma_max_px: Number(response.headers.get('X-Sigma-Max-Px')),
        scales_px: (response.headers.get('X-Sigma-Scales-Px') ?? '').split(',').filter(Boolean).map(Number),
        colormap: response.headers.get('X-Colormap') ?? 'viridis',
        bitmap: await decode(response, path),
      };
    },
    centres: (p, w, sensor, index, method) => json(layerPath(p, w, 'centres', sensor, index, '', method), FIRST),
    profile: (p, w, method, signal) =>
      json(`${wheelPath(p, w)}/profile?method=${encodeURIComponent(method)}`, after(signal)),
    trend: (wheelId, signal) => json(`/api/wheels/${wheelId}/trend`, after(signal)),
    report: (p, w, format) =>
      download(
        `${w === null ? `/api/passes/${p}` : wheelPath(p, w)}/report.${format}`,
        `wheelscan-pass-${p}${w === null ? '' : `-wheel-${w}`}.${format}`,
      ),
    profileFile: (p, w, method, format) =>
      download(
        `${wheelPath(p, w)}/profile.${format}?method=${encodeURIComponent(method)}`,
        `wheelscan-pass-${p}-wheel-${w}-${method}.${format}`,
      ),
    referenceComparison: (p, w, signal) => json(`${wheelPath(p, w)}/reference-comparison`, after(signal)),
    importReference: async (wheelId, file) => {
      const body = new FormData();
      body.append('file', file, file.name);
      return (await request(`/api/wheels/${wheelId}/references`, { method: 'POST', body })).json();
    },
    viewer: (p, w) => json(`${wheelPath(p, w)}/viewer`),
    getWheel: (p, w, signal) => json(wheelPath(p, w), after(signal)),
    worstWheels: (query) => json(`/api/review/worst-wheels?${new URLSearchParams(query)}`),
    searchVehicles: (text) => json(`/api/vehicles?${new URLSearchParams({ q: text })}`),
    vehicle: (vehicleId) => json(`/api/vehicles/${encodeURIComponent(vehicleId)}`),
    dispositions: (p, w, signal) => json(`${wheelPath(p, w)}/dispositions`, after(signal)),
    addDisposition: async (p, w, body) =>
      (
        await request(`${wheelPath(p, w)}/dispositions`, {
          method: 'POST',
          headers: { 'Content-Type': 'application/json' },
          body: JSON.stringify(body),
        })
      ).json(),
    getJob: (jobId) => json(`/api/jobs/${jobId}`),
    uploadPass: (file, onProgress) => uploadWithProgress(base, getToken(), file, onProgress),
    watch: (path, onMessage, onState) => watchSocket(base, getToken, path, onMessage, onState),
  };
}

/**
 * @param {Response} response
 * @param {string} path
 * @returns {Promise<ApiError>}
 */
async function errorFrom(response, path) {
  let detail = '';
  let code = `http_${response.status}`;
  try {
    const body = await response.json();
    detail = typeof body.detail === 'string' ? body.detail : JSON.stringify(body.detail);
    code = body.code ?? code;
  } catch {
    detail = response.statusText;
  }
  const what =
    response.status === 401
      ? 'the token was refused'
      : response.status === 403
        ? 'not allowed'
        : `${response.status} ${response.statusText}`;
  return new ApiError(`${what}: ${detail || 'no detail'} (${path.split('?')[0]})`, response.status, code);
}

/**
 * POST a pass archive as multipart `file`, reporting upload progress 0..1.
 * @param {string} base
 * @param {string|null} token
 * @param {File} file
 * @param {(fraction: number) => void} onProgress
 * @returns {Promise<{pass_id: number, job_id: number}>}
 */
function uploadWithProgress(base, token, file, onProgress) {
  return new Promise((resolve, reject) => {
    const xhr = new XMLHttpRequest();
    xhr.open('POST', `${base}/api/passes`);
    if (token) xhr.setRequestHeader('Authorization', `Bearer ${token}`);
    xhr.upload.onprogress = (e) => e.lengthComputable && onProgress(e.loaded / e.total);
    xhr.onerror = () => reject(new ApiError('upload failed: the connection to the service broke', 0, 'network'));
    xhr.onload = () => {
      let body = {};
      try {
        body = JSON.parse(xhr.responseText);
      } catch {
        body = { detail: xhr.responseText };
      }
      if (xhr.status >= 200 && xhr.status < 300) resolve(/** @type {any} */ (body));
      else
        reject(
          new ApiError(
            `upload refused (${xhr.status}): ${/** @type {any} */ (body).detail ?? 'no detail'}`,
            xhr.status,
            /** @type {any} */ (body).code ?? `http_${xhr.status}`,
          ),
        );
    };
    const form = new FormData();
    form.append('file', file, file.name);
    xhr.send(form);
  });
}

/**
 * Keep a WebSocket to /api/ws/{path} open (reconnecting with back-off) until closed.
 * @param {string} base
 * @param {() => string|null} getToken
 * @param {string} path "passes" or "jobs/{id}"
 * @param {(msg: any) => void} onMessage
 * @param {(open: boolean) => void} onState
 * @returns {() => void} stops watching
 */
function watchSocket(base, getToken, path, onMessage, onState) {
  let socket = /** @type {WebSocket|null} */ (null);
  let stopped = false;
  let delayMs = 500;
  const origin = base || window.location.origin;
  const connect = () => {
    const url = `${origin.replace(/^http/, 'ws')}/api/ws/${path}?token=${encodeURIComponent(getToken() ?? '')}`;
    socket = new WebSocket(url);
    socket.onopen = () => {
      delayMs = 500;
      onState(true);
    };
    socket.onmessage = (event) => {
      try {
        onMessage(JSON.parse(event.data));
      } catch {
        // a frame that is not JSON is not ours to show; the next one will be
      }
    };
    socket.onclose = () => {
      onState(false);
      if (!stopped) window.setTimeout(connect, (delayMs = Math.min(delayMs * 2, 10000)));
    };
  };
  connect();
  return () => {
    stopped = true;
    socket?.close();
  };
}
