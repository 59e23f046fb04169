// @ts-check
/** Pure formatting helpers for numbers, times and names shown in the UI. */

/**
 * The measured wheel parameters, in table order: key (the API's field), label, title, unit,
 * decimals shown, the definition shown a click away, the limit field bounding it from
 * above where that is not `<stem>_max_mm`, the limit sets that check it (`families`: EN
 * checks Sd at 10 mm, LM at 12 mm; none for unchecked ones), whether a wheel card and the
 * trend show it (`card`: `shownParameters`) and its colour in every plot. The one list every view iterates (as the
 * service's GET /api/parameters for the checked ones).
 */
export const PARAMETERS = [
  {
    key: 'flange_height_mm',
    label: 'Sh',
    title: 'Flange height',
    unit: 'mm',
    digits: 2,
    families: ['EN', 'LM'],
    card: true,
    colour: '#f59e0b',
    definition: 'Highest point of the flange above the tread reference point (70 mm from the back face).',
  },
  {
    key: 'flange_thickness_mm',
    label: 'Sd',
    title: 'Flange thickness at 12 mm',
    unit: 'mm',
    digits: 2,
    families: ['LM'],
    card: true,
    colour: '#a78bfa',
    definition: 'Back face to the flange flank, 12 mm above the tread reference point (LM wheels).',
  },
  {
    key: 'flange_thickness_10_mm',
    label: 'Sd EN',
    title: 'Flange thickness at 10 mm (EN)',
    unit: 'mm',
    digits: 2,
    families: ['EN'],
    card: true,
    colour: '#c084fc',
    definition: 'Back face to the flange flank, 10 mm above the tread reference point (EN 15313).',
  },
  {
    key: 'qr_mm',
    label: 'qR',
    title: 'Flange slope qR',
    unit: 'mm',
    digits: 2,
    families: ['EN', 'LM'],
    card: true,
    colour: '#34d399',
    definition: 'Horizontal distance between the flank at 10 mm and 2 mm below the flange top.',
  },
  {
    key: 'back_to_back_mm',
    label: 'B2B',
    title: 'Back-to-back distance',
    unit: 'mm',
    digits: 2,
    families: ['EN', 'LM'],
    card: false,
    colour: '#60a5fa',
    definition: "Distance between the back faces of the axle's two wheels.",
  },
  {
    key: 'tread_hollow_mm',
    label: 'Hollow',
    title: 'Tread hollow',
    unit: 'mm',
    digits: 2,
    families: [],
    card: true,
    colour: '#f472b6',
    definition:
      'Largest depth of the tread below a straight edge through the profile at 60 and 120 mm from the back face (new LMA 0.05 mm, S1002 0.12 mm).',
  },
  {
    key: 'flange_angle_deg',
    label: 'δ',
    title: 'Flange angle',
    unit: '°',
    digits: 1,
    families: [],
    card: true,
    colour: '#22d3ee',
    definition:
      "Steepest angle of the flange flank to the horizontal, from lines over 10 mm of flank height (centred from 6 mm to Sh − 6 mm) on the flank resampled every 0.25 mm; it sets Nadal's derailment limit Y/Q = (tan δ − μ)/(1 + μ tan δ). Gaps up to 2.5 mm are bridged; not measured where the flank's points leave a longer gap.",
  },
  {
    key: 'rim_width_mm',
    label: 'Rim',
    title: 'Rim width',
    unit: 'mm',
    digits: 2,
    families: [],
    card: true,
    colour: '#94a3b8',
    definition: 'Back face to field-side face, where the outer sensor sees that face.',
  },
  {
    key: 'equivalent_conicity',
    label: 'λe',
    title: 'Equivalent conicity (axle)',
    unit: '',
    digits: 3,
    families: ['EN', 'LM'],
    card: true,
    colour: '#facc15',
    limitMax: 'conicity_max',
    definition:
      "The axle's equivalent conicity at 3 mm amplitude (EN 15302, nonlinear method): from the rolling-radius difference Δr(y) of both measured wheels at their back-to-back distance on the site's rails (60E1 at 1:40, gauge 1435 mm by default), wheel radii taken equal. Above the fleet's limit (0.4 by default) the axle may hunt.",
  },
];

/**
 * The parameters a wheel card and the trend show for a wheel checked against `family`'s
 * limits: those the set checks and those no set checks (tread hollow, flange angle, rim
 * width), never those only the other set checks (Sd at 12 mm for EN wheels).
 * @param {string} family 'EN' or 'LM'
 */
export function shownParameters(family) {
  return PARAMETERS.filter((p) => p.card && (p.families.length === 0 || p.families.includes(family)));
}

/** Why the wheel diameter is not among the parameters (shown on the wheel page). */
export const DIAMETER_NOTE =
  "Wheel diameter is not measured: each sensor's single laser plane cuts the wheel in one cross-section, which fixes the profile but not the radius. A second laser plane per sensor at a known offset along the rail, calibrated into the same track frame and triggered so both planes cross the tread reference circle, would give the radius from the two sections' heights and the rail top.";

/**
 * The parameter with `key`, or a stand-in naming the key (a parameter this page predates).
 * @param {string} key
 */
export function parameterOf(key) {
  return (
    PARAMETERS.find((p) => p.key === key) ?? {
      key,
      label: key,
      title: key,
      unit: 'mm',
      digits: 2,
      definition: '',
      families: [],
      card: false,
      colour: '#d6dce4',
    }
  );
}

/** Dispositions an operator can record, with their labels. */
export const DISPOSITIONS = [
  ['re_profile', 'Re-profile'],
  ['monitor', 'Monitor'],
  ['false_alarm', 'False alarm'],
  ['measurement_doubtful', 'Measurement doubtful'],
  ['comment', 'Comment'],
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
  return value === null || value === undefined || !Number.isFinite(value) ? '–' : value.toFixed(digits);
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
