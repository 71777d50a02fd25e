//! Plane geometry the operators share: exact-grid quantisation of moved
//! points, rings (area, orientation, simplicity, containment), segment
//! intersection (geo's robust predicate), distances and mean value
//! coordinates.

use geo::{Coord, Line, LineString, Polygon, line_intersection::LineIntersection};

/// Moved node positions are snapped to multiples of 2^-16 m (about 15
/// micrometres): sums and differences of such numbers are exact in f64 well
/// past city sizes, so moving a node by `d` and back by `-d` restores its
/// bits (circular editing).
pub const GRID: f64 = 1.0 / 65536.0;

/// The largest coordinate (m) any input may give: far past any city, and
/// well inside what the grid and the clipper handle exactly.
pub const MAX_COORD: f64 = 1e9;

/// Snaps a coordinate to the grid (round half away from zero, so
/// `q(-x) == -q(x)`).
pub fn quantize(c: Coord) -> Coord {
    // `+ 0.0` turns -0 into 0: a point moved away and back writes the same.
    Coord {
        x: (c.x / GRID).round() * GRID + 0.0,
        y: (c.y / GRID).round() * GRID + 0.0,
    }
}

/// The signed area of an open ring (positive when
/// counter-clockwise).
pub fn signed_area(ring: &[Coord]) -> f64 {
    let n = ring.len();
    if n < 3 {
        return 0.0;
    }
    let mut a = 0.0;
    for i in 0..n {
        let p = ring[i];
        let q = ring[(i + 1) % n];
        a += p.x * q.y - q.x * p.y;
    }
    a * 0.5
}

/// The mean of a ring's vertices.
pub fn vertex_centroid(ring: &[Coord]) -> Coord {
    if ring.is_empty() {
        return Coord { x: 0.0, y: 0.0 };
    }
    let n = ring.len() as f64;
    let (sx, sy) = ring.iter().fold((0.0, 0.0), |(x, y), c| (x + c.x, y + c.y));
    Coord {
        x: sx / n,
        y: sy / n,
    }
}

/// The point halfway along a polyline.
pub fn polyline_midpoint(pl: &[Coord]) -> Coord {
    let total = polyline_length(pl);
    let mut left = total * 0.5;
    for w in pl.windows(2) {
        let l = dist(w[0], w[1]);
        if l >= left && l > 0.0 {
            let t = left / l;
            return lerp(w[0], w[1], t);
        }
        left -= l;
    }
    pl.first().copied().unwrap_or(Coord { x: 0.0, y: 0.0 })
}

pub fn polyline_length(pl: &[Coord]) -> f64 {
    pl.windows(2).map(|w| dist(w[0], w[1])).sum()
}

pub fn dist(a: Coord, b: Coord) -> f64 {
    ((a.x - b.x).powi(2) + (a.y - b.y).powi(2)).sqrt()
}

pub fn lerp(a: Coord, b: Coord, t: f64) -> Coord {
    Coord {
        x: a.x + (b.x - a.x) * t,
        y: a.y + (b.y - a.y) * t,
    }
}

/// An open ring as a geo polygon.
pub fn polygon(ring: &[Coord]) -> Polygon {
    Polygon::new(LineString::new(close(ring)), vec![])
}

/// The ring closed (first point repeated at the end).
pub fn close(ring: &[Coord]) -> Vec<Coord> {
    let mut v = ring.to_vec();
    if let (Some(f), Some(l)) = (v.first().copied(), v.last().copied())
        && f != l
    {
        v.push(f);
    }
    v
}

/// A geo ring opened (the closing point dropped) and made
/// counter-clockwise, with repeated points removed.
pub fn open_ccw(ls: &LineString) -> Vec<Coord> {
    let mut v: Vec<Coord> = Vec::with_capacity(ls.0.len());
    for &c in &ls.0 {
        if v.last() != Some(&c) {
            v.push(c);
        }
    }
    if v.len() > 1 && v.first() == v.last() {
        v.pop();
    }
    if signed_area(&v) < 0.0 {
        v.reverse();
    }
    v
}

/// A face walk's ring without its spikes (a dead end walked out and back,
/// `a, b, a`), so what is left is a simple outline the clipper reads
/// right; the dead ends' streets are cut away separately.
pub fn remove_spikes(ring: &[Coord]) -> Vec<Coord> {
    let mut v = ring.to_vec();
    loop {
        let n = v.len();
        if n < 3 {
            return v;
        }
        let mut changed = false;
        for i in 0..n {
            let prev = v[(i + n - 1) % n];
            let next = v[(i + 1) % n];
            if prev == next {
                // Drop the tip and one copy of the point it returns to.
                let (a, b) = (i, (i + 1) % n);
                let (hi, lo) = if a > b { (a, b) } else { (b, a) };
                v.remove(hi);
                v.remove(lo);
                changed = true;
                break;
            }
            if v[i] == next {
                v.remove(i);
                changed = true;
                break;
            }
        }
        if !changed {
            return v;
        }
    }
}

/// Point in an open ring (even-odd; points on the boundary may go either
/// way).
pub fn point_in_ring(p: Coord, ring: &[Coord]) -> bool {
    let n = ring.len();
    let mut inside = false;
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let a = ring[i];
        let b = ring[j];
        if (a.y > p.y) != (b.y > p.y) {
            let x = (b.x - a.x) * (p.y - a.y) / (b.y - a.y) + a.x;
            if p.x < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// How two segments meet.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Meet {
    /// In one point.
    Point(Coord),
    /// Along a stretch (collinear overlap longer than a point).
    Overlap,
}

/// Where two segments meet, if they do (geo's robust predicate).
pub fn meet(a: Coord, b: Coord, c: Coord, d: Coord) -> Option<Meet> {
    match geo::algorithm::line_intersection::line_intersection(Line::new(a, b), Line::new(c, d))? {
        LineIntersection::SinglePoint { intersection, .. } => Some(Meet::Point(intersection)),
        LineIntersection::Collinear { intersection } => {
            if intersection.start == intersection.end {
                Some(Meet::Point(intersection.start))
            } else {
                Some(Meet::Overlap)
            }
        }
    }
}

/// The distance from a point to a segment.
pub fn point_segment_dist(p: Coord, a: Coord, b: Coord) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let l2 = dx * dx + dy * dy;
    if l2 == 0.0 {
        return dist(p, a);
    }
    let t = (((p.x - a.x) * dx + (p.y - a.y) * dy) / l2).clamp(0.0, 1.0);
    dist(
        p,
        Coord {
            x: a.x + t * dx,
            y: a.y + t * dy,
        },
    )
}

/// The distance between two segments (0 when they meet).
pub fn segment_dist(a: Coord, b: Coord, c: Coord, d: Coord) -> f64 {
    if meet(a, b, c, d).is_some() {
        return 0.0;
    }
    point_segment_dist(a, c, d)
        .min(point_segment_dist(b, c, d))
        .min(point_segment_dist(c, a, b))
        .min(point_segment_dist(d, a, b))
}

/// The distance from a segment to the area of a ring (0 when it enters it).
pub fn segment_ring_dist(a: Coord, b: Coord, ring: &[Coord]) -> f64 {
    if point_in_ring(a, ring) || point_in_ring(b, ring) {
        return 0.0;
    }
    let n = ring.len();
    let mut best = f64::INFINITY;
    for i in 0..n {
        let d = segment_dist(a, b, ring[i], ring[(i + 1) % n]);
        if d < best {
            best = d;
        }
    }
    best
}

/// Why a ring is not a simple polygon.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RingProblem {
    TooFewPoints,
    NotFinite,
    ZeroArea,
    SelfIntersecting,
}

/// Checks that an open ring is a simple polygon with at least three
/// distinct vertices and a non-zero area.
pub fn check_ring(ring: &[Coord]) -> Result<(), RingProblem> {
    if ring.iter().any(|c| !c.x.is_finite() || !c.y.is_finite()) {
        return Err(RingProblem::NotFinite);
    }
    if ring.len() < 3 {
        return Err(RingProblem::TooFewPoints);
    }
    if signed_area(ring).abs() < 1e-9 {
        return Err(RingProblem::ZeroArea);
    }
    let n = ring.len();
    for i in 0..n {
        let (a, b) = (ring[i], ring[(i + 1) % n]);
        if a == b {
            return Err(RingProblem::SelfIntersecting);
        }
        for j in i + 1..n {
            let (c, d) = (ring[j], ring[(j + 1) % n]);
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            match meet(a, b, c, d) {
                None => {}
                Some(Meet::Overlap) => return Err(RingProblem::SelfIntersecting),
                Some(Meet::Point(p)) => {
                    if !adjacent {
                        return Err(RingProblem::SelfIntersecting);
                    }
                    // Adjacent edges meet only at their shared vertex.
                    let shared = if j == i + 1 { b } else { a };
                    if p != shared {
                        return Err(RingProblem::SelfIntersecting);
                    }
                }
            }
        }
    }
    Ok(())
}

/// Mean value coordinates of `p` with respect to an open ring (Floater;
/// Hormann and Floater 2006 for any simple polygon). None when `p` is
/// too close to a vertex or the weights do not sum to a usable number.
pub fn mean_value_coords(p: Coord, ring: &[Coord]) -> Option<Vec<f64>> {
    let n = ring.len();
    if n < 3 {
        return None;
    }
    let s: Vec<Coord> = ring
        .iter()
        .map(|v| Coord {
            x: v.x - p.x,
            y: v.y - p.y,
        })
        .collect();
    let r: Vec<f64> = s.iter().map(|v| (v.x * v.x + v.y * v.y).sqrt()).collect();
    if r.iter().any(|&x| x < 1e-12) {
        return None;
    }
    let mut tan_half = vec![0.0; n];
    for i in 0..n {
        let j = (i + 1) % n;
        let cross = s[i].x * s[j].y - s[i].y * s[j].x;
        let dot = s[i].x * s[j].x + s[i].y * s[j].y;
        let denom = r[i] * r[j] + dot;
        if denom.abs() < 1e-14 {
            return None;
        }
        tan_half[i] = cross / denom;
    }
    let mut w = vec![0.0; n];
    let mut sum = 0.0;
    for i in 0..n {
        let prev = (i + n - 1) % n;
        w[i] = (tan_half[prev] + tan_half[i]) / r[i];
        sum += w[i];
    }
    if !sum.is_finite() || sum.abs() < 1e-14 {
        return None;
    }
    for x in &mut w {
        *x /= sum;
    }
    Some(w)
}

/// Evaluates mean value coordinates on another ring with as many vertices.
pub fn apply_coords(w: &[f64], ring: &[Coord]) -> Coord {
    let mut c = Coord { x: 0.0, y: 0.0 };
    for (wi, v) in w.iter().zip(ring) {
        c.x += wi * v.x;
        c.y += wi * v.y;
    }
    c
}

/// The interior angles of an open ring, in radians.
pub fn angles(ring: &[Coord]) -> Vec<f64> {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let p = ring[(i + n - 1) % n];
            let c = ring[i];
            let q = ring[(i + 1) % n];
            let a1 = (p.y - c.y).atan2(p.x - c.x);
            let a2 = (q.y - c.y).atan2(q.x - c.x);
            (a1 - a2).rem_euclid(std::f64::consts::TAU)
        })
        .collect()
}

/// An affine map of the plane: `x' = a x + b y + c`, `y' = d x + e y + f`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Affine {
    pub m: [f64; 6],
}

impl Affine {
    pub fn identity() -> Affine {
        Affine {
            m: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        }
    }

    pub fn translate(dx: f64, dy: f64) -> Affine {
        Affine {
            m: [1.0, 0.0, dx, 0.0, 1.0, dy],
        }
    }

    /// A rotation by `deg` degrees counter-clockwise about `c`.
    pub fn rotate(deg: f64, c: Coord) -> Affine {
        let (s, co) = deg.to_radians().sin_cos();
        Affine {
            m: [
                co,
                -s,
                c.x - co * c.x + s * c.y,
                s,
                co,
                c.y - s * c.x - co * c.y,
            ],
        }
    }

    /// A uniform scale by `k` about `c`.
    pub fn scale(k: f64, c: Coord) -> Affine {
        Affine {
            m: [k, 0.0, c.x - k * c.x, 0.0, k, c.y - k * c.y],
        }
    }

    /// `other` after `self`.
    pub fn then(&self, o: &Affine) -> Affine {
        let [a, b, c, d, e, f] = self.m;
        let [a2, b2, c2, d2, e2, f2] = o.m;
        Affine {
            m: [
                a2 * a + b2 * d,
                a2 * b + b2 * e,
                a2 * c + b2 * f + c2,
                d2 * a + e2 * d,
                d2 * b + e2 * e,
                d2 * c + e2 * f + f2,
            ],
        }
    }

    pub fn apply(&self, p: Coord) -> Coord {
        let [a, b, c, d, e, f] = self.m;
        Coord {
            x: a * p.x + b * p.y + c,
            y: d * p.x + e * p.y + f,
        }
    }

    pub fn is_finite(&self) -> bool {
        self.m.iter().all(|v| v.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c(x: f64, y: f64) -> Coord {
        Coord { x, y }
    }

    #[test]
    fn rings_are_checked() {
        let sq = [c(0.0, 0.0), c(1.0, 0.0), c(1.0, 1.0), c(0.0, 1.0)];
        assert_eq!(check_ring(&sq), Ok(()));
        let bow = [c(0.0, 0.0), c(2.0, 2.0), c(2.0, 0.0), c(0.0, 1.0)];
        assert_eq!(check_ring(&bow), Err(RingProblem::SelfIntersecting));
        assert_eq!(check_ring(&sq[..2]), Err(RingProblem::TooFewPoints));
        let flat = [c(0.0, 0.0), c(1.0, 0.0), c(2.0, 0.0)];
        assert_eq!(check_ring(&flat), Err(RingProblem::ZeroArea));
    }

    #[test]
    fn mean_value_coordinates_reproduce_the_point() {
        let ring = [
            c(0.0, 0.0),
            c(4.0, 0.0),
            c(5.0, 3.0),
            c(1.0, 4.0),
            c(-1.0, 2.0),
        ];
        let p = c(1.5, 1.7);
        let w = mean_value_coords(p, &ring).unwrap();
        let q = apply_coords(&w, &ring);
        assert!(dist(p, q) < 1e-12, "{q:?}");
    }

    #[test]
    fn spikes_come_off_a_face_walk() {
        // A square with a dead end from (1, 1) out to (2, 2) and back.
        let ring = [
            c(0.0, 0.0),
            c(1.0, 0.0),
            c(1.0, 1.0),
            c(2.0, 2.0),
            c(1.0, 1.0),
            c(0.0, 1.0),
        ];
        assert_eq!(
            remove_spikes(&ring),
            vec![c(0.0, 0.0), c(1.0, 0.0), c(1.0, 1.0), c(0.0, 1.0)]
        );
        // A two-segment dead end.
        let ring = [
            c(0.0, 0.0),
            c(1.0, 0.0),
            c(1.0, 1.0),
            c(2.0, 2.0),
            c(3.0, 2.0),
            c(2.0, 2.0),
            c(1.0, 1.0),
            c(0.0, 1.0),
        ];
        assert_eq!(remove_spikes(&ring).len(), 4);
    }

    #[test]
    fn quantized_moves_go_back_exactly() {
        let p = quantize(c(123.456789, -98.7654321));
        let d = quantize(c(17.3333333, 0.1));
        let moved = quantize(c(p.x + d.x, p.y + d.y));
        let back = quantize(c(moved.x - d.x, moved.y - d.y));
        assert_eq!(back, p);
    }

    #[test]
    fn affine_maps_compose() {
        let r = Affine::rotate(90.0, c(1.0, 1.0));
        let p = r.apply(c(2.0, 1.0));
        assert!(dist(p, c(1.0, 2.0)) < 1e-12);
        let t = Affine::translate(1.0, 2.0).then(&Affine::scale(2.0, c(0.0, 0.0)));
        assert!(dist(t.apply(c(1.0, 1.0)), c(4.0, 6.0)) < 1e-12);
    }
}
