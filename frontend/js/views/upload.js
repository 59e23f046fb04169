// @ts-check
/**
 * Upload: drag-and-drop (or pick) a wheelscan-pass/1 archive; shows upload progress, then the
 * measurement job's progress live, then a link to the pass.
 */
import { fmtBytes, fmtPercent } from '../lib/format.js';
import { buildHash } from '../lib/route.js';
import { html, nothing, render } from '../../vendor/lit-html-3.3.3.js';

/**
 * Render the upload page.
 * @param {HTMLElement} root
 * @param {any} state
 * @param {{upload: (file: File) => void}} handlers
 */
export function renderUpload(root, state, handlers) {
  const role = state.me?.role;
  if (role === 'viewer') {
    render(
      html`<section class="upload">
        <h1>Upload</h1>
        <p class="notice">Your token is a viewer token: uploading needs an operator token.</p>
      </section>`,
      root,
    );
    return;
  }
  const picker = () => /** @type {HTMLInputElement} */ (root.querySelector('.drop-zone input[type=file]'));
  const onPicked = (/** @type {Event} */ e) => {
    const input = /** @type {HTMLInputElement} */ (e.target);
    if (input.files?.[0]) handlers.upload(input.files[0]);
    input.value = ''; // the same file picked again is a new upload
  };
  const zone = (/** @type {Event} */ e) => /** @type {HTMLElement} */ (e.currentTarget);
  const onDrop = (/** @type {DragEvent} */ e) => {
    e.preventDefault();
    zone(e).classList.remove('over');
    const file = e.dataTransfer?.files?.[0];
    if (file) handlers.upload(file);
  };
  render(
    html`<section class="upload">
      <h1>Upload a pass</h1>
      <div
        class="drop-zone"
        tabindex="0"
        role="button"
        @click=${(/** @type {Event} */ e) => e.target !== picker() && picker().click()}
        @keydown=${(/** @type {KeyboardEvent} */ e) => (e.key === 'Enter' || e.key === ' ') && picker().click()}
        @dragover=${(/** @type {DragEvent} */ e) => {
          e.preventDefault();
          zone(e).classList.add('over');
        }}
        @dragleave=${(/** @type {DragEvent} */ e) => zone(e).classList.remove('over')}
        @drop=${onDrop}
      >
        <strong>Drop a pass archive here</strong><br />or press Enter to choose a .zip (wheelscan-pass/1)<input
          type="file"
          accept=".zip,application/zip"
          hidden
          @change=${onPicked}
        />
      </div>
      ${progress(state.upload)}
    </section>`,
    root,
  );
}

/**
 * @param {any} upload the upload state, or null
 * @returns {import('../../vendor/lit-html-3.3.3.js').TemplateResult|typeof nothing}
 */
function progress(upload) {
  if (!upload) return nothing;
  const job = upload.job;
  const done = job && (job.state === 'done' || job.state === 'succeeded' || job.state === 'failed');
  const measured = upload.pass_id != null;
  return html`<div class="upload-progress">
    <div>${upload.fileName} (${fmtBytes(upload.bytes)})</div>
    <label
      >upload
      <progress max="1" .value=${upload.uploadFraction ?? 0}></progress> ${fmtPercent(upload.uploadFraction)}</label
    >
    ${
      measured
        ? html`<label
            >measurement <progress max="1" .value=${job?.progress ?? 0}></progress>
            ${fmtPercent(job?.progress ?? 0)} · ${job?.wheels_done ?? 0} / ${job?.wheels_total ?? '?'} wheels ·
            <span class="status status-${job?.state ?? 'queued'}">${job?.state ?? 'queued'}</span></label
          >`
        : nothing
    }
    ${job?.error ? html`<p class="error">${job.error}</p>` : nothing}
    ${
      measured
        ? html`<p>
            <a href=${buildHash(['passes', upload.pass_id])} class=${done ? 'button' : nothing}
              >${done ? `Open pass #${upload.pass_id}` : `Pass #${upload.pass_id} (fills in as wheels finish)`}</a
            >
          </p>`
        : nothing
    }
  </div>`;
}
