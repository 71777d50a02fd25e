import assert from 'node:assert/strict';
import { test } from 'node:test';
import { type Bezier, type V3, closestParam, dist, evalBezier, fitCubicBezier, sampleBezier } from '../preview/src/bezier.js';

const close = (a: V3, b: V3, eps: number, what = '') => assert.ok(dist(a, b) < eps, `${what} ${JSON.stringify(a)} vs ${JSON.stringify(b)}`);

test('a stroke sampled from a cubic is fitted back to that cubic', () => {
  const c: Bezier = [[0, 0, 0], [0.5, 2, 0.2], [2, 2.5, -0.3], [3, 0.5, 0.1]];
  // Uneven sampling, as a mouse gives: dense at the start, sparse at the end.
  const stroke: V3[] = [];
  for (let i = 0; i <= 60; i++) stroke.push(evalBezier(c, Math.pow(i / 60, 1.4)));
  const fit = fitCubicBezier(stroke);
  assert.ok(fit);
  close(fit[0], c[0], 1e-12, 'P0');
  close(fit[3], c[3], 1e-12, 'P3');
  // The fitted curve passes close to every stroke point (the curve is ~3 units long)...
  for (const p of stroke) {
    const q = evalBezier(fit, closestParam(fit, p));
    assert.ok(dist(p, q) < 5e-3, `point ${p} is ${dist(p, q)} from the fit`);
  }
  // ...and the original curve is close to the fit all along (no overshoot between points).
  for (const p of sampleBezier(c, 50)) assert.ok(dist(p, evalBezier(fit, closestParam(fit, p))) < 5e-3);
  // The least-squares start (chord-length parameters) is much worse than the refined fit.
  const rough = fitCubicBezier(stroke, 0)!;
  const worst = (b: typeof fit) => Math.max(...stroke.map((p) => dist(p, evalBezier(b, closestParam(b, p)))));
  assert.ok(worst(fit) * 10 < worst(rough), `${worst(fit)} vs ${worst(rough)}`);
  close(fit[1], c[1], 0.1, 'P1');
  close(fit[2], c[2], 0.1, 'P2');
});

test('a noisy stroke gives a smooth curve near it', () => {
  let seed = 7;
  const rnd = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648 - 0.5) * 0.02;
  const stroke: V3[] = [];
  for (let i = 0; i <= 100; i++) {
    const t = i / 100;
    stroke.push([t * 4 + rnd(), Math.sin(t * Math.PI) * 2 + rnd(), rnd()]);
  }
  const fit = fitCubicBezier(stroke);
  assert.ok(fit);
  let worst = 0;
  for (const p of stroke) worst = Math.max(worst, dist(p, evalBezier(fit, closestParam(fit, p))));
  assert.ok(worst < 0.12, `worst distance ${worst}`);
  // A half sine is well above the chord: the fit bulges the same way.
  assert.ok(evalBezier(fit, 0.5)[1] > 1.7);
});

test('a straight stroke gives a straight curve; two points give thirds', () => {
  const fit = fitCubicBezier([[0, 0, 0], [1, 1, 0], [2, 2, 0], [3, 3, 0]]);
  assert.ok(fit);
  for (const p of sampleBezier(fit, 10)) assert.ok(Math.abs(p[0] - p[1]) < 1e-9 && Math.abs(p[2]) < 1e-12);
  const two = fitCubicBezier([[0, 0, 0], [3, 0, 0]]);
  assert.deepEqual(two, [[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]);
});

test('strokes that are not curves are refused', () => {
  assert.equal(fitCubicBezier([]), null);
  assert.equal(fitCubicBezier([[1, 2, 3]]), null);
  assert.equal(fitCubicBezier([[1, 2, 3], [1, 2, 3], [1, 2, 3]]), null);
  assert.equal(fitCubicBezier([[0, 0, 0], [NaN, 0, 0]]), null);
});

test('a closed loop stroke keeps its ends and goes around', () => {
  const stroke: V3[] = [];
  for (let i = 0; i <= 40; i++) stroke.push([Math.cos((i / 40) * 2 * Math.PI), Math.sin((i / 40) * 2 * Math.PI), 0]);
  const fit = fitCubicBezier(stroke);
  assert.ok(fit);
  assert.ok(dist(fit[0], fit[3]) < 1e-9);
  assert.ok(fit.every((p) => p.every(Number.isFinite)));
});

test('closestParam finds the nearest point (against brute force)', () => {
  const c: Bezier = [[0, 0, 0], [1, 3, 1], [3, -2, 0], [4, 1, 2]];
  for (const p of [[0, 1, 0], [2, 2, 2], [5, 0, 0], [-1, -1, -1]] as V3[]) {
    let best = Infinity;
    for (let i = 0; i <= 20000; i++) best = Math.min(best, dist(p, evalBezier(c, i / 20000)));
    const got = dist(p, evalBezier(c, closestParam(c, p)));
    assert.ok(got <= best + 1e-6, `${got} > ${best}`);
  }
});
