// The station page: the machine's state as machine.status gives it (polled twice a second, and at
// once on a machine.state notification), Home, Reset and Qualify, jogging, and taking the ball's
// position as a rough plate corner for the submit form. STOP lives in the header, always in view.
import {$, fmt, fmt_vec, attempt, show_message} from './ui.js';
import {describe_error} from './rpc.js';

let ctx = null;
let last_status = null;
let polling = false;

const POLL_MS = 500;
const JOG_RESEND_MS = 150;

export function init(context) {
  ctx = context;
  ctx.rpc.on('machine.state', (p) => {
    if (last_status) render({...last_status, ...p});
    poll_once();
  });
  ctx.rpc.on_open(() => {
    if (!polling) poll();
  });
  $('home').addEventListener('click', () => machine_call('machine.home', 600));
  $('reset').addEventListener('click', () => machine_call('machine.reset', 60));
  $('qualify').addEventListener('click', async () => {
    const tip = $('qualify-tip').value;
    const q = await attempt('machine.qualify', () => ctx.rpc.call('machine.qualify', tip ? {tip} : {}, 900));
    poll_once();
    if (q) show_message(`tip ${q.tip} qualified: r ${fmt(q.ball_radius_mm, 4)} mm, sphere fit RMS ${fmt(q.residual_rms_mm, 4)} mm`, 'note');
  });
  $('stop').addEventListener('click', () => {
    stop_jog(false);
    attempt('STOP', () => ctx.rpc.call('machine.stop', {}, 10)).then((r) => {
      if (r) show_message('machine stopped', 'note');
    });
  });
  for (const b of document.querySelectorAll('[data-jog]')) set_up_jog_button(b);
  window.addEventListener('blur', () => stop_jog());  // a release the page never hears
  $('take-corner').addEventListener('click', () => {
    if (!last_status || !Array.isArray(last_status.position)) {
      show_message('no machine position yet');
      return;
    }
    const id = Number($('corner-id').value);
    ctx.take_corner(id, last_status.position);
    show_message(`plate corner ${id}: rough machine position ${fmt_vec(last_status.position, 2)} taken into the submit form`, 'note');
  });
}

async function machine_call(method, timeout_s) {
  const r = await attempt(method, () => ctx.rpc.call(method, {}, timeout_s));
  poll_once();
  return r;
}

function poll() {
  polling = true;
  const next = () => setTimeout(poll, POLL_MS);
  if (!ctx.rpc.connected || ctx.rpc.role === 'none') {
    next();
    return;
  }
  ctx.rpc.call('machine.status', {}, 10).then(render, () => {}).finally(next);
}

function poll_once() {
  if (ctx.rpc.connected && ctx.rpc.role !== 'none') ctx.rpc.call('machine.status', {}, 10).then(render, () => {});
}

// A hal fault's message names its kind already ("CommLost: cannot reach …"); another error's does not.
function fault_text(f) {
  return f.message && f.message.startsWith(`${f.kind}:`) ? f.message : `${f.kind}: ${f.message}`;
}

function yes_no(b) { return b === undefined || b === null ? '–' : b ? 'yes' : 'no'; }

function render(s) {
  last_status = s;
  const set = (id, text, cls) => {
    const e = $(id);
    e.textContent = text;
    if (cls !== undefined) e.className = cls;
  };
  // While the link is down nothing the machine reports is known (a machine.state notification
  // merged over the last status would otherwise keep showing what it said while up), least of all
  // its e-stop: unknown, never a green "released".
  const up = s.link === 'up';
  const why_down = up ? null : s.connect_error;
  set('m-lifecycle', s.lifecycle || '–');
  set('m-link', s.link || '–', up ? 'good' : 'bad');
  set('m-why-down', why_down ? `connect failed ${why_down.utc}: ${fault_text(why_down)}` : up ? '–' : 'connecting…',
      why_down ? 'bad' : '');
  $('m-why-down-row').hidden = up;
  set('m-homed', up ? yes_no(s.homed) : 'unknown', !up ? 'unknown' : s.homed ? 'good' : 'warn');
  set('m-moving', up ? yes_no(s.moving) : 'unknown', up ? '' : 'unknown');
  const estop = up && typeof s.estop === 'boolean' ? s.estop : null;
  set('m-estop', estop === null ? 'unknown' : estop ? 'PRESSED' : 'released', estop === null ? 'unknown' : estop ? 'bad' : 'good');
  set('m-aborted', up ? yes_no(s.aborted) : 'unknown', !up ? 'unknown' : s.aborted ? 'bad' : '');
  // The connect error is the link row's; the fault row repeats it only when it is another one.
  const fault = s.fault && !(why_down && s.fault.message === why_down.message) ? s.fault : null;
  set('m-fault', fault ? fault_text(fault) : up ? 'none' : '–', fault ? 'bad' : up ? 'good' : 'unknown');
  set('m-job', s.job === null || s.job === undefined ? 'none' : `job ${s.job}`);
  if (Array.isArray(s.position)) {
    set('m-x', fmt(s.position[0], 3));
    set('m-y', fmt(s.position[1], 3));
    set('m-z', fmt(s.position[2], 3));
  }
  set('m-jog', s.jog ? `jogging ${fmt_vec(s.jog.direction, 0)} at ${fmt(s.jog.speed_mm_s, 1)} mm/s`
                     : s.last_jog ? `last jog: ${s.last_jog.reason}` : '–');
  render_tip();
  // The header's summary, on every page.
  const summary = !up ? `machine ${s.link || 'unknown'}${s.fault ? `: ${s.fault.kind}` : ''}` : s.estop ? 'E-STOP' : s.fault ? `fault: ${s.fault.kind}`
                : s.job !== null && s.job !== undefined ? `running job ${s.job}` : s.moving ? 'moving' : s.homed ? 'idle' : 'not homed';
  const pill = $('hdr-machine');
  pill.textContent = summary;
  pill.className = `pill ${!up || s.estop || s.fault ? 'bad' : s.homed ? 'good' : 'warn'}`;
}

// Every tip as the machine reports it, and whether and when it was qualified: a job makes no touch
// with a tip that is not (unless its request allows it).
function render_tip() {
  const tips = last_status && Array.isArray(last_status.tips) ? last_status.tips : [];
  $('m-tip').textContent = (last_status && last_status.tip) || '–';
  const table = $('m-tips');
  const ids = tips.map((t) => t.id).join(',');
  // Rows are made when the tips change and updated in place on every poll: nothing under the
  // operator's pointer (or a test's reference) is replaced twice a second.
  if (table.dataset.ids !== ids) {
    table.replaceChildren();
    for (const t of tips) {
      const row = table.insertRow();
      row.appendChild(document.createElement('th'));
      row.insertCell().dataset.tip = t.id;
    }
    table.dataset.ids = ids;
  }
  for (const [i, t] of tips.entries()) {
    const row = table.rows[i];
    const heading = `${t.id}${t.active ? ' (active)' : ''}`;
    if (row.cells[0].textContent !== heading) row.cells[0].textContent = heading;
    const td = row.cells[1];
    const text = t.qualification
      ? `r ${fmt(t.ball_radius_mm, 4)} mm, qualified ${t.qualification.time_utc} (sphere fit RMS ${fmt(t.qualification.residual_rms_mm, 4)} mm)`
      : `not qualified: nominal r ${fmt(t.ball_radius_mm, 4)} mm`;
    if (td.textContent !== text) td.textContent = text;
    td.className = t.qualification ? 'good' : 'warn';
  }
  const select = $('qualify-tip');
  if (select.dataset.ids !== ids) {
    const chosen = select.value;
    select.replaceChildren(...tips.map((t) => new Option(t.id, t.id)));
    select.dataset.ids = ids;
    const active = tips.find((t) => t.active);
    select.value = ids.split(',').includes(chosen) ? chosen : active ? active.id : '';
  }
}

// --- jogging: a continuous jog is renewed every 150 ms while its button is held, and stopped on release.

let jog = null;  // {direction, timer}

function jog_params(direction) {
  const p = {direction, speed_mm_s: Number($('jog-speed').value)};
  const step = $('jog-step').value;
  if (step !== 'hold') p.distance_mm = Number(step);
  else p.hold_s = 0.4;  // renewed every 150 ms; a lost page stops it within 0.4 s
  return p;
}

function send_jog(direction) {
  return ctx.rpc.call('machine.jog', jog_params(direction), 10).catch((e) => {
    stop_jog(false);
    show_message(`machine.jog: ${describe_error(e)}`);
  });
}

function start_jog(direction) {
  if ($('jog-step').value !== 'hold') {
    send_jog(direction);
    return;
  }
  stop_jog(false);
  jog = {direction, timer: setInterval(() => send_jog(direction), JOG_RESEND_MS)};
  send_jog(direction);
}

function stop_jog(tell_machine = true) {
  if (!jog) return;
  clearInterval(jog.timer);
  jog = null;
  if (tell_machine) attempt('machine.jog_stop', () => ctx.rpc.call('machine.jog_stop', {}, 10)).then(poll_once);
}

function set_up_jog_button(b) {
  const axis = {x: 0, y: 1, z: 2}[b.dataset.jog[1]];
  const direction = [0, 0, 0];
  direction[axis] = b.dataset.jog[0] === '-' ? -1 : 1;
  b.addEventListener('pointerdown', (e) => {
    if (e.button !== 0 || b.disabled) return;
    b.setPointerCapture(e.pointerId);
    start_jog(direction);
  });
  for (const type of ['pointerup', 'pointercancel', 'lostpointercapture']) b.addEventListener(type, () => stop_jog());
  b.addEventListener('keydown', (e) => {
    if ((e.key === ' ' || e.key === 'Enter') && !e.repeat) start_jog(direction);
  });
  b.addEventListener('keyup', (e) => {
    if (e.key === ' ' || e.key === 'Enter') stop_jog();
  });
}

export function position() { return last_status ? last_status.position : null; }
export function show() { poll_once(); }
export function hide() { stop_jog(); }

// The station's rows as plain text, for the tests.
export function snapshot() { return last_status; }
