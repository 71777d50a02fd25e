//! Street generators that fill a layer: a jittered grid and a radial
//! (rings and spokes) pattern. Node identities are minted from the
//! generator's kind, its seed and the node's grid address; street
//! identities from their end nodes. Positions are snapped to the
//! [`crate::geom::GRID`].

use crate::geom::{Affine, quantize};
use crate::id::{Id, Stream};
use crate::model::{Layout, Street, StreetClass};
use geo::Coord;

/// Why a generator's parameters cannot be used.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamError {
    pub param: &'static str,
    pub reason: &'static str,
}

impl std::fmt::Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "parameter `{}` {}", self.param, self.reason)
    }
}

/// A grid of `nx` by `ny` blocks.
#[derive(Debug, Clone, PartialEq)]
pub struct GridParams {
    pub origin: Coord,
    pub nx: u32,
    pub ny: u32,
    pub spacing: Coord,
    pub rotation_deg: f64,
    /// Nodes move up to this fraction of the spacing (below 0.25).
    pub jitter: f64,
    /// Every `major_every`-th row and column is a major street (0: none).
    pub major_every: u32,
    pub seed: u64,
}

impl Default for GridParams {
    fn default() -> Self {
        GridParams {
            origin: Coord { x: 0.0, y: 0.0 },
            nx: 4,
            ny: 4,
            spacing: Coord { x: 80.0, y: 60.0 },
            rotation_deg: 0.0,
            jitter: 0.1,
            major_every: 3,
            seed: 1,
        }
    }
}

fn finite(v: f64, param: &'static str) -> Result<(), ParamError> {
    if v.abs() <= crate::geom::MAX_COORD {
        Ok(())
    } else {
        Err(ParamError {
            param,
            reason: "is not a finite number",
        })
    }
}

/// A jittered grid of streets.
pub fn grid(p: &GridParams) -> Result<Layout, ParamError> {
    finite(p.origin.x, "origin")?;
    finite(p.origin.y, "origin")?;
    finite(p.rotation_deg, "rotation")?;
    if !(p.spacing.x > 1.0 && p.spacing.y > 1.0 && p.spacing.x <= 1e5 && p.spacing.y <= 1e5) {
        return Err(ParamError {
            param: "spacing",
            reason: "must be 1 m to 100 km",
        });
    }
    if !(p.jitter.is_finite() && (0.0..0.25).contains(&p.jitter)) {
        return Err(ParamError {
            param: "jitter",
            reason: "must be in [0, 0.25)",
        });
    }
    if p.nx == 0 || p.ny == 0 || p.nx > 1000 || p.ny > 1000 {
        return Err(ParamError {
            param: "size",
            reason: "must be 1 to 1000 blocks each way",
        });
    }
    let rot = Affine::rotate(p.rotation_deg, Coord { x: 0.0, y: 0.0 });
    let mut l = Layout::default();
    let node = |i: u32, j: u32| {
        Id::mint("node")
            .str("grid")
            .u64(p.seed)
            .u64(u64::from(i))
            .u64(u64::from(j))
            .finish()
    };
    for i in 0..=p.nx {
        for j in 0..=p.ny {
            let id = node(i, j);
            let mut r = Stream::new(id);
            let jx = r.range(-p.jitter, p.jitter) * p.spacing.x;
            let jy = r.range(-p.jitter, p.jitter) * p.spacing.y;
            let local = Coord {
                x: f64::from(i) * p.spacing.x + jx,
                y: f64::from(j) * p.spacing.y + jy,
            };
            let w = rot.apply(local);
            l.add_node(
                id,
                quantize(Coord {
                    x: w.x + p.origin.x,
                    y: w.y + p.origin.y,
                }),
            );
        }
    }
    let class = |k: u32, edge: bool| {
        if edge || (p.major_every > 0 && k.is_multiple_of(p.major_every)) {
            StreetClass::Major
        } else {
            StreetClass::Minor
        }
    };
    for i in 0..=p.nx {
        for j in 0..=p.ny {
            if i < p.nx {
                let (a, b) = (node(i, j), node(i + 1, j));
                let s = Street::new(
                    Street::mint_id(a, b, &[]),
                    a,
                    b,
                    class(j, j == 0 || j == p.ny),
                );
                l.streets.insert(s.id, s);
            }
            if j < p.ny {
                let (a, b) = (node(i, j), node(i, j + 1));
                let s = Street::new(
                    Street::mint_id(a, b, &[]),
                    a,
                    b,
                    class(i, i == 0 || i == p.nx),
                );
                l.streets.insert(s.id, s);
            }
        }
    }
    Ok(l)
}

/// Rings around a centre joined by spokes.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialParams {
    pub centre: Coord,
    pub rings: u32,
    pub ring_spacing: f64,
    pub spokes: u32,
    /// Points between two spokes along a ring (the arc's polyline).
    pub arc_points: u32,
    /// Each node turns up to this fraction of the angle between spokes.
    pub jitter: f64,
    pub seed: u64,
}

impl Default for RadialParams {
    fn default() -> Self {
        RadialParams {
            centre: Coord { x: 0.0, y: 0.0 },
            rings: 4,
            ring_spacing: 70.0,
            spokes: 12,
            arc_points: 2,
            jitter: 0.1,
            seed: 1,
        }
    }
}

/// A radial pattern: ring `r` (1..=rings) of `spokes` nodes; spokes join
/// consecutive rings, every other spoke reaches the centre.
pub fn radial(p: &RadialParams) -> Result<Layout, ParamError> {
    finite(p.centre.x, "centre")?;
    finite(p.centre.y, "centre")?;
    if !(p.ring_spacing > 1.0 && p.ring_spacing <= 1e5) {
        return Err(ParamError {
            param: "ring_spacing",
            reason: "must be 1 m to 100 km",
        });
    }
    if !(3..=256).contains(&p.spokes) {
        return Err(ParamError {
            param: "spokes",
            reason: "must be 3 to 256",
        });
    }
    if p.rings == 0 || p.rings > 200 || p.arc_points > 16 {
        return Err(ParamError {
            param: "rings",
            reason: "must be 1 to 200 (arc_points up to 16)",
        });
    }
    if !(p.jitter.is_finite() && (0.0..0.25).contains(&p.jitter)) {
        return Err(ParamError {
            param: "jitter",
            reason: "must be in [0, 0.25)",
        });
    }
    let mut l = Layout::default();
    let step = std::f64::consts::TAU / f64::from(p.spokes);
    let centre = Id::mint("node")
        .str("radial")
        .u64(p.seed)
        .str("centre")
        .finish();
    l.add_node(centre, quantize(p.centre));
    let node = |r: u32, k: u32| {
        Id::mint("node")
            .str("radial")
            .u64(p.seed)
            .u64(u64::from(r))
            .u64(u64::from(k % p.spokes))
            .finish()
    };
    let mut angle = vec![vec![0.0; p.spokes as usize]; p.rings as usize + 1];
    for r in 1..=p.rings {
        for k in 0..p.spokes {
            let id = node(r, k);
            let a = f64::from(k) * step + Stream::new(id).range(-p.jitter, p.jitter) * step;
            angle[r as usize][k as usize] = a;
            let rad = f64::from(r) * p.ring_spacing;
            l.add_node(
                id,
                quantize(Coord {
                    x: p.centre.x + rad * a.cos(),
                    y: p.centre.y + rad * a.sin(),
                }),
            );
        }
    }
    for r in 1..=p.rings {
        let rad = f64::from(r) * p.ring_spacing;
        for k in 0..p.spokes {
            let (a, b) = (node(r, k), node(r, k + 1));
            let a0 = angle[r as usize][k as usize];
            let mut a1 = angle[r as usize][((k + 1) % p.spokes) as usize];
            if a1 <= a0 {
                a1 += std::f64::consts::TAU;
            }
            let interior: Vec<Coord> = (1..=p.arc_points)
                .map(|i| {
                    let t = a0 + (a1 - a0) * f64::from(i) / f64::from(p.arc_points + 1);
                    quantize(Coord {
                        x: p.centre.x + rad * t.cos(),
                        y: p.centre.y + rad * t.sin(),
                    })
                })
                .collect();
            let class = if r == p.rings || r.is_multiple_of(2) {
                StreetClass::Major
            } else {
                StreetClass::Minor
            };
            let mut s = Street::new(Street::mint_id(a, b, &interior), a, b, class);
            s.interior = interior;
            l.streets.insert(s.id, s);
            let (inner, class) = if r == 1 {
                if !k.is_multiple_of(2) {
                    continue;
                }
                (centre, StreetClass::Major)
            } else {
                (
                    node(r - 1, k),
                    if k.is_multiple_of(3) {
                        StreetClass::Major
                    } else {
                        StreetClass::Minor
                    },
                )
            };
            let s = Street::new(Street::mint_id(inner, a, &[]), inner, a, class);
            l.streets.insert(s.id, s);
        }
    }
    Ok(l)
}
