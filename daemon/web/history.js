// The history page: the jobs that ended (done, failed, cancelled), newest first, with their verdict
// and counts, and each done job's report.
import {$, el} from './ui.js';
import {counts_text} from './verdict.js';

let ctx = null;
const FINAL = new Set(['done', 'failed', 'cancelled']);

export function init(context) { ctx = context; }


// Called with every job.list the page makes (queue.js lists on each state change).
export function render(jobs) {
  const rows = jobs.filter((j) => FINAL.has(j.state)).reverse().map((j) => {
    const v = j.verdict;
    const report = j.state === 'done'
      ? el('a', {href: `/jobs/${j.id}/report${ctx.token ? `?token=${encodeURIComponent(ctx.token)}` : ''}`, target: '_blank', text: 'report'})
      : null;
    return el('tr', {'data-job': String(j.id), 'data-state': j.state},
      el('td', {}, el('a', {href: `#/job/${j.id}`, text: String(j.id)})),
      el('td', {text: j.name || ''}),
      el('td', {}, el('span', {class: `state state-${j.state}`, text: j.state})),
      el('td', {text: j.updated || ''}),
      el('td', {}, v ? el('span', {class: `verdict verdict-${v.verdict}`, text: v.verdict}) : el('span', {class: 'hint', text: j.state === 'done' ? 'no nominal' : ''})),
      el('td', {class: 'counts'}, v && v.coverage ? el('div', {text: v.coverage}) : null,
        v ? el('div', {text: `edges: ${counts_text(v.edge_points, ' · ')}`}) : null,
        v ? el('div', {text: `holes: ${counts_text(v.holes, ' · ')}`}) : null),
      el('td', {class: 'reason', text: j.reason || ''}),
      el('td', {}, report));
  });
  $('history-table').querySelector('tbody').replaceChildren(...rows);
  $('history-empty').hidden = rows.length > 0;
}

export function show() { ctx.list_jobs(); }
export function hide() {}
