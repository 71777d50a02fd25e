//! The weighted straight skeleton of a ring, by simulating its wavefront
//! (edge, split and vertex events; the module doc of `roof` says how).

use super::*;

/// The skeleton of one ring: its nodes `(x, y, t)` (the ring's corners
/// first, at t = 0) and, per edge, its face: node indices counter-clockwise
/// seen from above, starting with the edge's start and end.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    pub nodes: Vec<[f64; 3]>,
    pub faces: Vec<Vec<u32>>,
}

/// An edge's supporting line: unit direction, inward unit normal, speed.
#[derive(Clone, Copy)]
pub(super) struct Line {
    d: [f64; 2],
    n: [f64; 2],
    w: f64,
}

/// A wavefront vertex: where it was made (`p0` at time `t0`, node `node`),
/// its velocity, and the edges before (`le`) and after (`re`) it.
#[derive(Clone, Copy)]
pub(super) struct Vtx {
    p0: [f64; 2],
    t0: f64,
    vel: [f64; 2],
    le: u32,
    re: u32,
    node: u32,
}

impl Vtx {
    #[inline]
    fn at(&self, t: f64) -> [f64; 2] {
        let dt = t - self.t0;
        [self.p0[0] + self.vel[0] * dt, self.p0[1] + self.vel[1] * dt]
    }
}

pub(super) struct Wave<'a> {
    lines: &'a [Line],
    nodes: Vec<[f64; 3]>,
    /// Per face: directed boundary segments (from node, to node).
    segs: Vec<Vec<(u32, u32)>>,
    eps: f64,
}

impl Wave<'_> {
    /// The velocity of a vertex between the lines `le` and `re`: it stays
    /// on both as they move (`v . n = w` for each).
    fn velocity(&self, le: u32, re: u32) -> [f64; 2] {
        let (Some(a), Some(b)) = (self.lines.get(le as usize), self.lines.get(re as usize)) else {
            return [0.0, 0.0];
        };
        let det = cross2(a.n, b.n);
        if det.abs() > 1e-9 {
            [
                (a.w * b.n[1] - b.w * a.n[1]) / det,
                (a.n[0] * b.w - b.n[0] * a.w) / det,
            ]
        } else if dot2(a.n, b.n) > 0.0 {
            // Parallel lines: the vertex moves with them.
            let w = a.w.max(b.w);
            [a.n[0] * w, a.n[1] * w]
        } else {
            [0.0, 0.0]
        }
    }

    /// The node at `p` and time `t`: an existing one within tolerance, or a
    /// new one.
    fn node(&mut self, p: [f64; 2], t: f64) -> u32 {
        let e = self.eps;
        if let Some(i) = self.nodes.iter().position(|q| {
            (q[0] - p[0]).abs() <= e && (q[1] - p[1]).abs() <= e && (q[2] - t).abs() <= e
        }) {
            return i as u32;
        }
        self.nodes.push([p[0], p[1], t]);
        self.nodes.len() as u32 - 1
    }

    fn seg(&mut self, face: u32, from: u32, to: u32) {
        if from != to
            && let Some(s) = self.segs.get_mut(face as usize)
        {
            s.push((from, to));
        }
    }

    /// Vertex `v` ends at node `end`: its trace bounds the faces on both
    /// sides (upward for the edge before it, downward for the one after).
    fn die(&mut self, v: &Vtx, end: u32) {
        self.seg(v.le, v.node, end);
        self.seg(v.re, end, v.node);
    }

    fn vertex(&mut self, p: [f64; 2], t: f64, le: u32, re: u32, node: u32) -> Vtx {
        Vtx {
            p0: p,
            t0: t,
            vel: self.velocity(le, re),
            le,
            re,
            node,
        }
    }

    /// The ring at time `t` with its zero-length edges collapsed (and edge
    /// `force`, from vertex `force` to the next, collapsed whatever its
    /// length); `None` when nothing of it is left (it is then closed off).
    fn cleanup(&mut self, ring: Vec<Vtx>, t: f64, force: Option<usize>) -> Option<Vec<Vtx>> {
        let m = ring.len();
        if m < 3 {
            self.kill(&ring, t);
            return None;
        }
        let pos: Vec<[f64; 2]> = ring.iter().map(|v| v.at(t)).collect();
        let join: Vec<bool> = (0..m)
            .map(|i| {
                let d = sub2(pos[(i + 1) % m], pos[i]);
                force == Some(i) || (d[0].abs() <= self.eps && d[1].abs() <= self.eps)
            })
            .collect();
        let out = if join.iter().all(|&j| j) {
            // The whole ring meets in one point.
            let c = mean(&pos);
            let n = self.node(c, t);
            for v in &ring {
                self.die(v, n);
            }
            return None;
        } else if join.iter().any(|&j| j) {
            // Start after an edge that is kept, so no run wraps around.
            let start = (0..m).find(|&i| !join[(i + m - 1) % m]).unwrap_or(0);
            let mut out = Vec::with_capacity(m);
            let mut k = 0;
            while k < m {
                let first = (start + k) % m;
                let mut len = 1;
                while len < m && join[(start + k + len - 1) % m] {
                    len += 1;
                }
                if len == 1 {
                    out.push(ring[first]);
                } else {
                    let members: Vec<usize> = (0..len).map(|j| (first + j) % m).collect();
                    let pts: Vec<[f64; 2]> = members.iter().map(|&i| pos[i]).collect();
                    let c = mean(&pts);
                    let n = self.node(c, t);
                    for &i in &members {
                        self.die(&ring[i], n);
                    }
                    let (le, re) = (ring[first].le, ring[(first + len - 1) % m].re);
                    let v = self.vertex(c, t, le, re, n);
                    out.push(v);
                }
                k += len;
            }
            out
        } else {
            ring
        };
        let pos: Vec<[f64; 2]> = out.iter().map(|v| v.at(t)).collect();
        // No width left (area over perimeter): the ring is a ridge.
        if out.len() < 3 || ring_area(&pos) <= self.eps * perimeter(&pos) {
            self.kill(&out, t);
            return None;
        }
        Some(out)
    }

    /// The ring has no area left at time `t`: each vertex ends where it is
    /// and each remaining edge closes its face from above.
    fn kill(&mut self, ring: &[Vtx], t: f64) {
        let ends: Vec<u32> = ring
            .iter()
            .map(|v| {
                let p = v.at(t);
                self.node(p, t)
            })
            .collect();
        for (v, &e) in ring.iter().zip(&ends) {
            self.die(v, e);
        }
        let m = ring.len();
        if m >= 2 {
            for i in 0..m {
                let j = (i + 1) % m;
                self.seg(ring[i].re, ends[j], ends[i]);
            }
        }
    }
}

pub(super) fn perimeter(r: &[[f64; 2]]) -> f64 {
    let n = r.len();
    (0..n)
        .map(|i| {
            let d = sub2(r[(i + 1) % n], r[i]);
            d[0].hypot(d[1])
        })
        .sum()
}

pub(super) fn mean(p: &[[f64; 2]]) -> [f64; 2] {
    let n = p.len().max(1) as f64;
    let s = p.iter().fold([0.0, 0.0], |a, q| [a[0] + q[0], a[1] + q[1]]);
    [s[0] / n, s[1] / n]
}

/// An event found in a step.
#[derive(Clone, Copy)]
pub(super) enum Event {
    /// The edge from vertex `i` of ring `r` to the next collapses.
    Edge { r: usize, i: usize },
    /// Reflex vertex `v` of ring `r` runs into the edge from vertex `i`.
    Split { r: usize, v: usize, i: usize },
}

/// The weighted straight skeleton of a simple counter-clockwise ring
/// without repeated points or straight corners, with a speed per edge
/// (edge `i` runs from corner `i` to corner `i + 1`; weights are 0 or
/// positive, at least one positive).
pub fn skeleton(ring: &[[f64; 2]], weights: &[f64]) -> Result<Skeleton, RoofError> {
    let n = ring.len();
    if n < 3 || weights.len() != n {
        return Err(RoofError::Empty);
    }
    if n > MAX_VERTICES {
        return Err(RoofError::TooManyVertices {
            count: n,
            max: MAX_VERTICES,
        });
    }
    if ring.iter().any(|p| !(p[0].is_finite() && p[1].is_finite()))
        || weights.iter().any(|w| !(w.is_finite() && *w >= 0.0))
        || !weights.iter().any(|&w| w > 0.0)
    {
        return Err(RoofError::Empty);
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in ring {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let scale = (hi[0] - lo[0]).max(hi[1] - lo[1]);
    if !(scale > 0.0 && scale.is_finite()) || ring_area(ring) <= 0.0 {
        return Err(RoofError::Empty);
    }
    let mut lines = Vec::with_capacity(n);
    for i in 0..n {
        let d = sub2(ring[(i + 1) % n], ring[i]);
        let len = d[0].hypot(d[1]);
        if len.is_nan() || len <= 0.0 {
            return Err(RoofError::Degenerate);
        }
        let d = [d[0] / len, d[1] / len];
        lines.push(Line {
            d,
            n: [-d[1], d[0]],
            w: weights[i],
        });
    }
    let eps = 1e-9 * scale;
    let mut wave = Wave {
        lines: &lines,
        nodes: ring.iter().map(|p| [p[0], p[1], 0.0]).collect(),
        segs: vec![Vec::new(); n],
        eps,
    };
    let first: Vec<Vtx> = (0..n)
        .map(|i| {
            let le = ((i + n - 1) % n) as u32;
            wave.vertex(ring[i], 0.0, le, i as u32, i as u32)
        })
        .collect();
    let mut rings: Vec<Vec<Vtx>> = wave.cleanup(first, 0.0, None).into_iter().collect();
    // The latest a wavefront can live: the slowest moving edge crossing the
    // whole footprint (with room).
    let w_min = weights
        .iter()
        .copied()
        .filter(|&w| w > 0.0)
        .fold(f64::INFINITY, f64::min);
    let t_max = 4.0 * scale / w_min;
    let mut steps = 0usize;
    let max_steps = 16 * n + 64;
    // The time of the last event: every live vertex was made at or before it.
    let mut clock = 0.0f64;
    while !rings.is_empty() {
        steps += 1;
        if steps > max_steps {
            return Err(RoofError::Degenerate);
        }
        let mut best: Option<(f64, Event)> = None;
        let mut best_edge: Option<(f64, Event)> = None;
        // Edge events.
        for (r, ring) in rings.iter().enumerate() {
            let m = ring.len();
            for i in 0..m {
                let (a, b) = (&ring[i], &ring[(i + 1) % m]);
                let Some(line) = lines.get(a.re as usize) else {
                    continue;
                };
                let s = dot2(sub2(b.at(clock), a.at(clock)), line.d);
                let rate = dot2(sub2(b.vel, a.vel), line.d);
                if rate < -1e-12 {
                    let t = clock + (s / -rate).max(0.0);
                    if best_edge.is_none_or(|(bt, _)| t < bt) {
                        best_edge = Some((t, Event::Edge { r, i }));
                    }
                }
            }
        }
        // Split events.
        let now = best_edge.map_or(t_max, |(t, _)| t);
        for (r, ring) in rings.iter().enumerate() {
            let m = ring.len();
            for (iv, v) in ring.iter().enumerate() {
                let (Some(l), Some(rr)) = (lines.get(v.le as usize), lines.get(v.re as usize))
                else {
                    continue;
                };
                if cross2(l.d, rr.d) >= -1e-9 {
                    continue; // not reflex
                }
                for i in 0..m {
                    let j = (i + 1) % m;
                    if i == iv || j == iv {
                        continue;
                    }
                    let (a, b) = (&ring[i], &ring[j]);
                    if a.re == v.le || a.re == v.re {
                        continue;
                    }
                    let Some(line) = lines.get(a.re as usize) else {
                        continue;
                    };
                    let dist = dot2(sub2(v.at(clock), a.at(clock)), line.n);
                    let rate = dot2(v.vel, line.n) - line.w;
                    if dist < -eps || rate >= -1e-12 {
                        continue;
                    }
                    let t = clock + dist.max(0.0) / -rate;
                    if t > now + eps || best.is_some_and(|(bt, _)| t >= bt) {
                        continue;
                    }
                    let (pv, pa, pb) = (v.at(t), a.at(t), b.at(t));
                    let u = dot2(sub2(pv, pa), line.d);
                    let len = dot2(sub2(pb, pa), line.d);
                    if len < -eps || u < -eps || u > len + eps {
                        continue;
                    }
                    best = Some((t, Event::Split { r, v: iv, i }));
                }
            }
        }
        // An edge event wins a tie.
        let event = match (best_edge, best) {
            (Some(e), Some(s)) => {
                if e.0 <= s.0 + eps {
                    e
                } else {
                    s
                }
            }
            (Some(e), None) => e,
            (None, Some(s)) => s,
            (None, None) => return Err(RoofError::Degenerate),
        };
        let (t, event) = event;
        if !(t.is_finite() && t <= t_max) {
            return Err(RoofError::Degenerate);
        }
        clock = t;
        match event {
            Event::Edge { r, i } => {
                let ring = rings.swap_remove(r);
                rings.extend(wave.cleanup(ring, t, Some(i)));
            }
            Event::Split { r, v, i } => {
                let ring = rings.swap_remove(r);
                let m = ring.len();
                let vv = ring[v];
                let j = (i + 1) % m;
                let e = ring[i].re;
                let p = vv.at(t);
                let node = wave.node(p, t);
                wave.die(&vv, node);
                let v1 = wave.vertex(p, t, vv.le, e, node);
                let v2 = wave.vertex(p, t, e, vv.re, node);
                // A: v1, then from the edge's end round to the vertex before v.
                let mut a = vec![v1];
                let mut k = j;
                while k != v {
                    a.push(ring[k]);
                    k = (k + 1) % m;
                }
                // B: v2, then from the vertex after v round to the edge's start.
                let mut b = vec![v2];
                let mut k = (v + 1) % m;
                while k != j {
                    b.push(ring[k]);
                    k = (k + 1) % m;
                }
                rings.extend(wave.cleanup(a, t, None));
                rings.extend(wave.cleanup(b, t, None));
            }
        }
    }
    // Each face: from the edge's end, follow its segments back to its start.
    let mut faces = Vec::with_capacity(n);
    for (f, segs) in wave.segs.iter().enumerate() {
        let (a, b) = (f as u32, ((f + 1) % n) as u32);
        let mut used = vec![false; segs.len()];
        let mut face = vec![a, b];
        let mut cur = b;
        let mut closed = false;
        for _ in 0..=segs.len() {
            let Some(k) = (0..segs.len()).find(|&k| !used[k] && segs[k].0 == cur) else {
                break;
            };
            used[k] = true;
            cur = segs[k].1;
            if cur == a {
                closed = true;
                break;
            }
            face.push(cur);
        }
        if !closed {
            return Err(RoofError::Degenerate);
        }
        faces.push(face);
    }
    Ok(Skeleton {
        nodes: wave.nodes,
        faces,
    })
}

// ---------------------------------------------------------------------------
// Roofs.
