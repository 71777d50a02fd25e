// Shape mode's pick in the preview without a browser: `grm/pick`'s `shape`
// decoded (locators, the operation that made the shape, its path's scopes),
// bad scopes refused, and the scopes as line segments: boxes (a face as
// its rectangle), the picked shape's own box, and each split plane.
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { ProtocolError, type ScopeBox, decodePick, decodePreview, modeFromSymbols } from '../preview/src/protocol.js';
import { scopeLines } from '../preview/src/scopes.js';

const RANGE = { start: { line: 17, character: 14 }, end: { line: 17, character: 58 } };

/** A facade 24 wide and 12 high (model frame: x along, y up, z out), split at 4 along y, and one tile of it. */
function pick(scopes: unknown[] = SCOPES) {
  return {
    uri: 'file:///t.grm',
    range: RANGE,
    symbol: 'Wall',
    version: 2,
    module: 40,
    key: '615544b3',
    ancestry: [],
    shape: { node: 40, exact: '{Lot, 1, Wall}', semantic: '(facade = 1/1, floor = 1/2) Wall', madeBy: 'split.x', scopes },
  };
}

const X = [1, 0, 0];
const Y = [0, 1, 0];
const Z = [0, 0, 1];
const SCOPES = [
  { node: 0, label: 'Mass', command: false, origin: [0, 0, 0], axes: [X, Y, Z], size: [24, 12, 10] },
  { node: 3, label: 'split.y', command: true, origin: [0, 0, 0], axes: [X, Y, Z], size: [24, 12, 0], axis: 1, cuts: [4] },
  { node: 40, label: 'Wall', command: false, origin: [0, 4, 0], axes: [X, Y, Z], size: [3, 8, 0] },
];

test('a shape pick decodes its locators and scopes', () => {
  const r = decodePick(pick());
  assert.ok(r && r.shape);
  assert.equal(r.key, '615544b3');
  assert.equal(r.shape.semantic, '(facade = 1/1, floor = 1/2) Wall');
  assert.equal(r.shape.madeBy, 'split.x');
  assert.equal(r.shape.rule, null);
  assert.equal(r.shape.scopes.length, 3);
  assert.deepEqual(r.shape.scopes[1].cuts, [4]);
  assert.equal(r.shape.scopes[1].axis, 1);
  assert.equal(r.shape.scopes[0].axis, null);
  // A pick of another mode has no shape.
  const plain = decodePick({ uri: 'file:///t.grm', range: RANGE, symbol: 'A', version: 1, module: 3 });
  assert.equal(plain?.shape, null);
  assert.equal(plain?.key, null);
});

test('bad scopes are refused', () => {
  assert.throws(() => decodePick(pick([{ ...SCOPES[0], axes: [X, Y] }])), ProtocolError);
  assert.throws(() => decodePick(pick([{ ...SCOPES[0], origin: [0, 'a', 0] }])), ProtocolError);
  assert.throws(() => decodePick(pick([{ ...SCOPES[0], size: [1, 2] }])), ProtocolError);
});

test('scopes become boxes, the picked box and split planes', () => {
  const r = decodePick(pick());
  const lines = scopeLines(r?.shape?.scopes ?? []);
  // The mass: a box's 12 edges; the wall (picked): a face's 4; the split: one plane across the facade.
  assert.equal(lines.boxCount, 2);
  assert.equal(lines.cutCount, 1);
  assert.equal(lines.boxes.length, 12 * 6);
  assert.equal(lines.picked.length, 4 * 6);
  // The plane at y = 4 across the facade's 24 (its z extent is 0: a segment).
  assert.deepEqual(lines.cuts, [0, 4, 0, 24, 4, 0]);
  // The picked face's corners lie on its rectangle.
  const ys = new Set<number>();
  for (let i = 1; i < lines.picked.length; i += 3) ys.add(lines.picked[i]);
  assert.deepEqual([...ys].sort((a, b) => a - b), [4, 12]);
});

test('a turned scope is drawn along its own axes', () => {
  // A wall facing -x: x along -z, y up, z out along -x; cut at 1 along its x.
  const s: ScopeBox = { node: 1, label: 'split.x', command: true, origin: [0, 0, 5], axes: [[0, 0, -1], [0, 1, 0], [-1, 0, 0]], size: [5, 3, 0], axis: 0, cuts: [1], key: null, planes: [] };
  const lines = scopeLines([s]);
  assert.deepEqual(lines.cuts, [0, 0, 4, 0, 3, 4]);
});

test('shape systems are a mode of the page', () => {
  const base = { uri: 'file:///t.grm', version: 1, system: 'T', seed: 1, encoding: 'base64-le', materials: [], parts: [], skeleton: { boneCount: 0 }, origins: [] };
  assert.equal(decodePreview({ ...base, mode: 'shape' }).mode, 'shape');
  assert.throws(() => decodePreview({ ...base, mode: 'other' }), ProtocolError);
  assert.equal(modeFromSymbols([{ kind: 3, name: 'T', detail: 'system (shape)' }]), 'shape');
});
