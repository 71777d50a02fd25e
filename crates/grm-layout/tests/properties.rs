//! Property tests over random operations, drawn from
//! `grm_testkit::Rng::seeded` (reproducible; `GRM_TEST_SEED=n` soaks):
//! validity holds after every operation (10,000 in all), moving a street
//! away and back restores identities and geometry, and the same inputs
//! give byte-identical GeoJSON.

use geo::Coord;
use grm_layout::blocks::blocks;
use grm_layout::generate::{GridParams, RadialParams, grid, radial};
use grm_layout::geojson_io;
use grm_layout::geom::{Affine, quantize};
use grm_layout::id::Id;
use grm_layout::layers::{Document, LayerSpec, Place, Source};
use grm_layout::merge::{MergeMode, MergeParams, merge};
use grm_layout::model::Layout;
use grm_layout::select::Selection;
use grm_layout::subdivide::{ParcelParams, block_seed, regrow};
use grm_layout::transform::{UpdateParams, transform};
use grm_layout::validity::check;
use grm_testkit::Rng;
use std::collections::{BTreeMap, BTreeSet};

/// Larger parcels than the default keep the 10,000 operations quick in a
/// debug build.
fn parcel_params() -> ParcelParams {
    ParcelParams {
        max_area: 2500.0,
        min_area: 150.0,
        ..ParcelParams::default()
    }
}

fn filled(mut l: Layout, seed: u64) -> Layout {
    let b = blocks(&l);
    regrow(&mut l, &b, seed, &parcel_params(), None);
    l
}

fn small_grid(rng: &mut Rng) -> Layout {
    small_grid_seeded(rng).0
}

/// A small random grid filled with parcels, and the seed they were drawn with.
fn small_grid_seeded(rng: &mut Rng) -> (Layout, u64) {
    let p = GridParams {
        nx: 2 + rng.below(2u32),
        ny: 2 + rng.below(2u32),
        spacing: Coord {
            x: rng.range(50.0, 90.0),
            y: rng.range(50.0, 90.0),
        },
        rotation_deg: rng.range(0.0, 90.0),
        jitter: rng.range(0.0, 0.2),
        seed: rng.next_u64(),
        ..GridParams::default()
    };
    let seed = rng.next_u64();
    (filled(grid(&p).unwrap(), seed), seed)
}

fn pick<T: Copy>(rng: &mut Rng, v: &[T]) -> Option<T> {
    if v.is_empty() {
        None
    } else {
        Some(*rng.pick(v))
    }
}

fn describe(l: &Layout) -> Vec<String> {
    check(l).iter().map(|v| v.describe()).collect()
}

/// One random operation; returns its name for failure messages.
fn operate(rng: &mut Rng, l: &mut Layout, up: &UpdateParams) -> String {
    let nodes: Vec<Id> = l.nodes.keys().copied().collect();
    let streets: Vec<Id> = l.streets.keys().copied().collect();
    let r = rng.below(100u32);
    if r < 45 {
        // Drag one node, small or far.
        let Some(n) = pick(rng, &nodes) else {
            return "none".into();
        };
        let reach = if rng.below(4u32) == 0 { 80.0 } else { 12.0 };
        let d = quantize(Coord {
            x: rng.range(-reach, reach),
            y: rng.range(-reach, reach),
        });
        let w = BTreeMap::from([(n, 1.0)]);
        let res = transform(l, &Affine::translate(d.x, d.y), &w, up);
        format!(
            "drag node {n} by {d:?}: {:?}",
            res.map(|m| m.blocks_regrown)
        )
    } else if r < 65 {
        // A soft selection rotated about its centre.
        let c = Coord {
            x: rng.range(-20.0, 250.0),
            y: rng.range(-20.0, 250.0),
        };
        let radius = rng.range(20.0, 120.0);
        let deg = rng.range(-15.0, 15.0);
        let w = Selection::soft(l, c, radius).node_weights(l);
        let res = transform(l, &Affine::rotate(deg, c), &w, up);
        format!("soft rotate {deg} about {c:?} r {radius}: {}", res.is_ok())
    } else if r < 80 {
        // A street and its continuation moved.
        let Some(s) = pick(rng, &streets) else {
            return "none".into();
        };
        let w = Selection::continuation(l, s, 30.0).node_weights(l);
        let d = quantize(Coord {
            x: rng.range(-15.0, 15.0),
            y: rng.range(-15.0, 15.0),
        });
        let res = transform(l, &Affine::translate(d.x, d.y), &w, up);
        format!("move continuation of {s} by {d:?}: {}", res.is_ok())
    } else if r < 90 {
        // Delete a street or a parcel.
        if rng.below(2u32) == 0 {
            let Some(s) = pick(rng, &streets) else {
                return "none".into();
            };
            l.delete(s);
            l.drop_isolated_nodes();
            format!("delete street {s}")
        } else {
            let ps: Vec<Id> = l.parcels.keys().copied().collect();
            let Some(p) = pick(rng, &ps) else {
                return "none".into();
            };
            l.delete(p);
            format!("delete parcel {p}")
        }
    } else if r < 95 {
        // Regrow one block with another seed.
        let b = blocks(l);
        let Some(k) = pick(rng, &(0..b.len()).collect::<Vec<_>>()) else {
            return "none".into();
        };
        let seed = rng.next_u64();
        regrow(l, &b, seed, &up.parcels, Some(&BTreeSet::from([b[k].id])));
        format!("regrow block {} seed {seed}", b[k].id)
    } else {
        // Merge a small layout in (an insertion), hard or by graph cut.
        let p = GridParams {
            nx: 1,
            ny: 1 + rng.below(2u32),
            spacing: Coord { x: 40.0, y: 40.0 },
            origin: Coord {
                x: rng.range(0.0, 200.0),
                y: rng.range(0.0, 200.0),
            },
            rotation_deg: rng.range(0.0, 90.0),
            seed: rng.next_u64(),
            jitter: 0.0,
            ..GridParams::default()
        };
        let ins = filled(grid(&p).unwrap(), 5);
        let mode = if rng.below(2u32) == 0 {
            MergeMode::Hard
        } else {
            MergeMode::GraphCut
        };
        match merge(
            l,
            &ins,
            mode,
            &MergeParams {
                parcels: parcel_params(),
                ..MergeParams::default()
            },
        ) {
            Ok((m, _)) => {
                *l = m;
                format!("merge {mode:?} at {:?}", p.origin)
            }
            // A merge always leaves a valid layout: an error is a bug.
            Err(e) => panic!(
                "merge {mode:?} at {:?} failed: {e}\nlower: {}",
                p.origin,
                geojson_io::write(l, None)
            ),
        }
    }
}

#[test]
fn validity_holds_after_ten_thousand_random_operations() {
    let mut rng = Rng::seeded(0x1a70_0001);
    let up = UpdateParams {
        parcels: parcel_params(),
        ..UpdateParams::default()
    };
    let (episodes, per) = (100, 100);
    let mut rejected = 0;
    let mut time: BTreeMap<String, (usize, f64)> = BTreeMap::new();
    for e in 0..episodes {
        let mut l = small_grid(&mut rng);
        assert!(
            check(&l).is_empty(),
            "episode {e}: the start is invalid: {:?}",
            describe(&l)
        );
        // Restart from a fresh layout when one runs out of streets or grows large.
        for i in 0..per {
            if l.streets.len() < 3 || l.streets.len() > 40 {
                l = small_grid(&mut rng);
            }
            let before = l.clone();
            let t0 = std::time::Instant::now();
            let what = operate(&mut rng, &mut l, &up);
            let kind = what.split(' ').next().unwrap_or("").to_string();
            let slot = time.entry(kind).or_insert((0, 0.0));
            slot.0 += 1;
            slot.1 += t0.elapsed().as_secs_f64();
            let t1 = std::time::Instant::now();
            if l == before {
                rejected += 1;
            }
            let v = describe(&l);
            assert!(
                v.is_empty(),
                "episode {e} op {i}: {what} left {v:?}\nbefore: {}",
                geojson_io::write(&before, None)
            );
            let slot = time.entry("check".into()).or_insert((0, 0.0));
            slot.0 += 1;
            slot.1 += t1.elapsed().as_secs_f64();
        }
    }
    eprintln!("operations and seconds by kind: {time:?}");
    eprintln!(
        "{} operations, {rejected} left the layout as it was",
        episodes * per
    );
    assert!(
        rejected < episodes * per / 2,
        "most operations did nothing ({rejected})"
    );
}

#[test]
fn moving_a_street_away_and_back_restores_identities_and_geometry() {
    let mut rng = Rng::seeded(0x1a70_0002);
    let mut moved_far = 0;
    for case in 0..60 {
        let (l0, seed) = if case % 3 == 2 {
            let p = RadialParams {
                seed: rng.next_u64(),
                ..RadialParams::default()
            };
            (filled(radial(&p).unwrap(), 3), 3)
        } else {
            small_grid_seeded(&mut rng)
        };
        // Blocks regrow with the seed the layer's parcels were drawn with.
        let up = UpdateParams {
            seed,
            parcels: parcel_params(),
            ..UpdateParams::default()
        };
        let streets: Vec<Id> = l0.streets.keys().copied().collect();
        let s = *rng.pick(&streets);
        let w = if case % 2 == 0 {
            Selection::simple([s]).node_weights(&l0)
        } else {
            let c = l0.position_of(s).unwrap();
            Selection::soft(&l0, c, rng.range(30.0, 90.0)).node_weights(&l0)
        };
        let reach = if case % 4 == 0 { 30.0 } else { 6.0 };
        let d = quantize(Coord {
            x: rng.range(-reach, reach),
            y: rng.range(-reach, reach),
        });
        let mut l = l0.clone();
        let out = match transform(&mut l, &Affine::translate(d.x, d.y), &w, &up) {
            Ok(o) => o,
            Err(_) => continue,
        };
        assert!(check(&l).is_empty());
        if l.nodes != l0.nodes && out.blocks_regrown + out.blocks_smoothed > 0 {
            moved_far += 1;
        }
        // Back by the inverse move (exact: positions are on the grid; a
        // path of several steps with fractional weights may end a grid
        // step away, see docs/layout.md).
        transform(&mut l, &Affine::translate(-d.x, -d.y), &w, &up).unwrap();
        assert_eq!(l.nodes, l0.nodes, "case {case}: nodes");
        assert_eq!(l.streets, l0.streets, "case {case}: streets");
        let ids: Vec<_> = l.parcels.keys().collect();
        let ids0: Vec<_> = l0.parcels.keys().collect();
        assert_eq!(ids, ids0, "case {case}: parcel identities");
        for (k, p) in &l0.parcels {
            assert_eq!(&l.parcels[k], p, "case {case}: parcel {k}");
        }
        assert_eq!(geojson_io::write(&l, None), geojson_io::write(&l0, None));
    }
    assert!(moved_far > 30, "{moved_far}");
}

fn doc(rng: &mut Rng) -> Document {
    let mut base = LayerSpec::new(
        "base",
        Source::Grid(GridParams {
            nx: 5,
            ny: 5,
            seed: rng.next_u64(),
            ..GridParams::default()
        }),
    );
    base.seed = rng.next_u64();
    let mut ring = LayerSpec::new(
        "ring",
        Source::Radial(RadialParams {
            centre: Coord { x: 200.0, y: 150.0 },
            rings: 2,
            ring_spacing: 40.0,
            spokes: 8,
            seed: rng.next_u64(),
            ..RadialParams::default()
        }),
    );
    ring.merge = if rng.below(2u32) == 0 {
        MergeMode::Hard
    } else {
        MergeMode::GraphCut
    };
    Document {
        layers: vec![base, ring],
        parcels: ParcelParams::default(),
        buildings: None,
    }
}

#[test]
fn the_same_inputs_give_byte_identical_geojson() {
    let mut rng = Rng::seeded(0x1a70_0003);
    let none = |_: &str| -> Result<String, String> { Err("no files".into()) };
    for case in 0..6 {
        let d = doc(&mut rng);
        let a = d.evaluate(&none);
        let b = d.clone().evaluate(&none);
        assert!(a.issues.is_empty(), "{:?}", a.issues);
        let (ga, gb) = (
            geojson_io::write(&a.merged, Some(&blocks(&a.merged))),
            geojson_io::write(&b.merged, Some(&blocks(&b.merged))),
        );
        assert_eq!(ga, gb, "case {case}");
        assert!(
            check(&a.merged).is_empty(),
            "case {case}: {:?}",
            describe(&a.merged)
        );
        // Read back, the file's identities and geometry stay.
        let back = geojson_io::read(&geojson_io::write(&a.merged, None), "x");
        assert!(back.errors.is_empty(), "{:?}", back.errors);
        assert_eq!(
            back.layout.streets.keys().collect::<Vec<_>>(),
            a.merged.streets.keys().collect::<Vec<_>>()
        );
        assert_eq!(
            back.layout.parcels.keys().collect::<Vec<_>>(),
            a.merged.parcels.keys().collect::<Vec<_>>()
        );
    }
}

#[test]
fn dragging_a_layer_away_and_back_restores_the_merge() {
    let mut rng = Rng::seeded(0x1a70_0004);
    let none = |_: &str| -> Result<String, String> { Err("no files".into()) };
    for case in 0..4 {
        let mut d = doc(&mut rng);
        let start = geojson_io::write(&d.evaluate(&none).merged, None);
        let t = quantize(Coord {
            x: rng.range(-60.0, 60.0),
            y: rng.range(-60.0, 60.0),
        });
        d.layers[1].place = Place {
            translate: t,
            ..Place::default()
        };
        let away = d.evaluate(&none);
        assert!(check(&away.merged).is_empty());
        assert_ne!(geojson_io::write(&away.merged, None), start, "case {case}");
        d.layers[1].place = Place::default();
        assert_eq!(
            geojson_io::write(&d.evaluate(&none).merged, None),
            start,
            "case {case}"
        );
    }
}

#[test]
fn a_block_seed_depends_on_the_layer_seed_and_the_block_only() {
    let b = Id::mint("block").u64(3).finish();
    assert_eq!(block_seed(7, b), block_seed(7, b));
    assert_ne!(block_seed(7, b), block_seed(8, b));
}
