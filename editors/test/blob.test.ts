// Preview protocol 3 (docs/lsp-extensions.md, "Binary buffers"): the same
// model sent as base64 (protocol 2) and as ranges of a blob decodes to the
// same scene, through each road the blob takes: the extension's stdio
// frames (BlobFrames), the host posting it to the page beside the message,
// the webview transport, and `grmc view`'s `GET /api/blob/ID`.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { BlobError, attachBlob, blobRef } from '../preview/src/blob.js';
import { type HostToPage, parseHostMessage } from '../preview/src/messages.js';
import { bytesToBase64, decodePreview, decodePreviewUpdated } from '../preview/src/protocol.js';
import { type FetchFn, HttpTransport, VsCodeTransport } from '../preview/src/transport.js';
import { BlobFrames, BlobShelf } from '../vscode/src/blobFrames.js';
import { PreviewHost } from '../vscode/src/host.js';

const le = (a: Float32Array | Uint32Array | Int32Array) => new Uint8Array(a.buffer.slice(0));
const BUFFERS = {
  positions: le(new Float32Array([0, 0, 0, 1, 0, 0, 0, 1, 0, 2, 2, 2])),
  normals: le(new Float32Array([0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1])),
  indices: le(new Uint32Array([0, 1, 2, 0, 2, 3])),
  picks: le(new Uint32Array([0, 2, 0x103, 5, 6, 0xffffffff])),
  bones: le(new Float32Array([0, 0, 0, 0, 1, 0, 0.2, 0.1])),
  parents: le(new Int32Array([-1])),
  origins: le(new Uint32Array([0])),
};

function wire(buf: (k: keyof typeof BUFFERS) => unknown, extra: Record<string, unknown>) {
  return {
    uri: 'file:///w/t.grm',
    version: 3,
    system: 'T',
    mode: 'derive',
    seed: 1,
    iterations: 2,
    materials: [{ name: 'm', color: [1, 0, 0], roughness: 0.5, metallic: 0, emissive: [0, 0, 0], opacity: 1 }],
    parts: [{ material: 0, vertexCount: 4, triangleCount: 2, positions: buf('positions'), normals: buf('normals'), indices: buf('indices'), pickCount: 1, picks: buf('picks') }],
    skeleton: { boneCount: 1, bones: buf('bones'), parents: buf('parents'), origins: buf('origins') },
    origins: [{ uri: 'file:///w/t.grm', range: { start: { line: 0, character: 0 }, end: { line: 0, character: 1 } }, symbol: 'A' }],
    stats: { vertices: 4, triangles: 2 },
    ...extra,
  };
}

/** The model as protocol 2 sends it. */
const base64 = () => wire((k) => bytesToBase64(BUFFERS[k]), { encoding: 'base64-le' });

/** The model as protocol 3 sends it: the JSON and its blob. */
function binary(id: number): { json: ReturnType<typeof wire> & { blob: { id: number; bytes: number } }; blob: Uint8Array<ArrayBuffer> } {
  const keys = Object.keys(BUFFERS) as Array<keyof typeof BUFFERS>;
  const total = keys.reduce((n, k) => n + BUFFERS[k].length, 0);
  const blob = new Uint8Array(total);
  const at: Record<string, { at: number; bytes: number }> = {};
  let o = 0;
  for (const k of keys) {
    blob.set(BUFFERS[k], o);
    at[k] = { at: o, bytes: BUFFERS[k].length };
    o += BUFFERS[k].length;
  }
  return { json: { ...wire((k) => at[k], { encoding: 'blob-le' }), blob: { id, bytes: total } }, blob };
}

const model = (r: unknown) => decodePreview(r).model;

test('blob: a blob-le answer with its bytes in place decodes to the base64 answer\'s model', () => {
  const { json, blob } = binary(4);
  assert.deepEqual(blobRef(json), { id: 4, bytes: blob.length });
  assert.equal(blobRef(base64()), null);
  const m = model(attachBlob(json, blob.buffer));
  assert.deepEqual(m, model(base64()));
  assert.equal(m.parts[0].picks[0].focus, true);
  assert.equal(m.bones.length, 1);
  // Without its bytes, or with other bytes, it is refused, never drawn wrong.
  assert.throws(() => attachBlob(binary(4).json, undefined), BlobError);
  assert.throws(() => attachBlob(binary(4).json, new ArrayBuffer(8)), /8 bytes where the answer says/);
  const bad = binary(5);
  (bad.json.parts[0].positions as { at: number }).at = bad.blob.length;
  assert.throws(() => attachBlob(bad.json, bad.blob.buffer), /outside the blob/);
  // Ranges never put in place are no model.
  assert.throws(() => decodePreview(binary(6).json));
});

/** Frames as `grmc lsp` writes them. */
function frame(body: Uint8Array | string, headers = ''): Buffer {
  const b = typeof body === 'string' ? Buffer.from(body) : Buffer.from(body);
  return Buffer.concat([Buffer.from(`Content-Length: ${b.length}\r\n${headers}\r\n`), b]);
}

test('blobFrames: blob frames are kept by id, every other frame passes unchanged, however the stream is cut', async () => {
  const { blob } = binary(9);
  const m1 = '{"jsonrpc":"2.0","method":"x","params":{"é":1}}';
  const m2 = '{"jsonrpc":"2.0","id":3,"result":{"blob":{"id":9}}}';
  const input = Buffer.concat([frame(m1), frame(blob, 'Content-Type: application/vnd.grm.blob\r\nGrm-Blob: 9\r\n'), frame(m2), frame(new Uint8Array(0), 'Content-Type: application/vnd.grm.blob\r\nGrm-Blob: 10\r\n')]);
  for (const step of [1, 3, 7, 64, input.length]) {
    const shelf = new BlobShelf();
    const t = new BlobFrames(shelf);
    const out: Buffer[] = [];
    t.on('data', (d: Buffer) => out.push(d));
    const seenBeforeM2: boolean[] = [];
    t.on('data', () => seenBeforeM2.push(shelf.size > 0));
    for (let i = 0; i < input.length; i += step) t.write(input.subarray(i, i + step));
    t.end();
    await new Promise((r) => t.on('end', r));
    assert.equal(Buffer.concat(out).toString(), frame(m1).toString() + frame(m2).toString(), `step ${step}`);
    const got = shelf.take(9);
    assert.ok(got, `step ${step}`);
    assert.deepEqual(new Uint8Array(got), blob);
    assert.equal(got.byteLength, blob.length, 'an ArrayBuffer of its own');
    assert.equal(shelf.take(9), undefined, 'taken once');
    assert.equal(shelf.take(10)?.byteLength, 0);
  }
  // Only the newest are kept.
  const shelf = new BlobShelf(2);
  for (const id of [1, 2, 3]) shelf.put(id, new ArrayBuffer(id));
  assert.equal(shelf.take(1), undefined);
  assert.equal(shelf.take(3)?.byteLength, 3);
});

test('host: a preview is asked with binary when the server has blobs, and its blob reaches the page beside the answer', async () => {
  const shelf = new BlobShelf();
  const asked: unknown[] = [];
  const posted: HostToPage[] = [];
  let enabled = true;
  let next = 20;
  const host = new PreviewHost({
    request: async (_m, params) => {
      asked.push(params);
      if (!(params as { binary?: boolean }).binary) return base64();
      const { json, blob } = binary(next++);
      shelf.put(json.blob.id, blob.buffer as ArrayBuffer);
      return json;
    },
    readFile: async () => null,
    writeFile: async () => {},
    savePicture: async () => null,
    reveal: async () => {},
    fsPath: () => null,
    post: (m) => posted.push(m),
    blobs: { enabled: () => enabled, take: (id) => shelf.take(id) },
  });
  const listeners: Array<(ev: { data: unknown }) => void> = [];
  const page = new VsCodeTransport(
    // As VS Code's postMessage: the message reaches the webview, ArrayBuffers included.
    { postMessage: (m) => void host.handle(m) },
    { addEventListener: (_t, l) => listeners.push(l), removeEventListener: () => {} },
  );
  let notified: unknown = null;
  page.onNotification((method, params) => {
    if (method === 'previewUpdated') notified = params;
  });
  host.setDocument('file:///w/t.grm', 't.grm');
  page.start();
  const deliver = () => {
    for (const m of posted.splice(0)) for (const l of listeners) l({ data: m });
  };
  deliver();
  const pending = page.request('preview', { textDocument: { uri: 'file:///w/t.grm' }, live: true });
  await new Promise((r) => setTimeout(r, 0));
  assert.equal((asked[0] as { binary?: boolean }).binary, true);
  const response = posted.find((m) => m.type === 'response');
  assert.ok(response && response.type === 'response' && response.blob instanceof ArrayBuffer);
  assert.equal(parseHostMessage(response)?.type, 'response');
  deliver();
  assert.deepEqual(model(await pending), model(base64()));
  assert.equal(shelf.size, 0, 'taken');
  // The live preview's notification and its blob.
  const { json, blob } = binary(30);
  shelf.put(30, blob.buffer as ArrayBuffer);
  host.previewUpdated({ uri: 'file:///w/t.grm', version: 4, result: json, error: null });
  deliver();
  assert.deepEqual(decodePreviewUpdated(notified).result?.model, model(base64()));
  // A blob that did not arrive: the page says so instead of a model.
  host.previewUpdated({ uri: 'file:///w/t.grm', version: 5, result: binary(31).json, error: null });
  deliver();
  assert.match(String((notified as { error: unknown }).error), /blob 31\) did not arrive/);
  // A server without blobs (protocol 2): asked without binary, answered in base64.
  enabled = false;
  const again = page.request('preview', { textDocument: { uri: 'file:///w/t.grm' } });
  await new Promise((r) => setTimeout(r, 0));
  assert.equal((asked[1] as { binary?: boolean }).binary, undefined);
  deliver();
  assert.deepEqual(model(await again), model(base64()));
});

test('http transport: previews are asked with binary and their blob fetched from /api/blob/ID', async () => {
  const { json, blob } = binary(7);
  const calls: string[] = [];
  const fetchFn: FetchFn = async (url, init) => {
    calls.push(`${init?.method ?? 'GET'} ${url} ${init?.body ?? ''}`);
    if (url.endsWith('/api/blob/7')) {
      return { ok: true, status: 200, json: async () => null, text: async () => '', arrayBuffer: async () => blob.buffer.slice(0) as ArrayBuffer };
    }
    if (url.endsWith('/api/preview')) return { ok: true, status: 200, json: async () => ({ result: structuredClone(json) }), text: async () => '' };
    if (url.endsWith('/api/pick')) return { ok: true, status: 200, json: async () => ({ result: { encoding: 'blob-le' } }), text: async () => '' };
    return { ok: false, status: 404, json: async () => ({ error: 'not found' }), text: async () => '' };
  };
  const t = new HttpTransport('http://h', fetchFn);
  const r = await t.request('preview', { textDocument: { uri: 'file:///w/t.grm' } });
  assert.deepEqual(model(r), model(base64()));
  assert.match(calls[0], /^POST http:\/\/h\/api\/preview .*"binary":true/);
  assert.equal(calls[1], 'GET http://h/api/blob/7 ');
  // Only previews ask for it.
  await t.request('pick', { uri: 'x' });
  assert.doesNotMatch(calls[2], /binary/);
  // A blob the server no longer has: an error, not a broken model.
  const gone = new HttpTransport('http://h', async (url, init) => (url.endsWith('/api/preview') ? fetchFn(url, init) : { ok: false, status: 404, json: async () => null, text: async () => '' }));
  await assert.rejects(gone.request('preview', {}), /blob 7: HTTP 404/);
});
