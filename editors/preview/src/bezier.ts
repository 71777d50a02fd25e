// Cubic Bézier curves in 3D: evaluation, and the least-squares fit that turns
// a drawn stroke into one curve (the Calder editor converts every stroke to a
// single Bézier so that guiding curves stay coarse and easy to edit).
//
// Pure functions over plain arrays, no three.js: unit-tested under node.

export type V3 = [number, number, number];
export type Bezier = [V3, V3, V3, V3];

export function add(a: V3, b: V3): V3 {
  return [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
}
export function sub(a: V3, b: V3): V3 {
  return [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
}
export function scale(a: V3, s: number): V3 {
  return [a[0] * s, a[1] * s, a[2] * s];
}
export function dot(a: V3, b: V3): number {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
export function dist(a: V3, b: V3): number {
  return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

/** Bernstein basis of degree 3 at t. */
export function bernstein(t: number): [number, number, number, number] {
  const s = 1 - t;
  return [s * s * s, 3 * s * s * t, 3 * s * t * t, t * t * t];
}

/** The point at parameter t in [0, 1]. */
export function evalBezier(c: Bezier, t: number): V3 {
  const b = bernstein(t);
  const out: V3 = [0, 0, 0];
  for (let k = 0; k < 3; k++) {
    out[k] = b[0] * c[0][k] + b[1] * c[1][k] + b[2] * c[2][k] + b[3] * c[3][k];
  }
  return out;
}

/** First derivative at t. */
export function derivBezier(c: Bezier, t: number): V3 {
  const s = 1 - t;
  const out: V3 = [0, 0, 0];
  for (let k = 0; k < 3; k++) {
    out[k] =
      3 * s * s * (c[1][k] - c[0][k]) +
      6 * s * t * (c[2][k] - c[1][k]) +
      3 * t * t * (c[3][k] - c[2][k]);
  }
  return out;
}

/** Second derivative at t. */
export function deriv2Bezier(c: Bezier, t: number): V3 {
  const out: V3 = [0, 0, 0];
  for (let k = 0; k < 3; k++) {
    out[k] =
      6 * (1 - t) * (c[2][k] - 2 * c[1][k] + c[0][k]) + 6 * t * (c[3][k] - 2 * c[2][k] + c[1][k]);
  }
  return out;
}

/** n + 1 points at evenly spaced parameters (n >= 1). */
export function sampleBezier(c: Bezier, n: number): V3[] {
  const pts: V3[] = [];
  for (let i = 0; i <= n; i++) pts.push(evalBezier(c, i / n));
  return pts;
}

/** Drop points closer than `eps` to the previous kept point (keeps the last point). */
export function dedupe(points: readonly V3[], eps = 1e-9): V3[] {
  const out: V3[] = [];
  for (const p of points) {
    if (!p.every(Number.isFinite)) continue;
    if (out.length === 0 || dist(out[out.length - 1], p) > eps) out.push([p[0], p[1], p[2]]);
  }
  return out;
}

/** Chord-length parameters in [0, 1] for a polyline with distinct consecutive points. */
export function chordParams(points: readonly V3[]): number[] {
  const u = [0];
  for (let i = 1; i < points.length; i++) u.push(u[i - 1] + dist(points[i - 1], points[i]));
  const total = u[u.length - 1];
  return u.map((x) => (total > 0 ? x / total : 0));
}

/**
 * Least-squares control points P1, P2 for fixed ends P0 = points[0],
 * P3 = points[n - 1] at the given parameters. Returns null when the normal
 * equations are singular (all parameters at the ends).
 */
function solveInner(points: readonly V3[], u: readonly number[]): [V3, V3] | null {
  const p0 = points[0];
  const p3 = points[points.length - 1];
  let c11 = 0;
  let c12 = 0;
  let c22 = 0;
  const x1: V3 = [0, 0, 0];
  const x2: V3 = [0, 0, 0];
  for (let i = 0; i < points.length; i++) {
    const [b0, b1, b2, b3] = bernstein(u[i]);
    c11 += b1 * b1;
    c12 += b1 * b2;
    c22 += b2 * b2;
    for (let k = 0; k < 3; k++) {
      const r = points[i][k] - b0 * p0[k] - b3 * p3[k];
      x1[k] += b1 * r;
      x2[k] += b2 * r;
    }
  }
  const det = c11 * c22 - c12 * c12;
  if (!(Math.abs(det) > 1e-12 * Math.max(1, c11 * c22))) return null;
  const p1: V3 = [0, 0, 0];
  const p2: V3 = [0, 0, 0];
  for (let k = 0; k < 3; k++) {
    p1[k] = (c22 * x1[k] - c12 * x2[k]) / det;
    p2[k] = (c11 * x2[k] - c12 * x1[k]) / det;
  }
  return [p1, p2];
}

/** Newton steps per parameter towards the nearest point of the curve (Schneider's reparameterisation). */
function reparameterize(c: Bezier, points: readonly V3[], u: number[], steps: number): void {
  for (let i = 1; i < points.length - 1; i++) {
    let t = u[i];
    for (let k = 0; k < steps; k++) {
      const d = sub(evalBezier(c, t), points[i]);
      const q1 = derivBezier(c, t);
      const q2 = deriv2Bezier(c, t);
      const den = dot(q1, q1) + dot(d, q2);
      if (!(den > 1e-12)) break;
      const next = Math.min(1, Math.max(0, t - dot(d, q1) / den));
      if (!Number.isFinite(next) || Math.abs(next - t) < 1e-12) break;
      t = next;
    }
    u[i] = t;
  }
}

/** Sum of squared distances from the points to the curve at their parameters. */
export function fitError(c: Bezier, points: readonly V3[], u: readonly number[]): number {
  let e = 0;
  for (let i = 0; i < points.length; i++) {
    const d = sub(evalBezier(c, u[i]), points[i]);
    e += dot(d, d);
  }
  return e;
}

/**
 * Fit one cubic Bézier to a stroke by least squares: the ends are the
 * stroke's first and last points, the inner control points minimise the sum
 * of squared distances at chord-length parameters, refined by a few
 * Newton reparameterisation passes. Returns null for a stroke with fewer
 * than two distinct points.
 */
export function fitCubicBezier(stroke: readonly V3[], iterations = 12): Bezier | null {
  const points = dedupe(stroke);
  if (points.length < 2) return null;
  const p0 = points[0];
  const p3 = points[points.length - 1];
  if (dist(p0, p3) === 0 && points.length < 3) return null;
  const third = (s: number): V3 => add(p0, scale(sub(p3, p0), s));
  if (points.length === 2) return [p0, third(1 / 3), third(2 / 3), p3];
  const u = chordParams(points);
  let best: Bezier | null = null;
  let bestErr = Infinity;
  for (let it = 0; it <= iterations; it++) {
    const inner = solveInner(points, u);
    const c: Bezier = inner ? [p0, inner[0], inner[1], p3] : [p0, third(1 / 3), third(2 / 3), p3];
    const err = fitError(c, points, u);
    if (err < bestErr) {
      best = c;
      bestErr = err;
    }
    if (!inner) break;
    reparameterize(c, points, u, 4);
  }
  return best;
}

/** Closest parameter on the curve to p (dense sampling then Newton refinement). */
export function closestParam(c: Bezier, p: V3, samples = 32): number {
  let bestT = 0;
  let bestD = Infinity;
  for (let i = 0; i <= samples; i++) {
    const t = i / samples;
    const d = sub(evalBezier(c, t), p);
    const dd = dot(d, d);
    if (dd < bestD) {
      bestD = dd;
      bestT = t;
    }
  }
  let t = bestT;
  for (let it = 0; it < 6; it++) {
    const d = sub(evalBezier(c, t), p);
    const q1 = derivBezier(c, t);
    const q2 = deriv2Bezier(c, t);
    const den = dot(q1, q1) + dot(d, q2);
    if (Math.abs(den) < 1e-12) break;
    t = Math.min(1, Math.max(0, t - dot(d, q1) / den));
  }
  const d = sub(evalBezier(c, t), p);
  return dot(d, d) <= bestD ? t : bestT;
}
