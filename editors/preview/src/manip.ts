// Direct manipulation in the preview (issue 28, docs/lsp-extensions.md
// "Direct manipulation"), the part without three.js: the draggable split
// planes of a picked shape's path, the geometry of a drag (the pointer's
// ray projected onto a plane's axis, or onto the view plane through a bone's
// tip), the sketched keyframes of a new slider, and what the page says of
// the server's answers. The scene draws the handles; main.ts sends the
// requests.

import type { V3 } from './bezier.js';
import type { ManipPart, ManipResult, ManipTarget, ProvenanceResult, ScopeBox, SketchKeyframe } from './protocol.js';

/** A draggable split plane: the plane at the end of child `edge` of the split or repeat `command`. */
export interface PlaneHandle {
  /** The command's identity key (what the drag names). */
  command: string;
  edge: number;
  /** Where the plane is: its distance from the command scope's corner along its axis. */
  at: number;
  /** The command's label (`split.x`, `repeat.y`). */
  label: string;
  /** The command's scope (the one it divides). */
  scope: ScopeBox;
  /** The axis it divides (0 x, 1 y, 2 z). */
  axis: number;
  /**
   * A size handle: the far face of a shape's own scope along `axis` (`command` is then the shape's key, `edge` 0);
   * dragging it sets the shape's size (`{kind: 'shape'}` to `{kind: 'size'}`), e.g. a mass's height.
   */
  size?: boolean;
}

/**
 * The draggable planes of a picked shape's path, from the axiom down: each split's or repeat's `planes`, then the top
 * of its mass (the first shape from the lot with a height: its size along its scope's z, the extrusion's) and its far
 * faces along x and y (its width and depth: the lot's).
 */
export function planeHandles(scopes: readonly ScopeBox[]): PlaneHandle[] {
  const out: PlaneHandle[] = [];
  const heights: PlaneHandle[] = [];
  for (const s of scopes) {
    if (s.key === null) continue;
    if (!s.command) {
      // The mass: the first shape from the lot with a height (the shapes inside it are sized by its splits): its
      // height, then its width and depth (its far faces along x and y; a drag scales it along that axis).
      if (s.size[2] > 1e-6 && heights.length === 0) {
        heights.push({ command: s.key, edge: 0, at: s.size[2], label: `${s.label} height`, scope: s, axis: 2, size: true });
        if (s.size[0] > 1e-6) heights.push({ command: s.key, edge: 0, at: s.size[0], label: `${s.label} width`, scope: s, axis: 0, size: true });
        if (s.size[1] > 1e-6) heights.push({ command: s.key, edge: 0, at: s.size[1], label: `${s.label} depth`, scope: s, axis: 1, size: true });
      }
      continue;
    }
    if (s.axis === null || s.axis < 0 || s.axis > 2) continue;
    for (const p of s.planes) out.push({ command: s.key, edge: p.edge, at: p.at, label: s.label, scope: s, axis: s.axis });
  }
  // The splits' planes first, then the heights.
  return [...out, ...heights];
}

/** What a handle's drag names: a split's plane, or a shape's size. */
export function handlePart(h: PlaneHandle, at: number): { part: ManipPart; target: ManipTarget } {
  return h.size
    ? { part: { kind: 'shape', key: h.command }, target: { kind: 'size', axis: h.axis, size: at } }
    : { part: { kind: 'plane', command: h.command, edge: h.edge }, target: { kind: 'plane', at } };
}

/** A point of a scope from its local coordinates (along its axes, from its corner). */
export function scopePoint(s: ScopeBox, local: V3): V3 {
  const [a, b, c] = s.axes;
  return [
    s.origin[0] + a[0] * local[0] + b[0] * local[1] + c[0] * local[2],
    s.origin[1] + a[1] * local[0] + b[1] * local[1] + c[1] * local[2],
    s.origin[2] + a[2] * local[0] + b[2] * local[1] + c[2] * local[2],
  ];
}

/** The centre of a plane handle's rectangle with the plane at `at` (where its grip is drawn). */
export function planeCentre(h: PlaneHandle, at = h.at): V3 {
  const local: V3 = [h.scope.size[0] / 2, h.scope.size[1] / 2, h.scope.size[2] / 2];
  local[h.axis] = at;
  return scopePoint(h.scope, local);
}

/** The handle's axis as a world direction (unit: the scope's axes are). */
export function planeAxis(h: PlaneHandle): V3 {
  return h.scope.axes[h.axis];
}

const dot = (a: V3, b: V3): number => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
const sub = (a: V3, b: V3): V3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];

/**
 * Where along the line `lineOrigin + s * lineDir` the ray `rayOrigin + t *
 * rayDir` passes closest: `s`, in units of `lineDir`'s length. Null where the
 * ray runs along the line (no one closest point) or either direction is zero.
 */
export function closestOnLine(rayOrigin: V3, rayDir: V3, lineOrigin: V3, lineDir: V3): number | null {
  const a = dot(rayDir, rayDir);
  const b = dot(rayDir, lineDir);
  const c = dot(lineDir, lineDir);
  if (!(a > 0) || !(c > 0)) return null;
  const w = sub(rayOrigin, lineOrigin);
  const d = dot(rayDir, w);
  const e = dot(lineDir, w);
  const denom = a * c - b * b;
  // Parallel (within float noise, relative to the lengths): every point of the line is as close.
  if (denom <= 1e-9 * a * c) return null;
  const s = (a * e - b * d) / denom;
  return Number.isFinite(s) ? s : null;
}

/** A ray from the camera through the pointer (world frame). */
export interface Ray {
  origin: V3;
  dir: V3;
}

/**
 * Where along the line `lineOrigin + s * lineDir` the pointer is: the ray
 * meets the plane that holds the line and faces `facing` (the view
 * direction) as nearly as a plane holding the line can, and that point is
 * projected onto the line. Unlike the closest point between the ray and the
 * line, a pointer moved across the line (not along it) stays where it was in
 * perspective too. Where the ray runs along that plane, the closest point.
 */
export function alongLine(ray: Ray, lineOrigin: V3, lineDir: V3, facing: V3): number | null {
  const c = dot(lineDir, lineDir);
  if (!(c > 0)) return null;
  // The part of the view direction across the line: the plane's normal.
  const k = dot(facing, lineDir) / c;
  const n: V3 = [facing[0] - k * lineDir[0], facing[1] - k * lineDir[1], facing[2] - k * lineDir[2]];
  const nn = Math.sqrt(dot(n, n));
  const dn = Math.sqrt(dot(ray.dir, ray.dir));
  if (nn > 1e-9 && dn > 0 && Math.abs(dot(n, ray.dir)) > 1e-6 * nn * dn) {
    const t = dot(n, sub(lineOrigin, ray.origin)) / dot(n, ray.dir);
    if (Number.isFinite(t)) {
      const p: V3 = [ray.origin[0] + ray.dir[0] * t, ray.origin[1] + ray.dir[1] * t, ray.origin[2] + ray.dir[2] * t];
      return dot(sub(p, lineOrigin), lineDir) / c;
    }
  }
  return closestOnLine(ray.origin, ray.dir, lineOrigin, lineDir);
}

/**
 * A plane drag: where the plane is (`at`) with the pointer's ray at `ray`,
 * for a drag that grabbed the plane at `at0` with the ray at `ray0`. Both
 * rays are projected onto the line through the grip along the plane's axis
 * (`alongLine`, in the plane through it that faces `facing`: the camera's
 * direction when it was grabbed; default the grabbing ray's); the plane
 * moves by the difference, so it does not jump to the pointer when grabbed
 * off its centre. Null where the ray runs along the axis.
 */
export function dragPlaneAt(h: PlaneHandle, at0: number, ray0: Ray, ray: Ray, facing: V3 = ray0.dir): number | null {
  const grip = planeCentre(h, at0);
  const axis = planeAxis(h);
  const len = Math.sqrt(dot(axis, axis));
  const s0 = alongLine(ray0, grip, axis, facing);
  const s = alongLine(ray, grip, axis, facing);
  if (s0 === null || s === null || !(len > 0)) return null;
  return at0 + (s - s0) * len;
}

/** Where the ray meets the plane through `point` with normal `normal`; null when it runs along the plane or meets it behind its origin. */
export function rayPlane(ray: Ray, normal: V3, point: V3): V3 | null {
  const denom = dot(normal, ray.dir);
  if (Math.abs(denom) < 1e-12) return null;
  const t = dot(normal, sub(point, ray.origin)) / denom;
  if (!(t >= 0) || !Number.isFinite(t)) return null;
  return [ray.origin[0] + ray.dir[0] * t, ray.origin[1] + ray.dir[1] * t, ray.origin[2] + ray.dir[2] * t];
}

const cross = (a: V3, b: V3): V3 => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
const unit = (a: V3): V3 | null => {
  const l = Math.sqrt(dot(a, a));
  return l > 1e-12 && Number.isFinite(l) ? [a[0] / l, a[1] / l, a[2] / l] : null;
};

/**
 * The normal of the plane a bone's tip is dragged in (through the tip):
 * the plane of the bone and the bone it grows from (the turtle's plane: a
 * flat L-system stays flat, so a tip dropped off that plane would be out of
 * the numbers' reach), unless that plane is seen nearly edge on or the two
 * bones are in line; then the plane that holds the bone and faces the view
 * as nearly as it can (a drag along the bone on screen stays on its line);
 * looking along the bone, the view plane.
 */
export function tipDragNormal(base: V3, tip: V3, parentDir: V3 | null, view: V3): V3 {
  const v = unit(view) ?? [0, 0, -1];
  const u = unit(sub(tip, base));
  if (!u) return v;
  const p = parentDir ? unit(parentDir) : null;
  const turtle = p ? unit(cross(u, p)) : null;
  // Edge on past about 78 degrees: the pointer's ray would meet it far off.
  if (turtle && Math.abs(dot(turtle, v)) > 0.2) return turtle;
  const k = dot(v, u);
  return unit([v[0] - k * u[0], v[1] - k * u[1], v[2] - k * u[2]]) ?? v;
}

/** How far beside a bone's tip its length and angle grips sit, as a share of the bone's length. */
export const BONE_GRIP_OFFSET = 0.35;

/**
 * A bone's length and angle grips beside its tip (issue 28, item 2): the length grip on the bone's line past the tip,
 * the angle grip off the tip across the bone, in the drag plane (whose normal is `normal`, as `tipDragNormal` gives).
 * Null for a bone of no length.
 */
export function boneGrips(base: V3, tip: V3, normal: V3): { length: V3; angle: V3 } | null {
  const d = sub(tip, base);
  const len = Math.hypot(d[0], d[1], d[2]);
  const u = unit(d);
  const w = u ? unit(cross(normal, u)) : null;
  if (!u || !w || !(len > 0)) return null;
  const k = BONE_GRIP_OFFSET * len;
  return {
    length: [tip[0] + k * u[0], tip[1] + k * u[1], tip[2] + k * u[2]],
    angle: [tip[0] + k * w[0], tip[1] + k * w[1], tip[2] + k * w[2]],
  };
}

/**
 * The length grip dragged from `grab` to `p` (points of the drag plane): the bone's new length, its old one plus
 * the move along the bone; null when it would be no length at all.
 */
export function draggedLength(base: V3, tip: V3, grab: V3, p: V3): number | null {
  const d = sub(tip, base);
  const u = unit(d);
  if (!u) return null;
  const len = Math.hypot(d[0], d[1], d[2]) + dot(sub(p, grab), u);
  return len > 1e-6 ? len : null;
}

/**
 * The angle grip dragged from `grab` to `p`: the bone turned about its base, in the drag plane (normal `normal`), by
 * the angle from `grab` to `p` as seen from the base; its length kept. The new tip and the angle (degrees,
 * counter-clockwise about `normal`).
 */
export function rotatedTip(base: V3, tip: V3, normal: V3, grab: V3, p: V3): { tip: V3; degrees: number } | null {
  const n = unit(normal);
  if (!n) return null;
  // Both in the plane through the base.
  const flat = (v: V3): V3 => {
    const k = dot(v, n);
    return [v[0] - k * n[0], v[1] - k * n[1], v[2] - k * n[2]];
  };
  const a = flat(sub(grab, base));
  const b = flat(sub(p, base));
  if (!unit(a) || !unit(b)) return null;
  const angle = Math.atan2(dot(cross(a, b), n), dot(a, b));
  // Rodrigues: the bone's vector turned by `angle` about n.
  const v = sub(tip, base);
  const c = Math.cos(angle);
  const s = Math.sin(angle);
  const kv = cross(n, v);
  const nv = dot(n, v) * (1 - c);
  const r: V3 = [0, 1, 2].map((i) => v[i]! * c + kv[i]! * s + n[i]! * nv) as V3;
  return { tip: [base[0] + r[0], base[1] + r[1], base[2] + r[2]], degrees: (angle * 180) / Math.PI };
}

/** A short number for the page: at most 3 decimals, no trailing zeros. */
export function short(x: number): string {
  if (!Number.isFinite(x)) return String(x);
  return String(Number(x.toFixed(3)));
}

/** What the page says of a drag's target while dragging and once sent. */
export function describeTarget(t: ManipTarget): string {
  switch (t.kind) {
    case 'plane':
      return `plane at ${short(t.at)}`;
    case 'tip':
      return `tip at (${t.at.map(short).join(', ')})`;
    case 'corner':
      return `corner at (${t.at.map(short).join(', ')})`;
    case 'size':
      return `size ${short(t.size)} along ${'xyz'[t.axis] ?? t.axis}`;
    case 'length':
      return `length ${short(t.length)}`;
  }
}

const plural = (n: number, one: string, many = `${one}s`): string => `${n} ${n === 1 ? one : many}`;

/**
 * The status line for a drag's (or a sketch's, or a write's) answer:
 * solved: the changes (`old → new`) and how many parts move; unchanged;
 * unreachable: why; and a change the editor did not apply.
 */
export function manipSummary(r: ManipResult, what = 'drag'): { text: string; error: boolean } {
  if (r.outcome === 'unreachable') return { text: `${what}: cannot be written: ${r.why ?? 'no source number places it there'}`, error: true };
  if (r.outcome === 'unchanged') return { text: `${what}: it is there already; nothing to change`, error: false };
  const parts: string[] = [];
  const changes = r.changes.map((c) => `${c.old} → ${c.new}`);
  parts.push(changes.length ? changes.join(', ') : 'no change');
  if (r.moved !== null) parts.push(`moves ${plural(r.moved, 'part')}`);
  if (r.residual !== null && r.residual > 1e-6) parts.push(`off by ${short(r.residual)}`);
  if (r.name !== null) parts.push(`slider ${r.name}`);
  if (r.residuals.length) parts.push(`residuals ${r.residuals.map(([t, d]) => `t=${short(t)}: ${short(d)}`).join(', ')}`);
  if (r.exactAtZero !== null) parts.push(r.exactAtZero ? 'exact at t = 0' : 'NOT exact at t = 0');
  if (r.applied === false) {
    parts.push(`not applied${r.failureReason ? `: ${r.failureReason}` : ''}`);
    return { text: `${what}: ${parts.join(' · ')}`, error: true };
  }
  return { text: `${what}: ${parts.join(' · ')}`, error: false };
}

/**
 * The poses sketched for a new slider (one part): a keyframe per value of t
 * (a later pose at the same t replaces the earlier), sent in order of t.
 * t = 1 is required: it is the pose the slider's end grows.
 */
export class SketchKeys {
  private keys = new Map<number, ManipTarget>();
  /** The part the poses are of (its JSON): poses of another part start over. */
  private partKey = '';

  /** Record the pose at `t` (0 < t <= 1) of the part named by `part` (JSON); false for a t out of range. */
  set(part: string, t: number, target: ManipTarget): boolean {
    if (!(t > 0 && t <= 1)) return false;
    if (part !== this.partKey) {
      this.keys.clear();
      this.partKey = part;
    }
    this.keys.set(t, target);
    return true;
  }

  clear(): void {
    this.keys.clear();
    this.partKey = '';
  }

  get part(): string {
    return this.partKey;
  }

  get size(): number {
    return this.keys.size;
  }

  /** A pose at t = 1 exists: a slider can be made. */
  get ready(): boolean {
    return this.keys.has(1);
  }

  keyframes(): SketchKeyframe[] {
    return [...this.keys.entries()].sort((a, b) => a[0] - b[0]).map(([t, target]) => ({ t, target }));
  }
}

/** A slider name the language takes (an identifier); null when it is fine, else why not. */
export function sliderNameProblem(name: string): string | null {
  if (name === '') return 'give the slider a name';
  if (!/^[A-Za-z_][A-Za-z0-9_]*$/.test(name)) return 'a name is letters, digits and _, not starting with a digit';
  return null;
}

/**
 * The sliders to write back: those whose value differs from the default
 * written in the grammar (writing the others would change nothing), with
 * the confirmation the page asks (never silently).
 */
export function paramsToWrite(info: readonly { name: string; default: number }[], value: (name: string) => number | undefined): { params: Record<string, number>; prompt: string } {
  const params: Record<string, number> = {};
  const lines: string[] = [];
  for (const p of info) {
    const v = value(p.name);
    if (v === undefined || !Number.isFinite(v) || v === p.default) continue;
    params[p.name] = v;
    lines.push(`${p.name}: ${short(p.default)} → ${short(v)}`);
  }
  return { params, prompt: lines.length ? `Write these slider values into the grammar as the defaults? ${lines.join(', ')}` : '' };
}

/**
 * What the page says of a part's provenance while it is dragged: the
 * numbers that place it (each with its line and how many parts move with
 * it), and that a random draw places it too (a drag may then not be
 * written).
 */
export function provenanceSummary(p: ProvenanceResult): string {
  const numbers = p.sources.map((s) => `${s.text} (line ${s.range.start.line + 1}${s.moves !== null ? `, moves ${plural(s.moves, 'part')}` : ''})`);
  const by = numbers.length ? `placed by ${numbers.join(', ')}` : 'no number in this file places it';
  return p.random ? `${by}; a random draw places it too` : by;
}
