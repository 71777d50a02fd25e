// Curve coverage in the preview without a browser: the result's
// `sample.coverage` decoded (gaps and their points along the curve), bad
// entries refused, and the status line's words (each curve's share; a curve
// no bone reaches named with the reason).
import assert from 'node:assert/strict';
import { test } from 'node:test';
import { coverageLabel, refinementsLabel } from '../preview/src/coverage.js';
import { type CurveCoverage, ProtocolError, decodePreview } from '../preview/src/protocol.js';

function result(coverage: unknown) {
  return {
    uri: 'file:///g.grm',
    system: 'G',
    mode: 'sample',
    seed: 3,
    params: [],
    sample: { objective: 1.5, generations: 6, candidates: 4, stoppedEarly: false, curves: 'request', coverage },
    parts: [],
  };
}

const trunk = {
  name: 'trunk',
  fraction: 0.75,
  radius: 0.15,
  nearest: 0.01,
  unreached: false,
  gaps: [[0.5, 0.75]],
  gapPoints: [[[0, 2, 0], [0, 2.5, 0], [0, 3, 0]]],
  note: 'gaps at 50-75%',
};
const far = { fraction: 0, radius: 0.15, nearest: 39.9, unreached: true, gaps: [[0, 1]], gapPoints: [[[40, 0, 0], [40, 3, 0]]], note: 'not reached: the nearest bone stays 39.90 from it (covering radius 0.15)' };

test('sample.coverage is decoded with its gaps and their points', () => {
  const r = decodePreview(result([trunk, far]));
  const c = r.sample?.coverage ?? [];
  assert.equal(c.length, 2);
  assert.deepEqual(c[0].gaps, [[0.5, 0.75]]);
  assert.deepEqual(c[0].gapPoints[0][2], [0, 3, 0]);
  assert.equal(c[1].name, null);
  assert.equal(c[1].unreached, true);
  assert.equal(c[1].nearest, 39.9);
});

test('a result without coverage has none; a malformed gap is refused', () => {
  assert.deepEqual(decodePreview(result(undefined)).sample?.coverage, []);
  assert.throws(() => decodePreview(result([{ ...trunk, gaps: [[0.5]] }])), ProtocolError);
  assert.throws(() => decodePreview(result([{ ...trunk, gapPoints: [[[0, 'x', 0]]] }])), ProtocolError);
});

test("the curve list's label gives a curve's share, and says why a curve is not reached", () => {
  const c = decodePreview(result([trunk, far])).sample?.coverage as CurveCoverage[];
  assert.equal(coverageLabel(c[0]), '75%');
  assert.equal(coverageLabel(c[1]), '⚠ 0%: not reached: the nearest bone stays 39.90 from it (covering radius 0.15)');
});

test('sample.refinements is decoded (0 when absent) and worded under the curve list', () => {
  const withRounds = result([trunk]);
  (withRounds.sample as Record<string, unknown>).refinements = 2;
  const r = decodePreview(withRounds);
  assert.equal(r.sample?.refinements, 2);
  assert.equal(refinementsLabel(r.sample)?.text, '2 refinement rounds');
  const none = decodePreview(result([trunk]));
  assert.equal(none.sample?.refinements, 0);
  assert.equal(refinementsLabel(none.sample)?.text, 'no refinement rounds');
  assert.equal(refinementsLabel(r.sample && { ...r.sample, refinements: 1 })?.text, '1 refinement round');
  // An earlier generation's model (the scrubber) was not refined: no line.
  assert.equal(refinementsLabel(r.sample && { ...r.sample, generation: 3 }), null);
  assert.equal(refinementsLabel(null), null);
});
