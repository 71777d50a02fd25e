// The extension's pure helpers: the export command line and the webview HTML.
import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';
import { defaultOutput, exportArgs, firstSystemMode, framesSummary, framesWritten, isFrameOf, pictureSize } from '../vscode/src/exportArgs.js';
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
  // A scrubbed search: the generation shown; a result (none), or a bad number, adds nothing; derive mode never.
  const base = { grammar: '/w/t.grm', output: '/w/t.glb', curves: '/w/t.curves.json' };
  assert.deepEqual(exportArgs({ ...base, mode: 'sample', generation: 12 }), [
    'sample', '/w/t.grm', '--curves', '/w/t.curves.json', '--generation', '12', '-o', '/w/t.glb',
  ]);
  for (const generation of [undefined, -1, 1.5, Number.NaN]) {
    assert.ok(!exportArgs({ ...base, mode: 'sample', generation }).includes('--generation'), String(generation));
  }
  assert.ok(!exportArgs({ ...base, mode: 'derive', generation: 3 }).includes('--generation'));
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

test("export as a picture through the preview's camera: --camera, --look-at, --fov in full, else the view", () => {
  const view = { azimuth: -24.2277, elevation: 17.7016 };
  const imageSize = { width: 1024, height: 640 };
  const camera = { position: [-3.0517578125e-5, 2.4, 6.123456789] as [number, number, number], target: [0.1 + 0.2, 1.5, -0] as [number, number, number], fov: 45 };
  assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output: '/w/t.png', mode: 'derive', seed: 4, view, camera, imageSize }), [
    'derive', '/w/t.grm', '--seed', '4',
    // `=` keeps a negative coordinate from being taken for a flag; every digit, so grmc reads the very numbers back.
    '--camera=-0.000030517578125,2.4,6.123456789', '--look-at=0.30000000000000004,1.5,0', '--fov=45',
    '--image-size=1024x640', '-o', '/w/t.png',
  ]);
  const png = (c: unknown, v?: { azimuth: number; elevation: number }) =>
    exportArgs({ grammar: '/w/t.grm', output: '/w/t.png', mode: 'sample', view: v, camera: c as typeof camera }).filter((a) => /^--(view|camera|look-at|fov)/.test(a));
  // Whatever the numbers, each one reads back as itself (an exponent is one Rust's parser takes), and none is NaN or infinite.
  const odd = { position: [1e-7, -1e21, 123456.789], target: [5e-324, 0, -1.7976931348623157e308], fov: 0.5 };
  const args = png(odd);
  assert.deepEqual(args, ['--camera=1e-7,-1e+21,123456.789', '--look-at=5e-324,0,-1.7976931348623157e+308', '--fov=0.5']);
  const numbers = args.flatMap((a) => a.replace(/^--[a-z-]+=/, '').split(',')).map(Number);
  assert.deepEqual(numbers, [...odd.position, ...odd.target, odd.fov]);
  for (const a of args) assert.match(a, /^--[a-z-]+=[-+.e\d,]+$/, a);
  // A camera grmc cannot draw through: the view's angles as before; neither: grmc's own view.
  for (const bad of [
    { ...camera, position: [Number.NaN, 0, 1] },
    { ...camera, target: [0, Number.NEGATIVE_INFINITY, 0] },
    { ...camera, target: [...camera.position] },
    { ...camera, fov: 0 },
    { ...camera, fov: 179.5 },
    { ...camera, fov: Number.POSITIVE_INFINITY },
    { ...camera, position: [1, 2] },
    null,
  ]) {
    assert.deepEqual(png(bad, view), ['--view=-24.23,17.7'], JSON.stringify(bad));
    assert.deepEqual(png(bad), [], JSON.stringify(bad));
  }
  assert.deepEqual(png({ ...camera, fov: 179 }), ['--camera=-0.000030517578125,2.4,6.123456789', '--look-at=0.30000000000000004,1.5,0', '--fov=179']);
  // grmc refuses the picture flags for a model file.
  for (const output of ['/w/t.glb', '/w/t.obj']) {
    assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output, mode: 'derive', view, camera, imageSize }), ['derive', '/w/t.grm', '-o', output]);
  }
});

test('export frames: --frames with the preview\'s seed, parameters, camera and size; never --generation', () => {
  const camera = { position: [0, 2, 6] as [number, number, number], target: [0, 1, 0] as [number, number, number], fov: 45 };
  const view = { azimuth: 10, elevation: 20, camera };
  const imageSize = { width: 1024, height: 640 };
  // Derive, pictures: every iteration through the preview's camera, in its shape.
  assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output: '/w/f/t.png', mode: 'derive', seed: 4, params: { a: 1 }, frames: true, view, camera, imageSize }), [
    'derive', '/w/t.grm', '--frames', '--seed', '4', '--param', 'a=1',
    '--camera=0,2,6', '--look-at=0,1,0', '--fov=45', '--image-size=1024x640', '-o', '/w/f/t.png',
  ]);
  // Derive, glTF: no picture flags.
  assert.deepEqual(exportArgs({ grammar: '/w/t.grm', output: '/w/t.glb', mode: 'derive', system: 'Tree', frames: true, view, camera, imageSize }), [
    'derive', '/w/t.grm', '--system', 'Tree', '--frames', '-o', '/w/t.glb',
  ]);
  // Sample: the curves, every generation; the generation the preview shows is left out (grmc refuses both).
  const sample = { grammar: '/w/t.grm', mode: 'sample' as const, curves: '/w/t.curves.json', seed: 7, generation: 12, frames: true };
  assert.deepEqual(exportArgs({ ...sample, output: '/w/t.glb' }), [
    'sample', '/w/t.grm', '--curves', '/w/t.curves.json', '--frames', '--seed', '7', '-o', '/w/t.glb',
  ]);
  assert.deepEqual(exportArgs({ ...sample, output: '/w/t.png', view: { azimuth: -30, elevation: 15 }, imageSize }), [
    'sample', '/w/t.grm', '--curves', '/w/t.curves.json', '--frames', '--seed', '7', '--view=-30,15', '--image-size=1024x640', '-o', '/w/t.png',
  ]);
  for (const mode of ['derive', 'sample'] as const) {
    for (const output of ['/w/t.png', '/w/t.glb', '/w/t.obj']) {
      for (const generation of [undefined, 0, 12]) {
        const args = exportArgs({ grammar: '/w/t.grm', output, mode, generation, frames: true });
        assert.ok(args.includes('--frames'), `${mode} ${output} ${generation}`);
        assert.ok(!args.includes('--generation'), `${mode} ${output} ${generation}`);
      }
    }
  }
  // Without frames, as before: no --frames, the generation shown.
  assert.ok(!exportArgs({ ...sample, output: '/w/t.glb', frames: false }).includes('--frames'));
  assert.ok(exportArgs({ ...sample, output: '/w/t.glb', frames: false }).includes('--generation'));
});

test('export frames: the files grmc says it wrote, and what the command says', () => {
  assert.ok(isFrameOf('/w/f/tree.png', '/w/f/tree-0.png'));
  assert.ok(isFrameOf('/w/f/tree.png', '/w/f/tree-099.png'));
  assert.ok(isFrameOf('C:\\w\\my tree (2).v1.obj', 'C:\\w\\my tree (2).v1-12.obj'));
  for (const other of ['/w/f/tree.png', '/w/f/tree-0.mtl', '/w/f/tree-a.png', '/w/g/tree-0.png', '/w/f/treex-0.png', '/w/f/tree-0.png.png']) {
    assert.ok(!isFrameOf('/w/f/tree.png', other), other);
  }
  // grmc's stderr for `derive --frames -o /w/f (1)/tree.obj`: the statistics line, one `wrote` line per frame.
  const log = [
    'TernaryTree: 2 iterations: 44 modules (61 produced in all) in 0.3 ms, 20 modules/us',
    'wrote /w/f (1)/tree-0.obj (32 triangles, 1 bone)',
    'wrote /w/f (1)/tree-1.obj (128 triangles, 5 bones)',
    'wrote /w/f (1)/tree-2.obj (416 triangles, 17 bones)',
    'wrote /w/f (1)/tree.mtl',
    '',
  ].join('\n');
  const files = framesWritten(log, '/w/f (1)/tree.obj');
  assert.deepEqual(files, ['/w/f (1)/tree-0.obj', '/w/f (1)/tree-1.obj', '/w/f (1)/tree-2.obj']);
  assert.equal(framesSummary(files, '/w/f (1)/tree.obj'), 'Wrote 3 frames (tree-0.obj ... tree-2.obj, each with its .mtl) in /w/f (1)');
  // Pictures, Windows line ends, zero-padded.
  const pictures = framesWritten('wrote /w/s-00.png (200x200 picture of 68 triangles, 1 bone)\r\nwrote /w/s-01.png (200x200 picture of 120 triangles, 2 bones)\r\n', '/w/s.png');
  assert.deepEqual(pictures, ['/w/s-00.png', '/w/s-01.png']);
  assert.equal(framesSummary(['/w/s-0.png'], '/w/s.png'), 'Wrote 1 frame (s-0.png) in /w');
  assert.equal(framesSummary([], '/w/s.png'), 'grmc wrote no frames in /w');
  assert.equal(framesSummary(['/w/s-0.obj'], '/w/s.obj'), 'Wrote 1 frame (s-0.obj, with its .mtl) in /w');
  assert.deepEqual(framesWritten('error: something\n', '/w/s.png'), []);
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
