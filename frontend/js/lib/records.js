// @ts-check
/**
 * Reading the service's records (PassSummary, PassWheelRead, LimitsRead, WheelTrend) the way
 * the views need them. Pure: no DOM, no network.
 */

/** Rows per page of the worst-wheels view. */
export const REVIEW_PAGE_ROWS = 50;

/** Reference profile → limit family, as the service files its limits (EN or LM). */
const PROFILE_FAMILY = { S1002: 'EN', LMA: 'LM', LM: 'LM' };

/**
 * The result of one method for a wheel, or null when that method has none.
 * @param {any} wheel a PassWheelRead
 * @param {string} method "adaptive" or "steger"
 * @returns {any|null} a MethodResult
 */
export function resultOf(wheel, method) {
  return wheel?.results?.find((/** @type {any} */ r) => r.method === method) ?? null;
}

/**
 * The limit name ("flange_thickness") a displayed parameter is checked against, or null.
 * EN limits check the flange thickness at 10 mm, LM limits the one at 12 mm (as the service).
 * @param {string} key parameter key such as "flange_thickness_10_mm"
 * @param {string|null|undefined} family "EN" or "LM"
 * @returns {string|null}
 */
export function limitStem(key, family) {
  if (key === 'flange_thickness_10_mm') return family === 'LM' ? null : 'flange_thickness';
  if (key === 'flange_thickness_mm') return family === 'LM' ? 'flange_thickness' : null;
  return key.replace(/_mm$/, '');
}

/**
 * Whether a method result has an alarm on the displayed parameter `key`.
 * @param {any} result a MethodResult or null
 * @param {string} key parameter key with its unit suffix
 * @param {string|null|undefined} family "EN" or "LM"
 * @returns {boolean}
 */
export function hasAlarmOn(result, key, family) {
  const stem = limitStem(key, family);
  return (
    stem !== null && (result?.alarms ?? []).some((/** @type {any} */ a) => a.parameter.replace(/_mm$/, '') === stem)
  );
}

/**
 * Why a measured result lacks some of its flange values, or null: the service sends it as a
 * measured result's `reason`, each part naming its parameter ("Sd: …" when the flank at
 * 12 mm was not measured, "Sd 10: …; qR: …" when the flank at 10 mm was not, "qR: …" when only
 * qR was). A result that was not
 * measured at all has its own reason instead (the whole wheel's), so it gives null here.
 * @param {any} result a MethodResult or null
 * @returns {string|null}
 */
export function missingValuesReason(result) {
  return result?.status === 'measured' ? (result.reason ?? null) : null;
}

/**
 * The names of the values a `missingValuesReason` text gives reasons for, in its order:
 * "Sd: …; qR: …" → ["Sd", "qR"].
 * @param {string|null|undefined} reason
 * @returns {string[]}
 */
export function missingValueNames(reason) {
  return (reason ?? '')
    .split('; ')
    .map((part) => part.split(': ', 1)[0])
    .filter((name) => /^(Sd|Sd 10|qR)$/.test(name));
}

/**
 * Labels of the parameters a measured result could not be checked on: the limit row bounds
 * them but the result has no value (e.g. "Sd EN" when the flank at 10 mm was not measured).
 * "within limits" holds only for the others.
 * @param {any} result a MethodResult or null
 * @param {any} limits the LimitsRead row of its family, or null
 * @param {ReadonlyArray<{key: string, label: string, limitMax?: string}>} parameters the table's
 * @returns {string[]}
 */
export function uncheckedLimits(result, limits, parameters) {
  if (result?.status !== 'measured' || !limits) return [];
  return parameters
    .filter((p) => {
      const bounds = limitBounds(limits, p.key, p.limitMax);
      return bounds !== null && (bounds.min != null || bounds.max != null) && result[p.key] == null;
    })
    .map((p) => p.label);
}

/**
 * The bounds a limit row sets on one displayed parameter, or null when its family does not
 * check it; either bound is null/undefined where the row has none.
 * @param {any} limits a LimitsRead row, or null
 * @param {string} key parameter key such as "flange_height_mm"
 * @param {string} [maxKey] the limit field bounding it from above, when not `<stem>_max_mm`
 * @returns {{min: number|null|undefined, max: number|null|undefined}|null}
 */
export function limitBounds(limits, key, maxKey) {
  const stem = limitStem(key, limits?.wheel_profile);
  if (stem === null) return null;
  return { min: limits?.[`${stem}_min_mm`], max: limits?.[maxKey ?? `${stem}_max_mm`] };
}

/**
 * The limit family (EN or LM) of a result, from its reference profile.
 * @param {any} result a MethodResult or null
 * @returns {'EN'|'LM'}
 */
export function familyOf(result) {
  return /** @type {'EN'|'LM'} */ (
    PROFILE_FAMILY[/** @type {'S1002'} */ ((result?.reference_profile ?? '').toUpperCase())] ?? 'EN'
  );
}

/**
 * The limit set a wheel was checked against: that of its first result with a reference
 * profile (a result without a measured profile has none), or null when none has one.
 * @param {any[]} results a wheel's results, in the order to prefer them
 * @returns {'EN'|'LM'|null}
 */
export function checkedFamily(results) {
  const judged = results.find((r) => r?.reference_profile);
  return judged ? familyOf(judged) : null;
}

/**
 * The margin of one parameter of a wheel (adaptive), or null.
 * @param {any} wheel a PassWheelRead
 * @param {string} key parameter key
 * @returns {any|null} a MarginRead
 */
export function marginOf(wheel, key) {
  return wheel?.margins?.find((/** @type {any} */ m) => m.parameter === key) ?? null;
}

/**
 * The limits row that applies to a result's reference profile (EN unless LM).
 * @param {any[]|null} limits the list GET /api/limits returns
 * @param {string|null|undefined} referenceProfile e.g. "S1002", "LMA"
 * @returns {any|null} a LimitsRead
 */
export function limitsFor(limits, referenceProfile) {
  const family = familyOf({ reference_profile: referenceProfile });
  return limits?.find((l) => l.wheel_profile === family) ?? null;
}

/**
 * The state to show for a pass: its job's state while one exists, else open/closed.
 * @param {any} pass a PassSummary
 * @param {any} [live] the latest WebSocket JobProgress for it
 * @returns {{state: string, progress: number|null, running: boolean}}
 */
export function passStatus(pass, live) {
  const job = live ?? pass?.job ?? null;
  const state = job?.state ?? pass?.state ?? 'unknown';
  const running = state === 'queued' || state === 'running' || (!job && state === 'open');
  return { state, progress: job?.progress ?? null, running };
}

/**
 * The API query of the passes filter form: dates become UTC day bounds (the end exclusive).
 * @param {Record<string, string>} filter form values: site, vehicle, since, until (YYYY-MM-DD), alarm
 * @returns {Record<string, string>}
 */
export function passFilterQuery(filter) {
  /** @type {Record<string, string>} */
  const query = {};
  if (filter.site) query.site = filter.site;
  if (filter.vehicle) query.vehicle = filter.vehicle;
  if (filter.since) query.started_from = `${filter.since}T00:00:00Z`;
  if (filter.until) {
    const next = new Date(`${filter.until}T00:00:00Z`);
    next.setUTCDate(next.getUTCDate() + 1);
    query.started_to = next.toISOString().replace('.000Z', 'Z');
  }
  if (filter.alarm === 'true') query.alarm = 'true';
  return query;
}

/**
 * The API query of the worst-wheels filter form.
 * @param {Record<string, string>} filter site, fleet, vehicle, parameter, open ('1'), unchecked ('1'), history ('1'), pass, page (1-based)
 * @returns {Record<string, string>}
 */
export function reviewQuery(filter) {
  /** @type {Record<string, string>} */
  const query = {};
  for (const key of ['site', 'fleet', 'vehicle', 'parameter']) if (filter[key]) query[key] = filter[key];
  if (filter.open === '1') query.open_only = 'true';
  if (filter.unchecked === '1') query.unchecked_only = 'true';
  if (filter.history === '1') query.latest_only = 'false';
  if (filter.pass) query.pass_id = filter.pass;
  const page = Number(filter.page ?? 1);
  if (Number.isInteger(page) && page > 1) query.offset = String((page - 1) * REVIEW_PAGE_ROWS);
  query.limit = String(REVIEW_PAGE_ROWS);
  return query;
}

/**
 * A wheel trend as uPlot columns: pass times (s), the vehicle's odometer at each pass (km,
 * null where the pass carries none) and one column per method × parameter.
 * @param {any} trend a WheelTrend {points: [{pass_id, started_at, odometer_km, method, ...}]}
 * @param {string[]} methods
 * @param {string[]} keys parameter keys
 * @returns {{x: number[], km: Array<number|null>, columns: Record<string, Array<number|null>>}}
 *   columns keyed "method:key"
 */
export function trendColumns(trend, methods, keys) {
  const byPass = new Map();
  for (const point of trend?.points ?? []) {
    if (!byPass.has(point.pass_id))
      byPass.set(point.pass_id, { t: Date.parse(point.started_at) / 1000, km: point.odometer_km ?? null, methods: {} });
    byPass.get(point.pass_id).methods[point.method] = point;
  }
  const passes = [...byPass.values()].sort((a, b) => a.t - b.t);
  /** @type {Record<string, Array<number|null>>} */
  const columns = {};
  for (const m of methods) {
    for (const k of keys) columns[`${m}:${k}`] = passes.map((p) => p.methods[m]?.[k] ?? null);
  }
  return { x: passes.map((p) => p.t), km: passes.map((p) => p.km), columns };
}

/**
 * What a wheel page says when frame retention removed the pass's camera frames, else null.
 * @param {any} wheel a PassWheelRead (its frames_removed_at is an ISO-8601 time or null)
 * @returns {string|null}
 */
export function framesRemovedNote(wheel) {
  const removedAt = wheel?.frames_removed_at;
  if (!removedAt) return null;
  return (
    `camera frames removed by retention on ${String(removedAt).slice(0, 10)}; ` +
    'results, centres, mask and σ map are kept'
  );
}
