import assert from 'node:assert/strict';
import { test } from 'node:test';
import {
  ProtocolError,
  bytesToBase64,
  decodeF32,
  decodePick,
  decodePicks,
  decodePreview,
  decodePreviewUpdated,
  decodeU32,
  findPick,
  modeFromSymbols,
  paramsFromSymbols,
} from '../preview/src/protocol.js';

const b64f32 = (xs: number[]) => bytesToBase64(new Uint8Array(new Float32Array(xs).buffer));
const b64u32 = (xs: number[]) => bytesToBase64(new Uint8Array(new Uint32Array(xs).buffer));

/** A grm/preview result as crates/grm-lsp/src/preview.rs writes it. */
function wire(positions: number[], indices: number[], over: Record<string, unknown> = {}) {
  return {
    uri: 'file:///t.grm',
    version: 3,
    system: 'Tree',
    mode: 'derive',
    seed: 7,
    iterations: 4,
    encoding: 'base64-le',
    materials: [{ name: 'bark', color: [0.45, 0.32, 0.2], roughness: 0.9, metallic: 0, emissive: [0, 0, 0], opacity: 1 }],
    parts: [
      {
        material: 0,
        vertexCount: positions.length / 3,
        triangleCount: indices.length / 3,
        positions: b64f32(positions),
        normals: b64f32(positions.map(() => 0)),
        indices: b64u32(indices),
        // Six u32 per pick: first triangle, count, kind (+256 focus), index, module, origin.
        pickCount: 2,
        picks: b64u32([0, 1, 0 + 256, 0, 3, 1, 1, 1, 1, 0, 5, 0xffffffff]),
      },
    ],
    skeleton: {
      boneCount: 2,
      bones: b64f32([0, 0, 0, 0, 1, 0, 0.1, 0.08, 0, 1, 0, 1, 2, 0, 0.08, 0.05]),
      parents: bytesToBase64(new Uint8Array(new Int32Array([-1, 0]).buffer)),
      origins: b64u32([1, 0xffffffff]),
    },
    origins: [
      { uri: 'file:///t.grm', range: { start: { line: 2, character: 4 }, end: { line: 2, character: 9 } }, symbol: 'axiom' },
      { uri: 'file:///t.grm', range: { start: { line: 5, character: 4 }, end: { line: 5, character: 30 } }, symbol: 'A' },
    ],
    focus: { origin: 1, bones: 1, instances: 0, spreadBones: [1, 2, 1] },
    stats: { modules: 9, triangles: 2, boundsMin: [0, 0, 0], boundsMax: [1, 2, 0.5], deriveMs: 0.5, buildMs: 1.25, encodeMs: 0.1 },
    ...over,
  };
}

test('a preview result decodes: parts, picks with origins and focus, skeleton, origins, timings', () => {
  const pos = [0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.5];
  const r = decodePreview(wire(pos, [0, 1, 2, 2, 1, 3]));
  assert.equal(r.version, 3);
  assert.equal(r.seed, 7);
  assert.deepEqual(Array.from(r.model.parts[0].positions), pos);
  assert.equal(r.model.triangles, 2);
  assert.deepEqual(r.model.parts[0].picks[0], { firstTriangle: 0, triangleCount: 1, kind: 'bone', index: 0, module: 3, origin: 1, focus: true });
  assert.equal(r.model.parts[0].picks[1].origin, null);
  assert.equal(r.model.bones.length, 2);
  assert.deepEqual(r.model.bones[1], { base: [0, 1, 0], tip: [1, 2, 0], width: Math.fround(0.08), origin: null, parent: 0 });
  assert.equal(r.model.bones[0].origin, 1);
  assert.equal(r.model.bones[0].parent, null, 'a root');
  assert.deepEqual(r.model.bounds, { min: [0, 0, 0], max: [1, 2, 0.5] });
  assert.equal(r.origins[1].symbol, 'A');
  assert.equal(r.origins[1].range.start.line, 5);
  assert.deepEqual(r.focus, { origin: 1, bones: 1, instances: 0, spreadBones: [1, 2, 1] });
  assert.deepEqual(r.timings, { derive: 0.5, build: 1.25, encode: 0.1 });
  assert.deepEqual(r.params, []);
});

test("the model's warnings decode; a server that sends none gives none", () => {
  const pos = [0, 0, 0, 1, 0, 0, 0, 1, 0];
  const w = { code: 'W0013', message: 'the model has no triangles', notes: ['2 bones have no tube'], help: 'give the bones a width' };
  const r = decodePreview(wire(pos, [0, 1, 2], { warnings: [w, { code: 'W0014', message: '1 instance left out', help: null }] }));
  assert.deepEqual(r.warnings, [w, { code: 'W0014', message: '1 instance left out', notes: [], help: null }]);
  assert.deepEqual(decodePreview(wire(pos, [0, 1, 2])).warnings, []);
  assert.throws(() => decodePreview(wire(pos, [0, 1, 2], { warnings: ['W0013'] })), /warnings\[0\]: expected an object/);
});

test('malformed models are refused, not drawn', () => {
  const pos = [0, 0, 0, 1, 0, 0, 0, 1, 0];
  assert.throws(() => decodePreview(wire(pos, [0, 1, 3])), /out of range \(3 vertices\)/);
  assert.throws(() => decodePreview(wire(pos, [0, 1])), /not a multiple of 3/);
  assert.throws(() => decodePreview(wire([0, 0], [])), /not a multiple of 3/);
  assert.throws(() => decodePreview(wire(pos, [0, 1, 2], { skeleton: { boneCount: 3, bones: b64f32([0, 0, 0]) } })), /8 each/);
  assert.throws(() => decodePreview(wire(pos, [0, 1, 2], { encoding: 'json' })), /unknown encoding/);
  assert.throws(() => decodePreview(wire(pos, [0, 1, 2], { mode: 'gpu' })), /unknown mode/);
  assert.throws(() => decodeF32('AAA', 'x'), /whole number of f32/);
  assert.throws(() => decodeU32([1.5], 'x'), /not an index/);
  assert.throws(() => decodeF32([0, 'x'], 'x'), ProtocolError);
});

test("a part in the quads layout is rebuilt: the fourth corner a + c - b, triangles a b c and a c d, flat normals computed", () => {
  // Two quads: a unit square, and a sheared one far from the origin.
  const corners = [0, 0, 0, 1, 0, 0, 1, 1, 0, 1000, -2000, 5, 1002, -1999.5, 5, 1002.25, -1996.5, 5];
  const r = decodePreview(
    wire([], [], {
      parts: [{ material: 0, vertexCount: 8, triangleCount: 4, positions: b64f32(corners), normals: '', indices: '', layout: 'quads', pickCount: 0, picks: '' }],
    }),
  );
  const part = r.model.parts[0];
  assert.equal(r.model.triangles, 4);
  assert.equal(part.normals, null);
  assert.deepEqual(Array.from(part.indices), [0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7]);
  const p = Array.from(part.positions);
  assert.deepEqual(p.slice(0, 12), [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0]);
  assert.deepEqual(p.slice(21, 24), [1000.25, -1997, 5]);
  assert.throws(
    () => decodePreview(wire([], [], { parts: [{ material: 0, positions: b64f32([0, 0, 0, 1]), indices: '', layout: 'quads', pickCount: 0, picks: '' }] })),
    /multiple of 9/,
  );
  assert.throws(() => decodePreview(wire([], [], { parts: [{ material: 0, positions: '', indices: '', layout: 'strips' }] })), /unknown layout/);
});

test('picks find the range holding a triangle', () => {
  const r = decodePreview(wire([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0], [0, 1, 2, 2, 1, 3]));
  assert.equal(findPick(r.model.parts[0], 0)?.origin, 1);
  assert.equal(findPick(r.model.parts[0], 1)?.kind, 'instance');
  assert.equal(findPick(r.model.parts[0], 2), null);
});

test("picks: six u32 each (a bad length, kind or count is refused); an older server's objects still decode", () => {
  assert.throws(() => decodePicks(b64u32([0, 1, 0, 0, 3]), 1, 'picks'), /whole number of picks/);
  assert.throws(() => decodePicks(b64u32([0, 1, 7, 0, 3, 1]), 1, 'picks'), /unknown kind code 7/);
  assert.throws(() => decodePicks(b64u32([0, 1, 3, 0, 3, 1]), 2, 'picks'), /pickCount says 2/);
  assert.deepEqual(decodePicks(b64u32([4, 2, 3 + 256, 9, 9, 0xffffffff]), 1, 'picks'), [
    { firstTriangle: 4, triangleCount: 2, kind: 'shape', index: 9, module: 9, origin: null, focus: true },
  ]);
  const old = [{ firstTriangle: 0, triangleCount: 1, kind: 'polygon', index: 2, module: 3, origin: 1, focus: false }];
  assert.deepEqual(decodePicks(old, undefined, 'picks'), old);
  assert.deepEqual(decodePicks(undefined, undefined, 'picks'), []);
});

test('an empty model (nothing drawn) has no bounds', () => {
  const r = decodePreview(wire([], [], { parts: [], skeleton: { boneCount: 0, bones: '', parents: '', origins: '' }, focus: null }));
  assert.equal(r.model.bounds, null);
  assert.equal(r.focus, null);
});

test('previewUpdated carries a result or an error; pick results decode or are null', () => {
  const u = decodePreviewUpdated({ uri: 'file:///t.grm', version: 4, result: wire([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2]), error: null });
  assert.equal(u.result?.model.triangles, 1);
  const e = decodePreviewUpdated({ uri: 'file:///t.grm', version: 5, result: null, error: 'the program has 1 error: fix it to preview' });
  assert.equal(e.result, null);
  assert.match(e.error ?? '', /1 error/);
  assert.equal(decodePick(null), null);
  const p = decodePick({ uri: 'file:///t.grm', range: { start: { line: 41, character: 4 }, end: { line: 44, character: 1 } }, symbol: 'branch', version: 3, module: 12 });
  assert.equal(p?.range.start.line, 41);
  assert.throws(() => decodePick({ uri: 'x' }), /expected a range/);
});

test('meta-parameters are read from the document symbols (numbers only)', () => {
  const symbols = [
    { name: 'delta', kind: 13, detail: '22.5 in 5 .. 45' },
    { name: 'lr', kind: 13, detail: '1.109 in 1 .. 2' },
    { name: 'neg', kind: 13, detail: '-0.5 in -1 .. 1e0' },
    { name: 'expr', kind: 13, detail: 'BASE * 2 in 0 .. 10' },
    { name: 'R', kind: 14, detail: '1.456' },
    { name: 'Plant', kind: 3, children: [] },
    { name: 'upside', kind: 13, detail: '5 in 10 .. 0' },
  ];
  const { params, skipped } = paramsFromSymbols(symbols);
  assert.deepEqual(params, [
    { name: 'delta', value: 22.5, min: 5, max: 45, default: 22.5 },
    { name: 'lr', value: 1.109, min: 1, max: 2, default: 1.109 },
    { name: 'neg', value: -0.5, min: -1, max: 1, default: -0.5 },
  ]);
  assert.deepEqual(skipped, ['expr', 'upside']);
  assert.deepEqual(paramsFromSymbols(null), { params: [], skipped: [] });
});

test("the first system's mode is read from its symbol", () => {
  assert.equal(modeFromSymbols([{ name: 'delta', kind: 13, detail: '1 in 0 .. 2' }, { name: 'T', kind: 3, detail: 'system (sample)' }, { name: 'U', kind: 3, detail: 'system (derive)' }]), 'sample');
  assert.equal(modeFromSymbols([{ name: 'U', kind: 3, detail: 'system (derive)' }]), 'derive');
  assert.equal(modeFromSymbols([{ name: 'x', kind: 3, detail: 'class' }]), null);
  assert.equal(modeFromSymbols('junk'), null);
});

test('meta-parameters and sampler figures in a result; a parameter without a numeric range gets no slider', () => {
  const r = decodePreview(
    wire([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2], {
      mode: 'sample',
      params: [
        { name: 'spread', value: 40, default: 30, min: 10, max: 60 },
        { name: 'k', value: 2, default: 2, min: null, max: null },
      ],
      sample: { objective: -1234.5, generations: 100, candidates: 15, stoppedEarly: false, curves: 'request' },
    }),
  );
  assert.deepEqual(r.params, [{ name: 'spread', value: 40, min: 10, max: 60, default: 30 }]);
  assert.deepEqual(r.paramsWithoutRange, ['k']);
  assert.deepEqual(r.sample, { objective: -1234.5, generations: 100, candidates: 15, stoppedEarly: false, curves: 'request', generation: null, coverage: [], refinements: 0 });
  assert.equal(decodePreview(wire([0, 0, 0, 1, 0, 0, 0, 1, 0], [0, 1, 2])).sample, null);
});

test('base64 decodes the same through the native decoder and atob', () => {
  const xs = [0, -1.5, 3.25, 1e-7, 65504];
  const b64 = b64f32(xs);
  const viaAtob = Array.from(decodeF32(b64, 'x'));
  const holder = Uint8Array as unknown as { fromBase64?: (s: string) => Uint8Array };
  const had = Object.prototype.hasOwnProperty.call(holder, 'fromBase64');
  const saved = holder.fromBase64;
  let calls = 0;
  holder.fromBase64 = function (this: unknown, s: string) {
    assert.equal(this, Uint8Array);
    calls++;
    return new Uint8Array(Buffer.from(s, 'base64'));
  };
  try {
    assert.deepEqual(Array.from(decodeF32(b64, 'x')), viaAtob);
    assert.deepEqual(Array.from(decodeU32(b64u32([7, 0xffffffff]), 'x')), [7, 0xffffffff]);
    assert.equal(calls, 2);
  } finally {
    if (had) holder.fromBase64 = saved;
    else delete holder.fromBase64;
  }
  assert.deepEqual(viaAtob, xs.map(Math.fround));
});
