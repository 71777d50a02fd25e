// The scopes of a picked shape's path (shape mode, `grm/pick`'s
// `shape.scopes`) as line segments: each scope's box as its 12 edges (a
// face, of size 0 on one axis, draws as its rectangle), and each cut of a
// split or repeat as the rectangle where its plane crosses the command's
// scope. Pure (no three.js): the scene draws the segments.

import type { V3 } from './bezier.js';
import type { ScopeBox } from './protocol.js';

/** Line segments (pairs of points, flattened x, y, z) of the path's scopes. */
export interface ScopeLines {
  /** The shapes' boxes (the picked shape's last). */
  boxes: number[];
  /** The picked shape's own box. */
  picked: number[];
  /** The split planes of the path's splits and repeats. */
  cuts: number[];
  /** How many boxes and planes the segments draw. */
  boxCount: number;
  cutCount: number;
}

function at(s: ScopeBox, x: number, y: number, z: number): V3 {
  const [a, b, c] = s.axes;
  return [
    s.origin[0] + a[0] * x + b[0] * y + c[0] * z,
    s.origin[1] + a[1] * x + b[1] * y + c[1] * z,
    s.origin[2] + a[2] * x + b[2] * y + c[2] * z,
  ];
}

/** The edges of a scope's box, without repeats where it is flat. */
function boxEdges(s: ScopeBox, out: number[]): void {
  const [sx, sy, sz] = s.size;
  const corners: V3[] = [];
  for (const z of [0, sz]) for (const y of [0, sy]) for (const x of [0, sx]) corners.push(at(s, x, y, z));
  // Corner i has x = i & 1, y = i & 2, z = i & 4: an edge joins corners one bit apart.
  const seen = new Set<string>();
  for (let i = 0; i < 8; i++) {
    for (const bit of [1, 2, 4]) {
      const j = i | bit;
      if (j === i) continue;
      const key = [...corners[i], ...corners[j]].map((v) => v.toFixed(6)).join(',');
      if (seen.has(key) || (bit === 1 && sx === 0) || (bit === 2 && sy === 0) || (bit === 4 && sz === 0)) continue;
      seen.add(key);
      out.push(...corners[i], ...corners[j]);
    }
  }
}

/** The rectangle where the plane at `d` along `axis` crosses the scope. */
export function cutRect(s: ScopeBox, axis: number, d: number, out: number[]): void {
  const [u, v] = [0, 1, 2].filter((k) => k !== axis);
  const p = (a: number, b: number): V3 => {
    const local: V3 = [0, 0, 0];
    local[axis] = d;
    local[u] = a;
    local[v] = b;
    return at(s, local[0], local[1], local[2]);
  };
  const su = s.size[u];
  const sv = s.size[v];
  const ring: V3[] = sv === 0 ? [p(0, 0), p(su, 0)] : su === 0 ? [p(0, 0), p(0, sv)] : [p(0, 0), p(su, 0), p(su, sv), p(0, sv)];
  if (ring.length === 2) {
    out.push(...ring[0], ...ring[1]);
    return;
  }
  for (let i = 0; i < 4; i++) out.push(...ring[i], ...ring[(i + 1) % 4]);
}

/** The segments of a picked shape's path: its shapes' boxes, its own box, and every split plane. */
export function scopeLines(scopes: ScopeBox[]): ScopeLines {
  const out: ScopeLines = { boxes: [], picked: [], cuts: [], boxCount: 0, cutCount: 0 };
  scopes.forEach((s, i) => {
    if (s.command) {
      if (s.axis === null) return;
      for (const d of s.cuts) {
        cutRect(s, s.axis, d, out.cuts);
        out.cutCount++;
      }
      return;
    }
    boxEdges(s, i === scopes.length - 1 ? out.picked : out.boxes);
    out.boxCount++;
  });
  return out;
}
