//! The data model: generated layouts are valid, blocks are the graph's
//! faces, identities come from structure, regrowing one block changes
//! nothing elsewhere, and the validity check finds each kind of violation.

use geo::Coord;
use grm_layout::blocks::{blocks, ownership};
use grm_layout::generate::{GridParams, RadialParams, grid, radial};
use grm_layout::id::Id;
use grm_layout::model::{Layout, Parcel, ParcelOrigin, Street, StreetClass, Tags};
use grm_layout::subdivide::{ParcelParams, regrow};
use grm_layout::validity::{Violation, check};
use std::collections::BTreeSet;

fn filled(mut l: Layout, seed: u64) -> Layout {
    let b = blocks(&l);
    regrow(&mut l, &b, seed, &ParcelParams::default(), None);
    l
}

#[test]
fn a_grid_has_its_blocks_and_valid_parcels() {
    let l = filled(grid(&GridParams::default()).unwrap(), 1);
    let b = blocks(&l);
    assert_eq!(b.len(), 16);
    assert!(l.parcels.len() > 16, "{} parcels", l.parcels.len());
    let v = check(&l);
    assert!(
        v.is_empty(),
        "{:?}",
        v.iter().map(|x| x.describe()).collect::<Vec<_>>()
    );
    let own = ownership(&l, &b);
    for p in l.parcels.values() {
        let ParcelOrigin::Generated { block } = p.origin else {
            panic!()
        };
        assert_eq!(own.get(&p.id), Some(&block));
    }
}

#[test]
fn a_radial_layout_is_valid() {
    let l = filled(radial(&RadialParams::default()).unwrap(), 3);
    let b = blocks(&l);
    // 6 centre wedges + 12 per ring for three more rings.
    assert_eq!(b.len(), 6 + 12 * 3);
    let v = check(&l);
    assert!(
        v.is_empty(),
        "{:?}",
        v.iter().map(|x| x.describe()).collect::<Vec<_>>()
    );
    assert!(l.parcels.len() > b.len());
}

#[test]
fn identities_come_from_structure_not_order() {
    let a = grid(&GridParams::default()).unwrap();
    let b = grid(&GridParams {
        nx: 6,
        ..GridParams::default()
    })
    .unwrap();
    // The nodes both grids share keep their identities and places.
    for (id, n) in &a.nodes {
        assert_eq!(b.nodes.get(id).map(|m| m.pos), Some(n.pos));
    }
    let ba: BTreeSet<Id> = blocks(&a).iter().map(|x| x.id).collect();
    let bb: BTreeSet<Id> = blocks(&b).iter().map(|x| x.id).collect();
    // Every block of the narrower grid but those along its right edge (whose
    // right street is now a minor one, so a different street) is a block of the wider one.
    assert!(ba.intersection(&bb).count() >= 12);
}

#[test]
fn regrowing_one_block_changes_nothing_elsewhere() {
    let l = filled(grid(&GridParams::default()).unwrap(), 9);
    let b = blocks(&l);
    let target = b[5].id;
    let mut other = l.clone();
    // Another seed for every block, then the original seed back for all but the target.
    regrow(
        &mut other,
        &b,
        10,
        &ParcelParams::default(),
        Some(&BTreeSet::from([target])),
    );
    for (id, p) in &l.parcels {
        let ParcelOrigin::Generated { block } = p.origin else {
            continue;
        };
        if block != target {
            assert_eq!(other.parcels.get(id), Some(p));
        }
    }
    let changed = other
        .parcels
        .values()
        .filter(|p| p.origin == ParcelOrigin::Generated { block: target });
    assert!(changed.count() > 0);
    assert!(check(&other).is_empty());
}

fn c(x: f64, y: f64) -> Coord {
    Coord { x, y }
}

#[test]
fn the_check_finds_each_violation() {
    let mut l = Layout::default();
    let n =
        |l: &mut Layout, k: u64, x: f64, y: f64| l.add_node(Id::mint("n").u64(k).finish(), c(x, y));
    let a = n(&mut l, 1, 0.0, 0.0);
    let b = n(&mut l, 2, 100.0, 0.0);
    let cc = n(&mut l, 3, 50.0, -50.0);
    let d = n(&mut l, 4, 50.0, 50.0);
    for (x, y) in [(a, b), (cc, d)] {
        let s = Street::new(Street::mint_id(x, y, &[]), x, y, StreetClass::Minor);
        l.streets.insert(s.id, s);
    }
    let v = check(&l);
    assert!(
        matches!(v.as_slice(), [Violation::StreetsCross { .. }]),
        "{v:?}"
    );
    // A parcel on the first street, another overlapping it.
    l.streets.retain(|_, s| s.a != cc);
    let p1 = Parcel {
        id: Id::mint("p").u64(1).finish(),
        ring: vec![c(10.0, 2.0), c(30.0, 2.0), c(30.0, 20.0), c(10.0, 20.0)],
        origin: ParcelOrigin::Explicit,
        tags: Tags::new(),
    };
    let mut p2 = p1.clone();
    p2.id = Id::mint("p").u64(2).finish();
    p2.ring = vec![c(20.0, 10.0), c(40.0, 10.0), c(40.0, 30.0), c(20.0, 30.0)];
    l.parcels.insert(p1.id, p1.clone());
    l.parcels.insert(p2.id, p2);
    let v = check(&l);
    assert!(
        v.iter()
            .any(|x| matches!(x, Violation::ParcelOnStreet { parcel, .. } if *parcel == p1.id)),
        "{v:?}"
    );
    assert!(
        v.iter()
            .any(|x| matches!(x, Violation::ParcelsOverlap { .. })),
        "{v:?}"
    );
    // Two parcels sharing an edge do not overlap.
    let mut l2 = Layout::default();
    let mut q1 = p1.clone();
    q1.ring = vec![c(0.0, 0.0), c(10.0, 0.0), c(10.0, 10.0), c(0.0, 10.0)];
    let mut q2 = q1.clone();
    q2.id = Id::mint("p").u64(3).finish();
    q2.ring = vec![c(10.0, 0.0), c(20.0, 0.0), c(20.0, 10.0), c(10.0, 10.0)];
    l2.parcels.insert(q1.id, q1);
    l2.parcels.insert(q2.id, q2);
    assert!(check(&l2).is_empty());
}
