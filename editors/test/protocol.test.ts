import assert from 'node:assert/strict';
import { test } from 'node:test';
import { ProtocolError, bytesToBase64, decodeF32, decodeModel, decodePreview, decodeU32, findPick } from '../preview/src/protocol.js';

const b64f32 = (xs: number[]) => bytesToBase64(new Uint8Array(new Float32Array(xs).buffer));
const b64u32 = (xs: number[]) => bytesToBase64(new Uint8Array(new Uint32Array(xs).buffer));

const triangleModel = (positions: unknown, indices: unknown) => ({
  materials: [{ name: 'bark', color: [0.45, 0.32, 0.2], roughness: 0.9, metallic: 0, opacity: 1 }],
  parts: [
    {
      material: 0,
      positions,
      normals: null,
      indices,
      picks: [
        { first_triangle: 0, triangle_count: 1, kind: 'bone', index: 0, module: 3, origin: 1 },
        { first_triangle: 1, triangle_count: 1, kind: 'instance', index: 0, module: 5, origin: 2 },
      ],
    },
  ],
  bones: [{ base: [0, 0, 0], tip: [0, 1, 0], width: 0.1, module: 3, origin: 1 }],
});

test('a model decodes the same from numbers and from base64', () => {
  const pos = [0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0.5];
  const idx = [0, 1, 2, 2, 1, 3];
  const a = decodeModel(triangleModel(pos, idx));
  const b = decodeModel(triangleModel(b64f32(pos), b64u32(idx)));
  assert.deepEqual(a, b);
  assert.equal(a.triangles, 2);
  assert.deepEqual(Array.from(a.parts[0].positions), pos);
  assert.deepEqual(a.bounds, { min: [0, 0, 0], max: [1, 1, 0.5] });
  assert.equal(a.bones[0].origin, 1);
});

test('malformed models are refused, not drawn', () => {
  const pos = [0, 0, 0, 1, 0, 0, 0, 1, 0];
  assert.throws(() => decodeModel(triangleModel(pos, [0, 1, 3])), /out of range \(3 vertices\)/);
  assert.throws(() => decodeModel(triangleModel(pos, [0, 1])), /not a multiple of 3/);
  assert.throws(() => decodeModel(triangleModel([0, 0], [])), /not a multiple of 3/);
  assert.throws(() => decodeModel(triangleModel([0, 0, 'x'], [])), ProtocolError);
  assert.throws(() => decodeF32('AAA', 'x'), /whole number of f32/);
  assert.throws(() => decodeU32([1.5], 'x'), /not an index/);
});

test('picks find the range holding a triangle', () => {
  const m = decodeModel(triangleModel([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0], [0, 1, 2, 2, 1, 3]));
  assert.equal(findPick(m.parts[0], 0)?.origin, 1);
  assert.equal(findPick(m.parts[0], 1)?.kind, 'instance');
  assert.equal(findPick(m.parts[0], 2), null);
});

test('a preview result decodes with its parameters, rules and error', () => {
  const r = decodePreview({
    id: 4,
    uri: 'file:///t.grm',
    system: 'Tree',
    mode: 'sample',
    seed: 3,
    params: [{ name: 'spread', value: 30, min: 10, max: 60, default: 30 }],
    curves: { version: 1, curves: [] },
    curves_path: '/t.curves.json',
    model: null,
    error: 'E0101: no axiom',
    diagnostics: [{ message: 'no axiom', severity: 'error', line: 2, character: 4, code: 'E0101' }],
    rules: [{ origin: 0, label: 'A -> B', line: 5, character: 4 }],
    timings: { sample: 12.5 },
  });
  assert.equal(r.id, 4);
  assert.equal(r.mode, 'sample');
  assert.equal(r.params[0].max, 60);
  assert.equal(r.curvesPath, '/t.curves.json');
  assert.equal(r.model, null);
  assert.equal(r.error, 'E0101: no axiom');
  assert.equal(r.rules[0].line, 5);
  assert.equal(r.timings.sample, 12.5);
  assert.throws(() => decodePreview({ mode: 'gpu' }), /unknown mode/);
});
