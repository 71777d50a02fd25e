//! Dragging one layer of a city at Lipp's scale (4.4: about 3,000
//! parcels, 560 streets, four layers): each update places the top layer at
//! the next position of a drag and merges the four layers again
//! (`L_m = M(L_i, L_m)`, top down), once with every merge hard (`M_h`) and
//! once with every merge a graph cut (`M_f`), on one thread. Prints the
//! city's size and the time per update (median, mean, slowest), and the
//! merge's parts. Run: `cargo bench -p grm-layout --bench layout_drag`.

use geo::Coord;
use grm_layout::blocks::blocks;
use grm_layout::generate::{GridParams, RadialParams, grid, radial};
use grm_layout::layers::{LayerIssue, LayerSpec, Place, Source, merge_layers_cached, place};
use grm_layout::merge::MergeMode;
use grm_layout::model::Layout;
use grm_layout::subdivide::{MergeCache, ParcelParams, regrow};
use grm_layout::validity::check;
use std::time::Instant;

fn filled(mut l: Layout, seed: u64, p: &ParcelParams) -> Layout {
    let b = blocks(&l);
    regrow(&mut l, &b, seed, p, None);
    l
}

fn city(p: &ParcelParams) -> (Vec<LayerSpec>, Vec<Layout>) {
    let g = |name: &str, gp: GridParams| {
        (
            LayerSpec::new(name, Source::Grid(gp.clone())),
            grid(&gp).unwrap(),
        )
    };
    let (s0, l0) = g(
        "base",
        GridParams {
            nx: 13,
            ny: 13,
            spacing: Coord { x: 70.0, y: 55.0 },
            seed: 1,
            ..GridParams::default()
        },
    );
    let rp = RadialParams {
        centre: Coord { x: 300.0, y: 560.0 },
        rings: 3,
        ring_spacing: 55.0,
        spokes: 12,
        seed: 2,
        ..RadialParams::default()
    };
    let (s1, l1) = (
        LayerSpec::new("centre", Source::Radial(rp.clone())),
        radial(&rp).unwrap(),
    );
    let (s2, l2) = g(
        "quarter",
        GridParams {
            origin: Coord { x: 560.0, y: 180.0 },
            nx: 5,
            ny: 5,
            spacing: Coord { x: 50.0, y: 50.0 },
            rotation_deg: 30.0,
            seed: 3,
            ..GridParams::default()
        },
    );
    let (s3, l3) = g(
        "dragged",
        GridParams {
            origin: Coord { x: 180.0, y: 150.0 },
            nx: 6,
            ny: 6,
            spacing: Coord { x: 45.0, y: 40.0 },
            rotation_deg: 12.0,
            seed: 4,
            ..GridParams::default()
        },
    );
    let mut layouts = vec![
        filled(l0, 10, p),
        filled(l1, 11, p),
        filled(l2, 12, p),
        filled(l3, 13, p),
    ];
    // The artist's priorities: the layers placed on the base outweigh it.
    for l in &mut layouts[1..] {
        for s in l.streets.values_mut() {
            s.priority *= 4.0;
        }
    }
    (vec![s0, s1, s2, s3], layouts)
}

/// This thread's CPU time so far in ms (`/proc/thread-self/schedstat`: the
/// nanoseconds it ran), which a busy machine's waits do not inflate; None
/// where the file is missing.
fn cpu_ms() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns / 1e6)
}

fn stats(mut v: Vec<f64>) -> (f64, f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    (v[0], v[v.len() / 2], mean, v[v.len() - 1])
}

fn main() {
    let p = ParcelParams {
        max_area: 215.0,
        min_area: 40.0,
        ..ParcelParams::default()
    };
    let (mut specs, layouts) = city(&p);
    let streets: usize = layouts.iter().map(|l| l.streets.len()).sum();
    let parcels: usize = layouts.iter().map(|l| l.parcels.len()).sum();
    println!(
        "city: 4 layers, {streets} streets, {parcels} parcels (per layer: {:?})",
        layouts
            .iter()
            .map(|l| (l.streets.len(), l.parcels.len()))
            .collect::<Vec<_>>()
    );
    // `LAYOUT_DRAG_UPDATES=N` and `LAYOUT_DRAG_MODE=hard|graph_cut` narrow
    // the run (instruction counts under callgrind: `valgrind
    // --tool=callgrind` of a few updates of one mode).
    let updates: usize = std::env::var("LAYOUT_DRAG_UPDATES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(24);
    let only = std::env::var("LAYOUT_DRAG_MODE")
        .ok()
        .and_then(|v| MergeMode::parse(&v));
    for mode in [MergeMode::Hard, MergeMode::GraphCut] {
        if only.is_some_and(|m| m != mode) {
            continue;
        }
        for s in &mut specs {
            s.merge = mode;
        }
        let mut times = Vec::new();
        let mut cpu = Vec::new();
        // The editor's cache, kept over the drag.
        let cache = MergeCache::default();
        let mut last = (0, 0);
        for k in 0..updates + 2 {
            // The drag: 3 m a step along a diagonal, the layer re-placed from its source pose.
            let t = Coord {
                x: 3.0 * k as f64,
                y: 1.5 * k as f64,
            };
            let mut ls = layouts.clone();
            let t0 = Instant::now();
            let c0 = cpu_ms();
            // The dragged layer from its source pose (the lower layers as they are).
            ls[3] = layouts[3].clone();
            specs[3].place = Place {
                translate: t,
                ..Place::default()
            };
            place(&mut ls[3], &specs[3].place.affine());
            let mut issues: Vec<LayerIssue> = Vec::new();
            let (merged, reports) = merge_layers_cached(&specs, &ls, &p, &mut issues, &cache);
            let dt = t0.elapsed().as_secs_f64() * 1e3;
            let dc = cpu_ms().zip(c0).map(|(b, a)| b - a);
            assert!(
                issues.is_empty(),
                "{:?}",
                issues.iter().map(LayerIssue::describe).collect::<Vec<_>>()
            );
            if k >= 2 {
                times.push(dt);
                cpu.extend(dc);
            }
            last = (merged.streets.len(), merged.parcels.len());
            if k == updates + 1 {
                assert!(check(&merged).is_empty());
                for (i, r) in reports.iter().enumerate() {
                    println!(
                        "  {} merge {}: {} crossings, cut {}, pieces dropped {} below / {} above, {} mended, blocks kept {} / regrown {}, parcels dropped {}",
                        mode.name(),
                        i + 1,
                        r.crossings,
                        r.cut,
                        r.lower_pieces_dropped,
                        r.upper_pieces_dropped,
                        r.mended,
                        r.blocks_kept,
                        r.blocks_regrown,
                        r.parcels_dropped
                    );
                }
            }
        }
        let (min, med, mean, max) = stats(times);
        println!(
            "{:<9} per update: fastest {min:.1} ms, median {med:.1} ms, mean {mean:.1} ms, slowest {max:.1} ms ({updates} updates; merged: {} streets, {} parcels)",
            mode.name(),
            last.0,
            last.1
        );
        if !cpu.is_empty() {
            let (min, med, mean, max) = stats(cpu);
            println!(
                "{:<9} CPU time per update: fastest {min:.1} ms, median {med:.1} ms, mean {mean:.1} ms, slowest {max:.1} ms",
                mode.name()
            );
        }
    }
    // Where an update's time goes: one merge of the base under the rest, by parts.
    let t0 = Instant::now();
    let b = blocks(&layouts[0]);
    let t_blocks = t0.elapsed().as_secs_f64() * 1e3;
    let t0 = Instant::now();
    let v = check(&layouts[0]);
    let t_check = t0.elapsed().as_secs_f64() * 1e3;
    println!(
        "parts: blocks of the base layer ({} blocks) {t_blocks:.1} ms, its validity check {t_check:.1} ms ({} violations)",
        b.len(),
        v.len()
    );
}
