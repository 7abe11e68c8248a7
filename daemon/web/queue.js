// The queue page: a model uploaded by drag and drop or a file input, a job submitted with its
// registration (a measure_plate file, corners pasted, or corners taken from the station) and its
// tolerances and nominal model, and the list of jobs with pause, resume and cancel.
import {$, el, act_button, attempt, show_message} from './ui.js';
import {describe_error} from './rpc.js';
import {upload_model} from './upload.js';

let ctx = null;
let listing = false;

export function init(context) {
  ctx = context;
  const drop = $('dropzone');
  drop.addEventListener('dragover', (e) => {
    e.preventDefault();
    drop.classList.add('over');
  });
  drop.addEventListener('dragleave', () => drop.classList.remove('over'));
  drop.addEventListener('drop', (e) => {
    e.preventDefault();
    drop.classList.remove('over');
    const file = e.dataTransfer && e.dataTransfer.files[0];
    if (file) upload(file, 'model-id', 'upload-status');
  });
  $('model-file').addEventListener('change', (e) => {
    if (e.target.files[0]) upload(e.target.files[0], 'model-id', 'upload-status');
  });
  $('nominal-file').addEventListener('change', (e) => {
    if (e.target.files[0]) upload(e.target.files[0], 'nominal-id', 'nominal-status');
  });
  $('registration-file').addEventListener('change', async (e) => {
    const file = e.target.files[0];
    if (!file) return;
    $('registration').value = await file.text();
    show_corners();
  });
  $('registration').addEventListener('input', show_corners);
  $('submit-form').addEventListener('submit', (e) => {
    e.preventDefault();
    submit();
  });
  ctx.rpc.on('job.state', () => list());
  ctx.rpc.on('job.progress', (p) => {
    const cell = document.querySelector(`#job-table tr[data-job="${p.job}"] .progress`);
    if (cell) cell.textContent = progress_text(p);
  });
  ctx.rpc.on_open(() => list());
  setInterval(() => { if (!document.hidden) list(); }, 5000);
}

async function upload(file, target, status_id) {
  const status = $(status_id);
  status.textContent = `${file.name}: hashing…`;
  try {
    const model = await upload_model(ctx.rpc, file, (received, size) => {
      status.textContent = `${file.name}: ${Math.round((100 * received) / Math.max(1, size))} % of ${(size / 1048576).toFixed(2)} MiB`;
    });
    $(target).value = model;
    status.textContent = `${file.name}: uploaded as ${model}`;
    status.dataset.done = 'true';
  } catch (e) {
    status.textContent = `${file.name}: not uploaded`;
    show_message(`upload of ${file.name}: ${describe_error(e)}`);
  }
}

// The registration as the form holds it: a job request's "registration" ({"corners": …} given,
// or {"measure_plate": …}), or the bare measure_plate object cmm-scan --plate-corners writes.
function registration() {
  const text = $('registration').value.trim();
  if (!text) throw new Error('the registration is empty: load a plate corners file, paste corners or take them at the station');
  let r;
  try {
    r = JSON.parse(text);
  } catch (e) {
    throw new Error(`the registration is not JSON: ${e.message}`);
  }
  if (r && (r.scan_corners || r.rough_machine)) r = {measure_plate: r};
  if (!r || !(r.corners || r.measure_plate)) throw new Error('the registration needs "corners" (given) or "measure_plate" (scan_corners and rough_machine)');
  return r;
}

function show_corners() {
  const box = $('corner-summary');
  try {
    const r = registration();
    if (r.corners) box.textContent = `given: ${r.corners.length} corners with scan and machine positions`;
    else box.textContent = `measure the plate: ${(r.measure_plate.scan_corners || []).length} scan corners, ${(r.measure_plate.rough_machine || []).length} rough machine positions`;
  } catch (e) {
    box.textContent = e.message;
  }
}

// Station: "take position as corner N" — N's rough machine position in the form's measure_plate.
export function take_corner(id, position) {
  let r;
  try {
    r = registration();
  } catch (e) {
    r = {measure_plate: {scan_corners: [], rough_machine: []}};
  }
  if (!r.measure_plate) r = {measure_plate: {scan_corners: r.corners.map((c) => ({id: c.id, scan: c.scan})), rough_machine: []}};
  const rough = r.measure_plate.rough_machine || (r.measure_plate.rough_machine = []);
  const entry = {id, machine: position.map((x) => Math.round(x * 1000) / 1000)};
  const at = rough.findIndex((c) => c.id === id);
  if (at >= 0) rough[at] = entry;
  else rough.push(entry);
  rough.sort((a, b) => a.id - b.id);
  $('registration').value = JSON.stringify(r, null, 1);
  show_corners();
}

function number(id) {
  const text = $(id).value.trim();
  if (text === '') return null;
  const x = Number(text);
  if (!Number.isFinite(x)) throw new Error(`${$(id).dataset.label || id}: not a number`);
  return x;
}

// The job request the form describes (docs/api.md, job.submit).
export function request() {
  const model = $('model-id').value.trim();
  if (!model) throw new Error('no model: drop a file on the upload area first');
  const r = {model, registration: registration()};
  const name = $('job-name').value.trim();
  if (name) r.name = name;
  const spacing = number('spacing');
  if (spacing !== null) r.spacing_mm = spacing;
  const scan_tolerance = number('scan-tolerance');
  if (scan_tolerance !== null) r.tolerance_mm = scan_tolerance;
  if ($('requalify').checked) r.requalify = true;
  const tip = $('job-tip').value.trim();
  if (tip && tip !== 'auto') r.tip = tip;
  if ($('allow-unqualified-tip').checked) r.allow_unqualified_tip = true;
  if ($('units-checked').checked) r.units_checked = true;
  const t = {};
  const edge = number('tol-edge');
  if (edge !== null) t.edge_profile_mm = edge;
  const lower = number('tol-hole-lower'), upper = number('tol-hole-upper');
  if ((lower === null) !== (upper === null)) throw new Error('hole diameter: give both the lower and the upper limit');
  if (lower !== null) t.hole_diameter_mm = [lower, upper];
  const position = number('tol-hole-position');
  if (position !== null) t.hole_position_mm = position;
  if (Object.keys(t).length) r.tolerances = t;
  const nominal = $('nominal-id').value.trim();
  if (nominal) r.nominal = {model: nominal, placement: $('nominal-placement').value};
  return r;
}

async function submit() {
  let params;
  try {
    params = request();
  } catch (e) {
    show_message(`submit: ${e.message}`);
    return;
  }
  const record = await attempt('job.submit', () => ctx.rpc.call('job.submit', params, 120));
  if (!record) return;
  show_message(`job ${record.id} queued`, 'note');
  list();
  location.hash = `#/job/${record.id}`;
}

function progress_text(p) {
  if (!p || !p.total) return p && p.phase ? p.phase : '';
  return `${p.phase} ${p.done}/${p.total}`;
}

async function job_action(method, id) {
  await attempt(`${method} ${id}`, () => ctx.rpc.call(method, {job: id}));
  list();
}

export async function list() {
  if (listing || !ctx.rpc.connected || ctx.rpc.role === 'none') return;
  listing = true;
  try {
    const jobs = (await ctx.rpc.call('job.list')).jobs;
    ctx.jobs_listed(jobs);
    const rows = jobs.slice().reverse().map((j) => {
      const running = ['queued', 'planning', 'registering', 'probing'].includes(j.state);
      const resumable = ['paused', 'interrupted'].includes(j.state);
      const final = ['done', 'failed', 'cancelled'].includes(j.state);
      return el('tr', {'data-job': String(j.id), 'data-state': j.state},
        el('td', {}, el('a', {href: `#/job/${j.id}`, text: String(j.id)})),
        el('td', {text: j.name || ''}),
        el('td', {}, el('span', {class: `state state-${j.state}`, text: j.state})),
        el('td', {class: 'progress', text: progress_text(j.progress)}),
        el('td', {}, j.verdict ? el('span', {class: `verdict verdict-${j.verdict.verdict}`, text: j.verdict.verdict}) : null),
        el('td', {class: 'reason', text: j.fault ? `${j.fault.kind}: ${j.reason}` : j.reason || ''}),
        el('td', {class: 'actions'},
           running ? act_button('Pause', () => job_action('job.pause', j.id), {'data-action': 'pause'}) : null,
           resumable ? act_button('Resume', () => job_action('job.resume', j.id), {'data-action': 'resume'}) : null,
           final ? null : act_button('Cancel', () => job_action('job.cancel', j.id), {'data-action': 'cancel'})));
    });
    $('job-table').querySelector('tbody').replaceChildren(...rows);
    $('job-count').textContent = `${jobs.length} job${jobs.length === 1 ? '' : 's'}`;
  } catch (e) {
    // The next notification or tick lists again; a lost connection shows in the header.
  } finally {
    listing = false;
  }
}

export function show() { list(); }
export function hide() {}

