// model.upload from the browser: the file's sha256 (Web Crypto, which needs a secure context:
// http://127.0.0.1 and localhost are) and its bytes in base64 chunks of 512 KiB, in order.

const CHUNK = 512 * 1024;

function hex(buffer) {
  return Array.from(new Uint8Array(buffer), (b) => b.toString(16).padStart(2, '0')).join('');
}

export function base64_of(bytes) {
  let text = '';
  for (let i = 0; i < bytes.length; i += 0x8000) text += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(text);
}

export function bytes_of_base64(text) {
  const raw = atob(text);
  const bytes = new Uint8Array(raw.length);
  for (let i = 0; i < raw.length; ++i) bytes[i] = raw.charCodeAt(i);
  return bytes;
}

// Uploads `file` (a File or Blob with a name); on_progress(received, size). Resolves to the model's
// name for a job ("sha256:<hex><ext>"); rejects with the RpcError of a refused chunk.
export async function upload_model(rpc, file, on_progress = () => {}) {
  if (!crypto.subtle) throw new Error('this page is not a secure context (open it as http://127.0.0.1:PORT)');
  const bytes = new Uint8Array(await file.arrayBuffer());
  const sha256 = hex(await crypto.subtle.digest('SHA-256', bytes));
  let offset = 0;
  for (;;) {
    const chunk = bytes.subarray(offset, Math.min(bytes.length, offset + CHUNK));
    const r = await rpc.call('model.upload', {name: file.name, size: bytes.length, sha256, offset, data: base64_of(chunk)}, 120);
    on_progress(r.received, bytes.length);
    if (r.complete) return r.model;
    offset = r.received;
  }
}
