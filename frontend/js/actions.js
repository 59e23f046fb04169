// @ts-check
/**
 * What the application does: load data for a route through the API into the store, and
 * answer user intents (upload, export, toggle). Views call these; only api.js touches the network.
 */
import { ApiError } from './api.js';
import { METHODS } from './lib/format.js';
import { tintMask } from './lib/layer-pixels.js';
import { passFilterQuery, reviewQuery } from './lib/records.js';

/** Job states after which nothing more happens. */
const JOB_ENDS = ['done', 'failed'];

/** Tint of the stripe mask layer (RGBA): translucent magenta, visible on grey frames. */
const MASK_TINT = /** @type {[number, number, number, number]} */ ([236, 72, 153, 110]);

/** Tint of the candidate centres the extraction rejected (RGBA): opaque lime, a third colour
 * beside the magenta mask and the orange (adaptive) and cyan (Steger) centres. */
const REJECTED_TINT = /** @type {[number, number, number, number]} */ ([132, 204, 22, 230]);

/**
 * @typedef {ReturnType<typeof createActions>} Actions
 */

/**
 * Hand a downloaded file to the browser to save.
 * @param {{blob: Blob, filename: string}} file
 */
function saveFile({ blob, filename }) {
  const url = URL.createObjectURL(blob);
  const link = Object.assign(document.createElement('a'), { href: url, download: filename });
  document.body.append(link);
  link.click();
  link.remove();
  window.setTimeout(() => URL.revokeObjectURL(url), 10000);
}

/**
 * Bind the actions to an API client and the store.
 * @param {import('./api.js').Api} api
 * @param {import('./state.js').Store<any>} store
 */
export function createActions(api, store) {
  /** Run a load; on failure put its words in the error banner (never a blank page). */
  const guard = async (/** @type {string} */ what, /** @type {() => Promise<void>} */ fn) => {
    try {
      await fn();
    } catch (err) {
      store.set({ error: `${what}: ${err instanceof Error ? err.message : String(err)}` });
      if (err instanceof ApiError && err.status === 401) store.set({ me: null });
    }
  };
  /**
   * A numbered ticket per list: a response is applied only while its request is the latest,
   * so a slow answer to an earlier filter cannot overwrite a later one (a cleared filter
   * coming back when its older request answers last).
   * @type {Record<string, number>}
   */
  const latest = {};
  const ticket = (/** @type {string} */ list) => {
    const n = (latest[list] ?? 0) + 1;
    latest[list] = n;
    return () => latest[list] === n;
  };
  return {
    guard,
    signIn: async (/** @type {string} */ token) => {
      store.set({ token, error: null, signingIn: true });
      await guard('sign-in failed', async () => {
        store.set({ me: await api.me() });
      });
      store.set({ signingIn: false });
    },
    loadPasses: (/** @type {Record<string, string>} */ filter) =>
      guard('could not load the passes', async () => {
        const current = ticket('passes');
        store.set({ passes: { ...store.get().passes, filter, loading: true } });
        const page = await api.listPasses(passFilterQuery(filter));
        if (!current()) return;
        store.set({ passes: { filter, items: page.items, total: page.total, loading: false } });
      }),
    loadPass: (/** @type {string} */ passId) =>
      guard(`could not load pass ${passId}`, async () => {
        const current = store.get().pass;
        // a refresh of the pass on screen keeps showing it until the new data is there
        if (!(current?.id === passId && current.data)) {
          store.set({ pass: { id: passId, loading: true, data: null, wheels: [] } });
        }
        try {
          const [data, wheels, limits] = await Promise.all([
            api.getPass(passId),
            api.listWheels(passId),
            store.get().limits ?? api.getLimits(),
          ]);
          store.set({ pass: { id: passId, loading: false, data, wheels }, limits });
        } catch (err) {
          store.set({ pass: { id: passId, loading: false, data: null, wheels: [], failed: true } });
          throw err;
        }
      }),
    loadWheel: (
      /** @type {string} */ passId,
      /** @type {string} */ wheelId,
      /** @type {string|undefined} */ sensor,
      /** @type {number} */ index,
    ) =>
      guard(`could not load wheel ${wheelId} of pass ${passId}`, async () => {
        try {
          await loadWheel(api, store, passId, wheelId, sensor, index);
        } catch (err) {
          if (err instanceof DOMException && err.name === 'AbortError') return; // another wheel opened
          store.set({ wheel: { passId, wheelId, loading: false, failed: true } });
          throw err;
        }
      }),
    loadReview: (/** @type {Record<string, string>} */ filter) =>
      guard('could not load the worst wheels', async () => {
        const current = ticket('review');
        store.set({ review: { ...(store.get().review ?? {}), filter, loading: true } });
        const page = await api.worstWheels(reviewQuery(filter));
        if (!current()) return;
        store.set({ review: { filter, page, loading: false } });
      }),
    loadVehicle: (/** @type {string} */ vehicleId) =>
      guard(`could not load vehicle ${vehicleId}`, async () => {
        store.set({ vehicle: { id: vehicleId, loading: true } });
        try {
          store.set({ vehicle: { id: vehicleId, loading: false, history: await api.vehicle(vehicleId) } });
        } catch (err) {
          if (!(err instanceof ApiError) || err.status !== 404) throw err;
          // not an exact id: offer the vehicles that contain it
          store.set({
            vehicle: { id: vehicleId, loading: false, history: null, matches: await api.searchVehicles(vehicleId) },
          });
        }
      }),
    addDisposition: async (
      /** @type {string} */ passId,
      /** @type {string} */ wheelId,
      /** @type {{kind: string, comment?: string}} */ body,
    ) => {
      let recorded = false;
      await guard('could not record the disposition', async () => {
        await api.addDisposition(passId, wheelId, body);
        recorded = true;
        const [record, history] = await Promise.all([api.getWheel(passId, wheelId), api.dispositions(passId, wheelId)]);
        const w = store.get().wheel;
        if (w?.passId === passId && w?.wheelId === wheelId)
          store.set({ wheel: { ...w, record, dispositions: history } });
      });
      return recorded; // the form clears once it is recorded
    },
    patchWheel: (/** @type {object} */ patch) => store.set({ wheel: { ...store.get().wheel, ...patch } }),
    openViewer: (/** @type {string} */ passId, /** @type {string} */ wheelId) =>
      guard('could not open the 3D view', async () => {
        const { url } = await api.viewer(passId, wheelId);
        store.set({ wheel: { ...store.get().wheel, viewerUrl: url } });
      }),
    exportReport: (/** @type {string} */ passId, /** @type {string|null} */ wheelId, /** @type {string} */ format) =>
      guard(`could not export the ${format.toUpperCase()} report`, async () =>
        saveFile(await api.report(passId, wheelId, format)),
      ),
    importReference: (/** @type {string} */ passId, /** @type {string} */ wheelId, /** @type {File} */ file) =>
      guard(`could not import ${file.name} as the handheld reference`, async () => {
        const reference = await api.importReference(wheelId, file);
        const comparison = await api.referenceComparison(passId, wheelId);
        const w = store.get().wheel;
        if (!w || w.passId !== passId || w.wheelId !== wheelId) return;
        const shown = comparison.reference ?? reference;
        store.set({
          wheel: { ...w, comparison, profiles: { ...w.profiles, handheld: { x_mm: shown.x_mm, z_mm: shown.z_mm } } },
        });
      }),
    exportProfile: (
      /** @type {string} */ passId,
      /** @type {string} */ wheelId,
      /** @type {string} */ method,
      /** @type {string} */ format,
    ) =>
      guard(`could not export the ${method} profile as ${format.toUpperCase()}`, async () =>
        saveFile(await api.profileFile(passId, wheelId, method, format)),
      ),
    upload: (/** @type {File} */ file) => {
      if (!/\.zip$/i.test(file.name)) {
        store.set({
          upload: null,
          error: `${file.name} is not a pass archive: drop the .zip of a wheelscan-pass/1 archive`,
        });
        return Promise.resolve();
      }
      return uploadArchive(file);
    },
    jobUpdate: (/** @type {any} */ msg) => jobUpdate(store, msg),
  };

  /**
   * Upload an archive and follow its measurement job; a refusal leaves no progress bar.
   * @param {File} file
   */
  function uploadArchive(file) {
    return guard(`upload of ${file.name} failed`, async () => {
      try {
        // a new upload starts without the last one's refusal above it
        store.set({ upload: { fileName: file.name, bytes: file.size, uploadFraction: 0, job: null }, error: null });
        const onProgress = (/** @type {number} */ f) =>
          store.set({ upload: { ...store.get().upload, uploadFraction: f } });
        const created = await api.uploadPass(file, onProgress);
        store.set({ upload: { ...store.get().upload, uploadFraction: 1, ...created } });
        const job = await api.getJob(created.job_id);
        jobUpdate(store, { ...job, job_id: created.job_id, pass_id: created.pass_id });
        // the job's own socket reports every step up to and including the end
        const stop = api.watch(
          `jobs/${created.job_id}`,
          (msg) => {
            jobUpdate(store, msg);
            if (JOB_ENDS.includes(msg.state)) stop();
          },
          () => {},
        );
      } catch (err) {
        store.set({ upload: null });
        throw err;
      }
    });
  }
}

/**
 * Record one job progress message (from the WebSocket or a poll) in the store.
 * @param {import('./state.js').Store<any>} store
 * @param {any} msg {job_id, pass_id, state, progress, wheels_done, wheels_total}
 */
function jobUpdate(store, msg) {
  const state = store.get();
  const liveJobs = { ...state.liveJobs, [msg.pass_id]: msg };
  const upload = state.upload && state.upload.job_id === msg.job_id ? { ...state.upload, job: msg } : state.upload;
  store.set({ liveJobs, upload });
}

/** Frames (image and both methods' centres) fetched ahead, kept for the last few wheels. */
const FRAME_CACHE_SIZE = 4;
/** @type {Map<string, Promise<{image: ImageBitmap|null, adaptive: any, steger: any}>>} */
const frameCache = new Map();

/**
 * One frame's image and both methods' centres, from the cache of frames fetched ahead or
 * the service (a failed image is not kept, so the next look asks again).
 * @param {import('./api.js').Api} api
 * @param {string} passId
 * @param {string} wheelId
 * @param {any} record the wheel's PassWheelRead (is its camera frame still kept?)
 * @param {string} sensor
 * @param {number} index
 * @returns {Promise<{image: ImageBitmap|null, adaptive: any, steger: any}>}
 */
function frameLayers(api, passId, wheelId, record, sensor, index) {
  // a measurement by another pipeline version gives other centres: another entry
  const versions = (record.results ?? []).map((/** @type {any} */ r) => `${r.method}:${r.pipeline_version}`);
  const key = `${passId}/${wheelId}/${sensor}/${index}/${versions.join(',')}`;
  let entry = frameCache.get(key);
  if (!entry) {
    entry = Promise.all([
      record.frames_removed_at ? null : api.frameImage(passId, wheelId, sensor, index),
      ...METHODS.map((m) => api.centres(passId, wheelId, sensor, index, m).catch((err) => ({ error: err.message }))),
    ]).then(([image, adaptive, steger]) => ({ image, adaptive, steger }));
    entry.catch(() => frameCache.delete(key));
  }
  frameCache.delete(key); // most recently used last
  frameCache.set(key, entry);
  while (frameCache.size > FRAME_CACHE_SIZE) frameCache.delete(/** @type {string} */ (frameCache.keys().next().value));
  return entry;
}

/**
 * The frames of a wheel from its record's count per sensor, inner before outer.
 * @param {any} record a PassWheelRead
 * @returns {Array<{sensor: string, index: number}>}
 */
function framesOf(record) {
  return Object.entries(record.frames ?? {})
    .sort(([a], [b]) => a.localeCompare(b))
    .flatMap(([sensor, count]) => Array.from({ length: Number(count) }, (_, index) => ({ sensor, index })));
}

/** @returns {Promise<void>} resolved after the next animation frame (the frame drawn) */
const nextAnimationFrame = () => new Promise((resolve) => requestAnimationFrame(() => resolve()));

/**
 * Load everything the wheel page shows, timing it (the bar: < 1 s on loopback), in two
 * steps: the frame with both methods' centres and the parameter table first (drawn at
 * once), then the side panels (profiles, trend, handheld comparison, dispositions) after
 * that draw; `loading` stays true until both are in. The pass's wheel list, once fetched,
 * gives the record; the next wheel's frame is fetched ahead while this one is on screen.
 * @param {import('./api.js').Api} api
 * @param {import('./state.js').Store<any>} store
 * @param {string} passId
 * @param {string} wheelId
 * @param {string|undefined} sensor
 * @param {number} index frame of that sensor, 0-based
 */
async function loadWheel(api, store, passId, wheelId, sensor, index) {
  const started = performance.now();
  const previous = store.get().wheel;
  previous?.requests?.abort(); // the last wheel's panels and layers still on their way
  const requests = new AbortController();
  const { signal } = requests;
  const sameWheel = previous && previous.passId === passId && previous.wheelId === wheelId;
  store.set({ wheel: { ...(sameWheel ? previous : {}), passId, wheelId, loading: true, viewerUrl: null, requests } });
  const byId = (/** @type {any[]} */ list) => list.find((w) => String(w.wheel_id) === String(wheelId));
  // the pass's wheel list is fetched once per pass (for prev/next), never per wheel change
  const listed = store.get().pass?.id === passId && store.get().pass.wheels?.length ? store.get().pass.wheels : null;
  const known = listed ? byId(listed) : null;
  const recordLoad = known ? null : api.getWheel(passId, wheelId, signal);
  const record = known ?? (await recordLoad);
  const frames = framesOf(record);
  const frame = frames.find((f) => f.sensor === (sensor ?? frames[0]?.sensor) && f.index === index);
  if (!frame && frames.length) {
    const count = frames.filter((f) => f.sensor === sensor).length;
    throw new ApiError(
      sensor && count === 0
        ? `wheel ${wheelId} has no ${sensor} frames (it has ${[...new Set(frames.map((f) => f.sensor))].join(', ')})`
        : `wheel ${wheelId} has ${count} ${sensor ?? frames[0].sensor} frame(s); frame ${index + 1} does not exist`,
      404,
      'no_frame',
    );
  }
  if (!frame) throw new ApiError(`no frames are stored for wheel ${wheelId} of pass ${passId}`, 404, 'no_frames');
  const { sensor: s, index: i } = frame;
  // the frame's requests go first: the browser holds six connections to the service
  const layers = frameLayers(api, passId, wheelId, record, s, i);
  const panels = Promise.all([
    recordLoad ?? api.getWheel(passId, wheelId, signal),
    api.dispositions(passId, wheelId, signal).catch(() => []),
    Promise.all(METHODS.map((m) => api.profile(passId, wheelId, m, signal).catch((err) => ({ error: err.message })))),
    api.trend(wheelId, signal).catch((err) => ({ error: err.message })),
    api.referenceComparison(passId, wheelId, signal).catch((err) => ({ error: err.message })),
  ]);
  panels.catch(() => {}); // awaited below; a failure must not go unhandled meanwhile
  const [limits, { image, adaptive, steger }] = await Promise.all([store.get().limits ?? api.getLimits(), layers]);
  if (signal.aborted) return; // another wheel or frame was opened meanwhile
  const current = () => {
    const w = store.get().wheel;
    return w?.passId === passId && w?.wheelId === wheelId && w?.sensor === s && w?.index === i ? w : null;
  };
  // first the frame, its centres and the table: drawn before the side panels are built
  store.set({
    limits,
    wheel: {
      ...store.get().wheel,
      passId,
      wheelId,
      frames,
      sensor: s,
      index: i,
      record,
      layers: { image: image ?? (await blankFrame(adaptive, steger)), mask: null, sigma: null },
      sigmaScale: null,
      centres: { adaptive, steger },
    },
  });
  // what `]` opens next is fetched while this frame is looked at (before its side panels)
  if (listed) prefetchNext(api, store, passId, wheelId);
  const [[fresh, dispositions, profiles, trend, comparison]] = await Promise.all([panels, nextAnimationFrame()]).catch(
    (err) => {
      if (signal.aborted) return [[]]; // another wheel or frame was opened meanwhile
      throw err;
    },
  );
  const shown = current();
  if (!shown || signal.aborted) return;
  const wheels = (listed ?? [fresh]).map((/** @type {any} */ w) =>
    String(w.wheel_id) === String(wheelId) ? fresh : w,
  );
  store.set({
    pass: { ...(store.get().pass?.id === passId ? store.get().pass : { id: passId, data: null }), wheels },
    wheel: {
      ...shown,
      loading: false,
      record: fresh,
      dispositions,
      profiles: {
        adaptive: profiles[0],
        steger: profiles[1],
        ...('reference' in comparison && comparison.reference
          ? { handheld: { x_mm: comparison.reference.x_mm, z_mm: comparison.reference.z_mm } }
          : {}),
      },
      comparison,
      trend,
      loadMs: performance.now() - started,
    },
  });
  if (!listed) {
    api
      .listWheels(passId)
      .then((all) => {
        if (store.get().pass?.id !== passId) return;
        store.set({ pass: { ...store.get().pass, wheels: all } });
        prefetchNext(api, store, passId, wheelId);
      })
      .catch(() => {});
  }
  await loadSideLayers(api, store, passId, wheelId, s, i, signal);
}

/**
 * Fetch the first frame of the wheel after this one in the pass (what `]` opens) while this
 * one is on screen (kept in the frame cache).
 * @param {import('./api.js').Api} api
 * @param {import('./state.js').Store<any>} store
 * @param {string} passId
 * @param {string} wheelId
 */
function prefetchNext(api, store, passId, wheelId) {
  const wheels = store.get().pass?.id === passId ? (store.get().pass.wheels ?? []) : [];
  const next = wheels[wheels.findIndex((/** @type {any} */ w) => String(w.wheel_id) === String(wheelId)) + 1];
  const first = next ? framesOf(next)[0] : null;
  if (next && first) frameLayers(api, passId, String(next.wheel_id), next, first.sensor, first.index).catch(() => {});
}

/**
 * Fetch the stripe mask and σ map after the frame and centres are on screen (they are
 * layers the user switches on; the page must not wait for them), then add them.
 * @param {import('./api.js').Api} api
 * @param {import('./state.js').Store<any>} store
 * @param {string} passId
 * @param {string} wheelId
 * @param {string} sensor
 * @param {number} index
 * @param {AbortSignal} signal aborted when another wheel or frame is opened
 */
async function loadSideLayers(api, store, passId, wheelId, sensor, index, signal) {
  const [mask, sigma] = /** @type {any[]} */ (
    await Promise.all([
      api
        .maskImage(passId, wheelId, sensor, index, 'adaptive', signal)
        .then(maskLayer)
        .catch((/** @type {Error} */ err) => ({ error: err.message })),
      api
        .sigmaImage(passId, wheelId, sensor, index, 'adaptive', signal)
        .catch((/** @type {Error} */ err) => ({ error: err.message })),
    ])
  );
  const w = store.get().wheel;
  if (!w || w.passId !== passId || w.wheelId !== wheelId || w.sensor !== sensor || w.index !== index) return;
  const sigmaOk = sigma && !('error' in sigma);
  store.set({
    wheel: {
      ...w,
      layers: { ...w.layers, mask: 'error' in mask ? null : mask, sigma: sigmaOk ? sigma.bitmap : null },
      sigmaScale: sigmaOk
        ? { sigma_min_px: sigma.sigma_min_px, sigma_max_px: sigma.sigma_max_px, scales_px: sigma.scales_px }
        : null,
      layerErrors: { mask: 'error' in mask ? mask.error : null, sigma: sigmaOk ? null : sigma.error },
    },
  });
}

/**
 * A transparent frame of the recorded size in place of a camera frame removed by retention,
 * so the centres, mask and σ map keep their positions (the wheel page says why).
 * @param {...any} centres CentresRead responses (or {error}), which carry width_px, height_px
 * @returns {Promise<ImageBitmap>}
 */
function blankFrame(...centres) {
  const size = centres.find((c) => c?.width_px > 0) ?? { width_px: 1, height_px: 1 };
  return createImageBitmap(new ImageData(size.width_px, size.height_px));
}

/**
 * Turn the mask PNG into a translucent tint layer the frame canvas draws over the image.
 * @param {ImageBitmap} bitmap
 * @returns {Promise<ImageBitmap>}
 */
async function maskLayer(bitmap) {
  const canvas = new OffscreenCanvas(bitmap.width, bitmap.height);
  const ctx = /** @type {OffscreenCanvasRenderingContext2D} */ (canvas.getContext('2d'));
  ctx.drawImage(bitmap, 0, 0);
  const pixels = ctx.getImageData(0, 0, bitmap.width, bitmap.height);
  const tinted = new ImageData(tintMask(pixels.data, MASK_TINT, REJECTED_TINT), bitmap.width, bitmap.height);
  return createImageBitmap(tinted);
}
