//! `cargo bench -p grm-sample --bench sample [-- --seeds N --runs R --only NAME --volume-weight W]`:
//! the guided sampler on the Calder tree (examples/calder_tree.grm with
//! examples/calder_tree.curves.json), one thread.
//!
//! For each configuration and each seed `0 .. N` (default 50) it samples one
//! model and records the wall time of `Sampler::sample` (search, wrap-up
//! and geometry phase; the expected directions are computed once per
//! sampler and timed separately) and the final model's curve cost. It
//! prints the median, p10 and p90 of both, and the effective sample size
//! per generation of the guided playground runs (mean over seeds).
//!
//! Configurations: Calder's playground schedule (100 generations, 100 -> 15
//! particles, heuristic 0.013 -> 0 by generation 40) with the default
//! weights (3 candidate expansions per bone, adaptive tempering to an ESS
//! of at least 0.1 of the particles), with Calder's weights (one
//! candidate, untempered: the default before), with each half of the
//! default alone (tempering with one candidate; three candidates
//! untempered) and with more of either (4 candidates; ESS 0.2 N); the
//! calder library's default (10 generations of 50 particles); each of the
//! main ones with the heuristic on and off; the playground schedule with one
//! expansion per particle step instead of Calder's expand-until-a-bone
//! step, heuristic on and off; unguided forward sampling (one particle, 100
//! steps); the playground schedule without weights (infinite temperature:
//! the best of the final 15 unguided particles, the same amount of work as
//! guided); and the volume-matching baseline on the playground schedule.
//!
//! For the playground rows it also prints the effective sample size per
//! generation (mean over seeds), the smallest ESS as a share of the
//! particles, the share of generations below a tenth of the particles,
//! the distinct particles resampling kept (`GenerationStats::survivors`)
//! and the tempering factors.

use std::path::PathBuf;
use std::time::{Duration, Instant};

use grm_guide::{Curves, VolumeOptions};
use grm_sample::{ExpectedOptions, Objective, SampleOptions, Sampler, Schedule};

struct Args {
    seeds: u32,
    runs: u32,
    volume_weight: f64,
    only: Vec<String>,
}

fn args() -> Args {
    let mut a = Args {
        seeds: 50,
        runs: 1,
        volume_weight: 20000.0,
        only: Vec::new(),
    };
    let mut it = std::env::args().skip(1);
    while let Some(x) = it.next() {
        match x.as_str() {
            "--seeds" => a.seeds = it.next().and_then(|s| s.parse().ok()).unwrap_or(50),
            "--only" => a.only.extend(it.next()),
            "--runs" => a.runs = it.next().and_then(|s| s.parse().ok()).unwrap_or(1),
            "--volume-weight" => {
                a.volume_weight = it.next().and_then(|s| s.parse().ok()).unwrap_or(20000.0)
            }
            // `cargo bench` passes `--bench`; ignore it and anything else.
            _ => {}
        }
    }
    a
}

fn pct(xs: &[f64], p: f64) -> f64 {
    let mut v = xs.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    if v.is_empty() {
        return f64::NAN;
    }
    v[((p / 100.0) * (v.len() - 1) as f64).round() as usize]
}

/// CPU time of this process so far (user + system), from /proc/self/stat
/// (clock ticks of 10 ms: `getconf CLK_TCK` is 100 on Linux x86-64). Unlike
/// wall time it does not count the time the machine's other work kept this
/// process waiting for a core.
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name (which is in parentheses).
    let rest = s.rsplit_once(')')?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let utime: f64 = f.get(11)?.parse().ok()?;
    let stime: f64 = f.get(12)?.parse().ok()?;
    Some((utime + stime) / 100.0)
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// Standard error of the median of `xs`: the standard deviation of the
/// medians of 400 bootstrap resamples (a fixed generator: the same figure
/// for the same costs).
fn median_se(xs: &[f64]) -> f64 {
    if xs.len() < 2 {
        return f64::NAN;
    }
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut meds = Vec::with_capacity(400);
    let mut v = vec![0.0; xs.len()];
    for _ in 0..400 {
        for x in v.iter_mut() {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            *x = xs[(state >> 33) as usize % xs.len()];
        }
        meds.push(pct(&v, 50.0));
    }
    let mean = meds.iter().sum::<f64>() / meds.len() as f64;
    (meds.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / meds.len() as f64).sqrt()
}

/// The 1, 5 and 15 minute load averages (`/proc/loadavg`).
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "unknown".into())
}

struct Row {
    name: &'static str,
    times: Vec<f64>,
    /// CPU milliseconds per model (process CPU time over all seeds / seeds).
    cpu_ms: f64,
    costs: Vec<f64>,
    bones: Vec<f64>,
    volume: Vec<f64>,
    ess: Vec<Vec<f64>>,
    /// Per seed, per generation: the tempering factor.
    beta: Vec<Vec<f64>>,
    /// Per seed, per generation: ESS / particles.
    share: Vec<Vec<f64>>,
    /// Per seed, per generation: distinct particles kept by resampling.
    survivors: Vec<Vec<f64>>,
    particles: Vec<usize>,
}

fn main() {
    let a = args();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let path = root.join("calder_tree.grm");
    let text = std::fs::read_to_string(&path).expect("example");
    let (_s, checked) = grm_sema::check_text(path.to_str().expect("path"), &text);
    assert!(!checked.has_errors(), "calder_tree.grm has errors");
    let program = checked.program;
    let system = &program.systems[0];
    let compiled =
        grm_compile::compile(&program, system, &program.default_params()).expect("compiles");
    let curves = Curves::load(root.join("calder_tree.curves.json")).expect("curves");
    let t = Instant::now();
    let guided = Sampler::new(
        system,
        &compiled,
        &curves,
        Objective::Curves,
        ExpectedOptions::default(),
    )
    .expect("sampler");
    let new_time = t.elapsed();
    let volume_weight = a.volume_weight;
    let volume = Sampler::new(
        system,
        &compiled,
        &curves,
        Objective::Volume {
            options: VolumeOptions::default(),
            weight: volume_weight,
        },
        ExpectedOptions::default(),
    )
    .expect("sampler");

    println!(
        "Guided sampling, calder_tree.grm + calder_tree.curves.json, {} seeds, 1 thread, {}; load average {}",
        a.seeds,
        cpu_model(),
        load_average()
    );
    println!(
        "Sampler::new (expected directions, {} models x {} expansions per skeleton symbol): {:.2} ms",
        ExpectedOptions::default().models,
        ExpectedOptions::default().expansions,
        new_time.as_secs_f64() * 1e3
    );
    for s in ["START", "branch", "branchOrLeaf", "maybeBranch"] {
        let e = guided.expected_direction(s).unwrap_or_default();
        println!("  EXPECTED({s}) = ({:.3}, {:.3}, {:.3})", e.x, e.y, e.z);
    }

    let playground = Schedule::calder_playground();
    let library = Schedule::calder_library();
    // Calder's weights: the plain proposal, untempered.
    let calder = SampleOptions {
        candidates: 1,
        ess_target: 0.0,
        ..SampleOptions::default()
    };
    let configs: Vec<(&'static str, &Sampler<'_>, SampleOptions)> = vec![
        (
            "playground, default, heur. on",
            &guided,
            SampleOptions {
                schedule: playground,
                ..SampleOptions::default()
            },
        ),
        (
            "playground, default, heur. off",
            &guided,
            SampleOptions {
                schedule: playground,
                heuristic: false,
                ..SampleOptions::default()
            },
        ),
        (
            "playground, Calder wts, heur. on",
            &guided,
            SampleOptions {
                schedule: playground,
                ..calder.clone()
            },
        ),
        (
            "playground, Calder wts, heur. off",
            &guided,
            SampleOptions {
                schedule: playground,
                heuristic: false,
                ..calder.clone()
            },
        ),
        (
            "playground, 1 cand., ESS 0.1",
            &guided,
            SampleOptions {
                schedule: playground,
                candidates: 1,
                ..SampleOptions::default()
            },
        ),
        (
            "playground, 3 cand., untempered",
            &guided,
            SampleOptions {
                schedule: playground,
                ess_target: 0.0,
                ..SampleOptions::default()
            },
        ),
        (
            "playground, 4 cand., ESS 0.1",
            &guided,
            SampleOptions {
                schedule: playground,
                candidates: 4,
                ..SampleOptions::default()
            },
        ),
        (
            "playground, 3 cand., ESS 0.2",
            &guided,
            SampleOptions {
                schedule: playground,
                ess_target: 0.2,
                ..SampleOptions::default()
            },
        ),
        (
            "library 10x50, default, heur. on",
            &guided,
            SampleOptions {
                schedule: library,
                ..SampleOptions::default()
            },
        ),
        (
            "library 10x50, default, heur. off",
            &guided,
            SampleOptions {
                schedule: library,
                heuristic: false,
                ..SampleOptions::default()
            },
        ),
        (
            "library 10x50, Calder wts, h. on",
            &guided,
            SampleOptions {
                schedule: library,
                ..calder.clone()
            },
        ),
        (
            "library 10x50, Calder wts, h. off",
            &guided,
            SampleOptions {
                schedule: library,
                heuristic: false,
                ..calder.clone()
            },
        ),
        (
            "playground 1-exp, heur. on",
            &guided,
            SampleOptions {
                schedule: playground,
                max_expansions_per_step: 1,
                ..SampleOptions::default()
            },
        ),
        (
            "playground 1-exp, heur. off",
            &guided,
            SampleOptions {
                schedule: playground,
                max_expansions_per_step: 1,
                heuristic: false,
                ..SampleOptions::default()
            },
        ),
        (
            "unguided forward, 1 particle",
            &guided,
            SampleOptions::unguided(0, 100),
        ),
        (
            "playground, no weights",
            &guided,
            SampleOptions {
                schedule: playground,
                heuristic: false,
                temperature: f64::INFINITY,
                ..SampleOptions::default()
            },
        ),
        (
            "unguided forward (volume)",
            &volume,
            SampleOptions::unguided(0, 100),
        ),
        (
            "playground, volume baseline",
            &volume,
            SampleOptions {
                schedule: playground,
                heuristic: false,
                ..SampleOptions::default()
            },
        ),
    ];
    let mut rows = Vec::new();
    for (name, sampler, opts) in configs {
        if !a.only.is_empty() && !a.only.iter().any(|o| name.contains(o.as_str())) {
            continue;
        }
        let mut row = Row {
            name,
            times: Vec::new(),
            cpu_ms: f64::NAN,
            costs: Vec::new(),
            bones: Vec::new(),
            volume: Vec::new(),
            ess: Vec::new(),
            beta: Vec::new(),
            share: Vec::new(),
            survivors: Vec::new(),
            particles: Vec::new(),
        };
        let cpu0 = cpu_seconds();
        for seed in 0..a.seeds {
            let o = SampleOptions {
                seed,
                ..opts.clone()
            };
            // Best of `runs` wall times (the machine is shared; the model is
            // the same each run).
            let mut dt = Duration::MAX;
            let mut r = None;
            for _ in 0..a.runs.max(1) {
                let t = Instant::now();
                let x = sampler.sample(&o).expect("samples");
                dt = dt.min(t.elapsed());
                r = Some(x);
            }
            let r = r.expect("ran");
            let m = r.best().expect("a model");
            row.times.push(dt.as_secs_f64() * 1e3);
            row.costs.push(m.cost.total());
            row.bones.push(f64::from(m.skeleton_bones));
            if let Some(v) = m.volume {
                row.volume.push(v.total());
            }
            row.ess.push(r.ess());
            row.beta
                .push(r.generations.iter().map(|g| g.beta).collect());
            row.share.push(
                r.generations
                    .iter()
                    .map(|g| g.ess / g.particles.max(1) as f64)
                    .collect(),
            );
            row.survivors
                .push(r.generations.iter().map(|g| g.survivors as f64).collect());
            row.particles = r.generations.iter().map(|g| g.particles).collect();
        }
        if let (Some(c0), Some(c1)) = (cpu0, cpu_seconds()) {
            row.cpu_ms = (c1 - c0) * 1e3 / f64::from(a.seeds * a.runs.max(1));
        }
        rows.push(row);
    }

    println!();
    println!(
        "wall ms: best of {} runs per seed; CPU ms: process CPU time per run (10 ms ticks, summed over all runs); load average now {}",
        a.runs.max(1),
        load_average()
    );
    println!(
        "{:<30} {:>8} {:>8} {:>8} {:>7} | {:>10} {:>10} {:>10} | {:>6}",
        "configuration",
        "ms p50",
        "ms p10",
        "ms p90",
        "CPU ms",
        "cost p50",
        "cost p10",
        "cost p90",
        "bones"
    );
    for r in &rows {
        println!(
            "{:<30} {:>8.2} {:>8.2} {:>8.2} {:>7.2} | {:>10.1} {:>10.1} {:>10.1} | {:>6.0}",
            r.name,
            pct(&r.times, 50.0),
            pct(&r.times, 10.0),
            pct(&r.times, 90.0),
            r.cpu_ms,
            pct(&r.costs, 50.0),
            pct(&r.costs, 10.0),
            pct(&r.costs, 90.0),
            pct(&r.bones, 50.0),
        );
        println!(
            "{:<30} cost p50 standard error {:.0} (bootstrap, 400 resamples of the seeds)",
            "",
            median_se(&r.costs)
        );
        if !r.volume.is_empty() {
            println!(
                "{:<30} volume cost p50 {:.3} p10 {:.3} p90 {:.3} (weight {volume_weight})",
                "",
                pct(&r.volume, 50.0),
                pct(&r.volume, 10.0),
                pct(&r.volume, 90.0)
            );
        }
    }

    for r in &rows {
        if r.ess.is_empty() || r.ess[0].len() < 2 || !r.name.starts_with("playground,") {
            continue;
        }
        if r.name.contains("no weights") || r.name.contains("volume") {
            continue;
        }
        let gens = r.ess[0].len();
        let mean_of = |v: &Vec<Vec<f64>>, g: usize| {
            v.iter().filter_map(|e| e.get(g)).sum::<f64>() / v.len() as f64
        };
        println!();
        println!(
            "{}: per generation, mean over seeds: ESS [distinct particles kept by resampling] / particles, b = beta",
            r.name
        );
        let mut line = String::new();
        for g in (0..gens).step_by(10).chain([gens - 2, gens - 1]) {
            // The last generation is not resampled (its "survivors" are
            // its distinct particles, all wrapped up).
            let surv = if g + 1 < gens {
                format!("{:.1}", mean_of(&r.survivors, g))
            } else {
                "-".into()
            };
            line.push_str(&format!(
                " g{g}: {:.1} [{surv}] / {} b{:.2};",
                mean_of(&r.ess, g),
                r.particles.get(g).copied().unwrap_or(0),
                mean_of(&r.beta, g)
            ));
        }
        println!("{line}");
        let all: Vec<f64> = r.ess.iter().flatten().copied().collect();
        let shares: Vec<f64> = r.share.iter().flatten().copied().collect();
        // Survivors of the resampled generations (all but the last).
        let surv: Vec<f64> = r
            .survivors
            .iter()
            .flat_map(|v| v[..v.len().saturating_sub(1)].iter().copied())
            .collect();
        println!(
            "  all generations and seeds: ESS mean {:.2}, median {:.2}, min {:.2}, max {:.2}; ESS / particles min {:.3}, below 0.1 in {:.1}% of generations; kept by resampling: mean {:.1}, min {:.0}",
            all.iter().sum::<f64>() / all.len() as f64,
            pct(&all, 50.0),
            pct(&all, 0.0),
            pct(&all, 100.0),
            pct(&shares, 0.0),
            100.0 * shares.iter().filter(|&&x| x < 0.1 - 1e-9).count() as f64 / shares.len() as f64,
            surv.iter().sum::<f64>() / surv.len() as f64,
            pct(&surv, 0.0),
        );
        let betas: Vec<f64> = r.beta.iter().flatten().copied().collect();
        println!(
            "  tempering factor beta: mean {:.4}, median {:.4}, min {:.2e}; beta = 1 in {:.0}% of generations",
            betas.iter().sum::<f64>() / betas.len() as f64,
            pct(&betas, 50.0),
            pct(&betas, 0.0),
            100.0 * betas.iter().filter(|&&b| b == 1.0).count() as f64 / betas.len() as f64
        );
    }
}
