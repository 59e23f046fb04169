// @ts-check
/**
 * Upload: drag-and-drop (or pick) a wheelscan-pass/1 archive; shows upload progress, then the
 * measurement job's progress live, then a link to the pass.
 */
import { fmtBytes, fmtPercent } from '../lib/format.js';
import { buildHash } from '../lib/route.js';
import { h } from './dom.js';

/**
 * Render the upload page.
 * @param {HTMLElement} root
 * @param {any} state
 * @param {{upload: (file: File) => void}} handlers
 */
export function renderUpload(root, state, handlers) {
  const role = state.me?.role;
  if (role === 'viewer') {
    root.replaceChildren(
      h(
        'section',
        { class: 'upload' },
        h('h1', {}, 'Upload'),
        h('p', { class: 'notice' }, 'Your token is a viewer token: uploading needs an operator token.'),
      ),
    );
    return;
  }
  const picker = /** @type {HTMLInputElement} */ (
    h('input', {
      type: 'file',
      accept: '.zip,application/zip',
      hidden: true,
      onchange: () => picker.files?.[0] && handlers.upload(picker.files[0]),
    })
  );
  const zone = h(
    'div',
    {
      class: 'drop-zone',
      tabindex: 0,
      role: 'button',
      onclick: () => picker.click(),
      onkeydown: (/** @type {KeyboardEvent} */ e) => (e.key === 'Enter' || e.key === ' ') && picker.click(),
      ondragover: (/** @type {DragEvent} */ e) => {
        e.preventDefault();
        zone.classList.add('over');
      },
      ondragleave: () => zone.classList.remove('over'),
      ondrop: (/** @type {DragEvent} */ e) => {
        e.preventDefault();
        zone.classList.remove('over');
        const file = e.dataTransfer?.files?.[0];
        if (file) handlers.upload(file);
      },
    },
    h('strong', {}, 'Drop a pass archive here'),
    h('br'),
    'or press Enter to choose a .zip (wheelscan-pass/1)',
    picker,
  );
  root.replaceChildren(h('section', { class: 'upload' }, h('h1', {}, 'Upload a pass'), zone, progress(state.upload)));
}

/**
 * @param {any} upload the upload state, or null
 * @returns {HTMLElement|null}
 */
function progress(upload) {
  if (!upload) return null;
  const job = upload.job;
  const done = job && (job.state === 'done' || job.state === 'succeeded' || job.state === 'failed');
  return h(
    'div',
    { class: 'upload-progress' },
    h('div', {}, `${upload.fileName} (${fmtBytes(upload.bytes)})`),
    h(
      'label',
      {},
      'upload ',
      h('progress', { max: 1, value: upload.uploadFraction ?? 0 }),
      ` ${fmtPercent(upload.uploadFraction)}`,
    ),
    upload.pass_id != null
      ? h(
          'label',
          {},
          'measurement ',
          h('progress', { max: 1, value: job?.progress ?? 0 }),
          ` ${fmtPercent(job?.progress ?? 0)} · ${job?.wheels_done ?? 0} / ${job?.wheels_total ?? '?'} wheels · `,
          h('span', { class: `status status-${job?.state ?? 'queued'}` }, job?.state ?? 'queued'),
        )
      : null,
    job?.error ? h('p', { class: 'error' }, job.error) : null,
    upload.pass_id != null
      ? h(
          'p',
          {},
          h(
            'a',
            { href: buildHash(['passes', upload.pass_id]), class: done ? 'button' : null },
            done ? `Open pass #${upload.pass_id}` : `Pass #${upload.pass_id} (fills in as wheels finish)`,
          ),
        )
      : null,
  );
}
