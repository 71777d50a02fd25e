import assert from 'node:assert/strict';
import { test } from 'node:test';
import type { PageToHost } from '../preview/src/messages.js';
import { type FetchFn, HttpTransport, type RequestTiming, TransportError, VsCodeTransport, detectTransport, isSuperseded, serverTimingMs } from '../preview/src/transport.js';

class FakeWindow {
  listeners: Array<(ev: { data: unknown }) => void> = [];
  addEventListener(_t: 'message', l: (ev: { data: unknown }) => void) {
    this.listeners.push(l);
  }
  removeEventListener(_t: 'message', l: (ev: { data: unknown }) => void) {
    this.listeners = this.listeners.filter((x) => x !== l);
  }
  deliver(data: unknown) {
    for (const l of this.listeners) l({ data });
  }
}

test('webview transport: ready first, responses matched by id in any order', async () => {
  const sent: PageToHost[] = [];
  const win = new FakeWindow();
  const t = new VsCodeTransport({ postMessage: (m) => sent.push(m) }, win);
  t.start();
  assert.deepEqual(sent[0], { type: 'ready' });
  const a = t.request('preview', { uri: 'a' });
  const b = t.request('pick', { uri: 'a', origin: 1 });
  assert.equal(t.pendingCount, 2);
  const [ra, rb] = sent.slice(1) as Array<{ id: number; method: string }>;
  assert.equal(ra.method, 'preview');
  assert.notEqual(ra.id, rb.id);
  win.deliver({ type: 'response', id: rb.id, result: { rule: null } });
  win.deliver({ type: 'response', id: ra.id, error: 'grammar has errors' });
  assert.deepEqual(await b, { rule: null });
  await assert.rejects(a, (e: Error) => e instanceof TransportError && e.message === 'grammar has errors');
  assert.equal(t.pendingCount, 0);
});

test('webview transport: notifications reach the handler; junk and unknown ids are ignored', () => {
  const win = new FakeWindow();
  const t = new VsCodeTransport({ postMessage: () => {} }, win);
  const got: unknown[] = [];
  t.onNotification((m, p) => got.push([m, p]));
  t.start();
  win.deliver({ type: 'notify', method: 'previewUpdated', params: { uri: 'u', version: 3 } });
  win.deliver({ type: 'notify', method: 'evil', params: {} });
  win.deliver('hello');
  win.deliver(null);
  win.deliver({ type: 'response', id: 999, result: 1 });
  assert.deepEqual(got, [['previewUpdated', { uri: 'u', version: 3 }]]);
});

test('webview transport: dispose rejects what is pending and stops listening', async () => {
  const win = new FakeWindow();
  const t = new VsCodeTransport({ postMessage: () => {} }, win);
  t.start();
  const p = t.request('preview', {});
  t.dispose();
  await assert.rejects(p, /closed/);
  assert.equal(win.listeners.length, 0);
});

test("the page's notifications: posted to the extension, not sent to grmc view (it exports nothing)", () => {
  const sent: PageToHost[] = [];
  const win = new FakeWindow();
  const t = new VsCodeTransport({ postMessage: (m) => sent.push(m) }, win);
  t.start();
  const view = { uri: 'u', azimuth: 24.2, elevation: 17.7, width: 800, height: 500 };
  t.notify('view', view);
  assert.deepEqual(sent, [{ type: 'ready' }, { type: 'notify', method: 'view', params: view }]);
  assert.equal(t.pendingCount, 0);
  const urls: string[] = [];
  const http = new HttpTransport('http://h', async (url) => {
    urls.push(url);
    return { ok: true, status: 200, json: async () => ({ result: {} }), text: async () => '' };
  });
  http.notify('view', view);
  assert.deepEqual(urls, []);
});

test('http transport: POST JSON per method, result or error', async () => {
  const calls: Array<{ url: string; body?: string; method?: string }> = [];
  const fetchFn: FetchFn = async (url, init) => {
    calls.push({ url, body: init?.body, method: init?.method });
    const body = JSON.parse(init?.body ?? 'null');
    if (url.endsWith('/api/pick')) return { ok: false, status: 400, json: async () => ({ error: 'no such preview' }), text: async () => '' };
    return { ok: true, status: 200, json: async () => ({ result: { echo: body } }), text: async () => '' };
  };
  const t = new HttpTransport('http://127.0.0.1:9', fetchFn);
  // A preview asks for its buffers as a blob (protocol 3, test/blob.test.ts).
  assert.deepEqual(await t.request('preview', { uri: 'x', seed: 2 }), { echo: { uri: 'x', seed: 2, binary: true } });
  await assert.rejects(t.request('pick', {}), /no such preview/);
  assert.deepEqual(calls[0], { url: 'http://127.0.0.1:9/api/preview', body: '{"uri":"x","seed":2,"binary":true}', method: 'POST' });
});

test('http transport and webview transport: the server error code comes with the error', async () => {
  const fetchFn: FetchFn = async (url) => {
    if (url.endsWith('/api/preview')) return { ok: false, status: 422, json: async () => ({ error: 'superseded by a newer grm/preview request for this document', code: -32802 }), text: async () => '' };
    return { ok: false, status: 422, json: async () => ({ error: 'saveCurves: no text' }), text: async () => '' };
  };
  const t = new HttpTransport('http://h', fetchFn);
  await assert.rejects(t.request('preview', {}), (e: unknown) => e instanceof TransportError && e.code === -32802 && isSuperseded(e) && /superseded/.test(e.message));
  await assert.rejects(t.request('saveCurves', {}), (e: unknown) => e instanceof TransportError && e.code === undefined && !isSuperseded(e));
  // grmc view passes a failed preview's document version on, as the extension does.
  const failed = new HttpTransport('http://h', async () => ({ ok: true, status: 200, json: async () => ({ error: 'the program has 1 error', code: -32803, version: 7 }), text: async () => '' }));
  await assert.rejects(failed.request('preview', {}), (e: unknown) => e instanceof TransportError && e.code === -32803 && e.version === 7);

  const sent: PageToHost[] = [];
  const win = new FakeWindow();
  const vs = new VsCodeTransport({ postMessage: (m) => sent.push(m) }, win);
  vs.start();
  const a = vs.request('preview', {});
  const b = vs.request('preview', {});
  const [ra, rb] = sent.slice(1) as Array<{ id: number }>;
  win.deliver({ type: 'response', id: ra.id, error: 'superseded', code: -32802 });
  win.deliver({ type: 'response', id: rb.id, error: 'failed', code: 'x' });
  await assert.rejects(a, (e: unknown) => isSuperseded(e));
  await assert.rejects(b, (e: unknown) => e instanceof TransportError && e.code === undefined);
});

test('http transport: the server time of a request comes from its Server-Timing header', async () => {
  assert.equal(serverTimingMs('app;dur=12.5'), 12.5);
  assert.equal(serverTimingMs('db;dur=3, app;desc="grmc view";dur=7'), 7);
  assert.equal(serverTimingMs('db;dur=3'), undefined);
  assert.equal(serverTimingMs(null), undefined);
  const headers = (h: Record<string, string>) => ({ get: (n: string) => h[n.toLowerCase()] ?? null });
  const fetchFn: FetchFn = async (url) => ({
    ok: true,
    status: 200,
    headers: headers(url.endsWith('/api/preview') ? { 'server-timing': 'app;dur=21.25' } : {}),
    json: async () => ({ result: 1 }),
    text: async () => '',
  });
  const t = new HttpTransport('http://h', fetchFn);
  const timing: RequestTiming = {};
  assert.equal(await t.request('preview', {}, timing), 1);
  assert.equal(timing.serverMs, 21.25);
  const none: RequestTiming = { serverMs: 5 };
  await t.request('pick', {}, none);
  assert.equal(none.serverMs, undefined, 'an answer without the header leaves no stale figure');
});

test('http transport: long-polled events become notifications, in order, with the cursor advanced', async () => {
  const urls: string[] = [];
  const batches = [
    { seq: 2, events: [{ method: 'previewUpdated', params: { uri: 'a' } }, { method: 'document', params: { uri: 'b' } }] },
    { seq: 3, events: [{ method: 'previewUpdated', params: { uri: 'b' } }] },
  ];
  let t: HttpTransport;
  const got: string[] = [];
  const done = new Promise<void>((resolve) => {
    const fetchFn: FetchFn = async (url) => {
      urls.push(url);
      const b = batches.shift();
      if (!b) {
        resolve();
        return new Promise(() => {}); // hang like a long poll
      }
      return { ok: true, status: 200, json: async () => b, text: async () => '' };
    };
    t = new HttpTransport('http://h', fetchFn, 1);
    t.onNotification((m, p) => got.push(`${m}:${(p as { uri: string }).uri}`));
    t.start();
  });
  await done;
  t!.dispose();
  assert.deepEqual(got, ['previewUpdated:a', 'document:b', 'previewUpdated:b']);
  assert.deepEqual(urls, ['http://h/api/events?after=0', 'http://h/api/events?after=2', 'http://h/api/events?after=3']);
});

test('the transport is picked from the environment', () => {
  const win = new FakeWindow();
  const vs = detectTransport({
    acquireVsCodeApi: () => ({ postMessage: () => {} }),
    addEventListener: win.addEventListener.bind(win),
    removeEventListener: win.removeEventListener.bind(win),
  });
  assert.equal(vs.kind, 'vscode');
  const http = detectTransport({ location: { origin: 'http://127.0.0.1:1' }, fetch: (async () => ({})) as unknown as FetchFn });
  assert.equal(http.kind, 'http');
  assert.throws(() => detectTransport({}), /no host/);
});
