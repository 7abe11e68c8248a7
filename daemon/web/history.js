// The history page: the jobs that ended (done, failed, cancelled), newest first, with their verdict
// and counts, and each done job's report.
import {$, el, show_message} from './ui.js';
import {describe_error} from './rpc.js';
import {counts_text} from './verdict.js';

let ctx = null;
const FINAL = new Set(['done', 'failed', 'cancelled']);

export function init(context) { ctx = context; }

// A job's report in a new tab, got over this page's authenticated connection (job.report) and shown
// from a blob: no token ever goes into a URL, where browser history, proxy logs and a printed
// report's footer would keep it (docs/dashboard.md). The tab opens at the click, before the answer,
// so that no pop-up blocker takes it for a window nobody asked for.
export async function open_report(id) {
  const tab = window.open('', '_blank');
  if (!tab) {
    show_message(`job ${id}'s report: the browser blocked its tab (allow pop-ups for the dashboard)`);
    return;
  }
  tab.opener = null;  // the report is no page of the dashboard's
  tab.document.title = `job ${id}: report…`;
  try {
    const {html} = await ctx.rpc.call('job.report', {job: id});
    tab.location.replace(URL.createObjectURL(new Blob([html], {type: 'text/html'})));
  } catch (e) {
    tab.close();
    show_message(`job ${id}'s report: ${describe_error(e)}`);
  }
}

// The link to a done job's report: a click opens it as above; the address (for a copy, or a station
// without tokens) names no token.
export function report_click(event, id) {
  event.preventDefault();
  open_report(id);
}


// Called with every job.list the page makes (queue.js lists on each state change).
export function render(jobs) {
  const rows = jobs.filter((j) => FINAL.has(j.state)).reverse().map((j) => {
    const v = j.verdict;
    const report = j.state === 'done'
      ? el('a', {href: `/jobs/${j.id}/report`, target: '_blank', text: 'report', onclick: (e) => report_click(e, j.id)})
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
