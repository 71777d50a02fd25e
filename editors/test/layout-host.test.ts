// VS Code's host for the layout view (issue 29): the page's layout
// requests go to the server for the shown sidecar only, and the server's
// `grm/layoutUpdated` reaches the page only for the document it shows.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { type HostToPage } from '../preview/src/messages.js';
import { type HostDeps, PreviewHost } from '../vscode/src/host.js';

function layoutHost() {
  const posted: HostToPage[] = [];
  const requests: Array<[string, unknown]> = [];
  const deps: HostDeps = {
    request: async (method, params) => {
      requests.push([method, params]);
      return { method };
    },
    readFile: async () => null,
    writeFile: async () => {},
    savePicture: async () => null,
    reveal: async () => {},
    fsPath: (uri) => (uri.startsWith('file://') ? uri.slice('file://'.length) : null),
    post: (m) => posted.push(m),
  };
  return { host: new PreviewHost(deps), posted, requests };
}

const CITY = 'file:///w/city.layout.json';

test('layout requests go to the server for the shown sidecar, and no other', async () => {
  const { host, posted, requests } = layoutHost();
  host.setDocument(CITY, 'city.layout.json');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 1, method: 'layout', params: { uri: CITY } });
  await host.handle({ type: 'request', id: 2, method: 'layoutEdit', params: { uri: CITY, layer: 0, op: { visible: false } } });
  await host.handle({ type: 'request', id: 3, method: 'layoutCity', params: { uri: CITY, width: 10, height: 10 } });
  assert.deepEqual(
    requests.map(([m]) => m),
    ['grm/layout', 'grm/layoutEdit', 'grm/layoutCity'],
  );
  assert.deepEqual(requests[1][1], { uri: CITY, layer: 0, op: { visible: false } });
  assert.deepEqual(posted.at(-1), { type: 'response', id: 3, result: { method: 'grm/layoutCity' } });
  await host.handle({ type: 'request', id: 4, method: 'layout', params: { uri: 'file:///w/other.layout.json' } });
  const last = posted.at(-1) as { type: string; id: number; error?: string };
  assert.equal(last.id, 4);
  assert.match(last.error ?? '', /shows file:\/\/\/w\/city\.layout\.json/);
  assert.equal(requests.length, 3, 'another document is not asked about');
});

test("the server's layoutUpdated reaches the page for the shown sidecar only", async () => {
  const { host, posted } = layoutHost();
  host.setDocument(CITY, 'city.layout.json');
  await host.handle({ type: 'ready' });
  host.layoutUpdated({ uri: 'file:///w/other.layout.json', version: 2 });
  host.layoutUpdated('junk');
  host.layoutUpdated({ uri: CITY, version: 3 });
  assert.deepEqual(posted.slice(1), [{ type: 'notify', method: 'layoutUpdated', params: { uri: CITY, version: 3 } }]);
});

test("the 3D mode's city is asked with binary when the server sends blobs, and its blob reaches the page beside the answer", async () => {
  const posted: HostToPage[] = [];
  const requests: Array<[string, unknown]> = [];
  const blob = new ArrayBuffer(12);
  const taken: number[] = [];
  const deps: HostDeps = {
    request: async (method, params) => {
      requests.push([method, params]);
      return { encoding: 'blob-le', blob: { id: 5, bytes: 12 }, parts: [] };
    },
    readFile: async () => null,
    writeFile: async () => {},
    savePicture: async () => null,
    reveal: async () => {},
    fsPath: (uri) => (uri.startsWith('file://') ? uri.slice('file://'.length) : null),
    post: (m) => posted.push(m),
    blobs: {
      enabled: () => true,
      take: (id) => {
        taken.push(id);
        return id === 5 ? blob : undefined;
      },
    },
  };
  const host = new PreviewHost(deps);
  const grm = 'file:///w/city.grm';
  host.setDocument(grm, 'city.grm');
  await host.handle({ type: 'ready' });
  await host.handle({ type: 'request', id: 7, method: 'layoutCity', params: { uri: grm } });
  assert.deepEqual(requests, [['grm/layoutCity', { uri: grm, binary: true }]]);
  assert.deepEqual(taken, [5]);
  const last = posted.at(-1) as { type: string; id: number; blob?: ArrayBuffer };
  assert.equal(last.id, 7);
  assert.equal(last.blob, blob, 'the blob goes beside the answer');
});
