//! `cargo bench -p grm-sample --bench coverage [-- --seeds N --only NAME
//! --config NAME --with KEY=VALUE]`: does the guided sampler follow every
//! curve the artist draws?
//!
//! For each scene (a sample-mode grammar and a curve set), each sampler
//! configuration and each seed `0 .. N` (default 50), one model is sampled
//! on one thread with the system's own schedule (`Schedule::from_settings`);
//! its bones' coverage of each curve is measured (`grm_guide::coverage`:
//! the share of the curve's arc length with a bone within 0.15 units, plus
//! the curve's thickness). Printed per scene: the median wall time per
//! model, the mean CPU time per model (the thread's time on the CPU,
//! from `/proc/thread-self/schedstat`, which counts in scheduler ticks, so
//! a mean over the seeds and not a median: what a busy machine does not
//! inflate), the median cost, the share of models that cover **every** curve
//! at 80% or more (the curve-coverage issue's target is 90% of them, at a
//! median of at most 25 ms), the refinement rounds run per model (mean),
//! and each curve's median coverage; a curve no
//! model came near is named as unreached.
//!
//! Configurations, run in the same process, interleaved seed by seed (for
//! each seed every configuration in turn) so that their times compare:
//! `paper` (Calder's weights: one candidate, no tempering, uniform
//! expansion order, the paper's equations alone), `before` (the defaults
//! before the curve-coverage work: 3 candidates, ESS floor 0.1, the
//! paper's cost and order), `prev` (the defaults before the reach
//! look-ahead: 12 candidates, a tournament of 4, the coverage term, each
//! bone covering eq. 1's curve alone), `lookahead` (the defaults of the
//! reach look-ahead, before paced symbols drew fewer candidates:
//! `Reach::paced` 0), `pass` (the defaults before refinement: the SMC
//! pass alone, `Refine::off()`), `default` (`SampleOptions::default()`)
//! and `s26` (the refinement defaults of session 26, before
//! `Refine::followed_ends` and `Refine::min_rounds` were on: 3 rounds,
//! ended by the first best model that covers every curve by the
//! segment check).
//! Every row but `default`, `s26` and `custom` runs without refinement.
//! `paper` and `before` run with the particle counts the grammars asked
//! for before that work (Calder's 100 -> 15, the vine's 400 -> 60),
//! `prev` and `lookahead` with those of their time (the vine's 100 -> 15,
//! before it grew twice the particles with paced candidates), `default`
//! with the grammars' own.
//! `--config NAME` (repeatable) runs only those; `--detail` prints a line
//! per seed and configuration (each curve's coverage, the bones, and the
//! `--stats` report's "too few bones" verdicts of a model that misses a
//! curve); `--with KEY=VALUE`
//! (repeatable) adds a row `custom`: the defaults with those changes
//! (keys: `particles=A..B`, `pscale` (the
//! schedule's particle counts times this), `candidates`, `ess`, `order`, `cover`,
//! `generations`, and the [`grm_sample::Reach`] look-ahead's `reach_c`,
//! `reach_o`, `reach_s`, `reach_w`, `recent`, `branches`, `paced`, and
//! [`grm_sample::Refine`]'s `refine` (rounds), `refine_from`,
//! `refine_prefer` and `refine_followed` (0 or 1) and `refine_min` (rounds at
//! least once started); `others=0`: bones cover
//! eq. 1's curve alone), for trying a
//! change before it is made a default; `--custom K=V,K=V` (repeatable) adds
//! rows `custom1`, `custom2`, ... the same way.
//!
//! Scenes: the Calder tree with its own curves file (a trunk and two arms),
//! and with three curve sets of this bench's own (a single S-curve, a fork
//! of four arms, a curve that leaves the plane); the vine wall with its
//! curves file.

use std::path::PathBuf;
use std::time::Instant;

use grm_guide::{CoverageOptions, Curves, FOLLOWED, coverage, describe_coverage};
use grm_sample::{
    ExpectedOptions, Guide, Objective, Reach, Refine, SampleOptions, Sampler, Schedule,
};

const S_CURVE: &str = r#"{ "version": 1, "defaults": { "utilization_scale": 100 }, "curves": [
  { "name": "s_curve", "points": [[0, 0, 0], [1.5, 1.5, 0], [-1.5, 3, 0], [0, 4.5, 0]] } ] }"#;

const FORK: &str = r#"{ "version": 1, "defaults": { "utilization_scale": 100 }, "curves": [
  { "name": "trunk", "points": [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] },
  { "name": "arm_px", "points": [[0, 3, 0], [0.5, 3.5, 0], [1.2, 4, 0], [2, 4.3, 0]] },
  { "name": "arm_nx", "points": [[0, 3, 0], [-0.5, 3.5, 0], [-1.2, 4, 0], [-2, 4.3, 0]] },
  { "name": "arm_pz", "points": [[0, 3, 0], [0, 3.5, 0.5], [0, 4, 1.2], [0, 4.3, 2]] },
  { "name": "arm_nz", "points": [[0, 3, 0], [0, 3.5, -0.5], [0, 4, -1.2], [0, 4.3, -2]] } ] }"#;

const OUT_OF_PLANE: &str = r#"{ "version": 1, "defaults": { "utilization_scale": 100 }, "curves": [
  { "name": "trunk", "points": [[0, 0, 0], [0, 1.2, 0], [0, 2.4, 0], [0, 3.2, 0]] },
  { "name": "helix_arm", "points": [[0, 3.2, 0], [1, 3.6, 1], [0, 4.2, 2], [-1, 4.6, 1.5]] } ] }"#;

/// CPU time this thread has run, in ms (`/proc/thread-self/schedstat`,
/// nanoseconds on the CPU): unlike the wall clock, not inflated by other
/// processes on a busy machine. NaN where it cannot be read.
fn cpu_ms() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(f64::NAN, |ns| ns / 1e6)
}

/// A scene: its name, grammar file, curves, the particle counts of the
/// `paper` and `before` rows, and those of the `prev` and `lookahead` rows
/// (`None`: the grammar's own).
type Scene<'a> = (&'a str, &'a str, Curves, (u32, u32), Option<(u32, u32)>);

/// Which sampler a row runs.
enum Config {
    Paper,
    Before,
    Prev,
    Lookahead,
    Pass,
    Default,
    S26,
    Custom(Vec<(String, String)>),
}

/// One row's figures, seed by seed.
struct Row {
    times: Vec<f64>,
    cpus: Vec<f64>,
    costs: Vec<f64>,
    per_curve: Vec<Vec<f64>>,
    all80: u32,
    /// Refinement rounds run, summed over the seeds.
    rounds: u32,
}

impl Row {
    fn new(curves: usize) -> Row {
        Row {
            times: Vec::new(),
            cpus: Vec::new(),
            costs: Vec::new(),
            per_curve: vec![Vec::new(); curves],
            all80: 0,
            rounds: 0,
        }
    }
}

fn pct(xs: &[f64], p: f64) -> f64 {
    let mut v = xs.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    if v.is_empty() {
        return f64::NAN;
    }
    v[((p / 100.0) * (v.len() - 1) as f64).round() as usize]
}

/// The defaults before the curve-coverage work.
fn before(mut o: SampleOptions) -> SampleOptions {
    o.refine = Refine::off();
    o.candidates = 3;
    o.ess_target = 0.1;
    o.guide = Guide::paper();
    o
}

/// The defaults before the reach look-ahead (issue 30's first search: 12
/// candidates, a tournament of 4, the coverage term at W = 150, no reach
/// look-ahead; with a sampler whose bones cover eq. 1's curve alone).
fn prev(mut o: SampleOptions) -> SampleOptions {
    o.guide = Guide {
        order: 4,
        cover: 150.0,
    };
    o.reach = Reach::off();
    o.refine = Refine::off();
    o
}

/// The defaults of the reach look-ahead (`docs/sampling.md` 4.4, before
/// paced symbols drew fewer candidates): `Reach::paced` 0, 12 candidates
/// for every bone.
fn lookahead(mut o: SampleOptions) -> SampleOptions {
    o.reach.paced = 0;
    o.refine = Refine::off();
    o
}

/// The defaults before refinement (`docs/sampling.md` 4.5): the SMC pass
/// alone.
fn pass(mut o: SampleOptions) -> SampleOptions {
    o.refine = Refine::off();
    o
}

/// The refinement defaults of session 26: 3 rounds, `followed_ends` off,
/// no minimum once started.
fn s26(mut o: SampleOptions) -> SampleOptions {
    o.refine.rounds = 3;
    o.refine.followed_ends = false;
    o.refine.min_rounds = 0;
    o
}

/// Calder's paper: one candidate, untempered weights, uniform order.
fn paper(o: SampleOptions) -> SampleOptions {
    SampleOptions {
        candidates: 1,
        ess_target: 0.0,
        ..before(o)
    }
}

/// The defaults with `--with` changes.
fn custom(mut o: SampleOptions, with: &[(String, String)]) -> SampleOptions {
    for (k, v) in with {
        let f = || {
            v.parse::<f64>()
                .unwrap_or_else(|_| panic!("{k}={v}: a number"))
        };
        match k.as_str() {
            "particles" => {
                let (a, b) = v.split_once("..").unwrap_or((v, v));
                o.schedule.particles_start = a.parse().expect("particles");
                o.schedule.particles_end = b.parse().expect("particles");
            }
            "pscale" => {
                let k = f();
                o.schedule.particles_start =
                    ((f64::from(o.schedule.particles_start) * k).round() as u32).max(1);
                o.schedule.particles_end =
                    ((f64::from(o.schedule.particles_end) * k).round() as u32).max(1);
            }
            "generations" => o.schedule = o.schedule.with_generations(f() as u32),
            "candidates" => o.candidates = f() as u32,
            "ess" => o.ess_target = f(),
            "order" => o.guide.order = f() as u32,
            "cover" => o.guide.cover = f(),
            "reach_c" => o.reach.candidates = f(),
            "reach_o" => o.reach.order = f(),
            "reach_s" => o.reach.scale = f(),
            "reach_w" => o.reach.weights = f(),
            // Which sampler: `others=0` covers eq. 1's curve alone.
            "others" => {}
            "branches" => o.reach.branches = f() != 0.0,
            "recent" => o.reach.recent = f() as u32,
            "paced" => o.reach.paced = f() as u32,
            "refine" => o.refine.rounds = f() as u32,
            "refine_from" => o.refine.from = f(),
            "refine_prefer" => o.refine.prefer_covering = f() != 0.0,
            "refine_followed" => o.refine.followed_ends = f() != 0.0,
            "refine_min" => o.refine.min_rounds = f() as u32,
            _ => panic!("unknown --with key {k}"),
        }
    }
    o
}

fn main() {
    let mut seeds = 50u32;
    let mut only: Vec<String> = Vec::new();
    let mut configs: Vec<String> = Vec::new();
    let mut with: Vec<(String, String)> = Vec::new();
    let mut customs: Vec<Vec<(String, String)>> = Vec::new();
    let mut detail = false;
    let mut it = std::env::args().skip(1);
    while let Some(x) = it.next() {
        match x.as_str() {
            "--seeds" => seeds = it.next().and_then(|s| s.parse().ok()).unwrap_or(50),
            "--only" => only.extend(it.next()),
            "--config" => configs.extend(it.next()),
            "--detail" => detail = true,
            "--custom" => {
                let list = it.next().unwrap_or_default();
                customs.push(
                    list.split(',')
                        .filter(|kv| !kv.is_empty())
                        .map(|kv| {
                            let (k, v) = kv.split_once('=').expect("--custom K=V,K=V");
                            (k.to_string(), v.to_string())
                        })
                        .collect(),
                );
            }
            "--with" => {
                let kv = it.next().unwrap_or_default();
                let (k, v) = kv.split_once('=').expect("--with KEY=VALUE");
                with.push((k.to_string(), v.to_string()));
            }
            // `cargo bench` passes `--bench`.
            _ => {}
        }
    }
    let mut rows: Vec<(String, Config)> = vec![
        ("paper".into(), Config::Paper),
        ("before".into(), Config::Before),
        ("prev".into(), Config::Prev),
        ("lookahead".into(), Config::Lookahead),
        ("pass".into(), Config::Pass),
        ("default".into(), Config::Default),
        ("s26".into(), Config::S26),
    ];
    if !with.is_empty() {
        rows.push(("custom".into(), Config::Custom(with.clone())));
    }
    for (k, c) in customs.iter().enumerate() {
        rows.push((format!("custom{}", k + 1), Config::Custom(c.clone())));
    }
    if !configs.is_empty() {
        rows.retain(|(r, _)| configs.iter().any(|c| c == r));
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let file_curves = |name: &str| Curves::load(root.join(name)).expect("curves");
    let inline = |name: &str, json: &str| Curves::from_json_str(name, json).expect("curves");
    // Per scene, the particle counts its grammar asked for before the
    // curve-coverage work (Calder's 100 -> 15; the vine's 400 -> 60): the
    // `paper` and `before` rows run with them, as they ran then.
    // The `prev` and `lookahead` rows run with the counts of their time
    // (the vine's 100 -> 15; `None`: the grammar's own).
    let scenes: Vec<Scene> = vec![
        (
            "calder_tree",
            "calder_tree.grm",
            file_curves("calder_tree.curves.json"),
            (100, 15),
            None,
        ),
        (
            "calder_s_curve",
            "calder_tree.grm",
            inline("s_curve", S_CURVE),
            (100, 15),
            None,
        ),
        (
            "calder_fork4",
            "calder_tree.grm",
            inline("fork4", FORK),
            (100, 15),
            None,
        ),
        (
            "calder_out_of_plane",
            "calder_tree.grm",
            inline("out_of_plane", OUT_OF_PLANE),
            (100, 15),
            None,
        ),
        (
            "vine_wall",
            "vine_wall.grm",
            file_curves("vine_wall.curves.json"),
            (400, 60),
            Some((100, 15)),
        ),
    ];
    let load = || {
        std::fs::read_to_string("/proc/loadavg")
            .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
            .unwrap_or_default()
    };
    println!(
        "Curve coverage, {seeds} seeds, 1 thread, system schedules; load average {}",
        load()
    );
    if !with.is_empty() {
        println!("custom: the defaults with {with:?}");
    }
    println!(
        "{:<20} {:<9} {:>9} {:>8} {:>11} {:>12} {:>6} | median coverage per curve",
        "scene", "config", "median ms", "mean cpu", "median cost", "all >= 80%", "rounds"
    );
    for (name, file, curves, old_particles, then_particles) in &scenes {
        if !only.is_empty() && !only.iter().any(|o| o == name) {
            continue;
        }
        let path = root.join(file);
        let text = std::fs::read_to_string(&path).expect("example");
        let (_s, checked) = grm_sema::check_text(path.to_str().expect("path"), &text);
        assert!(!checked.has_errors(), "{file} has errors");
        let program = checked.program;
        let system = program.default_system().expect("system");
        let compiled =
            grm_compile::compile(&program, system, &program.default_params()).expect("compiles");
        let sampler = Sampler::new(
            system,
            &compiled,
            curves,
            Objective::Curves,
            ExpectedOptions::default(),
        )
        .expect("sampler");
        // `prev`: each bone covers eq. 1's curve alone, as then.
        let prev_sampler = Sampler::new(
            system,
            &compiled,
            curves,
            Objective::Curves,
            ExpectedOptions::default(),
        )
        .expect("sampler")
        .with_cover_others(false);
        let n = curves.curves().len();
        // Seeds outer, configurations inner: the rows' times are taken
        // interleaved, so a load that comes and goes weighs on each alike.
        let mut stats: Vec<Row> = rows.iter().map(|_| Row::new(n)).collect();
        for seed in 0..seeds {
            for ((label, config), st) in rows.iter().zip(&mut stats) {
                let base = SampleOptions {
                    seed,
                    schedule: Schedule::from_settings(&compiled.settings),
                    threads: 1,
                    ..SampleOptions::default()
                };
                let mut old = base.clone();
                (old.schedule.particles_start, old.schedule.particles_end) = *old_particles;
                let mut then = base.clone();
                if let Some(counts) = then_particles {
                    (then.schedule.particles_start, then.schedule.particles_end) = *counts;
                }
                let opts = match config {
                    Config::Paper => paper(old),
                    Config::Before => before(old),
                    Config::Prev => prev(then),
                    Config::Lookahead => lookahead(then),
                    Config::Pass => pass(base),
                    Config::S26 => s26(base),
                    Config::Custom(with) => custom(base, with),
                    Config::Default => base,
                };
                let others_off = match config {
                    Config::Prev => true,
                    Config::Custom(with) => with.iter().any(|(k, v)| k == "others" && v == "0"),
                    _ => false,
                };
                let s = if others_off { &prev_sampler } else { &sampler };
                let (t, c) = (Instant::now(), cpu_ms());
                let r = s.sample(&opts).expect("samples");
                st.times.push(t.elapsed().as_secs_f64() * 1e3);
                st.cpus.push(cpu_ms() - c);
                st.rounds += r.refinements;
                let m = r.best().expect("a model");
                st.costs.push(m.cost.total());
                let bones: Vec<(glam::Vec3, glam::Vec3)> = m
                    .bone_list()
                    .into_iter()
                    .map(|(a, b)| (glam::Vec3::from_array(a), glam::Vec3::from_array(b)))
                    .collect();
                let cov = coverage(curves, &bones, &CoverageOptions::default());
                if detail {
                    // Per seed: each curve's coverage, the bones (how many,
                    // how long in all) and, for a model that misses a curve,
                    // the `--stats` report's verdict lines.
                    let length: f32 = bones.iter().map(|(a, b)| a.distance(*b)).sum();
                    let per: Vec<String> = cov
                        .iter()
                        .map(|c| format!("{:.0}%", 100.0 * c.fraction))
                        .collect();
                    println!(
                        "  seed {seed:>3} {:<9} cost {:>9.1} bones {:>3} ({length:.2} long) rounds {} | {}",
                        label,
                        m.cost.total(),
                        bones.len(),
                        r.refinements,
                        per.join(" ")
                    );
                    if cov.iter().any(|c| c.fraction < FOLLOWED) {
                        for line in describe_coverage(curves, &bones, &CoverageOptions::default())
                            .iter()
                            .filter(|l| l.contains("too few"))
                        {
                            println!("    {}", line.trim());
                        }
                    }
                }
                if cov.iter().all(|c| c.fraction >= FOLLOWED) {
                    st.all80 += 1;
                }
                for (k, c) in cov.iter().enumerate() {
                    st.per_curve[k].push(c.fraction);
                }
            }
        }
        for ((label, _), st) in rows.iter().zip(&stats) {
            let curve_text: Vec<String> = curves
                .curves()
                .iter()
                .zip(&st.per_curve)
                .enumerate()
                .map(|(k, (c, v))| {
                    let name = c.name.clone().unwrap_or_else(|| format!("curve {k}"));
                    if v.iter().all(|&x| x == 0.0) {
                        format!("{name} unreached")
                    } else {
                        format!("{name} {:.0}%", 100.0 * pct(v, 50.0))
                    }
                })
                .collect();
            println!(
                "{:<20} {:<9} {:>9.1} {:>8.1} {:>11.1} {:>11.0}% {:>6.2} | {}",
                name,
                label,
                pct(&st.times, 50.0),
                st.cpus.iter().sum::<f64>() / st.cpus.len().max(1) as f64,
                pct(&st.costs, 50.0),
                100.0 * f64::from(st.all80) / f64::from(seeds.max(1)),
                f64::from(st.rounds) / f64::from(seeds.max(1)),
                curve_text.join(", ")
            );
        }
    }
    println!("load average at the end {}", load());
}
