// A job's page: its state, progress and ETA (job.progress), the touches counting up as job.touch
// notifications arrive, the 3-D view (job_view3d.js), and once done the verdict, the deviation
// legend and histogram, and the link to the job's report. A click on a point shows its figures.
import {$, el, fmt, fmt_vec, fmt_duration, attempt, show_message} from './ui.js';
import {describe_error} from './rpc.js';
import {JobView3D} from './job_view3d.js';
import {css, relative_colour, METHOD_COLOURS, NOT_MEASURED, OUTSIDE, REASON_PALETTE, SCAN_SCALE_MM} from './colours.js';
import {draw_histogram} from './histogram.js';
import {counts_text, verdict_of} from './verdict.js';
import {report_click} from './history.js';

let ctx = null;
let view3d = null;
let current = null;  // {id, record, view, fetching, again, touches: touch id → centre (M) heard live}

const FINAL = new Set(['done', 'failed', 'cancelled']);

export function init(context) {
  ctx = context;
  $('report-link').addEventListener('click', (e) => report_click(e, current.id));
  ctx.rpc.on('job.state', (p) => {
    if (current && p.job === current.id) refresh();
  });
  ctx.rpc.on('job.progress', (p) => {
    if (current && p.job === current.id) show_progress(p);
  });
  ctx.rpc.on('job.touch', (p) => {
    if (!current || p.job !== current.id) return;
    // Kept for the next job.view too: a touch made while one is read may be in neither its journal
    // nor, had it been dropped, the view.
    current.touches.set(p.touch, p.centre);
    if (view3d && current.view && view3d.add_touch(p.touch, p.centre)) show_touch_count();
  });
  ctx.rpc.on_open(() => { if (current) refresh(); });
  $('job-pause').addEventListener('click', () => job_call('job.pause'));
  $('job-resume').addEventListener('click', () => job_call('job.resume'));
  $('job-cancel').addEventListener('click', () => job_call('job.cancel'));
  $('colour-by').addEventListener('change', (e) => {
    if (!view3d) return;
    view3d.set_colour_by(e.target.value);
    show_legend();
  });
}

async function job_call(method) {
  if (!current) return;
  const record = await attempt(method, () => ctx.rpc.call(method, {job: current.id}));
  if (record) show_record(record);
}

export function show(id) {
  if (!view3d) view3d = new JobView3D($('view3d'), show_pick);
  if (!current || current.id !== id) {
    current = {id, record: null, view: null, fetching: false, again: false, touches: new Map()};
    $('job-id').textContent = id;
    $('job-name').textContent = '';
    $('job-state').textContent = '…';
    $('touch-count').textContent = '0';
    $('point-info').replaceChildren(el('p', {class: 'hint', text: 'Click a point in the view for its figures.'}));
  }
  view3d.resize();
  refresh();
}

export function hide() {}

// job.get and job.view again (a state change, a reconnect); one fetch at a time, the last asked for.
async function refresh() {
  if (!current || !ctx.rpc.connected) return;
  if (current.fetching) {
    current.again = true;
    return;
  }
  const job = current;
  job.fetching = true;
  try {
    const record = await ctx.rpc.call('job.get', {job: job.id});
    if (job !== current) return;
    show_record(record);
    const view = await ctx.rpc.call('job.view', {job: job.id}, 120);
    if (job !== current) return;
    job.view = view;
    view3d.load(view, job.touches);
    show_touch_count();
    show_legend();
    show_result();
  } catch (e) {
    if (job === current) show_message(`job ${job.id}: ${describe_error(e)}`);
  } finally {
    job.fetching = false;
    if (job.again && job === current) {
      job.again = false;
      refresh();
    }
  }
}

function show_record(record) {
  if (!current || record.id !== current.id) return;
  current.record = record;
  $('job-name').textContent = record.name || '';
  const state = $('job-state');
  state.textContent = record.state;
  state.className = `state state-${record.state}`;
  $('job-reason').textContent = record.reason || '';
  $('job-fault').textContent = record.fault ? `${record.fault.kind}: ${record.fault.message}` : '';
  show_progress({...record.progress});
  const running = ['queued', 'planning', 'registering', 'probing'].includes(record.state);
  const resumable = ['paused', 'interrupted'].includes(record.state);
  $('job-pause').hidden = !running;
  $('job-resume').hidden = !resumable;
  $('job-cancel').hidden = FINAL.has(record.state);
  const link = $('report-link');
  link.hidden = record.state !== 'done';
  link.href = `/jobs/${record.id}/report`;
  show_verdict();
}

function show_progress(p) {
  $('job-phase').textContent = p.phase || '';
  const bar = $('job-progress');
  bar.max = Math.max(1, p.total || 0);
  bar.value = Math.min(p.done || 0, bar.max);
  $('job-progress-text').textContent = p.total ? `${p.done} / ${p.total}` : '';
  const running = current && current.record && !FINAL.has(current.record.state);
  $('job-eta').textContent = running && p.eta_s > 0 ? fmt_duration(p.eta_s) : '–';
}

function show_touch_count() {
  $('touch-count').textContent = String(view3d.touch_count());
  const v = current.view;
  const total = v ? v.edge_points.reduce((n, p) => n + p.touches.length, 0) + v.holes.reduce((n, h) => n + h.touches.length, 0) : 0;
  $('touch-total').textContent = total ? String(total) : '–';
}

function show_verdict() {
  const box = $('verdict');
  const record = current.record;
  const view = current.view;
  const inspection = view && view.result ? view.result.inspection : null;
  const verdict = verdict_of(record, inspection);
  if (!record || record.state !== 'done') {
    box.textContent = '–';
    box.className = 'verdict';
    $('verdict-counts').textContent = '';
    return;
  }
  if (!verdict) {
    box.textContent = 'no verdict';
    box.className = 'verdict verdict-none';
    $('verdict-counts').textContent = 'the job named no nominal model: its deviations are against the scan';
    return;
  }
  box.textContent = verdict.verdict;
  box.className = `verdict verdict-${verdict.verdict}`;
  // What the verdict covers first: an incomplete or a pass means little without it.
  $('verdict-counts').textContent = [verdict.coverage,
    `edge points: ${counts_text(verdict.edge_points)}; holes: ${counts_text(verdict.holes)}`].filter(Boolean).join('. ');
}

function swatch(colour) { return el('span', {class: 'swatch', style: `background: ${css(colour)}`}); }

// The legend of what the view shows now: the plan by method or reason while the job runs, the
// deviation scale once it is done.
function show_legend() {
  const legend = $('legend');
  const view = current.view;
  legend.replaceChildren();
  if (!view) return;
  const result = view.result;
  $('colour-by').disabled = !!result;
  if (result) {
    const inspected = !!result.inspection;
    legend.dataset.kind = 'deviation';
    const stops = [];
    for (let i = 0; i <= 20; ++i) stops.push(css(relative_colour(-1 + i / 10)));
    const ticks = inspected ? ['−T', '−½T', '0', '+½T', '+T'] : [-1, -0.5, 0, 0.5, 1].map((t) => (t === 0 ? '0' : `${t > 0 ? '+' : '−'}${fmt(Math.abs(t) * SCAN_SCALE_MM, 3)}`));
    legend.append(
      el('h3', {text: inspected ? 'Deviation from the nominal' : 'Deviation against the scan (mm)'}),
      el('div', {class: 'scale'},
         inspected ? el('span', {class: 'end', style: `background: ${css(OUTSIDE)}`, text: 'below −T'}) : null,
         el('span', {class: 'bar', style: `background: linear-gradient(to right, ${stops.join(', ')})`}),
         inspected ? el('span', {class: 'end', style: `background: ${css(OUTSIDE)}`, text: 'above +T'}) : null),
      el('div', {class: 'ticks'}, ...ticks.map((t) => el('span', {text: t}))),
      el('div', {class: 'item'}, swatch(NOT_MEASURED), el('span', {text: 'not measured'})),
      el('p', {class: 'hint', text: inspected
        ? `T: the point's tolerance limit on that side (edge profile ±${fmt(result.inspection.tolerances ? result.inspection.tolerances.edge_profile_mm : null, 3)} mm unless overridden)`
        : 'no nominal model: no tolerance and no verdict; the scale ends at ±0.1 mm'}));
    return;
  }
  legend.dataset.kind = view3d.colour_by;
  legend.append(el('h3', {text: view3d.colour_by === 'method' ? 'Planned points by method' : 'Not probeable, by reason'}));
  if (view3d.colour_by === 'method') {
    const count = {};
    for (const p of view.edge_points) count[p.method] = (count[p.method] || 0) + 1;
    const names = {two_touch: 'two touches in the window', faces: 'touches on both faces', none: 'not probeable'};
    for (const m of ['two_touch', 'faces', 'none'])
      if (count[m]) legend.append(el('div', {class: 'item'}, swatch(METHOD_COLOURS[m]), el('span', {text: `${names[m]} (${count[m]})`})));
  } else {
    const groups = view3d.legend_groups || [];
    if (!groups.length) legend.append(el('p', {class: 'hint', text: 'every point is probeable'}));
    groups.forEach(([g, n], i) => legend.append(
      el('div', {class: 'item'}, swatch(i < REASON_PALETTE.length ? REASON_PALETTE[i] : NOT_MEASURED), el('span', {text: `${g} (${n})`}))));
  }
  legend.append(el('div', {class: 'item'}, swatch([230, 85, 13]), el('span', {text: 'touch made'})),
                el('div', {class: 'item'}, swatch([31, 119, 180]), el('span', {text: 'bore rim (planned)'})));
}

function show_result() {
  show_verdict();
  const result = current.view && current.view.result;
  $('histogram-box').hidden = !result;
  if (result) draw_histogram($('histogram'), result);
}

function row(label, value) { return el('tr', {}, el('th', {text: label}), el('td', {text: value})); }

// The figures of a clicked point: its plan, and once measured its deviations and verdict.
function show_pick(item, what) {
  const box = $('point-info');
  const rows = [];
  if (what === 'touch') {
    rows.push(row('touch', String(item.touch)));
    if (item.kind) rows.push(row('measures', `${item.kind} ${item.id}`));
    box.replaceChildren(el('table', {class: 'figures'}, ...rows));
    return;
  }
  const p = item.planned, r = item.result;
  rows.push(row('edge point', String(p.id)), row('kind', p.kind), row('method', p.method),
            row('reference (S)', fmt_vec(p.position_S)));
  if (!p.probeable) rows.push(row('not probeable', p.reason || '–'));
  rows.push(row('touches', p.touches.join(', ') || '–'));
  if (r) {
    rows.push(row('status', r.status));
    if (r.reason) rows.push(row('note', r.reason));
    if (r.measured_S) rows.push(row('measured (S)', fmt_vec(r.measured_S.position)));
    rows.push(row('deviation vs scan', `${fmt(r.deviation_mm, 4)} mm`), row('σ', `${fmt(r.sigma_mm, 4)} mm`));
    if (r.inspection) {
      const n = r.inspection;
      rows.push(row('deviation vs nominal', `${fmt(n.deviation_mm, 4)} mm`), row('U', `${fmt(n.uncertainty_mm, 4)} mm`),
                row('tolerance', n.tolerance_mm ? `${fmt(n.tolerance_mm[0], 3)} … ${fmt(n.tolerance_mm[1], 3)} mm` : '–'),
                row('verdict', n.verdict || '–'));
      if (n.reason) rows.push(row('nominal note', n.reason));
    }
  }
  box.replaceChildren(el('table', {class: 'figures', 'data-point': String(p.id)}, ...rows));
}

// For the tests and a curious operator's console.
export function view() { return view3d; }
