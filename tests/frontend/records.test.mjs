// Unit tests of reading the service's records (node --test).
import assert from 'node:assert/strict';
import { test } from 'node:test';

import {
  framesRemovedNote, hasAlarmOn, limitStem, limitsFor, passFilterQuery, passStatus, resultOf,
  trendColumns,
} from '../../frontend/js/lib/records.js';

const LIMITS = [{ wheel_profile: 'EN', flange_height_min_mm: 27.5 }, { wheel_profile: 'LM', flange_height_min_mm: 25 }];

test('resultOf picks the method from the results list', () => {
  const wheel = { results: [{ method: 'steger', qr_mm: 1 }, { method: 'adaptive', qr_mm: 2 }] };
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
  assert.equal(limitStem('flange_thickness_en_mm', 'EN'), 'flange_thickness');
  assert.equal(limitStem('flange_thickness_mm', 'EN'), null);
  assert.equal(limitStem('flange_thickness_mm', 'LM'), 'flange_thickness');
  const result = { alarms: [{ parameter: 'flange_thickness_mm' }] };
  assert.equal(hasAlarmOn(result, 'flange_thickness_en_mm', 'EN'), true);
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
    site: 'A', started_from: '2026-11-01T00:00:00Z', started_to: '2026-12-01T00:00:00Z', alarm: 'true',
  });
  assert.deepEqual(passFilterQuery({ site: '', vehicle: '' }), {});
});

test('trendColumns aligns both methods on pass time, ascending', () => {
  const trend = { points: [
    { pass_id: 2, started_at: '2026-11-02T00:00:00Z', method: 'adaptive', flange_height_mm: 29 },
    { pass_id: 1, started_at: '2026-11-01T00:00:00Z', method: 'steger', flange_height_mm: 28.5 },
    { pass_id: 1, started_at: '2026-11-01T00:00:00Z', method: 'adaptive', flange_height_mm: 28.4 },
  ] };
  const { x, columns } = trendColumns(trend, ['adaptive', 'steger'], ['flange_height_mm']);
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
