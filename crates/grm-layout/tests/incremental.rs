//! The incremental merge of a drag (issue 29, 4.4's timings): faces,
//! indexes and clash checks kept from the last update and recomputed only
//! where the moved layer was or is. Each property compares against the
//! same computation from scratch over many random drags, including drags
//! away and back (circular editing: the first result comes back, every
//! identity and every coordinate).

use geo::Coord;
use grm_layout::blocks::{Faces, blocks};
use grm_layout::generate::{GridParams, RadialParams, grid, radial};
use grm_layout::geojson_io::write;
use grm_layout::geom::Affine;
use grm_layout::layers::{LayerSpec, Source, merge_layers, merge_layers_cached, place};
use grm_layout::merge::{MergeMode, MergeParams, merge};
use grm_layout::model::Layout;
use grm_layout::subdivide::{MergeCache, ParcelParams, regrow};
use grm_testkit::Rng;

fn filled(mut l: Layout, seed: u64) -> Layout {
    let b = blocks(&l);
    regrow(&mut l, &b, seed, &ParcelParams::default(), None);
    l
}

fn base() -> Layout {
    filled(
        grid(&GridParams {
            nx: 6,
            ny: 5,
            seed: 1,
            ..GridParams::default()
        })
        .unwrap(),
        1,
    )
}

/// A small rotated grid: the layer an artist drags.
fn dragged() -> Layout {
    filled(
        grid(&GridParams {
            nx: 2,
            ny: 2,
            spacing: Coord { x: 45.0, y: 40.0 },
            origin: Coord { x: 150.0, y: 110.0 },
            rotation_deg: 17.0,
            seed: 77,
            major_every: 1,
            ..GridParams::default()
        })
        .unwrap(),
        2,
    )
}

/// Places a drag can go: some repeat, one is far off the base (the layer
/// then lies outside every block: a second component, or a hole when it
/// lands inside a block without crossing).
fn offset(rng: &mut Rng) -> Coord {
    match rng.below(6usize) {
        0 => Coord { x: 0.0, y: 0.0 },
        1 => Coord { x: 9.0, y: -6.0 },
        2 => Coord { x: 900.0, y: 40.0 },
        _ => Coord {
            x: rng.range(-120.0, 200.0).round(),
            y: rng.range(-100.0, 160.0).round(),
        },
    }
}

fn at(l: &Layout, o: Coord) -> Layout {
    let mut l = l.clone();
    place(&mut l, &Affine::translate(o.x, o.y));
    l
}

#[test]
fn faces_kept_over_random_drags_give_the_blocks_from_scratch() {
    let (a, b) = (base(), dragged());
    let mut rng = Rng::seeded(0x00fa_ce5e);
    let mut upper = Faces::default();
    let mut result = Faces::default();
    let mut retraced_some = false;
    for step in 0..40 {
        let o = offset(&mut rng);
        let u = at(&b, o);
        assert_eq!(upper.update(&u), blocks(&u), "step {step}: the upper side");
        let (m, _) = merge(&a, &u, MergeMode::Hard, &MergeParams::default()).unwrap();
        let got = result.update(&m);
        assert_eq!(got, blocks(&m), "step {step}: the merged layout at {o:?}");
        // The same layout again: nothing is traced.
        assert_eq!(result.update(&m), got);
        assert_eq!(result.retraced, 0, "step {step}");
        retraced_some |= !got.is_empty();
    }
    assert!(retraced_some);
}

#[test]
fn faces_follow_a_component_inside_a_block() {
    // A small square inside a big block of a sparse grid: a hole; dragged
    // across the block's edge it joins the grid, and back it is a hole again.
    let big = grid(&GridParams {
        nx: 2,
        ny: 2,
        spacing: Coord { x: 300.0, y: 300.0 },
        jitter: 0.0,
        seed: 5,
        ..GridParams::default()
    })
    .unwrap();
    let small = grid(&GridParams {
        nx: 1,
        ny: 1,
        spacing: Coord { x: 40.0, y: 40.0 },
        origin: Coord { x: 100.0, y: 100.0 },
        jitter: 0.0,
        seed: 6,
        ..GridParams::default()
    })
    .unwrap();
    let mut f = Faces::default();
    let mut holes_seen = 0;
    for (k, x) in [0.0, 30.0, 180.0, 200.0, 30.0, 0.0, 500.0, 0.0]
        .iter()
        .enumerate()
    {
        let (m, _) = merge(
            &big,
            &at(&small, Coord { x: *x, y: 7.0 }),
            MergeMode::Hard,
            &MergeParams::default(),
        )
        .unwrap();
        let want = blocks(&m);
        holes_seen += want.iter().filter(|b| !b.holes.is_empty()).count();
        assert_eq!(f.update(&m), want, "step {k} at x {x}");
    }
    assert!(holes_seen > 0, "no step had a hole");
}

/// A stack like the benchmark's, smaller: a base grid, a radial centre and
/// the dragged grid on top (the layers above the base outweigh it).
fn stack() -> (Vec<LayerSpec>, Vec<Layout>) {
    let rp = RadialParams {
        centre: Coord { x: 330.0, y: 230.0 },
        rings: 2,
        ring_spacing: 40.0,
        spokes: 7,
        seed: 2,
        ..RadialParams::default()
    };
    let mut layouts = vec![base(), filled(radial(&rp).unwrap(), 3), dragged()];
    for l in &mut layouts[1..] {
        for s in l.streets.values_mut() {
            s.priority *= 4.0;
        }
    }
    let specs = ["base", "centre", "dragged"]
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let mut s = LayerSpec::new(n, Source::Empty);
            s.seed = 20 + i as u64;
            s
        })
        .collect();
    (specs, layouts)
}

#[test]
fn the_incremental_merge_equals_the_merge_from_scratch_over_random_drags() {
    let (mut specs, layouts) = stack();
    let pp = ParcelParams::default();
    for mode in [MergeMode::Hard, MergeMode::GraphCut] {
        for s in &mut specs {
            s.merge = mode;
        }
        let cache = MergeCache::default();
        let mut rng = Rng::seeded(0x0064_7261_6773);
        let mut first: Option<String> = None;
        for step in 0..30 {
            // Now and then a step back to the start (circular editing).
            let o = if step % 7 == 6 {
                Coord { x: 0.0, y: 0.0 }
            } else {
                offset(&mut rng)
            };
            let mut ls = layouts.clone();
            ls[2] = at(&layouts[2], o);
            let (mut i1, mut i2) = (Vec::new(), Vec::new());
            let (m1, r1) = merge_layers(&specs, &ls, &pp, &mut i1);
            let (m2, r2) = merge_layers_cached(&specs, &ls, &pp, &mut i2, &cache);
            let (g1, g2) = (write(&m1, None), write(&m2, None));
            assert!(
                g1 == g2,
                "{mode:?} step {step} at {o:?}: the GeoJSON differs"
            );
            assert_eq!(format!("{m1:?}"), format!("{m2:?}"), "{mode:?} step {step}");
            assert_eq!(r1, r2, "{mode:?} step {step}");
            assert_eq!(i1, i2, "{mode:?} step {step}");
            if o == (Coord { x: 0.0, y: 0.0 }) {
                match &first {
                    None => first = Some(g2),
                    Some(f) => assert!(
                        *f == g2,
                        "{mode:?} step {step}: back at the start, not the same city"
                    ),
                }
            }
        }
        assert!(first.is_some());
    }
}

/// The dragged layer placed rigidly from its source pose: turned `deg`
/// about its middle, then moved by `t` (a layer's `Place`).
fn placed(l: &Layout, t: Coord, deg: f64) -> Layout {
    let mut l = l.clone();
    let p = grm_layout::layers::Place {
        translate: t,
        rotate_deg: deg,
        about: Coord { x: 190.0, y: 140.0 },
    };
    place(&mut l, &p.affine());
    l
}

/// A drag as an editor makes it: small steps along a path and back, now
/// and then turning the layer, each step placed from the source pose.
fn rigid_path(rng: &mut Rng, steps: usize) -> Vec<(Coord, f64)> {
    let mut out = vec![(Coord { x: 0.0, y: 0.0 }, 0.0)];
    let (mut t, mut deg) = (Coord { x: 0.0, y: 0.0 }, 0.0);
    for _ in 0..steps {
        t = Coord {
            x: t.x + rng.range(-2.0, 5.0),
            y: t.y + rng.range(-2.0, 4.0),
        };
        if rng.below(3usize) == 0 {
            deg += rng.range(-4.0, 4.0);
        }
        out.push((t, deg));
    }
    // Back the same way (circular editing: the first result comes back).
    let back: Vec<(Coord, f64)> = out.iter().rev().skip(1).copied().collect();
    out.extend(back);
    out
}

#[test]
fn faces_moved_rigidly_are_replaced_and_equal_the_blocks_from_scratch() {
    // A dragged grid with faces away from its edge: inside the merged
    // layout too they touch no seam.
    let b = filled(
        grid(&GridParams {
            nx: 4,
            ny: 4,
            spacing: Coord { x: 30.0, y: 28.0 },
            origin: Coord { x: 140.0, y: 90.0 },
            rotation_deg: 17.0,
            seed: 78,
            major_every: 1,
            ..GridParams::default()
        })
        .unwrap(),
        2,
    );
    let a = base();
    let mut rng = Rng::seeded(0x0072_6967_6964);
    let mut upper = Faces::default();
    let mut result = Faces::default();
    let (mut replaced, mut retraced) = (0, 0);
    let mut replaced_result = 0;
    for (step, (t, deg)) in rigid_path(&mut rng, 20).into_iter().enumerate() {
        let u = placed(&b, t, deg);
        assert_eq!(upper.update(&u), blocks(&u), "step {step}: the upper side");
        if step > 0 {
            replaced += upper.replaced;
            retraced += upper.retraced;
        }
        let (m, _) = merge(&a, &u, MergeMode::Hard, &MergeParams::default()).unwrap();
        assert_eq!(
            result.update(&m),
            blocks(&m),
            "step {step}: merged at {t:?}, {deg} degrees"
        );
        replaced_result += result.replaced;
    }
    // The moved layer's own faces kept their walks: re-placed, not traced
    // (a face is traced again only where a node's order changed).
    assert!(
        replaced > 0 && replaced_result > 0,
        "{replaced} {replaced_result}"
    );
    assert!(
        replaced > retraced,
        "re-placed {replaced}, traced {retraced}"
    );
}

#[test]
fn rigid_drags_merge_as_from_scratch_and_come_back() {
    let (mut specs, layouts) = stack();
    let pp = ParcelParams::default();
    for mode in [MergeMode::Hard, MergeMode::GraphCut] {
        for s in &mut specs {
            s.merge = mode;
        }
        let cache = MergeCache::default();
        let mut rng = Rng::seeded(0x0064_7261_6732);
        let mut first: Option<String> = None;
        let path = rigid_path(&mut rng, 12);
        let last = path.len() - 1;
        for (step, (t, deg)) in path.into_iter().enumerate() {
            let mut ls = layouts.clone();
            ls[2] = placed(&layouts[2], t, deg);
            let (mut i1, mut i2) = (Vec::new(), Vec::new());
            let (m1, r1) = merge_layers(&specs, &ls, &pp, &mut i1);
            let (m2, r2) = merge_layers_cached(&specs, &ls, &pp, &mut i2, &cache);
            let (g1, g2) = (write(&m1, None), write(&m2, None));
            assert!(
                g1 == g2,
                "{mode:?} step {step} at {t:?}, {deg} degrees: the GeoJSON differs"
            );
            assert_eq!(format!("{m1:?}"), format!("{m2:?}"), "{mode:?} step {step}");
            assert_eq!(r1, r2, "{mode:?} step {step}");
            assert_eq!(i1, i2, "{mode:?} step {step}");
            match &first {
                None => first = Some(g2),
                Some(f) if step == last => {
                    assert!(*f == g2, "{mode:?}: back at the start, not the same city")
                }
                Some(_) => {}
            }
        }
    }
}
