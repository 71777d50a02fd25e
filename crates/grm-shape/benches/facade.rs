//! Shape-grammar benchmark (DESIGN.md section 8): a 40-floor by 50-window
//! facade (2,000 windows) and a four-sided tower of 8,000 windows, derived
//! by grm-shape on one thread and on all of the machine's threads, and by
//! `symbios-shape` 0.2 (the peer) on its one thread, in the same run; the
//! ratio is the peer's time over ours on one thread (the target is 2.5).
//!
//! Both engines run the same grammar, derivation only (rules built once,
//! outside the timing):
//!
//! ```text
//! Facade   -> repeat(y) { 3: Floor }          tag floor
//! Floor    -> repeat(x) { 2: Tile }           tag column
//! Tile     -> split(x) { ~0.4: Wall | 1.2: WinStrip | ~0.4: Wall }
//! WinStrip -> split(y) { ~1: Wall | 1.5: Window | ~0.5: Wall }
//! Window   -> insert(window)      Wall -> insert(wall)
//! Tower    -> extrude(120) comp(faces) { side: Facade | top: Roof }
//! ```
//!
//! The facade is 100 by 120; the tower's lot 100 by 100. Then the scaling
//! with threads: grm-shape alone on 1, 2, 4, ... up to the machine's
//! threads (interleaved rounds), on the tower and on a bigger one (a 200
//! by 200 lot, 240 high: 80 floors of four 100-column facades, 32,000
//! windows), each count's median time and its speed-up over one thread
//! (the median over rounds of the one-thread time over its own). Run with
//! `cargo bench -p grm-shape --bench facade`.

use grm_shape::{Lot, Options, Program, Scope, derive};
use std::hint::black_box;
use std::time::{Duration, Instant};
use symbios_shape::{Quat, Scope as PeerScope, Vec3 as PeerVec3};

mod workloads;
use workloads::{grm_program, grm_program_of, peer};

/// Time the three contenders in interleaved rounds (one run of each per
/// round, so that all see the same load on a busy machine), for at least
/// 20 rounds and 2 s. Returns, per contender, the median and minimum time,
/// and the median over rounds of the peer's time over ours (one thread).
fn rounds(
    mut ours_one: impl FnMut(),
    mut ours_many: impl FnMut(),
    mut peer: impl FnMut(),
) -> ([(Duration, Duration); 3], f64) {
    ours_one();
    ours_many();
    peer();
    let mut t: [Vec<Duration>; 3] = Default::default();
    let mut ratios = Vec::new();
    let start = Instant::now();
    while t[0].len() < 20 || start.elapsed() < Duration::from_secs(2) {
        let a = Instant::now();
        ours_one();
        let b = Instant::now();
        ours_many();
        let c = Instant::now();
        peer();
        let d = Instant::now();
        t[0].push(b - a);
        t[1].push(c - b);
        t[2].push(d - c);
        ratios.push((d - c).as_secs_f64() / (b - a).as_secs_f64());
        if t[0].len() >= 1000 {
            break;
        }
    }
    ratios.sort_by(f64::total_cmp);
    let stat = |v: &mut Vec<Duration>| {
        v.sort();
        (v[v.len() / 2], v[0])
    };
    (
        [stat(&mut t[0]), stat(&mut t[1]), stat(&mut t[2])],
        ratios[ratios.len() / 2],
    )
}

/// grm-shape alone on each of `counts` threads, interleaved rounds (at
/// least 10 and 2 s): per count, the median time and the median over
/// rounds of the one-thread time over its own (the speed-up).
fn scaling(program: &Program, lot: &Lot, counts: &[usize]) -> Vec<(usize, Duration, f64)> {
    let run = |threads: usize| {
        let opts = Options {
            threads,
            ..Options::default()
        };
        black_box(derive(program, lot, &opts).expect("derive"));
    };
    for &k in counts {
        run(k);
    }
    let mut t: Vec<Vec<Duration>> = vec![Vec::new(); counts.len()];
    let mut speedups: Vec<Vec<f64>> = vec![Vec::new(); counts.len()];
    let start = Instant::now();
    while t[0].len() < 10 || start.elapsed() < Duration::from_secs(2) {
        let mut round = Vec::with_capacity(counts.len());
        for &k in counts {
            let a = Instant::now();
            run(k);
            round.push(a.elapsed());
        }
        for (i, d) in round.iter().enumerate() {
            t[i].push(*d);
            speedups[i].push(round[0].as_secs_f64() / d.as_secs_f64());
        }
        if t[0].len() >= 200 {
            break;
        }
    }
    counts
        .iter()
        .enumerate()
        .map(|(i, &k)| {
            t[i].sort();
            speedups[i].sort_by(f64::total_cmp);
            (k, t[i][t[i].len() / 2], speedups[i][speedups[i].len() / 2])
        })
        .collect()
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "grm-shape bench: {threads} hardware threads; times are median (minimum) per derivation, contenders interleaved"
    );
    for (name, tower, windows) in [
        ("facade 40x50", false, 2000usize),
        ("tower 4x40x50", true, 8000),
    ] {
        let program = grm_program(tower);
        let lot = if tower {
            Lot::rectangle(100.0, 100.0)
        } else {
            Lot::face(Scope::new(
                glam::Vec3::ZERO,
                glam::Vec3::new(100.0, 120.0, 0.0),
            ))
        };
        let window = program.symbol("Window").expect("Window");
        let opts = |threads| Options {
            threads,
            ..Options::default()
        };
        let tree = derive(&program, &lot, &opts(1)).expect("derive");
        let n_windows = tree
            .nodes()
            .iter()
            .filter(
                |n| matches!(n.kind, grm_shape::NodeKind::Shape { symbol, .. } if symbol == window),
            )
            .count();
        assert_eq!(n_windows, windows, "{name}: windows");
        assert_eq!(
            derive(&program, &lot, &opts(threads)).expect("derive"),
            tree,
            "{name}: threads agree"
        );

        let interp = peer(tower);
        let peer_scope = if tower {
            PeerScope::new(
                PeerVec3::ZERO,
                Quat::IDENTITY,
                PeerVec3::new(100.0, 0.0, 100.0),
            )
        } else {
            PeerScope::new(
                PeerVec3::ZERO,
                Quat::IDENTITY,
                PeerVec3::new(100.0, 120.0, 0.0),
            )
        };
        let root = if tower { "Tower" } else { "Facade" };
        let model = interp.derive(peer_scope, root).expect("peer derive");
        let peer_windows = model
            .terminals
            .iter()
            .filter(|t| t.mesh_id == "window")
            .count();
        assert_eq!(peer_windows, windows, "{name}: peer windows");

        let ([(one, one_min), (many, many_min), (p, p_min)], ratio) = rounds(
            || {
                black_box(derive(&program, &lot, &opts(1)).expect("derive"));
            },
            || {
                black_box(derive(&program, &lot, &opts(threads)).expect("derive"));
            },
            || {
                black_box(interp.derive(peer_scope, root).expect("peer"));
            },
        );
        println!(
            "{name}: {windows} windows, {} nodes | grm-shape 1 thread {:.3} ms ({:.3}) | {threads} threads {:.3} ms ({:.3}) | symbios-shape 0.2 {:.3} ms ({:.3}) | symbios-shape / grm-shape 1 thread, median of rounds {:.2}x, of minima {:.2}x",
            tree.len(),
            ms(one),
            ms(one_min),
            ms(many),
            ms(many_min),
            ms(p),
            ms(p_min),
            ratio,
            p_min.as_secs_f64() / one_min.as_secs_f64(),
        );
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "thread scaling (grm-shape alone; load average {}):",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    let mut counts = vec![1usize];
    while counts[counts.len() - 1] * 2 <= threads {
        counts.push(counts[counts.len() - 1] * 2);
    }
    if counts[counts.len() - 1] != threads {
        counts.push(threads);
    }
    if counts.len() == 1 {
        counts.push(2); // one hardware thread: two still show the overhead
    }
    for (name, lot, height, windows) in [
        (
            "tower 4x40x50",
            Lot::rectangle(100.0, 100.0),
            120.0,
            8000usize,
        ),
        ("tower 4x80x100", Lot::rectangle(200.0, 200.0), 240.0, 32000),
    ] {
        let program = grm_program_of(true, height);
        let window = program.symbol("Window").expect("Window");
        let tree = derive(&program, &lot, &Options::default()).expect("derive");
        let n = tree
            .nodes()
            .iter()
            .filter(
                |n| matches!(n.kind, grm_shape::NodeKind::Shape { symbol, .. } if symbol == window),
            )
            .count();
        assert_eq!(n, windows, "{name}: windows");
        let line: Vec<String> = scaling(&program, &lot, &counts)
            .into_iter()
            .map(|(k, d, up)| {
                format!(
                    "{k} thread{}: {:.3} ms ({up:.2}x)",
                    if k == 1 { "" } else { "s" },
                    ms(d)
                )
            })
            .collect();
        println!(
            "{name}: {windows} windows, {} nodes | {}",
            tree.len(),
            line.join(" | ")
        );
    }
}
