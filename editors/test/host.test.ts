// The extension's handling of the page's messages, and the two ends wired
// together: the page's webview transport talking to the extension's host.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { type HostToPage, parseHostMessage, viewAngles } from '../preview/src/messages.js';
import { pngSize } from '../preview/src/picture.js';
import { bytesToBase64, decodePicture } from '../preview/src/protocol.js';
import { TransportError, VsCodeTransport, isSuperseded } from '../preview/src/transport.js';
import { type HostDeps, PreviewHost, curvesPathFor } from '../vscode/src/host.js';
import { pngHeader } from './png.js';

const CURVES = JSON.stringify({ version: 1, curves: [{ name: 'a', points: [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] }] });


function fakeHost(overrides: Partial<HostDeps> = {}) {
  const posted: HostToPage[] = [];
  const requests: Array<[string, unknown]> = [];
  const writes: Array<[string, string]> = [];
  const reveals: Array<[string, number, number]> = [];
  const pictures: Array<[string, Uint8Array]> = [];
  const deps: HostDeps = {
    request: async (method, params) => {
      requests.push([method, params]);
      if (method === 'grm/preview') {
        const p = params as { textDocument: { uri: string }; generation?: number };
        // A scrubbed search says which generation it shows.
        return { uri: p.textDocument.uri, mode: 'sample', seed: 9, system: 'Tree', ...(p.generation !== undefined ? { sample: { generation: p.generation } } : {}) };
      }
      if (method === 'textDocument/documentSymbol') return [{ name: 'spread', kind: 13, detail: '30 in 10 .. 60' }];
      if (method === 'grm/picture') {
        const p = params as { width?: number; height?: number; seed?: number };
        const [width, height] = [p.width ?? 1024, p.height ?? 1024];
        return { uri: 'file:///w/tree.grm', version: 1, system: 'Tree', seed: p.seed ?? 0, width, height, view: { azimuth: 0, elevation: 0 }, png: bytesToBase64(pngHeader(width, height)), triangles: 10, bones: 2 };
      }
      if (method === 'grm/pick') return { uri: 'file:///t.grm', range: { start: { line: 41, character: 4 }, end: { line: 42, character: 0 } }, symbol: 'branch', version: 1, module: 3 };
      throw new Error(`unexpected ${method}`);
    },
    readFile: async (p) => (p === '/w/tree.curves.json' ? CURVES : null),
    writeFile: async (p, t) => {
      writes.push([p, t]);
    },
    // The user accepts the suggested place.
    savePicture: async (suggested, png) => {
      pictures.push([suggested, png]);
      return suggested;
    },
    reveal: async (u, l, c) => {
      reveals.push([u, l, c]);
    },
    fsPath: (uri) => (uri.startsWith('file://') ? uri.slice('file://'.length) : null),
    post: (m) => posted.push(m),
    ...overrides,
  };
  return { host: new PreviewHost(deps), posted, requests, writes, reveals, pictures };
}

test('notifications wait for the page to be ready; only the latest document is kept', async () => {
  const { host, posted } = fakeHost();
  host.setDocument('file:///a.grm', 'a.grm');
  host.previewUpdated({ uri: 'file:///a.grm', version: 2, result: null, error: 'x' });
  host.setDocument('file:///b.grm', 'b.grm');
  assert.equal(posted.length, 0);
  await host.handle({ type: 'ready' });
  assert.deepEqual(posted, [{ type: 'notify', method: 'document', params: { uri: 'file:///b.grm', title: 'b.grm' } }]);
  host.previewUpdated({ uri: 'file:///a.grm', version: 3, result: null, error: 'x' }); // not the shown document
  host.previewUpdated({ uri: 'file:///b.grm', version: 4, result: { seed: 1 }, error: null });
  host.previewUpdated('junk');
  host.cursor('file:///b.grm', 7, 2);
  host.refresh();
  assert.deepEqual(posted.slice(1), [
    { type: 'notify', method: 'previewUpdated', params: { uri: 'file:///b.grm', version: 4, result: { seed: 1 }, error: null } },
    { type: 'notify', method: 'cursor', params: { uri: 'file:///b.grm', line: 7, character: 2 } },
    { type: 'notify', method: 'document', params: { uri: 'file:///b.grm', title: 'b.grm' } },
  ]);
});

test('saving the curves file in the editor tells the page to reload it', async () => {
  const { host, posted } = fakeHost();
  host.setDocument('file:///w/tree.grm', 'tree.grm');
  await host.handle({ type: 'ready' });
  const n = posted.length;
  host.fileSaved('/w/other.curves.json');
  host.fileSaved('/w/tree.grm');
  assert.equal(posted.length, n);
  host.fileSaved('/w/tree.curves.json');
  assert.deepEqual(posted.at(-1), { type: 'notify', method: 'curvesChanged', params: { uri: 'file:///w/tree.grm' } });
});

test("a node chosen in the editor's derivation view is sent to the page showing its document (the page highlights its parts)", async () => {
  const { host, posted } = fakeHost();
  host.setDocument('file:///w/house.grm', 'house.grm');
  host.treeNode('file:///w/house.grm', '5ad0c3e1');
  assert.equal(posted.length, 0, 'not before the page is ready');
  await host.handle({ type: 'ready' });
  const n = posted.length;
  host.treeNode('file:///w/other.grm', '5ad0c3e1');
  assert.equal(posted.length, n, 'another document: nothing');
  host.treeNode('file:///w/house.grm', '5ad0c3e1');
  host.treeNode('file:///w/house.grm', null);
  assert.deepEqual(posted.slice(n), [
    { type: 'notify', method: 'treeNode', params: { uri: 'file:///w/house.grm', key: '5ad0c3e1' } },
    { type: 'notify', method: 'treeNode', params: { uri: 'file:///w/house.grm', key: null } },
  ]);  // The page reads it as a notification.
  for (const m of posted.slice(n)) assert.deepEqual(parseHostMessage(JSON.parse(JSON.stringify(m))), m);
});

test('server URIs are matched however they escape the path', async () => {
  const { host, posted } = fakeHost();
  host.setDocument('file:///c%3A/w/t.grm', 't.grm');
  await host.handle({ type: 'ready' });
  host.previewUpdated({ uri: 'file:///c:/w/t.grm', version: 1, result: null, error: 'e' });
  assert.deepEqual((posted.at(-1) as { params: { uri: string } }).params.uri, 'file:///c%3A/w/t.grm');
});

test('preview requests go to grm/preview and the answer comes back with the same id', async () => {
  const { host, posted, requests } = fakeHost();
  host.setDocument('file:///t.grm', 't.grm');
  await host.handle({ type: 'ready' });
  const params = { textDocument: { uri: 'file:///t.grm' }, mode: 'sample', seed: 9, params: { spread: 40 }, live: true };
  await host.handle({ type: 'request', id: 7, method: 'preview', params });
  assert.deepEqual(requests, [['grm/preview', params]]);
  assert.deepEqual(posted.at(-1), { type: 'response', id: 7, result: { uri: 'file:///t.grm', mode: 'sample', seed: 9, system: 'Tree' } });
  assert.deepEqual(host.lastPreview('file:///t.grm'), { params: { spread: 40 }, mode: 'sample', seed: 9, system: 'Tree' });
  // A scrubbed search: the export writes the generation shown.
  await host.handle({ type: 'request', id: 8, method: 'preview', params: { ...params, generation: 4 } });
  assert.equal(host.lastPreview('file:///t.grm')?.generation, 4);
  // No seed picked in the page: the export leaves the seed to the file (whose `seed` setting may be edited since),
  // not the seed of the last answer.
  const { seed: _seed, ...fileSeed } = params;
  await host.handle({ type: 'request', id: 9, method: 'preview', params: fileSeed });
  assert.equal(host.lastPreview('file:///t.grm')?.seed, undefined);
});

test('symbols come from textDocument/documentSymbol of the shown document', async () => {
  const { host, posted, requests } = fakeHost();
  host.setDocument('file:///t.grm', 't.grm');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 3, method: 'symbols', params: { uri: 'file:///t.grm' } });
  assert.deepEqual(requests, [['textDocument/documentSymbol', { textDocument: { uri: 'file:///t.grm' } }]]);
  assert.deepEqual(posted.at(-1), { type: 'response', id: 3, result: [{ name: 'spread', kind: 13, detail: '30 in 10 .. 60' }] });
});

test('a pick asks the server and jumps to the rule', async () => {
  const { host, posted, reveals } = fakeHost();
  host.setDocument('file:///t.grm', 't.grm');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 1, method: 'pick', params: { textDocument: { uri: 'file:///t.grm' }, part: 0, triangle: 12 } });
  assert.deepEqual(reveals, [['file:///t.grm', 41, 4]]);
  assert.equal((posted.at(-1) as { result: { symbol: string } }).result.symbol, 'branch');
});

test('curves are read from and saved next to the grammar, and only valid curves', async () => {
  const { host, posted, writes } = fakeHost();
  host.setDocument('file:///w/tree.grm', 'tree.grm');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 1, method: 'loadCurves', params: { uri: 'file:///w/tree.grm' } });
  assert.deepEqual(posted.at(-1), { type: 'response', id: 1, result: { path: '/w/tree.curves.json', text: CURVES } });
  await host.handle({ type: 'request', id: 2, method: 'saveCurves', params: { uri: 'file:///w/tree.grm', text: CURVES } });
  assert.deepEqual(writes, [['/w/tree.curves.json', CURVES]]);
  assert.deepEqual(posted.at(-1), { type: 'response', id: 2, result: { path: '/w/tree.curves.json' } });
  await host.handle({ type: 'request', id: 3, method: 'saveCurves', params: { uri: 'file:///w/tree.grm', text: '{"version": 1, "curves": []}' } });
  assert.equal(writes.length, 1);
  assert.match((posted.at(-1) as { error: string }).error, /at least one curve/);
  // A file the sampler refuses for its utilization segments is not written either.
  const tiny = CURVES.replace(/"points"/, '"segment_length": 0.00001, "points"');
  assert.notEqual(tiny, CURVES);
  await host.handle({ type: 'request', id: 4, method: 'saveCurves', params: { uri: 'file:///w/tree.grm', text: tiny } });
  assert.equal(writes.length, 1);
  assert.match((posted.at(-1) as { error: string }).error, /at most 2048 are allowed/);
});

test("the server's error code reaches the page with the error (a superseded preview is told apart)", async () => {
  class ResponseError extends Error {
    constructor(
      readonly code: number,
      message: string,
    ) {
      super(message);
    }
  }
  const { host, posted } = fakeHost({
    request: async () => {
      throw new ResponseError(-32802, 'superseded by a newer grm/preview request for this document');
    },
  });
  host.setDocument('file:///t.grm', 't.grm');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 4, method: 'preview', params: { textDocument: { uri: 'file:///t.grm' }, live: true } });
  assert.deepEqual(posted.at(-1), { type: 'response', id: 4, error: 'superseded by a newer grm/preview request for this document', code: -32802 });
  // And the page's transport turns it into an error it recognises.
  const win = { listeners: [] as Array<(ev: { data: unknown }) => void> };
  const t = new VsCodeTransport(
    { postMessage: (m) => void (m.type === 'request' && host.handle(m).then(() => win.listeners.forEach((l) => l({ data: posted.at(-1) })))) },
    { addEventListener: (_t, l) => win.listeners.push(l), removeEventListener: () => {} },
  );
  t.start();
  await assert.rejects(t.request('preview', { textDocument: { uri: 'file:///t.grm' } }), (e: unknown) => isSuperseded(e));
});

test("a failed preview's document version (the server's data.version) reaches the page with the error", async () => {
  class ResponseError extends Error {
    constructor(
      readonly code: number,
      message: string,
      readonly data?: unknown,
    ) {
      super(message);
    }
  }
  let data: unknown = { version: 7 };
  const { host, posted } = fakeHost({
    request: async () => {
      throw new ResponseError(-32803, 'the program has 1 error: fix it to preview', data);
    },
  });
  host.setDocument('file:///t.grm', 't.grm');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 5, method: 'preview', params: { textDocument: { uri: 'file:///t.grm' }, live: true } });
  assert.deepEqual(posted.at(-1), { type: 'response', id: 5, error: 'the program has 1 error: fix it to preview', code: -32803, version: 7 });
  // The page's transport gives it to the page with the error.
  const win = { listeners: [] as Array<(ev: { data: unknown }) => void> };
  const t = new VsCodeTransport(
    { postMessage: (m) => void (m.type === 'request' && host.handle(m).then(() => win.listeners.forEach((l) => l({ data: posted.at(-1) })))) },
    { addEventListener: (_t, l) => win.listeners.push(l), removeEventListener: () => {} },
  );
  t.start();
  await assert.rejects(t.request('preview', { textDocument: { uri: 'file:///t.grm' } }), (e: unknown) => e instanceof TransportError && e.version === 7 && e.code === -32803 && !isSuperseded(e));
  // No data, or a version that is not a whole number: no version.
  for (const d of [undefined, { version: 1.5 }, { version: '7' }, 7]) {
    data = d;
    await host.handle({ type: 'request', id: 6, method: 'preview', params: { textDocument: { uri: 'file:///t.grm' }, live: true } });
    assert.deepEqual(posted.at(-1), { type: 'response', id: 6, error: 'the program has 1 error: fix it to preview', code: -32803 }, JSON.stringify(d));
  }
});

test('requests about another document, unsaved documents and server failures answer with an error', async () => {
  const { host, posted, writes } = fakeHost({
    request: async () => {
      throw new Error('server crashed');
    },
  });
  host.setDocument('untitled:Untitled-1', 'Untitled-1');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 1, method: 'preview', params: { textDocument: { uri: 'file:///other.grm' } } });
  assert.match((posted.at(-1) as { error: string }).error, /not file:\/\/\/other.grm/);
  await host.handle({ type: 'request', id: 2, method: 'preview', params: { textDocument: { uri: 'untitled:Untitled-1' } } });
  assert.deepEqual(posted.at(-1), { type: 'response', id: 2, error: 'server crashed' });
  await host.handle({ type: 'request', id: 3, method: 'saveCurves', params: { uri: 'untitled:Untitled-1', text: CURVES } });
  assert.match((posted.at(-1) as { error: string }).error, /save it first/);
  await host.handle({ type: 'request', id: 4, method: 'preview', params: null });
  assert.match((posted.at(-1) as { error: string }).error, /names no document/);
  await host.handle({ type: 'request', id: 5, method: 'loadCurves', params: { uri: 'untitled:Untitled-1' } });
  assert.match((posted.at(-1) as { error: string }).error, /save it first/);
  assert.equal(writes.length, 0);
});

test('malformed messages are ignored', async () => {
  const { host, posted, requests } = fakeHost();
  for (const m of [
    null,
    'x',
    { type: 'request', id: 'a', method: 'preview' },
    { type: 'request', id: 1, method: 'rm -rf' },
    { type: 'response', id: 1 },
    { type: 'notify', method: 'preview', params: {} },
  ]) {
    await host.handle(m);
  }
  assert.equal(posted.length, 0);
  assert.equal(requests.length, 0);
});

test("the page's view is kept for the shown document only, and only a valid one", async () => {
  const { host, posted } = fakeHost();
  host.setDocument('file:///w/a.grm', 'a.grm');
  await host.handle({ type: 'ready' });
  const view = { uri: 'file:///w/a.grm', azimuth: 24.2, elevation: -17.7, width: 800, height: 500 };
  await host.handle({ type: 'notify', method: 'view', params: view });
  assert.deepEqual(host.lastView('file:///w/a.grm'), view);
  assert.equal(host.lastView('file:///w/b.grm'), undefined);
  // Nothing is answered: a notification.
  assert.equal(posted.length, 1);
  for (const bad of [
    { ...view, uri: 'file:///w/b.grm' },
    { ...view, azimuth: null },
    { ...view, elevation: Number.NaN },
    { ...view, width: 0 },
    { ...view, height: '500' },
    null,
  ]) {
    await host.handle({ type: 'notify', method: 'view', params: bad });
    assert.deepEqual(host.lastView('file:///w/a.grm'), view, JSON.stringify(bad));
  }
  await host.handle({ type: 'notify', method: 'view', params: { ...view, azimuth: -90 } });
  assert.equal(host.lastView('file:///w/a.grm')?.azimuth, -90);
  // With the camera itself (the export draws through it); one that cannot be drawn through is dropped, the view's angles stay.
  const camera = { position: [-2, 1.5, 4.25], target: [0, 1, 0], fov: 45 };
  await host.handle({ type: 'notify', method: 'view', params: { ...view, camera } });
  assert.deepEqual(host.lastView('file:///w/a.grm'), { ...view, camera });
  for (const bad of [{ ...camera, fov: 0 }, { ...camera, target: camera.position }, { ...camera, position: [null, 1, 2] }, 'camera']) {
    await host.handle({ type: 'notify', method: 'view', params: { ...view, azimuth: 12, camera: bad } });
    assert.deepEqual(host.lastView('file:///w/a.grm'), { ...view, azimuth: 12 }, JSON.stringify(bad));
  }
  // Another document: the old view is stale, and the page tells the new one.
  host.setDocument('file:///w/b.grm', 'b.grm');
  assert.equal(host.lastView('file:///w/a.grm'), undefined);
  assert.equal(host.lastView('file:///w/b.grm'), undefined);
  await host.handle({ type: 'notify', method: 'view', params: view });
  assert.equal(host.lastView('file:///w/a.grm'), undefined);
});

test('view angles: azimuth about +y from +z towards +x, elevation above the xz plane, in degrees', () => {
  const near = (a: { azimuth: number; elevation: number } | null, azimuth: number, elevation: number) => {
    assert.ok(a, 'no angles');
    assert.ok(Math.abs(a.azimuth - azimuth) < 1e-9 && Math.abs(a.elevation - elevation) < 1e-9, `${JSON.stringify(a)} is not ${azimuth},${elevation}`);
  };
  near(viewAngles(0, 0, 5), 0, 0);
  near(viewAngles(3, 0, 0), 90, 0);
  near(viewAngles(-3, 0, 0), -90, 0);
  near(viewAngles(0, 0, -1), 180, 0);
  near(viewAngles(1, Math.SQRT2, 1), 45, 45);
  near(viewAngles(0, -2, 0), 0, -90);
  // The preview's first framing (scene.ts): from (0.45, 0.35, 1).
  near(viewAngles(0.45, 0.35, 1), Math.atan2(0.45, 1) * (180 / Math.PI), Math.asin(0.35 / Math.hypot(0.45, 0.35, 1)) * (180 / Math.PI));
  assert.equal(viewAngles(0, 0, 0), null);
  assert.equal(viewAngles(Number.NaN, 0, 1), null);
  assert.equal(viewAngles(Number.POSITIVE_INFINITY, 0, 1), null);
});

test('page and extension end to end: the page transport talks to the host', async () => {
  // An in-memory webview: page -> host through handle(), host -> page through message events.
  const listeners: Array<(ev: { data: unknown }) => void> = [];
  const win = {
    addEventListener: (_t: 'message', l: (ev: { data: unknown }) => void) => listeners.push(l),
    removeEventListener: () => {},
  };
  let host!: PreviewHost;
  const pending: Promise<void>[] = [];
  const page = new VsCodeTransport({ postMessage: (m) => pending.push(host.handle(structuredClone(m))) }, win);
  host = fakeHost({ post: (m) => listeners.forEach((l) => l({ data: structuredClone(m) })) }).host;
  const notes: unknown[] = [];
  page.onNotification((m, p) => notes.push([m, p]));
  host.setDocument('file:///w/tree.grm', 'tree.grm');
  page.start();
  await Promise.all(pending);
  assert.deepEqual(notes, [['document', { uri: 'file:///w/tree.grm', title: 'tree.grm' }]]);
  const r = (await page.request('preview', { textDocument: { uri: 'file:///w/tree.grm' } })) as { seed: number };
  assert.equal(r.seed, 9);
  await assert.rejects(page.request('saveCurves', { uri: 'file:///w/tree.grm', text: '{' }), /invalid JSON/);
  page.notify('view', { uri: 'file:///w/tree.grm', azimuth: 10, elevation: 20, width: 300, height: 200 });
  await Promise.all(pending);
  assert.deepEqual(host.lastView('file:///w/tree.grm'), { uri: 'file:///w/tree.grm', azimuth: 10, elevation: 20, width: 300, height: 200 });
  // The camera travels with the view, every digit of it.
  const camera = { position: [0.1 + 0.2, 2.000001, -7.5], target: [0, 1.25, 1 / 3], fov: 45 };
  page.notify('view', { uri: 'file:///w/tree.grm', azimuth: 10, elevation: 20, width: 300, height: 200, camera });
  await Promise.all(pending);
  assert.deepEqual(host.lastView('file:///w/tree.grm')?.camera, camera);
});

test('a picture is drawn by grm/picture and saved by the extension where the user says; the PNG does not travel back', async () => {
  const { host, posted, requests, pictures } = fakeHost();
  host.setDocument('file:///w/tree.grm', 'tree.grm');
  await host.handle({ type: 'ready' });
  // What the page sends: through its camera (zoom, pan and perspective as shown).
  const camera = { position: [-2, 1.5, 4.25], target: [0, 1, 0], fov: 45 };
  const params = { textDocument: { uri: 'file:///w/tree.grm' }, mode: 'derive', seed: 3, params: { spread: 40 }, camera, width: 1024, height: 640 };
  await host.handle({ type: 'request', id: 5, method: 'picture', params });
  // Forwarded as it is, like a preview.
  assert.deepEqual(requests, [['grm/picture', params]]);
  // Offered beside the grammar, under its name; the bytes are the PNG's.
  assert.equal(pictures.length, 1);
  assert.equal(pictures[0][0], '/w/tree.png');
  assert.deepEqual(pngSize(pictures[0][1]), { width: 1024, height: 640 });
  const answer = posted.at(-1) as { type: string; id: number; result: Record<string, unknown> };
  assert.equal(answer.id, 5);
  assert.equal('png' in answer.result, false);
  assert.equal(answer.result.saved, '/w/tree.png');
  // What the page makes of it: saved, nothing to download.
  assert.deepEqual(decodePicture(answer.result), { system: 'Tree', seed: 3, width: 1024, height: 640, png: null, saved: '/w/tree.png' });
  // A picture is no preview: the export's seed and parameters stay the last preview's.
  assert.equal(host.lastPreview('file:///w/tree.grm'), undefined);
});

test('a picture the user does not save, of an unsaved document, of another document, or refused by the server', async () => {
  const cancelled = fakeHost({ savePicture: async () => null });
  cancelled.host.setDocument('untitled:Untitled-1', 'Untitled-1');
  await cancelled.host.handle({ type: 'ready' });
  await cancelled.host.handle({ type: 'request', id: 1, method: 'picture', params: { textDocument: { uri: 'untitled:Untitled-1' } } });
  assert.deepEqual((cancelled.posted.at(-1) as { result: { saved: unknown } }).result.saved, null);
  // Not a file: a bare name, placed by the extension.
  const named = fakeHost();
  named.host.setDocument('untitled:Untitled-1', 'Untitled-1');
  await named.host.handle({ type: 'ready' });
  await named.host.handle({ type: 'request', id: 1, method: 'picture', params: { textDocument: { uri: 'untitled:Untitled-1' } } });
  assert.equal(named.pictures[0][0], 'Untitled-1.png');
  await named.host.handle({ type: 'request', id: 2, method: 'picture', params: { textDocument: { uri: 'file:///w/other.grm' } } });
  assert.match((named.posted.at(-1) as { error: string }).error, /not file:\/\/\/w\/other.grm/);
  assert.equal(named.pictures.length, 1);
  // The server's refusal (errors in the program) reaches the page with its code; nothing is asked or saved.
  class ResponseError extends Error {
    constructor(
      readonly code: number,
      message: string,
    ) {
      super(message);
    }
  }
  const refused = fakeHost({
    request: async () => {
      throw new ResponseError(-32803, 'the program has 1 error: fix it to preview');
    },
  });
  refused.host.setDocument('file:///w/tree.grm', 'tree.grm');
  await refused.host.handle({ type: 'ready' });
  await refused.host.handle({ type: 'request', id: 3, method: 'picture', params: { textDocument: { uri: 'file:///w/tree.grm' } } });
  assert.deepEqual(refused.posted.at(-1), { type: 'response', id: 3, error: 'the program has 1 error: fix it to preview', code: -32803 });
  assert.equal(refused.pictures.length, 0);
  // An answer without a picture is an error, not an empty file.
  const empty = fakeHost({ request: async () => ({ width: 1, height: 1 }) });
  empty.host.setDocument('file:///w/tree.grm', 'tree.grm');
  await empty.host.handle({ type: 'ready' });
  await empty.host.handle({ type: 'request', id: 4, method: 'picture', params: { textDocument: { uri: 'file:///w/tree.grm' } } });
  assert.match((empty.posted.at(-1) as { error: string }).error, /no png/);
  assert.equal(empty.pictures.length, 0);
});

test('the curves file is named after the grammar', () => {
  assert.equal(curvesPathFor('/a/b/tree.grm'), '/a/b/tree.curves.json');
  assert.equal(curvesPathFor('C:\\x\\Tree.GRM'), 'C:\\x\\Tree.curves.json');
});
