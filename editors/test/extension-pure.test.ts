// The extension's pure helpers: the export command line and the webview HTML.
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';
import { defaultOutput, exportArgs, firstSystemMode, pictureSize } from '../vscode/src/exportArgs.js';
import { makeNonce, webviewHtml } from '../vscode/src/webviewHtml.js';

test('export: derive systems use grmc derive with the preview seed and parameters', () => {
  assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output: '/w/t.glb', mode: 'derive', seed: 4, params: { b: 2, a: 1.5, bad: 'x' } }), [
    'derive', '/w/t.grm', '--seed', '4', '--param', 'a=1.5', '--param', 'b=2', '-o', '/w/t.glb',
  ]);
});

test('export: sample systems use grmc sample with the curves file', () => {
  assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output: '/w/t.obj', mode: 'sample', curves: '/w/t.curves.json', system: 'Tree' }), [
    'sample', '/w/t.grm', '--system', 'Tree', '--curves', '/w/t.curves.json', '-o', '/w/t.obj',
  ]);
  assert.equal(defaultOutput('/w/calder_tree.grm', 'glb'), '/w/calder_tree.glb');
  assert.equal(defaultOutput('/w/calder_tree.grm', 'obj'), '/w/calder_tree.obj');
});

test("export as a picture: the preview's view and shape, rounded, only for a .png output", () => {
  const view = { azimuth: -24.2277, elevation: 17.7016 };
  const imageSize = { width: 1024, height: 640 };
  assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output: '/w/T.PNG', mode: 'derive', seed: 4, view, imageSize }), [
    'derive', '/w/t.grm', '--seed', '4', '--view=-24.23,17.7', '--image-size=1024x640', '-o', '/w/T.PNG',
  ]);
  // grmc refuses the picture flags for a model file.
  for (const output of ['/w/t.glb', '/w/t.obj', '/w/t.png.glb']) {
    assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output, mode: 'derive', view, imageSize }), ['derive', '/w/t.grm', '-o', output]);
  }
  // Elevation within -90..90; -0 is 0; no view that is not a number; no size grmc would refuse.
  const png = (v: { azimuth: number; elevation: number }, size?: { width: number; height: number }) =>
    exportArgs({ grammar: '/w/t.grm', output: '/w/t.png', mode: 'sample', view: v, imageSize: size }).filter((a) => a.startsWith('--view') || a.startsWith('--image-size'));
  assert.deepEqual(png({ azimuth: 180, elevation: 95 }), ['--view=180,90']);
  assert.deepEqual(png({ azimuth: -0.001, elevation: -90.5 }), ['--view=0,-90']);
  assert.deepEqual(png({ azimuth: Number.NaN, elevation: 0 }), []);
  assert.deepEqual(png({ azimuth: 0, elevation: Number.POSITIVE_INFINITY }), []);
  for (const size of [{ width: 0, height: 10 }, { width: 10.5, height: 10 }, { width: 16385, height: 1 }, { width: 4097, height: 4096 }]) {
    assert.deepEqual(png({ azimuth: 1, elevation: 2 }, size), ['--view=1,2'], JSON.stringify(size));
  }
  assert.deepEqual(png({ azimuth: 1, elevation: 2 }, { width: 16384, height: 1024 }), ['--view=1,2', '--image-size=16384x1024']);
  // Without a preview: grmc's own view and size.
  assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output: '/w/t.png', mode: 'derive' }), ['derive', '/w/t.grm', '-o', '/w/t.png']);
  assert.equal(defaultOutput('/w/Calder_Tree.GRM', 'png'), '/w/Calder_Tree.png');
});

test("a picture has the preview canvas' shape, 1024 pixels on the longer side", () => {
  assert.deepEqual(pictureSize(800, 500), { width: 1024, height: 640 });
  assert.deepEqual(pictureSize(300.5, 901.5), { width: 341, height: 1024 });
  assert.deepEqual(pictureSize(640, 640), { width: 1024, height: 1024 });
  assert.deepEqual(pictureSize(5000, 1), { width: 1024, height: 1 });
  assert.deepEqual(pictureSize(400, 300, 2048), { width: 2048, height: 1536 });
  assert.equal(pictureSize(0, 300), undefined);
  assert.equal(pictureSize(300, Number.NaN), undefined);
});

test('export without a preview: the mode of the file\'s first system, the one grmc exports', () => {
  assert.equal(firstSystemMode('system A { mode = sample; axiom X; }'), 'sample');
  assert.equal(firstSystemMode('system A { axiom F; F -> F F; }\nsystem B { mode = sample; axiom X; }'), 'derive');
  assert.equal(firstSystemMode('// mode = sample\n/* system Z { mode = sample; } */\nsystem A { axiom F; }'), 'derive');
  assert.equal(firstSystemMode('import "mode = sample";\nsystem A { F -> [ { . } ]; mode = sample; }'), 'sample');
  assert.equal(firstSystemMode('const x = 1;'), 'derive');
  for (const [file, mode] of [['calder_tree.grm', 'sample'], ['vine_wall.grm', 'sample'], ['koch_island.grm', 'derive'], ['ternary_tree.grm', 'derive']] as const) {
    assert.equal(firstSystemMode(readFileSync(join(import.meta.dirname, '../../../examples', file), 'utf8')), mode, file);
  }
});

test('webview html: the real page template gets a CSP, a nonce and webview URIs', () => {
  const template = readFileSync(join(import.meta.dirname, '../../preview/index.html'), 'utf8');
  const html = webviewHtml(template, { scriptUri: 'vscode-resource:/p.js', styleUri: 'vscode-resource:/p.css', cspSource: 'vscode-webview:', nonce: 'N0NCE' });
  assert.match(html, /<meta http-equiv="Content-Security-Policy" content="default-src 'none'; [^"]*script-src 'nonce-N0NCE'">/);
  assert.match(html, /<script nonce="N0NCE" src="vscode-resource:\/p.js"><\/script>/);
  assert.match(html, /href="vscode-resource:\/p.css"/);
  assert.doesNotMatch(html, /src="preview.js"/);
  assert.throws(() => webviewHtml('<html></html>', { scriptUri: 'a', styleUri: 'b', cspSource: 'c', nonce: 'd' }), /expected script/);
});

test('nonces are 32 alphanumerics', () => {
  const n = makeNonce((k) => Uint8Array.from({ length: k }, (_, i) => i * 37));
  assert.match(n, /^[A-Za-z0-9]{32}$/);
});
