import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';
import { CurvesError, DEFAULT_PARAMS, cloneSet, formatNumber, freshName, parseCurves, serializeCurves } from '../preview/src/curves.js';

const examples = join(import.meta.dirname, '../../../examples');

test('the example curves files parse, with defaults applied', () => {
  const set = parseCurves(readFileSync(join(examples, 'calder_tree.curves.json'), 'utf8'));
  assert.equal(set.curves.length, 3);
  assert.deepEqual(set.curves.map((c) => c.name), ['trunk', 'left_arm', 'right_arm']);
  assert.deepEqual(set.curves[0].points[3], [0, 4, 0]);
  assert.equal(set.curves[1].params.utilization_scale, 100);
  assert.equal(set.curves[1].params.alignment_offset, 0.6);
  const vine = parseCurves(readFileSync(join(examples, 'vine_wall.curves.json'), 'utf8'));
  assert.ok(vine.curves.length >= 2);
  assert.equal(vine.curves[0].params.thickness, 0.15);
});

test('the canonical text reads back to the same curves', () => {
  const set = parseCurves(readFileSync(join(examples, 'calder_tree.curves.json'), 'utf8'));
  set.density = { radius: 0.5, scale: 20 };
  set.curves[2].params.alignment_offset = -0.25;
  set.curves[0].points[1] = [0.1, 1.3333333333333333, -0];
  const text = serializeCurves(set);
  assert.match(text, /"version": 1,/);
  assert.doesNotMatch(text, /defaults/);
  assert.match(text, /"alignment_scale": 400\.0,/);
  assert.deepEqual(parseCurves(text), set);
  assert.equal(serializeCurves(parseCurves(text)), text);
});

test('numbers are written as grm-guide writes them', () => {
  assert.equal(formatNumber(0), '0.0');
  assert.equal(formatNumber(-0), '-0.0');
  assert.equal(formatNumber(100), '100.0');
  assert.equal(formatNumber(0.6), '0.6');
  assert.equal(formatNumber(1e-7), '1e-7');
  assert.equal(formatNumber(1e21), '1e+21');
  assert.throws(() => formatNumber(NaN), CurvesError);
});

test('invalid files are refused with the curve and the field named', () => {
  const base = { version: 1, curves: [{ name: 'a', points: [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] }] };
  const bad = (patch: (j: any) => void, re: RegExp) => {
    const j = structuredClone(base) as any;
    patch(j);
    assert.throws(() => parseCurves(JSON.stringify(j)), (e: Error) => e instanceof CurvesError && re.test(e.message), re.source);
  };
  bad((j) => (j.version = 2), /version 2 is not supported/);
  bad((j) => (j.curves[0].alignment_offset = 1.5), /curve 0 \("a"\): alignment_offset 1.5 is outside/);
  bad((j) => (j.curves[0].alignmnet_scale = 1), /alignmnet_scale is not a known curve key/);
  bad((j) => j.curves[0].points.pop(), /exactly 4 control points/);
  bad((j) => (j.curves[0].points = [[1, 1, 1], [1, 1, 1], [1, 1, 1], [1, 1, 1]]), /coincide/);
  bad((j) => j.curves.push(structuredClone(j.curves[0])), /used twice/);
  bad((j) => (j.defaults = { segment_length: 0 }), /segment_length 0 must be > 0/);
  bad((j) => (j.curves[0].distance = [0, -1, 0]), /m1 and m2 must be >= 0/);
  bad((j) => (j.curves = []), /at least one curve/);
  bad((j) => (j.density = { radius: 0, scale: 1 }), /radius 0 must be > 0/);
  assert.throws(() => parseCurves('{ "version": 1, '), /invalid JSON/);
});

test('serializing refuses what the sampler would refuse', () => {
  assert.throws(() => serializeCurves({ curves: [] }), /at least one curve/);
  const set = { curves: [{ points: [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]], params: { ...DEFAULT_PARAMS, thickness: -1 } }] } as any;
  assert.throws(() => serializeCurves(set), /thickness -1 must be >= 0/);
});

test('fresh names and deep copies', () => {
  const set = parseCurves(readFileSync(join(examples, 'calder_tree.curves.json'), 'utf8'));
  assert.equal(freshName(set), 'curve1');
  set.curves[0].name = 'curve1';
  assert.equal(freshName(set), 'curve2');
  const copy = cloneSet(set);
  copy.curves[0].points[0][0] = 42;
  copy.curves[0].params.distance[2] = 1;
  assert.equal(set.curves[0].points[0][0], 0);
  assert.equal(set.curves[0].params.distance[2], 100);
});
