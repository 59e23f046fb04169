// Unit tests of the canvas drawing modules against a recording context (node --test).
import assert from 'node:assert/strict';
import { test } from 'node:test';

import { drawDifference } from '../../frontend/js/draw/difference.js';
import { drawFrame } from '../../frontend/js/draw/frame.js';
import { drawColourLegend } from '../../frontend/js/draw/legend.js';
import { drawProfile } from '../../frontend/js/draw/profile.js';
import { VIRIDIS } from '../../frontend/js/lib/colormap.js';
import { fitViewport, zoomAt } from '../../frontend/js/lib/viewport.js';
import { recordingContext } from './recording-context.mjs';

const SHOW_ALL = { image: true, mask: true, sigma: true, adaptive: true, steger: true };

test('drawFrame culls centres outside the view and draws each method in one fill', () => {
  const { ctx, calls } = recordingContext();
  const x = Array.from({ length: 5000 }, (_, i) => (i % 100) * 16);
  const y = Array.from({ length: 5000 }, (_, i) => Math.floor(i / 100) * 24);
  const full = fitViewport(1600, 1200, 800, 600);
  const options = { viewport: full, widthPx: 800, heightPx: 600, pixelRatio: 1, show: SHOW_ALL };
  const layers = {
    image: null,
    mask: null,
    sigma: null,
    highlight: null,
    centres: [
      { method: 'adaptive', x, y },
      { method: 'steger', x, y },
    ],
  };
  assert.equal(drawFrame(ctx, layers, options), 10000);
  assert.equal(calls.filter(([name]) => name === 'fill').length, 2);
  const zoomed = zoomAt(full, 8, 0, 0);
  const drawn = drawFrame(ctx, layers, { ...options, viewport: zoomed });
  assert.ok(drawn > 0 && drawn < 10000 / 32, `only the zoomed-in corner is drawn, got ${drawn}`);
});

/** A 100×100 px frame fitted to a 100×100 px canvas with Steger's centres hidden. */
const stegerHiddenOptions = () => ({
  viewport: fitViewport(100, 100, 100, 100),
  widthPx: 100,
  heightPx: 100,
  pixelRatio: 1,
  show: { ...SHOW_ALL, steger: false },
});
const NO_RASTER_LAYERS = { image: null, mask: null, sigma: null, highlight: null };

test('drawFrame skips hidden methods', () => {
  const { ctx } = recordingContext();
  const options = stegerHiddenOptions();
  const layers = {
    ...NO_RASTER_LAYERS,
    centres: [
      { method: 'adaptive', x: [1, 2], y: [1, 2] },
      { method: 'steger', x: [3], y: [3] },
    ],
  };
  assert.equal(drawFrame(ctx, layers, options), 2);
});

test('drawFrame marks rejected candidates of shown methods only, apart from the centres', () => {
  const { ctx, calls } = recordingContext();
  const options = stegerHiddenOptions();
  const layers = {
    ...NO_RASTER_LAYERS,
    centres: [{ method: 'adaptive', x: [1, 2], y: [1, 2] }],
    rejected: [
      { method: 'adaptive', x: [5, 6, 7], y: [5, 6, 7] },
      { method: 'steger', x: [8], y: [8] },
    ],
  };
  assert.equal(drawFrame(ctx, layers, options), 2, 'rejected points are not counted as centres');
  const styles = calls.filter(([name]) => name === 'set:fillStyle').map(([, [v]]) => v);
  assert.equal(
    styles.filter((v) => v === '#f43f5e').length,
    1,
    'one fill for adaptive rejects, none for hidden Steger',
  );
  const rects = calls.filter(([name]) => name === 'rect').length;
  assert.equal(rects, 5);
});

test('drawProfile strokes the reference in its order, never sorted by x', () => {
  const { ctx, calls } = recordingContext();
  // back face going up, then over the flange and down its flank: x goes 0 → 10 → 5 → 30
  const reference = { name: 'LMA', x_mm: [0, 10, 5, 30], z_mm: [0, 28, 20, 0] };
  drawProfile(
    ctx,
    { curves: [], reference, constructions: null, values: {} },
    { widthPx: 400, heightPx: 300, pixelRatio: 1 },
  );
  const xs = calls.filter(([name]) => name === 'moveTo' || name === 'lineTo').map(([, [px]]) => px);
  const run = xs.slice(-4);
  assert.ok(run[0] < run[2] && run[2] < run[1] && run[1] < run[3], `order kept: ${run}`);
});

test('drawProfile draws a measured profile as its points: no line joins interleaved frames', () => {
  const { ctx, calls } = recordingContext();
  // two frames of one tread, 0.4 mm apart, interleaved along x, and a stray point below
  const x = [60, 60.1, 60.2, 60.3, 61, 130];
  const z = [0, 0.4, 0, 0.4, 0, -20];
  const curve = { method: 'adaptive', x_mm: [...x, null], z_mm: [...z, null] };
  drawProfile(
    ctx,
    { curves: [curve], reference: null, constructions: null, values: {} },
    { widthPx: 400, heightPx: 300, pixelRatio: 1 },
  );
  const rects = calls.filter(([name]) => name === 'rect').map(([, args]) => args);
  // the clip rectangle, then one square per finite point
  assert.equal(rects.length, 1 + x.length);
  const afterClip = calls.slice(calls.findIndex(([name]) => name === 'clip'));
  assert.equal(afterClip.filter(([name]) => name === 'lineTo').length, 0, 'nothing is stroked between the points');
});

test('drawProfile strokes the outline the service gives over the points, broken at null', () => {
  const { ctx, calls } = recordingContext();
  const curve = {
    method: 'adaptive',
    x_mm: [60, 60.1, 60.2, 70],
    z_mm: [0, 0.4, 0, 0],
    outline_x_mm: [60, 60.2, null, 70, 71],
    outline_z_mm: [0.2, 0.2, null, 0, 0],
  };
  drawProfile(
    ctx,
    { curves: [curve], reference: null, constructions: null, values: {} },
    { widthPx: 400, heightPx: 300, pixelRatio: 1 },
  );
  const afterClip = calls.slice(calls.findIndex(([name]) => name === 'clip'));
  const ops = afterClip.filter(([n]) => n === 'moveTo' || n === 'lineTo').map(([n]) => n);
  assert.deepEqual(ops, ['moveTo', 'lineTo', 'moveTo', 'lineTo']);
});

test('drawProfile labels the constructions with the service values', () => {
  const { ctx, calls } = recordingContext();
  drawProfile(
    ctx,
    {
      curves: [{ method: 'adaptive', x_mm: [0, 20, 70], z_mm: [0, 28, 0] }],
      reference: { name: 'S1002', x_mm: [0, 70], z_mm: [0, 0] },
      constructions: {
        sh: { flange_top: [20, 28], tread_point: [70, 0] },
        sd: { back_face_x_mm: 0, flank_point: [27, 12] },
        qr: { upper_point: [25, 26], lower_point: [28, 10] },
      },
      values: { sh: 28.0, sd: 27.0, qr: 3.0 },
    },
    { widthPx: 460, heightPx: 300, pixelRatio: 1 },
  );
  const texts = calls.filter(([n]) => n === 'fillText').map(([, [t]]) => t);
  for (const label of ['Sh 28.00 mm', 'Sd 27.00 mm', 'qR 3.00 mm', 'reference S1002']) {
    assert.ok(texts.includes(label), `${label} drawn; got ${texts.join(' | ')}`);
  }
});

test('drawProfile returns null when there is nothing to draw', () => {
  const { ctx } = recordingContext();
  assert.equal(
    drawProfile(
      ctx,
      { curves: [], reference: null, constructions: null, values: {} },
      { widthPx: 10, heightPx: 10, pixelRatio: 1 },
    ),
    null,
  );
});

test('drawColourLegend writes its unit label and round ticks', () => {
  const { ctx, calls } = recordingContext();
  drawColourLegend(
    ctx,
    { lut: VIRIDIS, min: 2.89, max: 12.12, label: 'σ (px)' },
    { widthPx: 300, heightPx: 44, pixelRatio: 1 },
  );
  const texts = calls.filter(([n]) => n === 'fillText').map(([, [t]]) => t);
  assert.deepEqual(texts, ['σ (px)', '4', '6', '8', '10', '12']);
});

test('drawDifference reports false for an empty comparison', () => {
  const { ctx } = recordingContext();
  const empty = {
    alongPx: new Float64Array(0),
    diffPx: new Float64Array(0),
    x: new Float64Array(0),
    y: new Float64Array(0),
    unmatched: 3,
    meanPx: NaN,
    rmsPx: NaN,
    maxAbsPx: NaN,
  };
  assert.equal(drawDifference(ctx, empty, { widthPx: 300, heightPx: 150, pixelRatio: 1 }), false);
});
