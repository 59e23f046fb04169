// @ts-check
/** Pure formatting helpers for numbers, times and names shown in the UI. */

/**
 * The measured wheel parameters, in table order: the one list every view iterates (as the
 * service's GET /api/parameters). `families` are the limit sets that check the parameter
 * (EN checks Sd at 10 mm, LM at 12 mm); `card` marks those a wheel card shows; `colour` is
 * the parameter's colour in every plot.
 */
export const PARAMETERS = [
  { key: 'flange_height_mm', label: 'Sh', title: 'Flange height', unit: 'mm', families: ['EN', 'LM'], card: true, colour: '#f59e0b' },
  { key: 'flange_thickness_mm', label: 'Sd', title: 'Flange thickness at 12 mm', unit: 'mm', families: ['LM'], card: true, colour: '#a78bfa' },
  { key: 'flange_thickness_en_mm', label: 'Sd EN', title: 'Flange thickness at 10 mm (EN)', unit: 'mm', families: ['EN'], card: true, colour: '#c084fc' },
  { key: 'qr_mm', label: 'qR', title: 'Flange slope qR', unit: 'mm', families: ['EN', 'LM'], card: true, colour: '#34d399' },
  { key: 'back_to_back_mm', label: 'B2B', title: 'Back-to-back distance', unit: 'mm', families: ['EN', 'LM'], card: false, colour: '#60a5fa' },
];

/**
 * The parameter with `key`, or a stand-in naming the key (a parameter this page predates).
 * @param {string} key
 */
export function parameterOf(key) {
  return PARAMETERS.find((p) => p.key === key)
    ?? { key, label: key, title: key, unit: 'mm', families: ['EN', 'LM'], card: false, colour: '#d6dce4' };
}

/** Dispositions an operator can record, with their labels. */
export const DISPOSITIONS = [
  ['re_profile', 'Re-profile'], ['monitor', 'Monitor'], ['false_alarm', 'False alarm'],
  ['measurement_doubtful', 'Measurement doubtful'], ['comment', 'Comment'],
];

/**
 * A disposition in words: "monitor", "false alarm: wet rail"; "open" when there is none.
 * @param {any} disposition a DispositionRead or null
 * @returns {string}
 */
export function fmtDisposition(disposition) {
  if (!disposition) return 'open';
  const label = (DISPOSITIONS.find(([k]) => k === disposition.kind)?.[1] ?? disposition.kind).toLowerCase();
  return disposition.comment ? `${label}: ${disposition.comment}` : label;
}

/** The two extraction methods, in display order. */
export const METHODS = ['adaptive', 'steger'];

/**
 * A number with a fixed count of decimals, or an en dash when missing.
 * @param {number|null|undefined} value
 * @param {number} [digits]
 * @returns {string}
 */
export function fmtNumber(value, digits = 2) {
  return value === null || value === undefined || !Number.isFinite(value)
    ? '–'
    : value.toFixed(digits);
}

/**
 * A signed difference with an explicit + sign, or an en dash when missing.
 * @param {number|null|undefined} value
 * @param {number} [digits]
 * @returns {string}
 */
export function fmtSigned(value, digits = 2) {
  if (value === null || value === undefined || !Number.isFinite(value)) return '–';
  const text = Math.abs(value).toFixed(digits);
  if (Number(text) === 0) return text;
  return `${value > 0 ? '+' : '−'}${text}`;
}

/**
 * An ISO-8601 time as "YYYY-MM-DD HH:MM:SS UTC" (what a depot files; no local-time guessing).
 * @param {string|null|undefined} iso
 * @returns {string}
 */
export function fmtTime(iso) {
  if (!iso) return '–';
  const date = new Date(iso);
  if (Number.isNaN(date.getTime())) return String(iso);
  return `${date.toISOString().slice(0, 19).replace('T', ' ')} UTC`;
}

/**
 * A fraction 0..1 as a whole percentage.
 * @param {number|null|undefined} fraction
 * @returns {string}
 */
export function fmtPercent(fraction) {
  if (fraction === null || fraction === undefined || !Number.isFinite(fraction)) return '–';
  return `${Math.round(Math.max(0, Math.min(1, fraction)) * 100)} %`;
}

/**
 * A byte count in B, kB or MB.
 * @param {number} bytes
 * @returns {string}
 */
export function fmtBytes(bytes) {
  if (bytes < 1024) return `${bytes} B`;
  if (bytes < 1024 * 1024) return `${(bytes / 1024).toFixed(1)} kB`;
  return `${(bytes / 1024 / 1024).toFixed(1)} MB`;
}

/**
 * Human label of a sensor id such as "left_inner" → "left inner".
 * @param {string} sensor
 * @returns {string}
 */
export function fmtSensor(sensor) {
  return sensor.replace('_', ' ');
}
