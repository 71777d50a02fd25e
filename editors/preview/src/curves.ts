// The guiding-curves file (docs/curves.md, format version 1) as the editor
// holds it: parse (with the same rules as grm-guide, so the page never saves a
// file the sampler would refuse), edit, and write the canonical form (every
// parameter per curve, no `defaults`), which reads back to the same curves.

import type { Bezier, V3 } from './bezier.js';

export const FORMAT_VERSION = 1;

export interface CurveParams {
  distance: [number, number, number];
  alignment_scale: number;
  alignment_offset: number;
  utilization_scale: number;
  segment_length: number;
  thickness: number;
}

export interface Curve {
  name?: string;
  points: Bezier;
  params: CurveParams;
}

export interface Density {
  radius: number;
  scale: number;
}

export interface CurveSet {
  curves: Curve[];
  density?: Density;
}

/** grm-guide's `CurveParams::default()` (Calder's values; utilization and thickness off). */
export const DEFAULT_PARAMS: Readonly<CurveParams> = Object.freeze({
  distance: [0, 0, 100] as [number, number, number],
  alignment_scale: 400,
  alignment_offset: 0.6,
  utilization_scale: 0,
  segment_length: 0.2,
  thickness: 0,
});

export const PARAM_KEYS = [
  'distance',
  'alignment_scale',
  'alignment_offset',
  'utilization_scale',
  'segment_length',
  'thickness',
] as const;
export type ParamKey = (typeof PARAM_KEYS)[number];

/** What each scalar parameter accepts (docs/curves.md, "Parameters"). */
export const PARAM_RANGES: Record<Exclude<ParamKey, 'distance'>, { min: number; max: number; minExclusive?: boolean; label: string }> = {
  alignment_scale: { min: 0, max: Infinity, label: 'alignment scale' },
  alignment_offset: { min: -1, max: 1, label: 'alignment offset' },
  utilization_scale: { min: 0, max: Infinity, label: 'utilization scale' },
  segment_length: { min: 0, max: Infinity, minExclusive: true, label: 'segment length' },
  thickness: { min: 0, max: Infinity, label: 'thickness' },
};

/** Most utilization segments one curve may be split into (grm-guide's `MAX_SEGMENTS_PER_CURVE`). */
export const MAX_SEGMENTS_PER_CURVE = 2048;

/** Most utilization segments over all curves of a file (grm-guide's `MAX_SEGMENTS_TOTAL`). */
export const MAX_SEGMENTS_TOTAL = 8192;

export class CurvesError extends Error {}

/** Arc length of a cubic Bézier as grm-guide measures it (`Bezier3::length`: 1024 chords, power basis). */
export function curveLength(points: Bezier): number {
  const [p0, p1, p2, p3] = points;
  const a = [0, 1, 2].map((k) => p3[k] - p0[k] + 3 * (p1[k] - p2[k]));
  const b = [0, 1, 2].map((k) => 3 * (p0[k] - 2 * p1[k] + p2[k]));
  const c = [0, 1, 2].map((k) => 3 * (p1[k] - p0[k]));
  const at = (t: number) => [0, 1, 2].map((k) => ((a[k] * t + b[k]) * t + c[k]) * t + p0[k]);
  const n = 1024;
  let acc = 0;
  let prev = at(0);
  for (let i = 1; i <= n; i++) {
    const cur = at(i / n);
    acc += Math.hypot(cur[0] - prev[0], cur[1] - prev[1], cur[2] - prev[2]);
    prev = cur;
  }
  return acc;
}

/** grm-guide's `MAX_COORDINATE`: the largest absolute control-point coordinate. */
export const MAX_COORDINATE = 1e6;

/** grm-guide's `segment_count`: `ceil(length / segment_length)`, at least 1 (a ratio within 1e-9 above an integer counts as it). */
export function segmentCount(length: number, segmentLength: number): number {
  const n = Math.ceil(length / segmentLength - 1e-9);
  return Number.isFinite(n) && n >= 1 ? n : 1;
}

/**
 * The checks grm-guide makes on a curve's shape (`check_curve`): coordinates
 * within ±MAX_COORDINATE, not of zero length, and at most MAX_SEGMENTS_PER_CURVE utilization segments. Returns
 * its number of segments; throws CurvesError.
 */
function checkShape(c: Curve, at: string): number {
  c.points.forEach((p, j) => {
    if (p.some((x) => Math.abs(x) > MAX_COORDINATE)) {
      throw new CurvesError(`${at}points[${j}] has a coordinate beyond ±1e6 (models are built in single precision)`);
    }
  });
  const [p0, p1, p2, p3] = c.points;
  const polygon = dist3(p0, p1) + dist3(p1, p2) + dist3(p2, p3);
  const length = curveLength(c.points);
  if (Number.isNaN(length) || length <= 1e-9 * Math.max(polygon, 1)) throw new CurvesError(`${at}all control points coincide (a curve of zero length)`);
  const n = segmentCount(length, c.params.segment_length);
  if (n > MAX_SEGMENTS_PER_CURVE) {
    throw new CurvesError(
      `${at}segment_length ${c.params.segment_length} splits the curve (length ${length.toFixed(3)}) into ${n} segments; at most ${MAX_SEGMENTS_PER_CURVE} are allowed`,
    );
  }
  return n;
}

/** grm-guide's limits on a whole set's shapes: each curve's, then the segments of all curves together. Throws CurvesError. */
function checkShapes(set: CurveSet): void {
  let total = 0;
  set.curves.forEach((c, i) => (total += checkShape(c, where(i, c.name))));
  if (total > MAX_SEGMENTS_TOTAL) {
    throw new CurvesError(`curves: have ${total} utilization segments in all; at most ${MAX_SEGMENTS_TOTAL} are allowed (raise segment_length)`);
  }
}

/** Why grm-guide would refuse this set (a parameter out of range, a curve of zero length, too many utilization segments), or null. */
export function setProblem(set: CurveSet): string | null {
  try {
    if (set.curves.length === 0) return 'a curves file needs at least one curve';
    set.curves.forEach((c, i) => {
      for (const key of PARAM_KEYS) {
        const problem = checkParam(key, c.params[key]);
        if (problem) throw new CurvesError(where(i, c.name) + problem);
      }
    });
    checkShapes(set);
    return null;
  } catch (e) {
    if (e instanceof CurvesError) return e.message;
    throw e;
  }
}

function dist3(a: V3, b: V3): number {
  return Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);
}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

function where(index: number | null, name?: string): string {
  if (index === null) return 'defaults: ';
  return name === undefined ? `curve ${index}: ` : `curve ${index} (${JSON.stringify(name)}): `;
}

function finite(v: unknown, at: string, field: string): number {
  if (typeof v !== 'number' || !Number.isFinite(v)) {
    throw new CurvesError(`${at}${field} ${JSON.stringify(v)} must be a finite number`);
  }
  return v;
}

/** Check one parameter value; returns an error message or null. */
export function checkParam(key: ParamKey, value: unknown): string | null {
  if (key === 'distance') {
    if (!Array.isArray(value) || value.length !== 3) return 'distance needs three numbers [m0, m1, m2]';
    if (!value.every((x) => typeof x === 'number' && Number.isFinite(x))) return 'distance needs three finite numbers';
    if (value[1] < 0 || value[2] < 0) return 'distance: m1 and m2 must be >= 0';
    return null;
  }
  const r = PARAM_RANGES[key];
  if (typeof value !== 'number' || !Number.isFinite(value)) return `${key} must be a finite number`;
  if (r.minExclusive ? !(value > r.min) : value < r.min) return `${key} ${value} must be ${r.minExclusive ? '>' : '>='} ${r.min}`;
  if (value > r.max) return `${key} ${value} is outside [${r.min}, ${r.max}]`;
  return null;
}

function readParams(obj: Record<string, unknown>, base: CurveParams, at: string): CurveParams {
  const out: CurveParams = { ...base, distance: [...base.distance] as [number, number, number] };
  for (const key of PARAM_KEYS) {
    if (!(key in obj)) continue;
    const v = obj[key];
    if (key === 'distance') {
      if (Array.isArray(v)) v.forEach((x, i) => finite(x, at, `distance[${i}]`));
    } else {
      finite(v, at, key);
    }
    const problem = checkParam(key, v);
    if (problem) throw new CurvesError(at + problem);
    if (key === 'distance') out.distance = [...(v as number[])] as [number, number, number];
    else out[key] = v as number;
  }
  return out;
}

/** Parse and validate a curves file's text (version 1). Throws CurvesError. */
export function parseCurves(text: string): CurveSet {
  let json: unknown;
  try {
    json = JSON.parse(text);
  } catch (e) {
    throw new CurvesError(`invalid JSON: ${(e as Error).message}`);
  }
  return fromJson(json);
}

/** Validate an already parsed curves file (version 1). Throws CurvesError. */
export function fromJson(json: unknown): CurveSet {
  if (!isObject(json)) throw new CurvesError('a curves file is a JSON object');
  for (const k of Object.keys(json)) {
    if (!['version', 'defaults', 'density', 'curves'].includes(k)) {
      throw new CurvesError(`${k} is not a known top-level key (expected version, defaults, density, curves)`);
    }
  }
  if (json.version !== FORMAT_VERSION) {
    throw new CurvesError(`version ${JSON.stringify(json.version)} is not supported (this editor reads version 1)`);
  }
  let defaults: CurveParams = { ...DEFAULT_PARAMS, distance: [...DEFAULT_PARAMS.distance] as [number, number, number] };
  if (json.defaults !== undefined) {
    if (!isObject(json.defaults)) throw new CurvesError('defaults must be an object');
    for (const k of Object.keys(json.defaults)) {
      if (!(PARAM_KEYS as readonly string[]).includes(k)) throw new CurvesError(`defaults: ${k} is not a known parameter`);
    }
    defaults = readParams(json.defaults, defaults, where(null));
  }
  let density: Density | undefined;
  if (json.density !== undefined) {
    const d = json.density;
    if (!isObject(d)) throw new CurvesError('density must be an object { radius, scale }');
    const radius = finite(d.radius, 'density: ', 'radius');
    const sc = finite(d.scale, 'density: ', 'scale');
    if (!(radius > 0)) throw new CurvesError(`density: radius ${radius} must be > 0`);
    if (sc < 0) throw new CurvesError(`density: scale ${sc} must be >= 0`);
    density = { radius, scale: sc };
  }
  if (!Array.isArray(json.curves) || json.curves.length === 0) {
    throw new CurvesError('curves must be an array with at least one curve');
  }
  const names = new Set<string>();
  const curves: Curve[] = json.curves.map((c: unknown, i: number) => {
    if (!isObject(c)) throw new CurvesError(`curve ${i}: must be an object`);
    const name = typeof c.name === 'string' ? c.name : undefined;
    const at = where(i, name);
    if (c.name !== undefined && name === undefined) throw new CurvesError(`${at}name must be a string`);
    if (name !== undefined) {
      if (names.has(name)) throw new CurvesError(`${at}name ${JSON.stringify(name)} is used twice`);
      names.add(name);
    }
    for (const k of Object.keys(c)) {
      if (k !== 'name' && k !== 'points' && !(PARAM_KEYS as readonly string[]).includes(k)) {
        throw new CurvesError(`${at}${k} is not a known curve key (expected name, points, or a parameter)`);
      }
    }
    const pts = c.points;
    if (!Array.isArray(pts) || pts.length !== 4) {
      throw new CurvesError(`${at}points needs exactly 4 control points`);
    }
    const points = pts.map((p: unknown, j: number) => {
      if (!Array.isArray(p) || p.length !== 3) throw new CurvesError(`${at}points[${j}] must be [x, y, z]`);
      return p.map((x, k) => finite(x, at, `points[${j}][${k}]`)) as V3;
    }) as Bezier;
    const curve: Curve = { points, params: readParams(c, defaults, at) };
    if (name !== undefined) curve.name = name;
    return curve;
  });
  const set: CurveSet = density ? { curves, density } : { curves };
  checkShapes(set);
  return set;
}

/** A number as grm-guide writes it (`{:?}` on f64): integers get a `.0`. */
export function formatNumber(x: number): string {
  if (!Number.isFinite(x)) throw new CurvesError(`cannot write ${x}`);
  if (Object.is(x, -0)) return '-0.0';
  const s = String(x);
  return /[.eE]/.test(s) ? s : `${s}.0`;
}

/**
 * The canonical text, as `Curves::to_json_string` writes it: version 1, every
 * parameter per curve, no `defaults`. Refuses (throws) an empty set or a
 * parameter out of range, a curve of zero length or too many utilization
 * segments (grm-guide's limits), so a saved file always loads.
 */
export function serializeCurves(set: CurveSet): string {
  if (set.curves.length === 0) throw new CurvesError('a curves file needs at least one curve');
  const v = (p: V3) => `[${p.map(formatNumber).join(', ')}]`;
  let s = `{\n  "version": ${FORMAT_VERSION},\n`;
  if (set.density) {
    s += `  "density": { "radius": ${formatNumber(set.density.radius)}, "scale": ${formatNumber(set.density.scale)} },\n`;
  }
  s += '  "curves": [\n';
  const problem = setProblem(set);
  if (problem) throw new CurvesError(problem);
  set.curves.forEach((c, i) => {
    const p = c.params;
    s += '    {\n';
    if (c.name !== undefined) s += `      "name": ${JSON.stringify(c.name)},\n`;
    s += `      "points": [${c.points.map(v).join(', ')}],\n`;
    s += `      "distance": [${p.distance.map(formatNumber).join(', ')}],\n`;
    s += `      "alignment_scale": ${formatNumber(p.alignment_scale)},\n`;
    s += `      "alignment_offset": ${formatNumber(p.alignment_offset)},\n`;
    s += `      "utilization_scale": ${formatNumber(p.utilization_scale)},\n`;
    s += `      "segment_length": ${formatNumber(p.segment_length)},\n`;
    s += `      "thickness": ${formatNumber(p.thickness)}\n`;
    s += i + 1 === set.curves.length ? '    }\n' : '    },\n';
  });
  s += '  ]\n}\n';
  return s;
}

/** A name not used by any curve of the set: `curve1`, `curve2`, ... */
export function freshName(set: CurveSet): string {
  const used = new Set(set.curves.map((c) => c.name));
  for (let i = 1; ; i++) {
    const n = `curve${i}`;
    if (!used.has(n)) return n;
  }
}

/** Deep copy (the editor keeps an undo-free immutable history of sets). */
export function cloneSet(set: CurveSet): CurveSet {
  const curves = set.curves.map((c) => {
    const copy: Curve = {
      points: c.points.map((p) => [p[0], p[1], p[2]]) as Bezier,
      params: { ...c.params, distance: [...c.params.distance] as [number, number, number] },
    };
    if (c.name !== undefined) copy.name = c.name;
    return copy;
  });
  return set.density ? { curves, density: { ...set.density } } : { curves };
}
