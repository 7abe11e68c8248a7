// What every page of the dashboard shares: element lookup and building, number formats, the message
// line under the header, and the act buttons that only an operator may press.
import {describe_error} from './rpc.js';

export const $ = (id) => document.getElementById(id);

// el('td', {class: 'num', text: '3'}, child…): an element with attributes, text and children.
export function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (v === undefined || v === null || v === false) continue;
    if (k === 'text') e.textContent = v;
    else if (k === 'onclick') e.addEventListener('click', v);
    else e.setAttribute(k, v === true ? '' : v);
  }
  for (const c of children) if (c !== null && c !== undefined) e.append(c);
  return e;
}

export function fmt(x, digits = 3) {
  return x === null || x === undefined || Number.isNaN(x) ? '–' : Number(x).toFixed(digits);
}

export function fmt_vec(v, digits = 3) {
  return Array.isArray(v) ? v.map((x) => fmt(x, digits)).join(', ') : '–';
}

export function fmt_duration(s) {
  if (s === null || s === undefined || !Number.isFinite(s)) return '–';
  s = Math.max(0, Math.round(s));
  const m = Math.floor(s / 60);
  return m > 0 ? `${m} min ${s % 60} s` : `${s} s`;
}

let message_timer = null;
// The message line: errors stay until replaced or closed, notes go after a few seconds.
export function show_message(text, kind = 'error') {
  const box = $('message');
  $('message-text').textContent = text;
  box.className = kind;
  box.hidden = false;
  clearTimeout(message_timer);
  if (kind !== 'error') message_timer = setTimeout(() => { box.hidden = true; }, 6000);
}

export function clear_message() { $('message').hidden = true; }

let current_role = 'none';

// Operator-only controls carry the class "act": disabled for any other role.
export function apply_role(role) {
  current_role = role;
  document.body.dataset.role = role;
  for (const b of document.querySelectorAll('.act')) b.disabled = role !== 'operator';
  // A stop is always safe: everyone who can see the station may stop it, observers too.
  for (const b of document.querySelectorAll('.stop-any')) b.disabled = role === 'none';
}

export function role() { return current_role; }

// A button that calls `action` when pressed; an operator-only one starts disabled for other roles.
export function act_button(label, action, attrs = {}) {
  const b = el('button', {...attrs, class: `act ${attrs.class || ''}`.trim(), type: 'button', text: label});
  b.disabled = current_role !== 'operator';
  b.addEventListener('click', action);
  return b;
}

// Runs a call for an operator's action: a refusal or failure becomes the message line, never an
// uncaught error. Returns the call's result, or undefined when it failed.
export async function attempt(what, call) {
  try {
    return await call();
  } catch (e) {
    show_message(`${what}: ${describe_error(e)}`, 'error');
    return undefined;
  }
}
