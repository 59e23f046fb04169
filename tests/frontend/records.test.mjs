// Unit tests of reading the service's records (node --test).
import assert from 'node:assert/strict';
import { test } from 'node:test';

import { PARAMETERS, fmtDisposition } from '../../frontend/js/lib/format.js';
import {
  REVIEW_PAGE_ROWS,
  checkedFamily,
  familyOf,
  framesRemovedNote,
  hasAlarmOn,
  limitStem,
  limitsFor,
  marginOf,
  missingValueNames,
  missingValuesReason,
  passFilterQuery,
  passStatus,
  resultOf,
  reviewQuery,
  trendColumns,
  uncheckedLimits,
} from '../../frontend/js/lib/records.js';

const LIMITS = [
  { wheel_profile: 'EN', flange_height_min_mm: 27.5 },
  { wheel_profile: 'LM', flange_height_min_mm: 25 },
];

test('resultOf picks the method from the results list', () => {
  const wheel = {
    results: [
      { method: 'steger', qr_mm: 1 },
      { method: 'adaptive', qr_mm: 2 },
    ],
  };
  assert.equal(resultOf(wheel, 'adaptive').qr_mm, 2);
  assert.equal(resultOf(wheel, 'classic'), null);
  assert.equal(resultOf(undefined, 'adaptive'), null);
});

test('limitsFor maps the reference profile to its limit family', () => {
  assert.equal(limitsFor(LIMITS, 'S1002').wheel_profile, 'EN');
  assert.equal(limitsFor(LIMITS, 'LMA').wheel_profile, 'LM');
  assert.equal(limitsFor(LIMITS, null).wheel_profile, 'EN');
});

test('flange thickness limits apply at 10 mm for EN and at 12 mm for LM', () => {
  assert.equal(limitStem('flange_thickness_10_mm', 'EN'), 'flange_thickness');
  assert.equal(limitStem('flange_thickness_mm', 'EN'), null);
  assert.equal(limitStem('flange_thickness_mm', 'LM'), 'flange_thickness');
  const result = { alarms: [{ parameter: 'flange_thickness_mm' }] };
  assert.equal(hasAlarmOn(result, 'flange_thickness_10_mm', 'EN'), true);
  assert.equal(hasAlarmOn(result, 'flange_thickness_mm', 'EN'), false);
  assert.equal(hasAlarmOn(result, 'qr_mm', 'EN'), false);
});

test('passStatus prefers live job progress', () => {
  const pass = { state: 'closed', job: { state: 'running', progress: 0.25 } };
  assert.deepEqual(passStatus(pass), { state: 'running', progress: 0.25, running: true });
  assert.deepEqual(passStatus(pass, { state: 'done', progress: 1 }), { state: 'done', progress: 1, running: false });
  assert.equal(passStatus({ state: 'open', job: null }).running, true);
});

test('passFilterQuery turns dates into UTC day bounds with an exclusive end', () => {
  assert.deepEqual(passFilterQuery({ site: 'A', since: '2026-11-01', until: '2026-11-30', alarm: 'true' }), {
    site: 'A',
    started_from: '2026-11-01T00:00:00Z',
    started_to: '2026-12-01T00:00:00Z',
    alarm: 'true',
  });
  assert.deepEqual(passFilterQuery({ site: '', vehicle: '' }), {});
});

test('trendColumns aligns both methods on pass time, ascending', () => {
  const trend = {
    points: [
      { pass_id: 2, started_at: '2026-11-02T00:00:00Z', odometer_km: 1200, method: 'adaptive', flange_height_mm: 29 },
      { pass_id: 1, started_at: '2026-11-01T00:00:00Z', method: 'steger', flange_height_mm: 28.5 },
      { pass_id: 1, started_at: '2026-11-01T00:00:00Z', method: 'adaptive', flange_height_mm: 28.4 },
    ],
  };
  const { x, km, columns } = trendColumns(trend, ['adaptive', 'steger'], ['flange_height_mm']);
  assert.deepEqual(km, [null, 1200], 'the odometer per pass, null where the pass has none');
  assert.deepEqual(x, [Date.parse('2026-11-01T00:00:00Z') / 1000, Date.parse('2026-11-02T00:00:00Z') / 1000]);
  assert.deepEqual(columns['adaptive:flange_height_mm'], [28.4, 29]);
  assert.deepEqual(columns['steger:flange_height_mm'], [28.5, null]);
});

test('framesRemovedNote says when retention removed the frames, and nothing otherwise', () => {
  assert.equal(
    framesRemovedNote({ frames_removed_at: '2026-12-01T12:00:00Z' }),
    'camera frames removed by retention on 2026-12-01; results, centres, mask and σ map are kept',
  );
  assert.equal(framesRemovedNote({ frames_removed_at: null }), null);
  assert.equal(framesRemovedNote(undefined), null);
});

test('reviewQuery maps the worst-wheels form to the API, a page to its offset', () => {
  assert.deepEqual(reviewQuery({ site: 'bas', parameter: 'qr_mm', open: '1', history: '1', pass: '7', page: '3' }), {
    site: 'bas',
    parameter: 'qr_mm',
    open_only: 'true',
    latest_only: 'false',
    pass_id: '7',
    offset: String(2 * REVIEW_PAGE_ROWS),
    limit: String(REVIEW_PAGE_ROWS),
  });
  assert.deepEqual(reviewQuery({ page: 'x' }), { limit: String(REVIEW_PAGE_ROWS) });
  assert.deepEqual(reviewQuery({ unchecked: '1' }), { unchecked_only: 'true', limit: String(REVIEW_PAGE_ROWS) });
});

test('familyOf and marginOf read a wheel as the service files it', () => {
  assert.equal(familyOf({ reference_profile: 'LMA' }), 'LM');
  assert.equal(familyOf({ reference_profile: 's1002' }), 'EN');
  assert.equal(familyOf(null), 'EN');
  const wheel = { margins: [{ parameter: 'qr_mm', level: 'near' }] };
  assert.equal(marginOf(wheel, 'qr_mm').level, 'near');
  assert.equal(marginOf(wheel, 'flange_height_mm'), null);
});

test('checkedFamily names the limit set of the first result measured, none when neither was', () => {
  const failed = { method: 'adaptive', status: 'not_measured', reference_profile: null };
  assert.equal(checkedFamily([failed, { reference_profile: 'LMA' }]), 'LM');
  assert.equal(checkedFamily([{ reference_profile: 'S1002' }, { reference_profile: 'LMA' }]), 'EN');
  assert.equal(checkedFamily([failed, undefined]), null);
  assert.equal(checkedFamily([]), null);
});

test('missingValuesReason gives a measured result its missing values, not a failed one', () => {
  const why = 'Sd 10: too few profile points on the flank near z = 10.00 mm; qR: needs the flank at z = 10.00 mm';
  const partial = { status: 'measured', reason: why, flange_thickness_10_mm: null, qr_mm: null };
  assert.equal(missingValuesReason(partial), why);
  assert.equal(missingValuesReason({ status: 'measured', reason: null }), null);
  assert.equal(missingValuesReason({ status: 'not_measured', reason: 'no usable stripe' }), null);
  assert.equal(missingValuesReason(null), null);
});

test('missingValueNames reads the names of the values a reason is given for', () => {
  const sd =
    'Sd: too few profile points on the flank near z = 12.00 mm (a gap of 4.1 mm about it …, where gaps ≤ 2.5 mm are bridged)';
  assert.deepEqual(missingValueNames(sd), ['Sd']);
  assert.deepEqual(missingValueNames(`${sd}; Sd 10: too few; qR: needs the flank at z = 10.00 mm`), [
    'Sd',
    'Sd 10',
    'qR',
  ]);
  assert.deepEqual(missingValueNames('qR: too few profile points'), ['qR']);
  assert.deepEqual(missingValueNames(null), []);
  assert.deepEqual(missingValueNames('no usable stripe from the outer sensor'), []);
});

test('uncheckedLimits names the limited parameters a measured wheel has no value for', () => {
  const en = {
    wheel_profile: 'EN',
    flange_height_min_mm: 27.5,
    flange_height_max_mm: 36,
    flange_thickness_min_mm: 22,
    flange_thickness_max_mm: 33,
    qr_min_mm: 6.5,
  };
  const measured = { status: 'measured', flange_height_mm: 29, flange_thickness_mm: 30.3, qr_mm: 9.8 };
  const noSd10 = { ...measured, flange_thickness_10_mm: null, qr_mm: null };
  // EN checks Sd at 10 mm: without it Sd EN and qR are not checked; Sd (12 mm) has no EN limit
  assert.deepEqual(uncheckedLimits(noSd10, en, PARAMETERS), ['Sd EN', 'qR']);
  assert.deepEqual(uncheckedLimits({ ...measured, flange_thickness_10_mm: 31.4 }, en, PARAMETERS), []);
  // LM checks Sd at 12 mm, so a missing Sd 10 leaves nothing unchecked
  const lm = { ...en, wheel_profile: 'LM' };
  assert.deepEqual(uncheckedLimits({ ...measured, flange_thickness_10_mm: null }, lm, PARAMETERS), []);
  assert.deepEqual(uncheckedLimits({ status: 'not_measured' }, en, PARAMETERS), []);
  assert.deepEqual(uncheckedLimits(noSd10, null, PARAMETERS), []);
});

test('fmtDisposition says open without one and gives the reason of a false alarm', () => {
  assert.equal(fmtDisposition(null), 'open');
  assert.equal(fmtDisposition({ kind: 'false_alarm', comment: 'wet rail' }), 'false alarm: wet rail');
  assert.equal(fmtDisposition({ kind: 're_profile', comment: null }), 're-profile');
});
