import assert from 'node:assert/strict';
import { readFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';
import {
  CurvesError,
  DEFAULT_PARAMS,
  MAX_COORDINATE,
  MAX_SEGMENTS_PER_CURVE,
  cloneSet,
  curveLength,
  formatNumber,
  freshName,
  parseCurves,
  segmentCount,
  serializeCurves,
  setProblem,
} from '../preview/src/curves.js';

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

// grm-guide limits a curve to 2048 utilization segments and a file to 8192
// (docs/curves.md, "Validation"): the editor refused neither, so the page
// applied (and VS Code saved) a segment length the sampler then refused.
test('too many utilization segments are refused, as grm-guide refuses them', () => {
  const line = (len: number) => [[0, 0, 0], [0, len / 3, 0], [0, (2 * len) / 3, 0], [0, len, 0]];
  assert.ok(Math.abs(curveLength(line(4) as any) - 4) < 1e-9);
  assert.equal(segmentCount(2.1, 0.3), 7);
  assert.equal(segmentCount(4, 0.2), 20);
  const file = (curves: unknown[]) => JSON.stringify({ version: 1, curves });
  // 4 / 0.0001 = 40000 segments (the calder trunk with a tiny segment length).
  assert.throws(
    () => parseCurves(file([{ name: 'trunk', points: line(4), segment_length: 0.0001 }])),
    (e: Error) => e instanceof CurvesError && /curve 0 \("trunk"\): segment_length 0.0001 splits the curve \(length 4.000\) into 40000 segments; at most 2048 are allowed/.test(e.message),
  );
  // Exactly the limit is accepted.
  assert.equal(parseCurves(file([{ points: line(MAX_SEGMENTS_PER_CURVE * 0.25), segment_length: 0.25 }])).curves.length, 1);
  // Five curves of 2000 segments each: each within its limit, 10000 in all.
  const five = Array.from({ length: 5 }, (_, i) => ({ name: `c${i}`, points: line(200).map(([x, y, z]) => [x + i, y, z]), segment_length: 0.1 }));
  assert.throws(() => parseCurves(file(five)), /10000 utilization segments in all; at most 8192/);
  // Serializing (what the page saves) and the page's check of an edited set refuse it too.
  const set = parseCurves(readFileSync(join(examples, 'calder_tree.curves.json'), 'utf8'));
  assert.equal(setProblem(set), null);
  set.curves[0].params.segment_length = 0.0001;
  assert.match(setProblem(set) ?? '', /into 40000 segments/);
  assert.throws(() => serializeCurves(set), /into 40000 segments/);
  // A curve that is (nearly) a point, as grm-guide measures it.
  assert.throws(() => parseCurves(file([{ points: [[1, 1, 1], [1, 1, 1], [1, 1, 1 + 1e-12], [1, 1, 1]] }])), /coincide/);
  // Coordinates beyond grm-guide's MAX_COORDINATE (1e6), parsed or dragged there.
  assert.throws(() => parseCurves(file([{ points: [[0, 0, 0], [0, 1, 0], [0, 2e6, 0], [0, 3, 0]] }])), /points\[2\] has a coordinate beyond ±1e6/);
  set.curves[0].params.segment_length = 0.2;
  assert.equal(setProblem(set), null);
  set.curves[0].points[1][0] = -1e300;
  assert.match(setProblem(set) ?? '', /points\[1\] has a coordinate beyond/);
  // The limits are grm-guide's own (one definition, checked here).
  const rust = readFileSync(join(examples, '../crates/grm-guide/src/curves.rs'), 'utf8');
  assert.equal(Number(/pub const MAX_COORDINATE: f64 = ([0-9e.]+);/.exec(rust)?.[1]), MAX_COORDINATE);
  assert.equal(Number(/pub const MAX_SEGMENTS_PER_CURVE: usize = (\d+);/.exec(rust)?.[1]), MAX_SEGMENTS_PER_CURVE);
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
