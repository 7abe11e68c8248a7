// The dashboard's line to cmmd: JSON-RPC 2.0 over the WebSocket at /rpc (docs/api.md), one message
// per text frame. Reconnects by itself; on every (re)connect it authenticates with the page's token
// and subscribes to the job and machine topics, then tells its listeners the role it was granted.

export class RpcError extends Error {
  constructor(error) {
    super(error.message);
    this.code = error.code;
    this.data = error.data;
  }
}

// What a refused or failed call says to an operator: the message with the code's meaning.
export function describe_error(e) {
  if (!(e instanceof RpcError)) return String(e && e.message ? e.message : e);
  if (e.code === -32000) return `refused: this needs the ${e.data && e.data.needed ? e.data.needed : 'operator'} role (${e.message})`;
  return `${e.message} (${e.code})`;
}

export class Rpc {
  constructor(url, token) {
    this.url = url;
    this.token = token;
    this.next_id = 1;
    this.pending = new Map();  // id → {resolve, reject, timer}
    this.handlers = new Map(); // notification method → [fn]
    this.listeners = {open: [], close: []};
    this.role = 'none';
    this.connected = false;
    this.retry_ms = 500;
    this.open();
  }

  on(method, fn) {
    if (!this.handlers.has(method)) this.handlers.set(method, []);
    this.handlers.get(method).push(fn);
  }

  on_open(fn) { this.listeners.open.push(fn); }

  // A token pasted into the address bar: connects again with it (a token can raise a connection's
  // role, never lower it, so a new connection is the one way to take exactly what it grants).
  set_token(token) {
    this.token = token;
    this.auth_error = undefined;
    this.retry_ms = 0;
    if (this.ws && this.ws.readyState <= WebSocket.OPEN) this.ws.close();
  }
  on_close(fn) { this.listeners.close.push(fn); }

  open() {
    const ws = new WebSocket(this.url);
    this.ws = ws;
    ws.onopen = () => this.greet();
    ws.onmessage = (event) => this.receive(event.data);
    ws.onclose = () => {
      const was = this.connected;
      this.connected = false;
      this.role = 'none';
      for (const [, p] of this.pending) {
        clearTimeout(p.timer);
        p.reject(new RpcError({code: -32099, message: 'connection to cmmd lost'}));
      }
      this.pending.clear();
      if (was) for (const fn of this.listeners.close) fn();
      // Back off up to 5 s: a restarting cmmd is back within seconds.
      setTimeout(() => this.open(), this.retry_ms);
      this.retry_ms = Math.min(5000, Math.max(500, this.retry_ms * 2));
    };
  }

  async greet() {
    this.auth_error = undefined;
    try {
      if (this.token) {
        try {
          this.role = (await this.send('server.auth', {token: this.token})).role;
        } catch (e) {
          // A token no longer valid (rotated): the connection keeps what it has without one (an
          // observer where cmmd.json sets no tokens), so the tab still shows the station and STOP.
          this.auth_error = describe_error(e);
          this.role = (await this.send('server.info', {})).role;
        }
      } else {
        this.role = (await this.send('server.info', {})).role;
      }
    } catch (e) {
      this.role = 'none';
      this.auth_error = describe_error(e);
    }
    try {
      if (this.role !== 'none') await this.send('server.subscribe', {topics: ['job', 'machine']});
    } catch (e) {
      this.auth_error = describe_error(e);
    }
    this.connected = true;
    this.retry_ms = 500;
    for (const fn of this.listeners.open) fn(this.role);
  }

  receive(text) {
    let message;
    try {
      message = JSON.parse(text);
    } catch (e) {
      return;
    }
    for (const m of Array.isArray(message) ? message : [message]) {
      if (m.id !== undefined && m.id !== null && this.pending.has(m.id)) {
        const p = this.pending.get(m.id);
        this.pending.delete(m.id);
        clearTimeout(p.timer);
        if (m.error) p.reject(new RpcError(m.error));
        else p.resolve(m.result);
      } else if (m.method) {
        for (const fn of this.handlers.get(m.method) || []) fn(m.params || {});
      }
    }
  }

  send(method, params, timeout_s = 30) {
    return new Promise((resolve, reject) => {
      if (!this.ws || this.ws.readyState !== WebSocket.OPEN) {
        reject(new RpcError({code: -32099, message: 'not connected to cmmd'}));
        return;
      }
      const id = this.next_id++;
      const timer = setTimeout(() => {
        this.pending.delete(id);
        reject(new RpcError({code: -32098, message: `${method}: no answer within ${timeout_s} s`}));
      }, timeout_s * 1000);
      this.pending.set(id, {resolve, reject, timer});
      this.ws.send(JSON.stringify({jsonrpc: '2.0', id, method, params}));
    });
  }

  // A call once connected (and authenticated); rejects with RpcError.
  call(method, params = {}, timeout_s = 30) {
    if (!this.connected) return Promise.reject(new RpcError({code: -32099, message: 'not connected to cmmd'}));
    return this.send(method, params, timeout_s);
  }
}
