// The preview protocol as the page sees it: the requests it makes (preview a
// grammar with seed, meta-parameters and curves; pick a part; save curves),
// the notifications it receives, and the decoding of a model from the wire
// into typed arrays for three.js. The wire format is the language server's
// (docs/lsp-extensions.md); `grmc view` serves the same JSON over HTTP.
//
// Everything wire-specific is in this file, so a change of the server's
// format is a change here only.

import type { V3 } from './bezier.js';
import type { CameraParams } from './messages.js';
import { pngSize } from './picture.js';
import { type EditsInfo, decodeEdits } from './edits-protocol.js';

// ---------------------------------------------------------------- requests

/** A position in a document: 0-based line, UTF-16 character. */
export interface Position {
  line: number;
  character: number;
}

export interface Range {
  start: Position;
  end: Position;
}

/** How a system grows: parallel rewriting, the guided sampler, or a split grammar (shape systems). */
export type Mode = 'derive' | 'sample' | 'shape';

/** Parameters of a preview request (LSP `grm/preview`, HTTP POST /api/preview). */
export interface PreviewParams {
  textDocument: { uri: string };
  /** Parallel rewriting, the guided sampler, or a shape system's split grammar. */
  mode?: Mode;
  /** The system to grow; omitted = the file's first system. */
  system?: string;
  /** Seed; omitted = the system's `seed` setting. */
  seed?: number;
  /** Meta-parameter values by name (sliders). */
  params?: Record<string, number>;
  /** Guiding curves (curves file v1 JSON) for a sample system. */
  curves?: unknown;
  /** A position in a production: the parts it grows are marked. */
  focus?: Position;
  /** Seeds for the focus spread. */
  spreadSeeds?: number;
  /** Shape mode: focus and context: the shape with this key drawn `depth` levels down, the rest as proxies. */
  context?: { key: string; depth: number };
  /** Ask the server to send `grm/previewUpdated` after edits. */
  live?: boolean;
  /**
   * Live requests: the page's id and the request's place among its live requests. The server answers a live
   * request ServerCancelled when the same client has begun a later one, whatever order they arrive in.
   */
  client?: string;
  order?: number;
  /**
   * Sample mode: show what the search returns when stopped after this generation
   * (0-based, as `grmc sample --frames` numbers them) instead of its result;
   * at or past the last generation run, the result. Ignored in derive mode.
   */
  generation?: number;
}

/** Parameters of a pick (LSP `grm/pick`, HTTP POST /api/pick): a triangle of a part, or a bone. */
export interface PickParams {
  textDocument: { uri: string };
  part?: number;
  triangle?: number;
  bone?: number;
}

/**
 * Parameters of a picture (LSP `grm/picture`, HTTP POST /api/picture): the
 * preview's parameters (the server ignores `live` and `focus`), the camera
 * (a perspective one, or the direction of a fitted view) and the picture's
 * size.
 */
export interface PictureParams extends PreviewParams {
  /** Degrees, as `grmc --view`: a view fitted to the model; omitted: the server's automatic view. */
  view?: { azimuth: number; elevation: number };
  /** A perspective camera, as `grmc --camera/--look-at/--fov`, not fitted to the model; never with `view` (the server refuses both). */
  camera?: CameraParams;
  /** Pixels; omitted: 1024 each. */
  width?: number;
  height?: number;
  /** An RGBA picture on a transparent background. */
  transparent?: boolean;
}

// ---------------------------------------------------------------- results

export interface ParamInfo {
  name: string;
  value: number;
  min: number;
  max: number;
  default: number;
}

export interface SceneMaterial {
  name: string;
  color: V3;
  roughness: number;
  metallic: number;
  opacity: number;
}

export type SourceKind = 'bone' | 'instance' | 'polygon' | 'shape';

export interface PickRange {
  firstTriangle: number;
  triangleCount: number;
  kind: SourceKind;
  index: number;
  module: number;
  /** Index into the result's origins, or null when unknown. */
  origin: number | null;
  /** Grown by the focused production. */
  focus: boolean;
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
  /** Index into the result's origins, or null when unknown. */
  origin: number | null;
  /** The bone it grows from (an index into the bones), null for a root; absent where the server does not say. */
  parent?: number | null;
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

/** A production that made part of the model. */
export interface Origin {
  uri: string;
  range: Range;
  /** The predecessor symbol, or `axiom`. */
  symbol: string;
}

export interface Focus {
  origin: number;
  bones: number;
  instances: number;
  /** Bones the focused production grows with each spread seed. */
  spreadBones: number[];
}

/** How much of one guiding curve the shown model follows (docs/curves.md 2.8). */
export interface CurveCoverage {
  name: string | null;
  /** The covered share of its arc length, in [0, 1]. */
  fraction: number;
  /** The covering radius: the curve's thickness plus 0.15. */
  radius: number;
  /** How close the nearest bone comes; null without bones. */
  nearest: number | null;
  /** No bone comes within the radius anywhere along it. */
  unreached: boolean;
  /** The uncovered stretches, as arc-length fractions [from, to). */
  gaps: [number, number][];
  /** Each gap as points along the curve (world space), for tinting. */
  gapPoints: V3[][];
  /** What `grmc sample --stats` says of it ("no gaps", "gaps at ...", or why it is not reached). */
  note: string;
}

/** How a guided-sampler run went (sample mode). */
export interface SampleInfo {
  /** The returned model's curve cost. */
  objective: number;
  generations: number;
  candidates: number;
  /** The wall-clock budget stopped the search early. */
  stoppedEarly: boolean;
  /** Where the curves came from: `request` or a file path. */
  curves: string;
  /** The generation whose model this is (0-based), when the request asked for one; null: the search's result. */
  generation: number | null;
  /** Per curve, in the curves' order: how much of it the shown model follows. */
  coverage: CurveCoverage[];
  /** Refinement rounds run after the search (docs/sampling.md 4.5): the model shown is the best of the pass and these. */
  refinements: number;
}

/** A warning about the model itself (W0013 no triangles, W0014 geometry left out). */
export interface ModelWarning {
  code: string;
  message: string;
  /** What the builder counted (e.g. bones without a tube). */
  notes: string[];
  help: string | null;
}

export interface PreviewResult {
  uri: string;
  version: number;
  system: string;
  mode: Mode;
  seed: number;
  /** The meta-parameters with a numeric range, when the server lists them. */
  params: ParamInfo[];
  /** Meta-parameters the server lists without a numeric range (no slider). */
  paramsWithoutRange: string[];
  sample: SampleInfo | null;
  model: SceneModel;
  origins: Origin[];
  focus: Focus | null;
  /** Server-side timings in milliseconds. */
  timings: Record<string, number>;
  stats: Record<string, number>;
  /** What the model lacks that its string asked for (none from a server that does not send them). */
  warnings: ModelWarning[];
  /** The edits file's edits with their classes (shape and derive mode; null: none sent). */
  edits: EditsInfo | null;
}

/** `grm/previewUpdated`: a new model after an edit, or why there is none. */
export interface PreviewUpdated {
  uri: string;
  version: number;
  result: PreviewResult | null;
  error: string | null;
}

export interface PickResult {
  uri: string;
  range: Range;
  symbol: string;
  version: number;
  module: number;
  /** The picked part's identity key (8 hex digits), when the server sends it. */
  key: string | null;
  /** The nodes from the root to the picked part (its key and symbol each; the root's symbol null). */
  ancestry: { key: string; symbol: string | null; production?: number | null }[];
  /** Shape mode: the picked shape's locators and its path's scopes. */
  shape: ShapePick | null;
}

/** A scope of a picked shape's path (model frame): a box, and a split's or repeat's cuts. */
export interface ScopeBox {
  node: number;
  /** A shape's symbol, or a command's label (`split.y`). */
  label: string;
  command: boolean;
  origin: V3;
  /** Unit x, y, z axes. */
  axes: [V3, V3, V3];
  size: V3;
  /** The axis a split or repeat divides (0 x, 1 y, 2 z), or null. */
  axis: number | null;
  /** Where its parts begin and end along that axis: the split planes. */
  cuts: number[];
  /** A command's identity key (8 hex digits), when the server sends it: what a plane drag names. */
  key: string | null;
  /** A split's or repeat's draggable planes: the plane at the end of child `edge` (from 1), `at` along the axis from the origin. */
  planes: ScopePlane[];
  /** A shape's exact and semantic locators (null: a command or insert, or a server that does not send them). */
  exact?: string | null;
  semantic?: string | null;
}

/** A split plane of a command scope (`grm/pick`'s `planes`). */
export interface ScopePlane {
  edge: number;
  at: number;
}

/** What `grm/pick` says of a shape (shape mode). */
export interface ShapePick {
  node: number;
  exact: string;
  semantic: string;
  /** The command's label (`split.x`), `successor`, `insert` or `axiom`. */
  madeBy: string;
  /** The rule that rewrote the shape itself, if one did. */
  rule: Range | null;
  /** From the axiom down to the shape (last). */
  scopes: ScopeBox[];
}

/**
 * A picture's answer. From the server (`grmc view`) it holds the PNG; in VS
 * Code the extension saves the PNG itself (a webview cannot download) and
 * says where instead.
 */
export interface PictureResult {
  system: string;
  seed: number;
  width: number;
  height: number;
  /** The PNG file's bytes; null where the host saved it (`saved`). */
  png: Uint8Array | null;
  /** Where the host saved the picture; null: the user cancelled the save dialog; undefined: the page has `png` to save. */
  saved?: string | null;
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

function parseCoverage(v: unknown, what: string): CurveCoverage {
  if (!isObject(v)) throw new ProtocolError(`preview: ${what} is not an object`);
  const pair = (g: unknown, i: number): [number, number] => {
    if (!Array.isArray(g) || g.length !== 2) throw new ProtocolError(`preview: ${what}.gaps[${i}] is not a pair`);
    return [num(g[0], `${what}.gaps[${i}][0]`), num(g[1], `${what}.gaps[${i}][1]`)];
  };
  const gaps = (Array.isArray(v.gaps) ? v.gaps : []).map(pair);
  const gapPoints = (Array.isArray(v.gapPoints) ? v.gapPoints : []).map((line: unknown, i: number) =>
    (Array.isArray(line) ? line : []).map((p: unknown, k: number) => vec3(p, `${what}.gapPoints[${i}][${k}]`)),
  );
  return {
    name: typeof v.name === 'string' ? v.name : null,
    fraction: Math.min(1, Math.max(0, optNum(v.fraction, 0))),
    radius: optNum(v.radius, 0),
    nearest: typeof v.nearest === 'number' && Number.isFinite(v.nearest) ? v.nearest : null,
    unreached: v.unreached === true,
    gaps,
    gapPoints,
    note: str(v.note),
  };
}

function vec3(v: unknown, what: string): V3 {
  if (!Array.isArray(v) || v.length !== 3) throw new ProtocolError(`${what}: expected [x, y, z]`);
  return [num(v[0], what), num(v[1], what), num(v[2], what)];
}

/** Bytes of a base64 string (standard alphabet, padding optional). */
export function base64ToBytes(b64: string): Uint8Array {
  // Native where the browser has it (a single pass in C++), else atob.
  const native = (Uint8Array as unknown as { fromBase64?: (s: string) => Uint8Array }).fromBase64;
  if (native) {
    try {
      return native.call(Uint8Array, b64);
    } catch {
      // Fall through: atob accepts what fromBase64 might not (missing padding).
    }
  }
  const bin = atob(b64);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}

const LITTLE_ENDIAN = new Uint8Array(new Uint16Array([1]).buffer)[0] === 1;

/** Base64 of bytes (the inverse of base64ToBytes; the tests build wire data with it). */
export function bytesToBase64(bytes: Uint8Array): string {
  let bin = '';
  for (let i = 0; i < bytes.length; i += 0x8000) {
    bin += String.fromCharCode(...bytes.subarray(i, i + 0x8000));
  }
  return btoa(bin);
}

/** A float array given as numbers, as base64 of little-endian f32, or as those bytes (a blob's range, protocol 3: src/blob.ts). */
export function decodeF32(v: unknown, what: string): Float32Array {
  if (Array.isArray(v)) return Float32Array.from(v, (x) => num(x, what));
  if (typeof v === 'string' || v instanceof Uint8Array) {
    const bytes = typeof v === 'string' ? base64ToBytes(v) : v;
    if (bytes.length % 4 !== 0) throw new ProtocolError(`${what}: ${bytes.length} bytes is not a whole number of f32`);
    // The wire is little-endian, like every machine a browser runs on: view the bytes as they are.
    if (LITTLE_ENDIAN && bytes.byteOffset % 4 === 0) return new Float32Array(bytes.buffer, bytes.byteOffset, bytes.length / 4);
    const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const out = new Float32Array(bytes.length / 4);
    for (let i = 0; i < out.length; i++) out[i] = dv.getFloat32(i * 4, true);
    return out;
  }
  throw new ProtocolError(`${what}: expected numbers or base64`);
}

/** An index array given as numbers, as base64 of little-endian u32, or as those bytes (a blob's range). */
export function decodeU32(v: unknown, what: string): Uint32Array {
  if (Array.isArray(v)) {
    return Uint32Array.from(v, (x) => {
      const n = num(x, what);
      if (!Number.isInteger(n) || n < 0) throw new ProtocolError(`${what}: ${n} is not an index`);
      return n;
    });
  }
  if (typeof v === 'string' || v instanceof Uint8Array) {
    const bytes = typeof v === 'string' ? base64ToBytes(v) : v;
    if (bytes.length % 4 !== 0) throw new ProtocolError(`${what}: ${bytes.length} bytes is not a whole number of u32`);
    if (LITTLE_ENDIAN && bytes.byteOffset % 4 === 0) return new Uint32Array(bytes.buffer, bytes.byteOffset, bytes.length / 4);
    const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    const out = new Uint32Array(bytes.length / 4);
    for (let i = 0; i < out.length; i++) out[i] = dv.getUint32(i * 4, true);
    return out;
  }
  throw new ProtocolError(`${what}: expected numbers or base64`);
}

const NO_ORIGIN = 0xffffffff;

function optIndex(v: unknown): number | null {
  return typeof v === 'number' && Number.isInteger(v) && v >= 0 && v !== NO_ORIGIN ? v : null;
}

function decodePickRange(v: unknown, what: string): PickRange {
  if (!isObject(v)) throw new ProtocolError(`${what}: expected an object`);
  const kind = str(v.kind, 'bone');
  if (kind !== 'bone' && kind !== 'instance' && kind !== 'polygon' && kind !== 'shape') throw new ProtocolError(`${what}: unknown kind ${kind}`);
  return {
    firstTriangle: num(v.firstTriangle, `${what}.firstTriangle`),
    triangleCount: num(v.triangleCount, `${what}.triangleCount`),
    kind,
    index: optNum(v.index, 0),
    module: optNum(v.module, 0),
    origin: optIndex(v.origin),
    focus: v.focus === true,
  };
}

/** `u32`s per pick in a part's `picks` buffer (docs/lsp-extensions.md). */
export const PICK_WORDS = 6;
/** The kinds of a pick, by their code in the `picks` buffer. */
const PICK_KINDS: readonly SourceKind[] = ['bone', 'instance', 'polygon', 'shape'];
/** Added to a pick's kind code when the focused production grew it. */
const PICK_FOCUS = 0x100;

/**
 * A part's picks: base64 of six little-endian `u32`s per pick (first
 * triangle, triangle count, kind code + 256 when focused, index, module,
 * origin with 0xFFFFFFFF unknown), or (older servers) an array of objects.
 */
export function decodePicks(v: unknown, count: unknown, what: string): PickRange[] {
  if (v === undefined || v === null || v === '') return [];
  if (Array.isArray(v)) return v.map((q: unknown, k: number) => decodePickRange(q, `${what}[${k}]`));
  const w = decodeU32(v, what);
  if (w.length % PICK_WORDS !== 0) throw new ProtocolError(`${what}: ${w.length} u32 is not a whole number of picks (${PICK_WORDS} each)`);
  const n = w.length / PICK_WORDS;
  if (count !== undefined && count !== n) throw new ProtocolError(`${what}: ${n} picks where pickCount says ${String(count)}`);
  const out: PickRange[] = new Array(n);
  for (let k = 0, i = 0; k < n; k++, i += PICK_WORDS) {
    const kind = PICK_KINDS[w[i + 2] & 0xff];
    if (kind === undefined) throw new ProtocolError(`${what}[${k}]: unknown kind code ${w[i + 2] & 0xff}`);
    out[k] = {
      firstTriangle: w[i],
      triangleCount: w[i + 1],
      kind,
      index: w[i + 3],
      module: w[i + 4],
      origin: w[i + 5] === NO_ORIGIN ? null : w[i + 5],
      focus: (w[i + 2] & PICK_FOCUS) !== 0,
    };
  }
  return out;
}

/**
 * A part in the `quads` layout rebuilt: three corners `a b c` per quad on
 * the wire, the fourth `d = a + c - b`; vertices `a b c d`, triangles
 * `a b c` and `a c d` (the server's `MeshData::quad`). Normals are the
 * faces' own, computed by the scene.
 */
export function expandQuads(corners: Float32Array, what: string): { positions: Float32Array; indices: Uint32Array } {
  if (corners.length % 9 !== 0) throw new ProtocolError(`${what}: length ${corners.length} is not a multiple of 9 (three corners per quad)`);
  const quads = corners.length / 9;
  const positions = new Float32Array(quads * 12);
  const indices = new Uint32Array(quads * 6);
  for (let q = 0; q < quads; q++) {
    const c = q * 9;
    const o = q * 12;
    for (let k = 0; k < 9; k++) positions[o + k] = corners[c + k];
    for (let k = 0; k < 3; k++) positions[o + 9 + k] = corners[c + k] + corners[c + 6 + k] - corners[c + 3 + k];
    const b = q * 4;
    indices.set([b, b + 1, b + 2, b, b + 2, b + 3], q * 6);
  }
  return { positions, indices };
}

/** Decode a model (materials, parts, skeleton) from a preview result on the wire. */
export function decodeModel(v: Record<string, unknown>): SceneModel {
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
    let positions: Float32Array;
    let normals: Float32Array | null;
    let indices: Uint32Array;
    if (p.layout === 'quads') {
      ({ positions, indices } = expandQuads(decodeF32(p.positions, `parts[${i}].positions`), `parts[${i}].positions`));
      normals = null;
    } else if (p.layout === undefined || p.layout === null) {
      positions = decodeF32(p.positions, `parts[${i}].positions`);
      if (positions.length % 3 !== 0) throw new ProtocolError(`parts[${i}].positions: length ${positions.length} is not a multiple of 3`);
      normals = p.normals === undefined || p.normals === null || p.normals === '' ? null : decodeF32(p.normals, `parts[${i}].normals`);
      if (normals && normals.length !== positions.length) throw new ProtocolError(`parts[${i}].normals: length differs from positions`);
      indices = decodeU32(p.indices, `parts[${i}].indices`);
    } else {
      throw new ProtocolError(`parts[${i}].layout: unknown layout ${JSON.stringify(p.layout)}`);
    }
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
    const picks = decodePicks(p.picks, p.pickCount, `parts[${i}].picks`);
    return { material, positions, normals, indices, picks };
  });
  const bones: SceneBone[] = [];
  if (isObject(v.skeleton)) {
    const sk = v.skeleton;
    const count = num(sk.boneCount ?? 0, 'skeleton.boneCount');
    const f = count > 0 ? decodeF32(sk.bones, 'skeleton.bones') : new Float32Array(0);
    if (f.length !== count * 8) throw new ProtocolError(`skeleton.bones: ${f.length} floats for ${count} bones (8 each)`);
    const o = count > 0 && sk.origins !== undefined ? decodeU32(sk.origins, 'skeleton.origins') : null;
    if (o && o.length !== count) throw new ProtocolError(`skeleton.origins: ${o.length} for ${count} bones`);
    // i32 per bone, -1 (0xFFFFFFFF read as u32) for a root.
    const par = count > 0 && ((typeof sk.parents === 'string' && sk.parents !== '') || sk.parents instanceof Uint8Array) ? decodeU32(sk.parents, 'skeleton.parents') : null;
    if (par && par.length !== count) throw new ProtocolError(`skeleton.parents: ${par.length} for ${count} bones`);
    for (let i = 0; i < count; i++) {
      const b = f.subarray(i * 8, i * 8 + 8);
      const parent = par ? optIndex(par[i]) : null;
      bones.push({ base: [b[0], b[1], b[2]], tip: [b[3], b[4], b[5]], width: b[6], origin: o ? optIndex(o[i]) : null, parent: parent !== null && parent < count ? parent : null });
    }
  }
  let bounds: Bounds | null = null;
  const st = isObject(v.stats) ? v.stats : {};
  if (Array.isArray(st.boundsMin) && Array.isArray(st.boundsMax) && (parts.length > 0 || bones.length > 0)) {
    bounds = { min: vec3(st.boundsMin, 'stats.boundsMin'), max: vec3(st.boundsMax, 'stats.boundsMax') };
  }
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

function decodePosition(v: unknown, what: string): Position {
  if (!isObject(v)) throw new ProtocolError(`${what}: expected a position`);
  return { line: num(v.line, `${what}.line`), character: num(v.character, `${what}.character`) };
}

function decodeRange(v: unknown, what: string): Range {
  if (!isObject(v)) throw new ProtocolError(`${what}: expected a range`);
  return { start: decodePosition(v.start, `${what}.start`), end: decodePosition(v.end, `${what}.end`) };
}

function decodeOrigin(v: unknown, what: string): Origin {
  if (!isObject(v)) throw new ProtocolError(`${what}: expected an object`);
  return { uri: str(v.uri), range: decodeRange(v.range, `${what}.range`), symbol: str(v.symbol) };
}

function numberRecord(v: unknown): Record<string, number> {
  const out: Record<string, number> = {};
  if (isObject(v)) for (const [k, x] of Object.entries(v)) if (typeof x === 'number') out[k] = x;
  return out;
}

/** Decode a `grm/preview` result. */
export function decodePreview(v: unknown): PreviewResult {
  if (!isObject(v)) throw new ProtocolError('preview: expected an object');
  // `blob-le` (protocol 3): the transport has put the blob's bytes in place of the ranges (src/blob.ts).
  if (v.encoding !== undefined && v.encoding !== 'base64-le' && v.encoding !== 'blob-le') throw new ProtocolError(`preview: unknown encoding ${String(v.encoding)}`);
  const mode = str(v.mode, 'derive');
  if (mode !== 'derive' && mode !== 'sample' && mode !== 'shape') throw new ProtocolError(`preview: unknown mode ${mode}`);
  // Meta-parameters as the server lists them; one without a numeric range
  // (the server's min/max are null) gets no slider.
  const params: ParamInfo[] = [];
  const paramsWithoutRange: string[] = [];
  (Array.isArray(v.params) ? v.params : []).forEach((p: unknown, i: number) => {
    if (!isObject(p)) throw new ProtocolError(`params[${i}]: expected an object`);
    const value = num(p.value, `params[${i}].value`);
    const name = str(p.name);
    if (typeof p.min !== 'number' || typeof p.max !== 'number' || !(p.min <= p.max)) {
      paramsWithoutRange.push(name);
      return;
    }
    params.push({ name, value, min: p.min, max: p.max, default: optNum(p.default, value) });
  });
  let sample: SampleInfo | null = null;
  if (isObject(v.sample)) {
    sample = {
      objective: optNum(v.sample.objective, NaN),
      generations: optNum(v.sample.generations, 0),
      candidates: optNum(v.sample.candidates, 0),
      stoppedEarly: v.sample.stoppedEarly === true,
      curves: str(v.sample.curves),
      generation: typeof v.sample.generation === 'number' && Number.isInteger(v.sample.generation) && v.sample.generation >= 0 ? v.sample.generation : null,
      coverage: (Array.isArray(v.sample.coverage) ? v.sample.coverage : []).map((c: unknown, i: number) => parseCoverage(c, `sample.coverage[${i}]`)),
      refinements: optNum(v.sample.refinements, 0),
    };
  }
  const stats = numberRecord(v.stats);
  const timings: Record<string, number> = {};
  for (const [k, x] of Object.entries(stats)) if (k.endsWith('Ms')) timings[k.slice(0, -2)] = x;
  let focus: Focus | null = null;
  if (isObject(v.focus)) {
    const f = v.focus;
    focus = {
      origin: num(f.origin, 'focus.origin'),
      bones: optNum(f.bones, 0),
      instances: optNum(f.instances, 0),
      spreadBones: (Array.isArray(f.spreadBones) ? f.spreadBones : []).map((x: unknown, i: number) => num(x, `focus.spreadBones[${i}]`)),
    };
  }
  return {
    uri: str(v.uri),
    version: optNum(v.version, 0),
    system: str(v.system),
    mode,
    seed: optNum(v.seed, 0),
    params,
    paramsWithoutRange,
    sample,
    model: decodeModel(v),
    origins: (Array.isArray(v.origins) ? v.origins : []).map((o: unknown, i: number) => decodeOrigin(o, `origins[${i}]`)),
    focus,
    timings,
    stats,
    warnings: (Array.isArray(v.warnings) ? v.warnings : []).map((w: unknown, i: number) => {
      if (!isObject(w)) throw new ProtocolError(`warnings[${i}]: expected an object`);
      const notes = (Array.isArray(w.notes) ? w.notes : []).filter((n: unknown): n is string => typeof n === 'string');
      return { code: str(w.code), message: str(w.message), notes, help: typeof w.help === 'string' ? w.help : null };
    }),
    edits: decodeEdits(v.edits),
  };
}

/** Decode a `grm/previewUpdated` notification's parameters. */
export function decodePreviewUpdated(v: unknown): PreviewUpdated {
  if (!isObject(v)) throw new ProtocolError('previewUpdated: expected an object');
  return {
    uri: str(v.uri),
    version: optNum(v.version, 0),
    result: isObject(v.result) ? decodePreview(v.result) : null,
    error: typeof v.error === 'string' ? v.error : null,
  };
}

/** Decode a `grm/pick` result (null: nothing known made that part). */
export function decodePick(v: unknown): PickResult | null {
  if (v === null || v === undefined) return null;
  if (!isObject(v)) throw new ProtocolError('pick: expected an object or null');
  return {
    uri: str(v.uri),
    range: decodeRange(v.range, 'range'),
    symbol: str(v.symbol),
    version: optNum(v.version, 0),
    module: optNum(v.module, 0),
    key: typeof v.key === 'string' ? v.key : null,
    ancestry: (Array.isArray(v.ancestry) ? v.ancestry : []).flatMap((a: unknown) =>
      isObject(a) && typeof a.key === 'string' && KEY.test(a.key)
        ? [{ key: a.key, symbol: typeof a.symbol === 'string' ? a.symbol : null, production: typeof a.production === 'number' ? a.production : null }]
        : [],
    ),
    shape: isObject(v.shape) ? decodeShapePick(v.shape) : null,
  };
}

function decodeV3(v: unknown, what: string): V3 {
  if (!Array.isArray(v) || v.length !== 3) throw new ProtocolError(`${what}: expected 3 numbers`);
  return [num(v[0], what), num(v[1], what), num(v[2], what)];
}

function decodeShapePick(v: Record<string, unknown>): ShapePick {
  const scopes = (Array.isArray(v.scopes) ? v.scopes : []).map((q: unknown, i: number): ScopeBox => {
    const what = `shape.scopes[${i}]`;
    if (!isObject(q)) throw new ProtocolError(`${what}: expected an object`);
    if (!Array.isArray(q.axes) || q.axes.length !== 3) throw new ProtocolError(`${what}.axes: expected 3 axes`);
    return {
      node: optNum(q.node, 0),
      label: str(q.label),
      command: q.command === true,
      origin: decodeV3(q.origin, `${what}.origin`),
      axes: [decodeV3(q.axes[0], `${what}.axes`), decodeV3(q.axes[1], `${what}.axes`), decodeV3(q.axes[2], `${what}.axes`)],
      size: decodeV3(q.size, `${what}.size`),
      axis: typeof q.axis === 'number' ? q.axis : null,
      cuts: (Array.isArray(q.cuts) ? q.cuts : []).map((c: unknown) => num(c, `${what}.cuts`)),
      key: typeof q.key === 'string' && KEY.test(q.key) ? q.key : null,
      planes: (Array.isArray(q.planes) ? q.planes : []).map((c: unknown, k: number): ScopePlane => {
        if (!isObject(c)) throw new ProtocolError(`${what}.planes[${k}]: expected an object`);
        const edge = num(c.edge, `${what}.planes[${k}].edge`);
        if (!Number.isSafeInteger(edge) || edge < 1) throw new ProtocolError(`${what}.planes[${k}].edge: expected a child number from 1, got ${edge}`);
        return { edge, at: num(c.at, `${what}.planes[${k}].at`) };
      }),
      exact: typeof q.exact === 'string' ? q.exact : null,
      semantic: typeof q.semantic === 'string' ? q.semantic : null,
    };
  });
  return {
    node: optNum(v.node, 0),
    exact: str(v.exact),
    semantic: str(v.semantic),
    madeBy: str(v.madeBy),
    rule: isObject(v.rule) ? decodeRange(v.rule, 'shape.rule') : null,
    scopes,
  };
}

/** Decode a `picture` answer: a PNG of the size it says (base64 on the wire), or where the host saved it. */
export function decodePicture(v: unknown): PictureResult {
  if (!isObject(v)) throw new ProtocolError('picture: expected an object');
  const out: PictureResult = { system: str(v.system), seed: optNum(v.seed, 0), width: num(v.width, 'width'), height: num(v.height, 'height'), png: null };
  if (typeof v.png === 'string') {
    let bytes: Uint8Array;
    try {
      bytes = base64ToBytes(v.png);
    } catch {
      throw new ProtocolError('picture: png is not base64');
    }
    const size = pngSize(bytes);
    if (!size) throw new ProtocolError('picture: png is not a PNG file');
    if (size.width !== out.width || size.height !== out.height) {
      throw new ProtocolError(`picture: the PNG is ${size.width}x${size.height}, the answer says ${out.width}x${out.height}`);
    }
    out.png = bytes;
  } else if (typeof v.saved === 'string' || v.saved === null) {
    out.saved = v.saved;
  } else {
    throw new ProtocolError('picture: the answer has neither a png nor where it was saved');
  }
  return out;
}

/** LSP SymbolKind.Variable: how the server lists a meta-parameter (`param`). */
const SYMBOL_KIND_VARIABLE = 13;
const NUMBER = String.raw`[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?`;
const PARAM_DETAIL = new RegExp(String.raw`^\s*(${NUMBER})\s+in\s+(${NUMBER})\s*\.\.\s*(${NUMBER})\s*$`);

/**
 * The meta-parameters of a document from its `textDocument/documentSymbol`
 * answer: the server lists each `param` as a top-level variable whose detail
 * is its source text, `30 in 10 .. 60`. Parameters whose default or bounds
 * are expressions rather than numbers get no slider (their values are only
 * known to the checker); they are reported in `skipped`.
 */
export function paramsFromSymbols(symbols: unknown): { params: ParamInfo[]; skipped: string[] } {
  const params: ParamInfo[] = [];
  const skipped: string[] = [];
  if (!Array.isArray(symbols)) return { params, skipped };
  for (const s of symbols) {
    if (!isObject(s) || s.kind !== SYMBOL_KIND_VARIABLE || typeof s.name !== 'string') continue;
    const m = typeof s.detail === 'string' ? PARAM_DETAIL.exec(s.detail) : null;
    const [value, min, max] = m ? [Number(m[1]), Number(m[2]), Number(m[3])] : [NaN, NaN, NaN];
    if (![value, min, max].every(Number.isFinite) || !(min <= max)) {
      skipped.push(s.name);
      continue;
    }
    params.push({ name: s.name, value, min, max, default: value });
  }
  return { params, skipped };
}

/** LSP SymbolKind.Class: how the server lists a system, with detail `system (derive)`, `system (sample)` or `system (shape)`. */
const SYMBOL_KIND_CLASS = 3;

/** The mode of the document's first system (the one a preview grows by default), from its symbols. */
export function modeFromSymbols(symbols: unknown): Mode | null {
  if (!Array.isArray(symbols)) return null;
  for (const s of symbols) {
    if (!isObject(s) || s.kind !== SYMBOL_KIND_CLASS || typeof s.detail !== 'string') continue;
    const m = /^system \((derive|sample|shape)\)$/.exec(s.detail);
    if (m) return m[1] as Mode;
  }
  return null;
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

// ---------------------------------------------------------------- direct manipulation (issue 28)

/** An identity key as the server writes it: 8 hex digits. */
export const KEY = /^[0-9a-f]{8}$/i;

/** A picked part a drag moves (docs/lsp-extensions.md, "Direct manipulation"), named by identity key. */
export type ManipPart =
  /** Shape mode: the plane at the end of child `edge` (from 1) of the split or repeat whose key is `command`. */
  | { kind: 'plane'; command: string; edge: number }
  /** Shape mode: a shape's scope. */
  | { kind: 'shape'; key: string }
  /** Derive mode: a bone (its module's key). */
  | { kind: 'bone'; key: string };

/** Where a drag puts its part (the model's frame, y up). */
export type ManipTarget =
  /** A plane's distance from its command's scope corner, along its axis. */
  | { kind: 'plane'; at: number }
  | { kind: 'size'; axis: number; size: number }
  | { kind: 'corner'; at: V3 }
  /** A bone's tip. */
  | { kind: 'tip'; at: V3 }
  | { kind: 'length'; length: number };

/** What every manipulation request carries besides its own fields: the model on screen's system, seed and slider values. */
export interface ManipBase {
  textDocument: { uri: string };
  system?: string;
  seed?: number;
  params?: Record<string, number>;
}

/** `grm/provenance`: the source numbers that place a part. */
export interface ProvenanceParams extends ManipBase {
  part: ManipPart;
}

/** `grm/drag`: move a part to a target by rewriting the fewest source numbers. */
export interface DragParams extends ManipBase {
  /** The document version the model on screen was grown from (the server refuses a drag of an older model: ContentModified). */
  version?: number;
  part: ManipPart;
  target: ManipTarget;
  /** Default true; false: only propose. */
  apply?: boolean;
}

/** A sketched pose of the part at slider value `t` (0 < t <= 1; t = 0 is the model as it is). */
export interface SketchKeyframe {
  t: number;
  target: ManipTarget;
}

/** `grm/sketch`: a new meta-parameter `name` in 0 .. 1 that sweeps the part from where it is (t = 0) to the keyframes' poses. */
export interface SketchParams extends ManipBase {
  part: ManipPart;
  name: string;
  keyframes: SketchKeyframe[];
  apply?: boolean;
}

/** `grm/writeParams`: slider values written back as the `param` declarations' defaults. */
export interface WriteParamsParams {
  textDocument: { uri: string };
  system?: string;
  params: Record<string, number>;
}

/** One source number rewritten: its text before and after. */
export interface SourceChange {
  range: Range;
  old: string;
  new: string;
}

/** The answer to a drag, a sketch or a write of the sliders. */
export interface ManipResult {
  /** `solved`, `unchanged` (the part is there already) or `unreachable` (nothing written); null where the answer has none (`grm/writeParams`). */
  outcome: string | null;
  /** Why a drag is unreachable. */
  why: string | null;
  changes: SourceChange[];
  /** The part's distance from the target, grown with the edit. */
  residual: number | null;
  /** Terminal parts that move (the part included). */
  moved: number | null;
  /** Whether the edit was applied (the client's answer, or the file written); null when the answer does not say. */
  applied: boolean | null;
  failureReason: string | null;
  /** Sketch: the new meta-parameter, each keyframe's distance from its pose (`[t, distance]`), and whether t = 0 grows the original model bit for bit. */
  name: string | null;
  residuals: [number, number][];
  exactAtZero: boolean | null;
}

/** Decode the answer to `drag`, `sketch` or `writeParams` (`what` names it in errors). */
export function decodeManipResult(v: unknown, what: string): ManipResult {
  if (!isObject(v)) throw new ProtocolError(`${what}: expected an object`);
  const changes = (Array.isArray(v.changes) ? v.changes : []).map((c: unknown, i: number): SourceChange => {
    if (!isObject(c)) throw new ProtocolError(`${what}: changes[${i}] is not an object`);
    return { range: decodeRange(c.range, `${what}.changes[${i}].range`), old: str(c.old), new: str(c.new) };
  });
  const residuals = (Array.isArray(v.residuals) ? v.residuals : []).map((r: unknown, i: number): [number, number] => {
    if (!Array.isArray(r) || r.length !== 2) throw new ProtocolError(`${what}: residuals[${i}] is not a pair [t, distance]`);
    return [num(r[0], `${what}.residuals[${i}][0]`), num(r[1], `${what}.residuals[${i}][1]`)];
  });
  const optional = (x: unknown): number | null => (typeof x === 'number' && Number.isFinite(x) ? x : null);
  return {
    outcome: typeof v.outcome === 'string' ? v.outcome : null,
    why: typeof v.why === 'string' ? v.why : null,
    changes,
    residual: optional(v.residual),
    moved: optional(v.moved),
    applied: typeof v.applied === 'boolean' ? v.applied : null,
    failureReason: typeof v.failureReason === 'string' ? v.failureReason : null,
    name: typeof v.name === 'string' ? v.name : null,
    residuals,
    exactAtZero: typeof v.exactAtZero === 'boolean' ? v.exactAtZero : null,
  };
}

/** A source number that places a part (`grm/provenance`'s `sources`). */
export interface ProvenanceSource {
  range: Range;
  /** Its text in the source (`4`, `H`). */
  text: string;
  value: number;
  /** `literal`, `name` (a use of a constant or meta-parameter), ... as the server says. */
  kind: string;
  /** How the part's measures change with it (d measures / d value). */
  derivative: number[];
  /** Terminal parts that move with it. */
  moves: number | null;
}

/** `grm/provenance`'s answer: the numbers that place a part, and whether a random draw does too. */
export interface ProvenanceResult {
  measures: number[];
  random: boolean;
  probed: number;
  sources: ProvenanceSource[];
}

export function decodeProvenance(v: unknown): ProvenanceResult {
  if (!isObject(v)) throw new ProtocolError('provenance: expected an object');
  const sources = (Array.isArray(v.sources) ? v.sources : []).map((q: unknown, i: number): ProvenanceSource => {
    const what = `provenance.sources[${i}]`;
    if (!isObject(q)) throw new ProtocolError(`${what}: expected an object`);
    return {
      range: decodeRange(q.range, `${what}.range`),
      text: str(q.text),
      value: num(q.value, `${what}.value`),
      kind: str(q.kind),
      derivative: (Array.isArray(q.derivative) ? q.derivative : []).map((d: unknown) => num(d, `${what}.derivative`)),
      moves: typeof q.moves === 'number' && Number.isFinite(q.moves) ? q.moves : null,
    };
  });
  return {
    measures: (Array.isArray(v.measures) ? v.measures : []).map((m: unknown) => num(m, 'provenance.measures')),
    random: v.random === true,
    probed: optNum(v.probed, 0),
    sources,
  };
}
