// The dashboard's entry: takes the token from the address (#token=…, then out of the address bar
// and into this tab's sessionStorage) at load and whenever the address changes, connects to cmmd's
// WebSocket, shows the role granted, and routes #/station, #/queue, #/job/<id> and #/history to
// their pages. The station's token outlives a restart of cmmd, so a tab reconnects with its own.
import {Rpc} from './rpc.js';
import {$, apply_role, show_message, clear_message} from './ui.js';
import * as station from './station.js';
import * as queue from './queue.js';
import * as job_page from './job_page.js';
import * as history from './history.js';

// The token in the address, if any, moved into sessionStorage (so it is not left in the address
// bar, the history or a screenshot); else the one this tab has kept.
function take_token() {
  const m = /^#token=([^&]*)/.exec(location.hash);
  if (m) {
    let token = m[1];
    try {
      token = decodeURIComponent(token);
    } catch (e) {
      // A malformed escape: taken as typed, and cmmd says whether it is a token.
    }
    sessionStorage.setItem('cmmd.token', token);
    history_replace('#/station');
    return token;
  }
  return sessionStorage.getItem('cmmd.token');
}

function history_replace(hash) { window.history.replaceState(null, '', `${location.pathname}${location.search}${hash}`); }

const token = take_token();
const rpc = new Rpc(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/rpc`, token);
const ctx = {
  rpc,
  token,
  take_corner: (id, position) => queue.take_corner(id, position),
  jobs_listed: (jobs) => history.render(jobs),
  list_jobs: () => queue.list(),
};

const pages = {station, queue, job: job_page, history};
let shown = null;

function route() {
  // A pasted dashboard URL (#token=…) is a new token whenever it comes, not only at load.
  if (/^#token=/.test(location.hash)) {
    const pasted = take_token();
    if (pasted !== rpc.token) {
      ctx.token = pasted;
      rpc.set_token(pasted);
    }
  }
  const m = /^#\/(station|queue|history)$|^#\/job\/(\d+)$/.exec(location.hash);
  if (!m) history_replace('#/station');
  const name = !m ? 'station' : m[2] ? 'job' : m[1];
  for (const section of document.querySelectorAll('main > section')) section.hidden = section.id !== `page-${name}`;
  for (const a of document.querySelectorAll('#top nav a')) a.classList.toggle('here', a.dataset.page === name);
  if (shown && shown !== pages[name]) shown.hide();
  shown = pages[name];
  if (name === 'job') {
    $('nav-job').href = `#/job/${m[2]}`;
    $('nav-job').textContent = `Job ${m[2]}`;
    $('nav-job').hidden = false;
    job_page.show(Number(m[2]));
  } else {
    pages[name].show();
  }
}

rpc.on_open((role) => {
  const conn = $('conn');
  conn.textContent = 'connected';
  conn.className = 'pill good';
  const r = $('role');
  r.textContent = role === 'operator' ? 'operator' : role === 'observer' ? 'observer: watching only' : 'no access';
  r.className = `pill ${role === 'operator' ? 'good' : role === 'observer' ? 'warn' : 'bad'}`;
  apply_role(role);
  if (role === 'none') show_message(`cmmd refused this page's token (${rpc.auth_error || 'no token'}): open the dashboard URL cmmd logged, with its #token=`);
  else if (rpc.auth_error) show_message(`cmmd refused this page's token (${rpc.auth_error}): watching only; for the operator's role open the dashboard URL (cmmctl dashboard)`);
  else if ($('message').className === 'lost') clear_message();
});
rpc.on_close(() => {
  const conn = $('conn');
  conn.textContent = 'disconnected: reconnecting…';
  conn.className = 'pill bad';
  apply_role('none');
  show_message('the connection to cmmd was lost; reconnecting…', 'lost');
});

station.init(ctx);
queue.init(ctx);
job_page.init(ctx);
history.init(ctx);
apply_role('none');
$('message-close').addEventListener('click', clear_message);
window.addEventListener('hashchange', route);
route();

// For the browser test and a curious operator's console.
window.cmmd_dashboard = {rpc, view3d: () => job_page.view(), station};
