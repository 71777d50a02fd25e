//! The merges: both leave a valid layout; the hard merge keeps every upper
//! street; the graph cut keeps the important streets of both; the minimum
//! cut equals a brute-force minimum cut on small random graphs.

use geo::Coord;
use grm_layout::blocks::blocks;
use grm_layout::generate::{GridParams, grid};
use grm_layout::id::Id;
use grm_layout::merge::{MergeMode, MergeParams, merge, min_cut};
use grm_layout::model::Layout;
use grm_layout::subdivide::{ParcelParams, regrow};
use grm_layout::validity::check;
use grm_testkit::Rng;
use std::collections::BTreeSet;

fn filled(mut l: Layout, seed: u64) -> Layout {
    let b = blocks(&l);
    regrow(&mut l, &b, seed, &ParcelParams::default(), None);
    l
}

fn base() -> Layout {
    filled(
        grid(&GridParams {
            nx: 6,
            ny: 6,
            seed: 1,
            ..GridParams::default()
        })
        .unwrap(),
        1,
    )
}

fn insert(dx: f64, dy: f64, rot: f64) -> Layout {
    let p = GridParams {
        nx: 2,
        ny: 2,
        spacing: Coord { x: 50.0, y: 50.0 },
        origin: Coord {
            x: 150.0 + dx,
            y: 110.0 + dy,
        },
        rotation_deg: rot,
        seed: 77,
        major_every: 1,
        ..GridParams::default()
    };
    filled(grid(&p).unwrap(), 2)
}

fn describe(l: &Layout) -> Vec<String> {
    check(l).iter().map(|v| v.describe()).collect()
}

#[test]
fn the_hard_merge_keeps_every_upper_street_and_is_valid() {
    let (a, b) = (base(), insert(3.0, 7.0, 20.0));
    let (m, r) = merge(&a, &b, MergeMode::Hard, &MergeParams::default()).unwrap();
    assert!(check(&m).is_empty(), "{:?}", describe(&m));
    assert!(r.crossings > 0);
    assert!(r.lower_pieces_dropped > 0);
    let upper: BTreeSet<_> = b.streets.keys().collect();
    // Upper streets are all there, whole or in pieces at crossings.
    let whole = m.streets.keys().filter(|k| upper.contains(k)).count();
    assert!(
        whole + r.crossings >= upper.len(),
        "{whole} of {}",
        upper.len()
    );
    assert_eq!(r.upper_pieces_dropped, 0);
    // Parcels of untouched upper blocks come through with their identities
    // and polygons (owned now by the merged layout's block).
    let kept = b
        .parcels
        .iter()
        .filter(|(k, p)| m.parcels.get(k).is_some_and(|q| q.ring == p.ring))
        .count();
    assert!(kept * 2 > b.parcels.len(), "{kept} of {}", b.parcels.len());
}

#[test]
fn the_graph_cut_merge_is_valid_and_keeps_parts_of_both() {
    for (dx, dy, rot) in [(3.0, 7.0, 20.0), (-40.0, 15.0, 5.0), (61.0, -33.0, 45.0)] {
        let (a, b) = (base(), insert(dx, dy, rot));
        let (m, r) = merge(&a, &b, MergeMode::GraphCut, &MergeParams::default()).unwrap();
        assert!(check(&m).is_empty(), "{:?}", describe(&m));
        assert!(r.cut > 0);
        let from_b = m
            .streets
            .keys()
            .filter(|k| b.streets.contains_key(k))
            .count();
        let from_a = m
            .streets
            .keys()
            .filter(|k| a.streets.contains_key(k))
            .count();
        assert!(from_a > 0 && from_b > 0, "{from_a} {from_b} {r:?}");
    }
}

#[test]
fn disjoint_layouts_merge_into_their_union() {
    let a = base();
    let b = insert(2000.0, 0.0, 0.0);
    for mode in [MergeMode::Hard, MergeMode::GraphCut] {
        let (m, _) = merge(&a, &b, mode, &MergeParams::default()).unwrap();
        assert_eq!(m.streets.len(), a.streets.len() + b.streets.len());
        assert_eq!(m.parcels.len(), a.parcels.len() + b.parcels.len());
        assert!(check(&m).is_empty());
    }
}

/// Brute force: every assignment of the free nodes to a side.
fn brute(n: usize, edges: &[(usize, usize, i64)], src: &[usize], snk: &[usize]) -> i64 {
    let free: Vec<usize> = (0..n)
        .filter(|i| !src.contains(i) && !snk.contains(i))
        .collect();
    let mut best = i64::MAX;
    for mask in 0u32..(1 << free.len()) {
        let mut side = vec![false; n];
        for &s in src {
            side[s] = true;
        }
        for (k, &f) in free.iter().enumerate() {
            side[f] = mask & (1 << k) != 0;
        }
        let c: i64 = edges
            .iter()
            .filter(|(a, b, _)| side[*a] != side[*b])
            .map(|e| e.2)
            .sum();
        best = best.min(c);
    }
    best
}

#[test]
fn the_minimum_cut_equals_brute_force_on_small_graphs() {
    let mut rng = Rng::seeded(0x6c61_796f_7574);
    for case in 0..300 {
        let n = 4 + rng.below(7usize);
        let m = rng.below(3 * n) + 1;
        let mut edges = Vec::new();
        for _ in 0..m {
            let a = rng.below(n);
            let b = rng.below(n);
            if a != b {
                edges.push((a, b, 1 + rng.below(20i64)));
            }
        }
        let mut nodes: Vec<usize> = (0..n).collect();
        rng.shuffle(&mut nodes);
        let ns = 1 + rng.below(2usize);
        let nt = 1 + rng.below(2usize);
        let src: Vec<usize> = nodes[..ns].to_vec();
        let snk: Vec<usize> = nodes[ns..ns + nt].to_vec();
        let id = |i: usize| Id::mint("v").u64(i as u64).finish();
        let e: Vec<(Id, Id, i64)> = edges.iter().map(|&(a, b, c)| (id(a), id(b), c)).collect();
        let (cut, side) = min_cut(
            &e,
            &src.iter().map(|&i| id(i)).collect(),
            &snk.iter().map(|&i| id(i)).collect(),
        );
        let expect = brute(n, &edges, &src, &snk);
        assert_eq!(
            cut, expect,
            "case {case}: n={n} edges={edges:?} src={src:?} snk={snk:?}"
        );
        // The source side is a cut of that capacity.
        let on = |i: usize| side.contains(&id(i)) || src.contains(&i);
        let c: i64 = edges
            .iter()
            .filter(|(a, b, _)| on(*a) != on(*b))
            .map(|e| e.2)
            .sum();
        assert_eq!(c, expect, "case {case}: the source side's cut");
        assert!(
            src.iter().all(|&s| side.contains(&id(s)))
                && snk.iter().all(|&t| !side.contains(&id(t)))
        );
    }
}

#[test]
fn a_cache_kept_over_a_drag_gives_the_same_merges() {
    use grm_layout::geojson_io::write;
    use grm_layout::layers::place;
    use grm_layout::merge::merge_cached;
    use grm_layout::subdivide::MergeCache;
    let a = base();
    let cache = MergeCache::default();
    for k in 0..6 {
        let mut b = insert(0.0, 0.0, 20.0);
        // Back and forth, so later steps meet cached blocks and parcels.
        let t = [0.0, 4.0, 8.0, 4.0, 0.0, 8.0][k];
        place(&mut b, &grm_layout::geom::Affine::translate(t, t / 2.0));
        for mode in [MergeMode::Hard, MergeMode::GraphCut] {
            let (m1, r1) = merge(&a, &b, mode, &MergeParams::default()).unwrap();
            let (m2, r2) = merge_cached(&a, &b, mode, &MergeParams::default(), &cache).unwrap();
            assert_eq!(write(&m1, None), write(&m2, None), "step {k} {mode:?}");
            assert_eq!(r1, r2);
        }
    }
}

/// The layer stack's cache (merged prefixes of the stack, kept between
/// calls): over a random sequence of drags of any of three layers, each
/// merge mode, the cached stack gives the bytes a fresh merge gives, and a
/// call with nothing changed merges nothing again.
#[test]
fn a_stack_cache_kept_over_random_drags_gives_the_same_merges() {
    use grm_layout::geom::Affine;
    use grm_layout::layers::{LayerSpec, Source, merge_layers, merge_layers_cached, place};
    use grm_layout::subdivide::MergeCache;
    let top = {
        let p = GridParams {
            nx: 2,
            ny: 3,
            spacing: Coord { x: 45.0, y: 40.0 },
            origin: Coord { x: 60.0, y: 60.0 },
            rotation_deg: -15.0,
            seed: 91,
            ..GridParams::default()
        };
        filled(grid(&p).unwrap(), 3)
    };
    let sources = [base(), insert(0.0, 0.0, 20.0), top];
    let mut specs: Vec<LayerSpec> = ["base", "middle", "top"]
        .iter()
        .enumerate()
        .map(|(i, n)| {
            let mut s = LayerSpec::new(n, Source::Empty);
            s.seed = 10 + i as u64;
            s
        })
        .collect();
    let pp = ParcelParams::default();
    let mut offsets = [Coord { x: 0.0, y: 0.0 }; 3];
    let cache = MergeCache::default();
    let mut rng = Rng::seeded(0x0073_7461_636b);
    for step in 0..14 {
        // Drag one layer to one of a few places (so places repeat), and
        // now and then switch a layer's merge mode.
        let l = rng.below(3usize);
        offsets[l] = [
            Coord { x: 0.0, y: 0.0 },
            Coord { x: 6.0, y: 3.0 },
            Coord { x: -9.0, y: 12.0 },
        ][rng.below(3usize)];
        if rng.below(4usize) == 0 {
            let k = 1 + rng.below(2usize);
            specs[k].merge = match specs[k].merge {
                MergeMode::Hard => MergeMode::GraphCut,
                MergeMode::GraphCut => MergeMode::Hard,
            };
        }
        let layouts: Vec<Layout> = sources
            .iter()
            .zip(&offsets)
            .map(|(s, o)| {
                let mut s = s.clone();
                place(&mut s, &Affine::translate(o.x, o.y));
                s
            })
            .collect();
        let (mut i1, mut i2) = (Vec::new(), Vec::new());
        let (m1, r1) = merge_layers(&specs, &layouts, &pp, &mut i1);
        let (m2, r2) = merge_layers_cached(&specs, &layouts, &pp, &mut i2, &cache);
        assert_eq!(format!("{m1:?}"), format!("{m2:?}"), "step {step}");
        assert_eq!(r1, r2, "step {step}");
        assert_eq!(i1, i2, "step {step}");
        assert!(describe(&m2).is_empty(), "step {step}: {:?}", describe(&m2));
        // Nothing changed: every step of the stack comes from the cache.
        let kept = cache.stack.len();
        let mut i3 = Vec::new();
        let (m3, r3) = merge_layers_cached(&specs, &layouts, &pp, &mut i3, &cache);
        assert_eq!(
            cache.stack.len(),
            kept,
            "step {step}: a second call merged again"
        );
        assert_eq!(format!("{m1:?}"), format!("{m3:?}"), "step {step}");
        assert_eq!(r1, r3);
    }
}
