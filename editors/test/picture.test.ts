// The page's "Save picture" without a browser: the request it sends, the
// file name, the PNG header check, and the decoding of both kinds of answer.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { MAX_FOV, METHODS, parsePageMessage, usableCamera } from '../preview/src/messages.js';
import { pictureFileName, pictureParams, pictureSize, pngSize } from '../preview/src/picture.js';
import { ProtocolError, base64ToBytes, bytesToBase64, decodePicture } from '../preview/src/protocol.js';
import { PageState } from '../preview/src/state.js';
import { pngHeader } from './png.js';

test('picture is a page request method', () => {
  assert.ok(METHODS.includes('picture'));
  assert.deepEqual(parsePageMessage({ type: 'request', id: 2, method: 'picture', params: {} }), { type: 'request', id: 2, method: 'picture', params: {} });
});

test("the picture request is the preview request's, with the camera's view and the canvas' shape at 1024 pixels", () => {
  const s = new PageState();
  s.setDocument('file:///w/calder.grm');
  s.mode = 'sample';
  s.seed = 12;
  s.setParamInfo([{ name: 'spread', value: 30, default: 30, min: 10, max: 60 }]);
  s.setParam('spread', 45);
  s.loadCurves('/w/calder.curves.json', JSON.stringify({ version: 1, curves: [{ name: 'a', points: [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] }] }));
  s.focus = { line: 3, character: 1 };
  const preview = s.previewParams();
  assert.equal(preview.live, true);
  assert.ok(preview.focus);
  const p = pictureParams(preview, { azimuth: -24.5, elevation: 17.25 }, { width: 800, height: 500 });
  // Everything that decides the model is the preview's; live and focus are not a picture's.
  assert.deepEqual(p, {
    textDocument: { uri: 'file:///w/calder.grm' },
    mode: 'sample',
    seed: 12,
    params: { spread: 45 },
    curves: preview.curves,
    view: { azimuth: -24.5, elevation: 17.25 },
    width: 1024,
    height: 640,
  });
  assert.ok(Array.isArray((p.curves as { curves: unknown[] }).curves));
  // The preview's own parameters are left as they were.
  assert.equal(preview.live, true);
  // A portrait canvas: the height is the longer side.
  assert.deepEqual([pictureParams(preview, null, { width: 300, height: 600 }).width, pictureParams(preview, null, { width: 300, height: 600 }).height], [512, 1024]);
  // No direction (a zero vector) or no canvas (a hidden panel): the server's own view and size.
  const bare = pictureParams({ textDocument: { uri: 'u' }, mode: 'derive', live: true }, null, { width: 0, height: 0 });
  assert.deepEqual(bare, { textDocument: { uri: 'u' }, mode: 'derive' });
  // An elevation a rounding error past the pole is taken to it, not refused.
  assert.deepEqual(pictureParams(bare, { azimuth: 0, elevation: 90.0000001 }, { width: 1, height: 1 }).view, { azimuth: 0, elevation: 90 });
  assert.equal(pictureParams(bare, { azimuth: Number.NaN, elevation: 0 }, { width: 1, height: 1 }).view, undefined);
  assert.deepEqual(pictureSize(1100, 677), { width: 1024, height: 630 });
});

test("the picture request takes the preview's camera (zoom, pan, perspective) in place of its direction", () => {
  const preview = { textDocument: { uri: 'file:///w/tree.grm' }, mode: 'derive' as const, seed: 3, live: true };
  const view = { azimuth: 24.2, elevation: 17.7 };
  const camera = { position: [-1.5, 2.25, 6] as [number, number, number], target: [0, 1.75, -0.5] as [number, number, number], fov: 45 };
  const p = pictureParams(preview, view, { width: 800, height: 500 }, camera);
  // The camera alone: the server refuses a view and a camera together. The canvas' shape stays.
  assert.deepEqual(p, { textDocument: { uri: 'file:///w/tree.grm' }, mode: 'derive', seed: 3, camera, width: 1024, height: 640 });
  assert.equal('view' in p, false);
  // A copy: moving the camera later does not change a request already made.
  assert.notEqual(p.camera?.position, camera.position);
  camera.position[0] = 99;
  assert.equal(p.camera?.position[0], -1.5);
  camera.position[0] = -1.5;
  // Any field of view the server takes: narrow (a zoom) or wide, up to 179 degrees.
  for (const fov of [1e-3, 12.5, 179]) assert.equal(pictureParams(preview, view, { width: 1, height: 1 }, { ...camera, fov }).camera?.fov, fov);
  // A camera the server cannot draw through: the view's direction, fitted to the model, as before cameras.
  for (const bad of [
    { ...camera, position: [Number.NaN, 2, 6] },
    { ...camera, target: [0, Number.POSITIVE_INFINITY, 0] },
    { ...camera, position: [0, 1.75, -0.5] },
    { ...camera, position: [-0, 1.75, -0.5] },
    { ...camera, position: [1, 2] },
    { ...camera, fov: 0 },
    { ...camera, fov: -45 },
    { ...camera, fov: 180 },
    { ...camera, fov: Number.NaN },
  ] as (typeof camera)[]) {
    const q = pictureParams(preview, view, { width: 800, height: 500 }, bad);
    assert.deepEqual(q, { textDocument: { uri: 'file:///w/tree.grm' }, mode: 'derive', seed: 3, view, width: 1024, height: 640 }, JSON.stringify(bad));
  }
  // No camera at all (as before): the view; neither: the server's automatic view.
  assert.deepEqual(pictureParams(preview, view, { width: 0, height: 0 }, null), { textDocument: { uri: 'file:///w/tree.grm' }, mode: 'derive', seed: 3, view });
  assert.deepEqual(pictureParams(preview, null, { width: 0, height: 0 }, { ...camera, fov: 0 }), { textDocument: { uri: 'file:///w/tree.grm' }, mode: 'derive', seed: 3 });
});

test('a usable camera: finite, two different points, a field of view the server takes', () => {
  const camera = { position: [1, 2, 3], target: [0, 0, 0], fov: 45 };
  assert.deepEqual(usableCamera(camera), camera);
  assert.deepEqual(usableCamera({ ...camera, extra: 1 }), camera);
  assert.equal(MAX_FOV, 179);
  for (const bad of [null, undefined, 1, [1, 2, 3], {}, { ...camera, fov: undefined }, { ...camera, fov: '45' }, { ...camera, position: '1,2,3' }, { ...camera, target: [0, 0, '0'] }, { ...camera, target: [0, 0, 0, 0] }, { ...camera, target: [1, 2, 3] }]) {
    assert.equal(usableCamera(bad), null, JSON.stringify(bad));
  }
});

test('the picture file is named after the grammar', () => {
  assert.equal(pictureFileName('file:///w/tree.grm'), 'tree.png');
  assert.equal(pictureFileName('file:///w/Calder_Tree.GRM'), 'Calder_Tree.png');
  assert.equal(pictureFileName('file:///c%3A/w/my%20plant.grm'), 'my plant.png');
  assert.equal(pictureFileName('file:///w/notes.txt'), 'notes.txt.png');
  assert.equal(pictureFileName('untitled:Untitled-1'), 'Untitled-1.png');
  assert.equal(pictureFileName('file:///w/tree.grm?x=1#y'), 'tree.png');
  assert.equal(pictureFileName('file:///w/a%3Ab%2A.grm'), 'a_b_.png');
  assert.equal(pictureFileName('file:///w/100%.grm'), '100%.png');
  assert.equal(pictureFileName('file:///'), 'picture.png');
  assert.equal(pictureFileName('file:///w/.grm'), 'picture.png');
  assert.equal(pictureFileName(''), 'picture.png');
});

test('the size a PNG header says; other bytes are not a PNG', () => {
  assert.deepEqual(pngSize(pngHeader(1024, 630)), { width: 1024, height: 630 });
  assert.deepEqual(pngSize(pngHeader(70000, 1)), { width: 70000, height: 1 });
  // A view into a larger buffer is read from its own start.
  const big = new Uint8Array(40);
  big.set(pngHeader(3, 5), 7);
  assert.deepEqual(pngSize(big.subarray(7)), { width: 3, height: 5 });
  assert.equal(pngSize(pngHeader(3, 5).subarray(0, 23)), null);
  const gif = pngHeader(3, 5);
  gif.set([0x47, 0x49, 0x46]);
  assert.equal(pngSize(gif), null);
});

test("a picture answer: the server's PNG to download, or where the extension saved it", () => {
  const png = pngHeader(1024, 640);
  const wire = { uri: 'file:///w/tree.grm', version: 2, system: 'Tree', seed: 7, width: 1024, height: 640, view: { azimuth: 1, elevation: 2 }, png: bytesToBase64(png), triangles: 5, bones: 1 };
  const r = decodePicture(wire);
  assert.deepEqual([r.system, r.seed, r.width, r.height, r.saved], ['Tree', 7, 1024, 640, undefined]);
  assert.deepEqual(r.png, png);
  // base64 to bytes and back.
  assert.deepEqual(base64ToBytes(wire.png), png);
  assert.deepEqual(decodePicture({ ...wire, png: undefined, saved: '/w/tree.png' }), { system: 'Tree', seed: 7, width: 1024, height: 640, png: null, saved: '/w/tree.png' });
  assert.equal(decodePicture({ ...wire, png: undefined, saved: null }).saved, null);
  // What cannot be saved as the picture asked for is an error.
  for (const [bad, why] of [
    [{ ...wire, png: undefined }, /neither/],
    [{ ...wire, png: bytesToBase64(new Uint8Array([1, 2, 3])) }, /not a PNG/],
    [{ ...wire, png: '***' }, /not base64|not a PNG/],
    [{ ...wire, width: 512 }, /1024x640, the answer says 512x640/],
    [{ ...wire, height: 'x' }, /height/],
    [null, /expected an object/],
  ] as const) {
    assert.throws(() => decodePicture(bad), (e: unknown) => e instanceof ProtocolError && why.test(e.message), JSON.stringify(bad));
  }
});
