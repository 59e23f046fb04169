// @ts-check
/**
 * The interactive frame canvas of the wheel page: pan (drag, arrows), zoom (wheel, +/−,
 * double-click), fit, hover read-out of the nearest centre (x, y, σ, strength) and the σ
 * colour legend. Drawing itself is draw/frame.js; each redraw is timed as a
 * `performance.measure('frame-draw')` entry.
 */
import { drawFrame } from '../draw/frame.js';
import { drawColourLegend } from '../draw/legend.js';
import { VIRIDIS } from '../lib/colormap.js';
import { fmtNumber } from '../lib/format.js';
import { buildPointIndex, nearestPoint } from '../lib/point-index.js';
import { boundsOf } from '../lib/ticks.js';
import { fitRegion, fitViewport, panBy, screenToImage, zoomAt } from '../lib/viewport.js';
import { fitCanvas, h } from './dom.js';

/** Hover picks the nearest centre within this many screen px. */
const HOVER_RADIUS_CSS_PX = 8;
/** Margin around the stripe when the view fits it, image px. */
const STRIPE_MARGIN_PX = 60;
/** Default opacity of the σ map: the stripe stays visible under it. */
const SIGMA_ALPHA = 0.55;

/**
 * @typedef {object} FrameData
 * @property {ImageBitmap} image
 * @property {ImageBitmap|null} mask
 * @property {ImageBitmap|null} sigma
 * @property {{sigma_min_px: number, sigma_max_px: number, scales_px?: number[]}|null} sigmaScale
 * @property {Record<string, any>} centres method → columnar centres (or {error})
 */

export class FrameView {
  /**
   * @param {HTMLElement} root element to fill
   */
  constructor(root) {
    this.canvas = /** @type {HTMLCanvasElement} */ (
      h('canvas', { class: 'frame-canvas', tabindex: 0, 'aria-label': 'camera frame' })
    );
    this.readout = h('div', { class: 'readout mono' }, 'hover a centre point');
    this.legend = /** @type {HTMLCanvasElement} */ (h('canvas', { class: 'legend' }));
    /** opacity of the σ map over the frame, 0..1 (at 85 % it hid the stripe) */
    this.sigmaAlpha = SIGMA_ALPHA;
    this.opacity = /** @type {HTMLInputElement} */ (
      h('input', {
        type: 'range',
        min: 10,
        max: 100,
        step: 5,
        value: String(SIGMA_ALPHA * 100),
        class: 'sigma-opacity',
        'aria-label': 'σ map opacity',
        title: 'σ map opacity',
        oninput: () => {
          this.sigmaAlpha = Number(this.opacity.value) / 100;
          this.request();
        },
      })
    );
    this.opacityLabel = h('label', { class: 'opacity', hidden: true }, 'σ opacity ', this.opacity);
    /** what each point colour on the frame is */
    this.key = h('div', { class: 'overlay-key' });
    root.replaceChildren(
      h('div', { class: 'frame-wrap' }, this.canvas),
      h('div', { class: 'frame-foot' }, this.readout, this.key, this.opacityLabel, this.legend),
    );
    /** @type {FrameData|null} */
    this.data = null;
    this.show = { image: true, mask: false, sigma: false, adaptive: true, steger: true };
    /** @type {import('../lib/viewport.js').Viewport|null} */
    this.viewport = null;
    /** @type {{x: number, y: number}|null} */
    this.highlight = null;
    /** @type {Record<string, import('../lib/point-index.js').PointIndex>} */
    this.indexes = {};
    this.pending = false;
    /** @type {'stripe'|'frame'} what the next fit shows; a new frame opens on its stripe */
    this.fitTo = 'stripe';
    this.lastDrawMs = 0;
    this.pointsDrawn = 0;
    this.bindEvents();
    this.resizeObserver = new ResizeObserver(() => this.request());
    this.resizeObserver.observe(this.canvas);
  }

  /**
   * Show a frame's layers: a new frame is fitted to its stripe, more layers of the same
   * frame keep the view.
   * @param {FrameData} data
   */
  setData(data) {
    // a new frame opens on its stripe; layers added to the same frame keep the view
    const newFrame = !this.data || this.data.image !== data.image;
    this.data = data;
    this.indexes = {};
    for (const [method, c] of Object.entries(data.centres)) {
      if (c && Array.isArray(c.x)) this.indexes[method] = buildPointIndex(c.x, c.y, 8);
    }
    if (newFrame) {
      this.viewport = null;
      this.fitTo = 'stripe';
    }
    if (!this.highlight) this.readout.textContent = 'hover a centre point';
    this.drawLegend();
    this.renderKey();
    this.request();
  }

  /** @param {Partial<FrameView['show']>} show */
  setShow(show) {
    this.show = { ...this.show, ...show };
    this.legend.hidden = !this.show.sigma;
    this.drawLegend();
    this.renderKey();
    this.request();
  }

  /** The key to the point colours shown: each method's centres and the candidates they rejected. */
  renderKey() {
    const centres = Object.entries(this.data?.centres ?? {}).filter(
      ([method, c]) => c && Array.isArray(c.x) && this.show[/** @type {'adaptive'|'steger'} */ (method)],
    );
    const rejected = centres.reduce((n, [, c]) => n + (c.rejected_x?.length ?? 0), 0);
    // swatches coloured by class (the page's content policy refuses inline styles)
    const entry = (/** @type {string} */ kind, /** @type {string} */ text) =>
      h('span', { class: 'key', dataset: { kind } }, h('i', { class: kind }), text);
    this.key.replaceChildren(
      ...centres.map(([method, c]) => entry(method, `${method} centres (${c.x.length})`)),
      ...(rejected
        ? [
            entry(
              'rejected',
              `rejected candidates (${rejected}): an edge or a spot, not a line, or a chain too short, apart or wide`,
            ),
          ]
        : []),
    );
  }

  /** Forget the frame (another wheel is loading): an empty canvas, no read-out. */
  clear() {
    this.data = null;
    this.indexes = {};
    this.highlight = null;
    this.viewport = null;
    const { ctx } = fitCanvas(this.canvas);
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.clearRect(0, 0, this.canvas.width, this.canvas.height);
    this.canvas.dataset.pointsDrawn = '0';
    this.readout.textContent = 'loading…';
  }

  /** Fit the view, alternating between the stripe (all centres) and the whole frame. */
  fit() {
    this.fitTo = this.fitTo === 'stripe' ? 'frame' : 'stripe';
    this.viewport = null;
    this.request();
  }

  /**
   * The fitted view of the current frame: its stripe with a margin, or the whole frame.
   * @param {number} widthPx
   * @param {number} heightPx
   * @returns {import('../lib/viewport.js').Viewport}
   */
  fittedViewport(widthPx, heightPx) {
    const { image, centres } = /** @type {FrameData} */ (this.data);
    const sets = Object.values(centres).filter((c) => c && Array.isArray(c.x));
    const xs = boundsOf(sets.map((c) => c.x));
    const ys = boundsOf(sets.map((c) => c.y));
    if (this.fitTo === 'frame' || !xs || !ys) return fitViewport(image.width, image.height, widthPx, heightPx);
    return fitRegion(
      xs[0] - STRIPE_MARGIN_PX,
      ys[0] - STRIPE_MARGIN_PX,
      xs[1] + STRIPE_MARGIN_PX,
      ys[1] + STRIPE_MARGIN_PX,
      widthPx,
      heightPx,
    );
  }

  /**
   * Centre the view on an image point, zoomed in to at least `minScale` screen px per
   * image px, and ring it.
   * @param {number} x image x [px]
   * @param {number} y image y [px]
   * @param {number} [minScale]
   */
  centreOn(x, y, minScale = 4) {
    if (!this.data) return;
    const w = this.canvas.clientWidth;
    const hgt = this.canvas.clientHeight;
    const scale = Math.max(this.viewport?.scale ?? 1, minScale);
    this.viewport = { scale, offsetX: w / 2 - x * scale, offsetY: hgt / 2 - y * scale };
    this.highlight = { x, y };
    this.request();
  }

  /** @param {number} factor */
  zoom(factor) {
    if (!this.viewport) return;
    this.viewport = zoomAt(this.viewport, factor, this.canvas.clientWidth / 2, this.canvas.clientHeight / 2);
    this.request();
  }

  /** @param {number} dx @param {number} dy */
  pan(dx, dy) {
    if (!this.viewport) return;
    this.viewport = panBy(this.viewport, dx, dy);
    this.request();
  }

  destroy() {
    this.resizeObserver.disconnect();
  }

  /** Schedule one redraw on the next animation frame (coalesces bursts of events). */
  request() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.draw();
    });
  }

  draw() {
    if (!this.data) return;
    const started = performance.now();
    const { ctx, widthPx, heightPx, pixelRatio } = fitCanvas(this.canvas);
    if (!this.viewport) this.viewport = this.fittedViewport(widthPx, heightPx);
    const centres = Object.entries(this.data.centres)
      .filter(([, c]) => c && Array.isArray(c.x))
      .map(([method, c]) => ({ method, x: c.x, y: c.y }));
    const rejected = Object.entries(this.data.centres)
      .filter(([, c]) => c && Array.isArray(c.rejected_x) && c.rejected_x.length)
      .map(([method, c]) => ({ method, x: c.rejected_x, y: c.rejected_y }));
    this.pointsDrawn = drawFrame(
      ctx,
      { ...this.data, centres, rejected, highlight: this.highlight },
      {
        viewport: this.viewport,
        widthPx,
        heightPx,
        pixelRatio,
        show: this.show,
        sigmaAlpha: this.sigmaAlpha,
      },
    );
    const ended = performance.now();
    this.lastDrawMs = ended - started;
    performance.measure('frame-draw', { start: started, end: ended });
    this.canvas.dataset.pointsDrawn = String(this.pointsDrawn);
    // the viewport, for tools that point at image positions (tests, screen readers' helpers)
    this.canvas.dataset.viewport = JSON.stringify(this.viewport);
  }

  drawLegend() {
    const scale = this.data?.sigmaScale;
    this.legend.hidden = !this.show.sigma || !scale;
    this.opacityLabel.hidden = this.legend.hidden;
    if (this.legend.hidden || !scale) return;
    const { ctx, widthPx, heightPx, pixelRatio } = fitCanvas(this.legend);
    drawColourLegend(
      ctx,
      {
        lut: VIRIDIS,
        min: scale.sigma_min_px,
        max: scale.sigma_max_px,
        marks: scale.scales_px,
        label: 'σ map, chosen scale σ (px); ticks: σ1 σ2 σ3',
      },
      { widthPx, heightPx, pixelRatio },
    );
  }

  bindEvents() {
    const c = this.canvas;
    let drag = /** @type {{x: number, y: number}|null} */ (null);
    c.addEventListener(
      'wheel',
      (e) => {
        e.preventDefault();
        if (!this.viewport) return;
        this.viewport = zoomAt(this.viewport, Math.exp(-e.deltaY / 400), e.offsetX, e.offsetY);
        this.request();
      },
      { passive: false },
    );
    c.addEventListener('dblclick', (e) => {
      if (!this.viewport) return;
      this.viewport = zoomAt(this.viewport, e.shiftKey ? 0.5 : 2, e.offsetX, e.offsetY);
      this.request();
    });
    c.addEventListener('pointerdown', (e) => {
      drag = { x: e.clientX, y: e.clientY };
      c.setPointerCapture(e.pointerId);
    });
    c.addEventListener('pointerup', () => {
      drag = null;
    });
    c.addEventListener('pointermove', (e) => {
      if (drag) {
        this.pan(e.clientX - drag.x, e.clientY - drag.y);
        drag = { x: e.clientX, y: e.clientY };
        return;
      }
      this.hover(e.offsetX, e.offsetY);
    });
    c.addEventListener('pointerleave', () => {
      this.highlight = null;
      this.request();
    });
  }

  /**
   * Show the nearest visible centre under a screen point in the read-out.
   * @param {number} sx
   * @param {number} sy
   */
  hover(sx, sy) {
    if (!this.viewport || !this.data) return;
    const [ix, iy] = screenToImage(this.viewport, sx, sy);
    const radiusPx = HOVER_RADIUS_CSS_PX / this.viewport.scale;
    let best = /** @type {{method: string, i: number, d2: number}|null} */ (null);
    for (const [method, index] of Object.entries(this.indexes)) {
      if (!this.show[/** @type {'adaptive'|'steger'} */ (method)]) continue;
      const i = nearestPoint(index, ix, iy, radiusPx);
      if (i < 0) continue;
      const d2 = (index.x[i] - ix) ** 2 + (index.y[i] - iy) ** 2;
      if (!best || d2 < best.d2) best = { method, i, d2 };
    }
    if (!best) {
      this.readout.textContent = `pixel x ${fmtNumber(ix, 1)}, y ${fmtNumber(iy, 1)} · no centre within ${HOVER_RADIUS_CSS_PX} screen px`;
      if (this.highlight) {
        this.highlight = null;
        this.request();
      }
      return;
    }
    const c = this.data.centres[best.method];
    this.highlight = { x: c.x[best.i], y: c.y[best.i] };
    this.readout.replaceChildren(
      h('span', { class: `method-tag ${best.method}` }, best.method),
      ` x ${fmtNumber(c.x[best.i], 2)} px · y ${fmtNumber(c.y[best.i], 2)} px · σ ${fmtNumber(c.sigma?.[best.i], 2)} px · strength ${fmtNumber(c.strength?.[best.i], 2)}`,
    );
    this.readout.dataset.method = best.method;
    this.request();
  }
}
