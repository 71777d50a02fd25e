// The extension's pure helpers: the export command line and the webview HTML.
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';
import { defaultOutput, exportArgs, firstSystemMode } from '../vscode/src/exportArgs.js';
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
