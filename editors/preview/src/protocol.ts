// The preview protocol as the page sees it: the requests it makes (preview a
// grammar with seed, meta-parameters and curves; pick a part; save curves),
// the notifications it receives, and the decoding of a model from the wire
// into typed arrays for three.js. The wire format is the language server's
// (docs/lsp-extensions.md); `grmc view` serves the same JSON over HTTP.
//
// Everything wire-specific is in this file, so a change of the server's
// format is a change here only.

import type { V3 } from './bezier.js';

// ---------------------------------------------------------------- requests

/** Parameters of a preview request (LSP `grm/preview`, HTTP POST /api/preview). */
export interface PreviewParams {
  /** The grammar's document URI (`file:///...`). */
  uri: string;
  /** Seed; omitted = the system's `seed` setting. */
  seed?: number;
  /** Meta-parameter overrides by name; omitted ones take their defaults. */
  params?: Record<string, number>;
  /**
   * Guiding curves (curves file v1 JSON) for a sample system; omitted = the
   * curves file next to the grammar.
   */
  curves?: unknown;
  /** The system to grow; omitted = the file's first system. */
  system?: string;
}

/** Parameters of a pick (LSP `grm/pick`, HTTP POST /api/pick). */
export interface PickParams {
  uri: string;
  /** The production that made the part (the model's `origin`), or absent. */
  origin?: number;
  /** The module of the derived string that made the part. */
  module?: number;
  /** The preview the pick refers to (`PreviewResult.id`), so the server knows which model. */
  preview?: number;
  part?: number;
  triangle?: number;
}

// ---------------------------------------------------------------- results

export interface ParamInfo {
  name: string;
  value: number;
  min: number;
  max: number;
  default: number;
}

export interface Diagnostic {
  message: string;
  severity: 'error' | 'warning' | 'info';
  line?: number;
  character?: number;
  code?: string;
}

export interface SceneMaterial {
  name: string;
  color: V3;
  roughness: number;
  metallic: number;
  opacity: number;
}

export type SourceKind = 'bone' | 'instance' | 'polygon';

export interface PickRange {
  firstTriangle: number;
  triangleCount: number;
  kind: SourceKind;
  index: number;
  module: number;
  origin: number;
}

export interface ScenePart {
  material: number;
  positions: Float32Array;
  normals: Float32Array | null;
  indices: Uint32Array;
  picks: PickRange[];
}

export interface SceneBone {
  base: V3;
  tip: V3;
  width: number;
  module: number;
  origin: number;
}

export interface Bounds {
  min: V3;
  max: V3;
}

export interface SceneModel {
  parts: ScenePart[];
  materials: SceneMaterial[];
  bones: SceneBone[];
  bounds: Bounds | null;
  triangles: number;
}

export interface RuleInfo {
  origin: number;
  /** A label for the production, e.g. `branchOrLeaf -> (4) ...`. */
  label: string;
  uri?: string;
  /** 0-based line and character of the production's start. */
  line: number;
  character: number;
  endLine?: number;
  endCharacter?: number;
}

export interface PreviewResult {
  /** Identifies this preview for later picks. */
  id?: number;
  uri: string;
  system: string;
  mode: 'derive' | 'sample';
  seed: number;
  params: ParamInfo[];
  /** The curves used (a sample system), as curves-file JSON. */
  curves?: unknown;
  /** Where the curves file is (or would be). */
  curvesPath?: string;
  model: SceneModel | null;
  /** Why there is no model (errors in the grammar, a derivation limit...). */
  error?: string;
  diagnostics: Diagnostic[];
  /** Origin (production) -> rule, for labels and picks without a round trip. */
  rules: RuleInfo[];
  /** Server-side timings in milliseconds (derive, sample, build...). */
  timings: Record<string, number>;
  stats: Record<string, number>;
}

export interface PickResult {
  rule: RuleInfo | null;
}

/** Where a rule can grow: points (bone tips over many expansions) for the rule under the cursor. */
export interface SpreadResult {
  origin: number | null;
  label?: string;
  points: V3[];
  /** Bones of the current model made by that rule (indices into bones). */
  bones: number[];
}

// ---------------------------------------------------------------- decoding

export class ProtocolError extends Error {}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

function num(v: unknown, what: string): number {
  if (typeof v !== 'number' || !Number.isFinite(v)) throw new ProtocolError(`${what}: expected a number, got ${JSON.stringify(v)}`);
  return v;
}

function optNum(v: unknown, fallback: number): number {
  return typeof v === 'number' && Number.isFinite(v) ? v : fallback;
}

function str(v: unknown, fallback = ''): string {
  return typeof v === 'string' ? v : fallback;
}

function vec3(v: unknown, what: string): V3 {
  if (!Array.isArray(v) || v.length !== 3) throw new ProtocolError(`${what}: expected [x, y, z]`);
  return [num(v[0], what), num(v[1], what), num(v[2], what)];
}

/** Bytes of a base64 string (standard alphabet, padding optional). */
export function base64ToBytes(b64: string): Uint8Array {
  const bin = atob(b64);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}

/** Base64 of bytes (for tests and for the HTTP transport's echo). */
export function bytesToBase64(bytes: Uint8Array): string {
  let bin = '';
  for (let i = 0; i < bytes.length; i += 0x8000) {
    bin += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  }
  return btoa(bin);
}

/** A float array given as numbers or as base64 of little-endian f32. */
export function decodeF32(v: unknown, what: string): Float32Array {
  if (Array.isArray(v)) return Float32Array.from(v, (x) => num(x, what));
  if (typeof v === 'string') {
    const bytes = base64ToBytes(v);
    if (bytes.length % 4 !== 0) throw new ProtocolError(`${what}: ${bytes.length} bytes is not a whole number of f32`);
    const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const out = new Float32Array(bytes.length / 4);
    for (let i = 0; i < out.length; i++) out[i] = dv.getFloat32(i * 4, true);
    return out;
  }
  throw new ProtocolError(`${what}: expected numbers or base64`);
}

/** An index array given as numbers or as base64 of little-endian u32. */
export function decodeU32(v: unknown, what: string): Uint32Array {
  if (Array.isArray(v)) {
    return Uint32Array.from(v, (x) => {
      const n = num(x, what);
      if (!Number.isInteger(n) || n < 0) throw new ProtocolError(`${what}: ${n} is not an index`);
      return n;
    });
  }
  if (typeof v === 'string') {
    const bytes = base64ToBytes(v);
    if (bytes.length % 4 !== 0) throw new ProtocolError(`${what}: ${bytes.length} bytes is not a whole number of u32`);
    const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const out = new Uint32Array(bytes.length / 4);
    for (let i = 0; i < out.length; i++) out[i] = dv.getUint32(i * 4, true);
    return out;
  }
  throw new ProtocolError(`${what}: expected numbers or base64`);
}

const NO_ORIGIN = 0xffffffff;

function decodePickRange(v: unknown, what: string): PickRange {
  if (!isObject(v)) throw new ProtocolError(`${what}: expected an object`);
  const kind = str(v.kind, 'bone');
  if (kind !== 'bone' && kind !== 'instance' && kind !== 'polygon') throw new ProtocolError(`${what}: unknown kind ${kind}`);
  return {
    firstTriangle: num(v.first_triangle, `${what}.first_triangle`),
    triangleCount: num(v.triangle_count, `${what}.triangle_count`),
    kind,
    index: optNum(v.index, 0),
    module: optNum(v.module, 0),
    origin: optNum(v.origin, NO_ORIGIN),
  };
}

/** Decode a model from the wire; validates every index against its vertex count. */
export function decodeModel(v: unknown): SceneModel {
  if (!isObject(v)) throw new ProtocolError('model: expected an object');
  const materials: SceneMaterial[] = (Array.isArray(v.materials) ? v.materials : []).map((m: unknown, i: number) => {
    if (!isObject(m)) throw new ProtocolError(`materials[${i}]: expected an object`);
    return {
      name: str(m.name, `material${i}`),
      color: vec3(m.color, `materials[${i}].color`),
      roughness: optNum(m.roughness, 0.8),
      metallic: optNum(m.metallic, 0),
      opacity: optNum(m.opacity, 1),
    };
  });
  let triangles = 0;
  const parts: ScenePart[] = (Array.isArray(v.parts) ? v.parts : []).map((p: unknown, i: number) => {
    if (!isObject(p)) throw new ProtocolError(`parts[${i}]: expected an object`);
    const positions = decodeF32(p.positions, `parts[${i}].positions`);
    if (positions.length % 3 !== 0) throw new ProtocolError(`parts[${i}].positions: length ${positions.length} is not a multiple of 3`);
    const normals = p.normals === undefined || p.normals === null ? null : decodeF32(p.normals, `parts[${i}].normals`);
    if (normals && normals.length !== positions.length) throw new ProtocolError(`parts[${i}].normals: length differs from positions`);
    const indices = decodeU32(p.indices, `parts[${i}].indices`);
    if (indices.length % 3 !== 0) throw new ProtocolError(`parts[${i}].indices: length ${indices.length} is not a multiple of 3`);
    const nv = positions.length / 3;
    for (let k = 0; k < indices.length; k++) {
      if (indices[k] >= nv) throw new ProtocolError(`parts[${i}].indices[${k}] = ${indices[k]} is out of range (${nv} vertices)`);
    }
    const material = optNum(p.material, 0);
    if (material < 0 || (materials.length > 0 && material >= materials.length)) {
      throw new ProtocolError(`parts[${i}].material ${material} is out of range`);
    }
    triangles += indices.length / 3;
    const picks = (Array.isArray(p.picks) ? p.picks : []).map((q: unknown, k: number) => decodePickRange(q, `parts[${i}].picks[${k}]`));
    return { material, positions, normals, indices, picks };
  });
  const bones: SceneBone[] = (Array.isArray(v.bones) ? v.bones : []).map((b: unknown, i: number) => {
    if (!isObject(b)) throw new ProtocolError(`bones[${i}]: expected an object`);
    return {
      base: vec3(b.base, `bones[${i}].base`),
      tip: vec3(b.tip, `bones[${i}].tip`),
      width: optNum(b.width, 0),
      module: optNum(b.module, 0),
      origin: optNum(b.origin, NO_ORIGIN),
    };
  });
  let bounds: Bounds | null = null;
  if (isObject(v.bounds)) bounds = { min: vec3(v.bounds.min, 'bounds.min'), max: vec3(v.bounds.max, 'bounds.max') };
  return { parts, materials, bones, bounds: bounds ?? computeBounds(parts, bones), triangles };
}

/** Bounds of the parts' vertices and the bones, or null for an empty model. */
export function computeBounds(parts: readonly ScenePart[], bones: readonly SceneBone[]): Bounds | null {
  const min: V3 = [Infinity, Infinity, Infinity];
  const max: V3 = [-Infinity, -Infinity, -Infinity];
  const addPoint = (x: number, y: number, z: number) => {
    min[0] = Math.min(min[0], x);
    min[1] = Math.min(min[1], y);
    min[2] = Math.min(min[2], z);
    max[0] = Math.max(max[0], x);
    max[1] = Math.max(max[1], y);
    max[2] = Math.max(max[2], z);
  };
  for (const p of parts) for (let i = 0; i < p.positions.length; i += 3) addPoint(p.positions[i], p.positions[i + 1], p.positions[i + 2]);
  for (const b of bones) {
    addPoint(...b.base);
    addPoint(...b.tip);
  }
  return min[0] <= max[0] ? { min, max } : null;
}

function decodeRule(r: unknown, what: string): RuleInfo {
  if (!isObject(r)) throw new ProtocolError(`${what}: expected an object`);
  const out: RuleInfo = {
    origin: optNum(r.origin, NO_ORIGIN),
    label: str(r.label),
    line: num(r.line, `${what}.line`),
    character: optNum(r.character, 0),
  };
  if (typeof r.uri === 'string') out.uri = r.uri;
  if (typeof r.end_line === 'number') out.endLine = r.end_line;
  if (typeof r.end_character === 'number') out.endCharacter = r.end_character;
  return out;
}

function decodeDiagnostic(d: unknown, i: number): Diagnostic {
  if (!isObject(d)) throw new ProtocolError(`diagnostics[${i}]: expected an object`);
  const sev = str(d.severity, 'error');
  const out: Diagnostic = {
    message: str(d.message),
    severity: sev === 'warning' || sev === 'info' ? sev : 'error',
  };
  if (typeof d.line === 'number') out.line = d.line;
  if (typeof d.character === 'number') out.character = d.character;
  if (typeof d.code === 'string') out.code = d.code;
  return out;
}

function numberRecord(v: unknown): Record<string, number> {
  const out: Record<string, number> = {};
  if (isObject(v)) for (const [k, x] of Object.entries(v)) if (typeof x === 'number') out[k] = x;
  return out;
}

/** Decode a preview result from the wire. */
export function decodePreview(v: unknown): PreviewResult {
  if (!isObject(v)) throw new ProtocolError('preview: expected an object');
  const mode = str(v.mode, 'derive');
  if (mode !== 'derive' && mode !== 'sample') throw new ProtocolError(`preview: unknown mode ${mode}`);
  const params: ParamInfo[] = (Array.isArray(v.params) ? v.params : []).map((p: unknown, i: number) => {
    if (!isObject(p)) throw new ProtocolError(`params[${i}]: expected an object`);
    const value = num(p.value, `params[${i}].value`);
    return {
      name: str(p.name),
      value,
      min: num(p.min, `params[${i}].min`),
      max: num(p.max, `params[${i}].max`),
      default: optNum(p.default, value),
    };
  });
  const out: PreviewResult = {
    uri: str(v.uri),
    system: str(v.system),
    mode,
    seed: optNum(v.seed, 0),
    params,
    model: v.model === null || v.model === undefined ? null : decodeModel(v.model),
    diagnostics: (Array.isArray(v.diagnostics) ? v.diagnostics : []).map(decodeDiagnostic),
    rules: (Array.isArray(v.rules) ? v.rules : []).map((r: unknown, i: number) => decodeRule(r, `rules[${i}]`)),
    timings: numberRecord(v.timings),
    stats: numberRecord(v.stats),
  };
  if (typeof v.id === 'number') out.id = v.id;
  if (v.curves !== undefined && v.curves !== null) out.curves = v.curves;
  if (typeof v.curves_path === 'string') out.curvesPath = v.curves_path;
  if (typeof v.error === 'string') out.error = v.error;
  return out;
}

export function decodePick(v: unknown): PickResult {
  if (!isObject(v)) throw new ProtocolError('pick: expected an object');
  return { rule: v.rule === null || v.rule === undefined ? null : decodeRule(v.rule, 'rule') };
}

export function decodeSpread(v: unknown): SpreadResult {
  if (!isObject(v)) throw new ProtocolError('spread: expected an object');
  return {
    origin: typeof v.origin === 'number' ? v.origin : null,
    ...(typeof v.label === 'string' ? { label: v.label } : {}),
    points: (Array.isArray(v.points) ? v.points : []).map((p: unknown, i: number) => vec3(p, `points[${i}]`)),
    bones: (Array.isArray(v.bones) ? v.bones : []).map((b: unknown, i: number) => num(b, `bones[${i}]`)),
  };
}

/** The pick range holding triangle `triangle` of a part, by binary search. */
export function findPick(part: ScenePart, triangle: number): PickRange | null {
  const picks = part.picks;
  let lo = 0;
  let hi = picks.length;
  while (lo < hi) {
    const mid = (lo + hi) >> 1;
    if (picks[mid].firstTriangle <= triangle) lo = mid + 1;
    else hi = mid;
  }
  const p = picks[lo - 1];
  return p && triangle < p.firstTriangle + p.triangleCount ? p : null;
}
