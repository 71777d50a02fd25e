//! `grmc sample FILE --curves CURVES.json`: grow a sample-mode system with
//! the guided sampler (grm-sample, through `grm_grow::sample`, the road the
//! preview takes too) and print the model's cost by term, its bone count
//! and the time; optionally export the model(s) and the tree.

use std::path::{Path, PathBuf};
use std::time::Duration;

use grm_diag::Diagnostic;
use grm_guide::{Curves, VolumeOptions};
use grm_sample::{FinishLimits, Objective, SampleError, SampleOptions, Schedule};

use crate::Outcome;
use crate::derive::{emit, export_model, load_checked};

/// What the search minimizes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum CostKind {
    /// Calder's guiding-curve cost (distance, alignment, utilization, density).
    Curves,
    /// The volume-matching baseline: fill tubes around the curves.
    Volume,
}

#[derive(clap::Args, Debug)]
pub struct SampleArgs {
    /// The .grm file.
    pub file: PathBuf,
    /// The guiding curves (default: FILE's name with `.curves.json`).
    #[arg(long)]
    pub curves: Option<PathBuf>,
    /// The system to sample (default: the file's first system).
    #[arg(long)]
    pub system: Option<String>,
    /// Random seed (default: the system's `seed` setting).
    #[arg(long)]
    pub seed: Option<u32>,
    /// Generations of the search (default: the system's `generations`;
    /// 1 to 100,000).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=i64::from(grm_sema::MAX_GENERATIONS)))]
    pub generations: Option<u32>,
    /// Particles, ramped linearly from A to B over the generations (`A..B`,
    /// or one number for a constant count; default: the system's
    /// `particles_start..particles_end`).
    #[arg(long, value_name = "A..B")]
    pub particles: Option<String>,
    /// Stop the search after this many milliseconds of wall time (then wrap
    /// up and finish; a refinement round the budget would cut short is
    /// dropped). The one non-deterministic option.
    #[arg(long, value_name = "MS")]
    pub budget_ms: Option<u64>,
    /// Worker threads: 1 runs on the main thread, 0 uses all cores (at
    /// most 1024). The model does not depend on it.
    #[arg(long, default_value_t = 1, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// Report and export the best K distinct models (K >= 1; fewer when
    /// the search ends with fewer distinct ones).
    #[arg(long, default_value_t = 1, value_name = "K", value_parser = at_least_one)]
    pub best: usize,
    /// What to minimize: the curve cost or the volume baseline.
    #[arg(long, value_enum, default_value_t = CostKind::Curves)]
    pub cost: CostKind,
    /// Weight of the volume cost (likelihood exp(-weight * cost); a
    /// finite number > 0).
    #[arg(long, default_value_t = 20000.0, value_parser = finite_positive)]
    pub volume_weight: f64,
    /// Turn the expected-direction heuristic off.
    #[arg(long)]
    pub no_heuristic: bool,
    /// HEURISTICSCALE at generation 0 (default 0.013; a finite number >= 0).
    #[arg(long, value_parser = finite_non_negative)]
    pub heuristic_scale: Option<f64>,
    /// Generation by which the heuristic scale has ramped to 0 (default:
    /// 40% of the generations).
    #[arg(long)]
    pub heuristic_until: Option<u32>,
    /// Likelihood exp(-cost / T); 1 is Calder's (a number > 0; `inf`
    /// weighs every particle alike).
    #[arg(long, default_value_t = 1.0, value_parser = positive)]
    pub temperature: f64,
    /// Adaptive tempering: scale each generation's incremental log-weights
    /// down just enough to keep the effective sample size at this fraction
    /// of the particles; 0 turns it off (Calder's untempered weights).
    #[arg(long, value_name = "F", default_value_t = grm_sample::DEFAULT_ESS_TARGET, value_parser = fraction)]
    pub ess_target: f64,
    /// Candidate expansions per bone-making expansion, one kept in
    /// proportion to exp(-cost of its bones / T); 1: the grammar's own
    /// draws (Calder's proposal); at most 100,000.
    #[arg(long, value_name = "K", default_value_t = grm_sample::DEFAULT_CANDIDATES, value_parser = clap::value_parser!(u32).range(1..=i64::from(grm_sema::MAX_PARTICLES)))]
    pub candidates: u32,
    /// Expansion order: of N open symbols drawn at random, expand the one
    /// whose position promises the cheapest next bone along the curves; 1
    /// is Calder's uniform order (docs/sampling.md 4.3).
    #[arg(long, value_name = "N", default_value_t = grm_sample::DEFAULT_ORDER, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub order: u32,
    /// Weight W of the coverage term the search optimises besides the
    /// curve cost (rewarding the least-covered curve most); 0 searches by
    /// the paper's cost alone (docs/sampling.md 4.3). `--order 1 --cover 0
    /// --candidates 1 --ess-target 0` is Calder's method.
    #[arg(long, value_name = "W", default_value_t = grm_sample::DEFAULT_COVER, value_parser = finite_non_negative)]
    pub cover: f64,
    /// Expansions per particle step: a step expands open symbols until one
    /// adds a bone, at most this many (1: one symbol per step).
    #[arg(long, default_value_t = 1000, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_step_expansions: u32,
    /// Override a meta-parameter: `NAME=VALUE`. Repeatable.
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
    /// Print each generation's particles, effective sample size,
    /// heuristic scale, best cost and the memory the search holds.
    #[arg(long)]
    pub stats: bool,
    /// Stop with an error (R0310) after a generation that leaves the
    /// search holding more than this many MiB (default 2048).
    #[arg(long, value_name = "MIB", value_parser = clap::value_parser!(u64).range(1..=(u64::MAX >> 20)))]
    pub max_memory: Option<u64>,
    /// Build the best model and write it (format by extension: .glb .obj
    /// .ply .svg, or .png for a picture of it); with --best K the others
    /// go to NAME-2.EXT, ...
    #[arg(short = 'o', long = "output")]
    pub output: Option<PathBuf>,
    /// With -o: write a model per generation, 0 to G-1, as NAME-K.EXT (K
    /// zero-padded; at most 1,000 files): what the search returns when
    /// stopped after generation K (its particles wrapped up, the best
    /// built); the last is the result. Pictures share one view and
    /// framing. Not with --best.
    #[arg(long, requires = "output")]
    pub frames: bool,
    /// Report and write the model the search returns when stopped after
    /// generation K (0-based; the preview's generation scrubber) instead
    /// of the result; past the last generation run, the result. Costs one
    /// frame. Not with --frames or --best.
    #[arg(long, value_name = "K", conflicts_with_all = ["frames", "best"])]
    pub generation: Option<u32>,
    /// Write the best model's derivation tree as JSON: every expansion,
    /// its identity key, parent, symbol, the production applied (with its
    /// source range), its modules, bones and instances (docs/engine.md,
    /// "Identity").
    #[arg(long, value_name = "FILE.json")]
    pub tree: Option<PathBuf>,
    #[command(flatten)]
    pub image: crate::derive::ImageArgs,
    #[command(flatten)]
    pub edits: crate::derive::EditsArgs,
}

/// A number > 0 (`inf` included), for `--temperature`.
fn positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x > 0.0 => Ok(x),
        _ => Err(format!("`{s}` is not a number > 0")),
    }
}

/// A finite number > 0 (within 32-bit float), for `--volume-weight`.
fn finite_positive(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x > 0.0 && x.is_finite() && x <= f64::from(f32::MAX) => Ok(x),
        _ => Err(format!("`{s}` is not a finite number > 0")),
    }
}

/// A whole number >= 1, for `--best`.
fn at_least_one(s: &str) -> Result<usize, String> {
    match s.trim().parse::<usize>() {
        Ok(k) if k >= 1 => Ok(k),
        _ => Err(format!("`{s}` is not a whole number >= 1")),
    }
}

/// A number from 0 to 1, for `--ess-target`.
fn fraction(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if (0.0..=1.0).contains(&x) => Ok(x),
        _ => Err(format!("`{s}` is not a number from 0 to 1")),
    }
}

/// A finite number >= 0, for `--heuristic-scale`.
fn finite_non_negative(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x >= 0.0 => Ok(x),
        _ => Err(format!("`{s}` is not a finite number >= 0")),
    }
}

/// `A..B` or `N`.
fn parse_particles(s: &str) -> Result<(u32, u32), String> {
    let num = |t: &str| {
        t.trim()
            .parse::<u32>()
            .ok()
            .filter(|&n| n > 0 && n <= grm_sema::MAX_PARTICLES)
            .ok_or_else(|| {
                format!(
                    "`--particles {s}`: `{t}` is not a whole number from 1 to {}",
                    grm_sema::MAX_PARTICLES
                )
            })
    };
    match s.split_once("..") {
        Some((a, b)) => Ok((num(a)?, num(b)?)),
        None => {
            let n = num(s)?;
            Ok((n, n))
        }
    }
}

/// `path` for model `k` (0-based): the path itself, then NAME-2.EXT, ...
fn nth_path(path: &Path, k: usize) -> PathBuf {
    if k == 0 {
        return path.to_path_buf();
    }
    let stem = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let name = match path.extension() {
        Some(e) => format!("{stem}-{}.{}", k + 1, e.to_string_lossy()),
        None => format!("{stem}-{}", k + 1),
    };
    path.with_file_name(name)
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn report(loaded: &crate::derive::Loaded, e: &SampleError) -> Outcome {
    let c = &loaded.compiled;
    report_with(loaded, e, e.to_diagnostic(c.file, c.span))
}

/// Print `d`, the diagnostic of `e`, and exit as `e` asks.
fn report_with(loaded: &crate::derive::Loaded, e: &SampleError, d: Diagnostic) -> Outcome {
    emit(&loaded.sources, &d);
    match e {
        // (grmc never cancels a run; a cancelled one would not be the input's fault.)
        SampleError::ThreadPool(_) | SampleError::Options(_) | SampleError::Cancelled => {
            Outcome::Usage
        }
        _ => Outcome::InputErrors,
    }
}

/// A frame that cannot be finished: what a search stopped after
/// generation `g` ends with (the search itself went on; its result is the
/// one a run without frames reports).
fn report_frame(loaded: &crate::derive::Loaded, g: u32, e: &SampleError) -> Outcome {
    let c = &loaded.compiled;
    let d = e.to_diagnostic(c.file, c.span).with_note(format!(
        "in the model of generation {g}: a search stopped after it ends with this error (the full search finished; run without --frames or --generation for its result)"
    ));
    report_with(loaded, e, d)
}

pub fn run(args: SampleArgs) -> Outcome {
    let particles = match args.particles.as_deref().map(parse_particles) {
        Some(Err(m)) => {
            eprintln!("error: {m}");
            return Outcome::Usage;
        }
        Some(Ok(p)) => Some(p),
        None => None,
    };
    let curves_path = args.curves.clone().unwrap_or_else(|| {
        let stem = args
            .file
            .file_stem()
            .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        args.file.with_file_name(format!("{stem}.curves.json"))
    });
    let mut checked = match load_checked(&args.file, args.system.as_deref(), &args.params) {
        Ok(c) => c,
        Err(o) => return o,
    };
    // The persistent edits (docs/edits.md, "Sample mode"), read before
    // compiling; a derive system is refused below whatever its edits.
    let edits = if checked.system().mode == grm_sema::Mode::Sample {
        match crate::shape::edits_of(&args.edits, &mut checked) {
            Ok(e) => e,
            Err(o) => return o,
        }
    } else {
        None
    };
    let loaded = match checked.compile() {
        Ok(l) => l,
        Err(o) => return o,
    };
    // Before the curves: a derive system needs none, so "cannot read the
    // curves" would send the user the wrong way.
    if loaded.system().mode != grm_sema::Mode::Sample {
        let e = SampleError::NotSampleSystem {
            system: loaded.system().name.clone(),
        };
        return report(&loaded, &e);
    }
    if let Some(o) =
        crate::derive::check_output_format(&loaded, args.output.as_deref(), &args.image).or_else(
            || {
                args.tree
                    .as_deref()
                    .and_then(|p| crate::tree::check_path(&loaded, p))
            },
        )
    {
        return o;
    }
    let curves = match Curves::load(&curves_path) {
        Ok(c) => c,
        Err(e) => {
            let c = &loaded.compiled;
            emit(&loaded.sources, &e.to_diagnostic(c.file, c.span));
            return match e.kind {
                grm_guide::CurvesErrorKind::Io(_) => Outcome::Usage,
                _ => Outcome::InputErrors,
            };
        }
    };
    let c = &loaded.compiled;
    let mut schedule = Schedule::from_settings(&c.settings);
    if let Some(g) = args.generations {
        schedule = schedule.with_generations(g);
    }
    if args.frames {
        if args.best > 1 {
            eprintln!(
                "error: --frames writes NAME-K.EXT per generation and --best K writes NAME-K.EXT per model: use one of them"
            );
            return Outcome::Usage;
        }
        if u64::from(schedule.generations) > crate::derive::MAX_FRAMES {
            eprintln!(
                "error: --frames writes a file per generation, {}: at most {} files (run fewer generations with --generations)",
                schedule.generations,
                crate::derive::MAX_FRAMES
            );
            return Outcome::Usage;
        }
    }
    if let Some((a, b)) = particles {
        schedule.particles_start = a;
        schedule.particles_end = b;
    }
    if let Some(h) = args.heuristic_scale {
        schedule.heuristic_scale = h;
    }
    if let Some(u) = args.heuristic_until {
        schedule.heuristic_until = u;
    }
    let objective = match args.cost {
        CostKind::Curves => Objective::Curves,
        CostKind::Volume => Objective::Volume {
            options: VolumeOptions::default(),
            weight: args.volume_weight,
        },
    };
    let heuristic = !args.no_heuristic && args.cost == CostKind::Curves;
    // Options grm-sample adds take their defaults until a flag sets them.
    #[allow(clippy::needless_update)]
    let opts = SampleOptions {
        seed: args.seed.unwrap_or(c.settings.seed),
        schedule,
        heuristic,
        temperature: args.temperature,
        ess_target: args.ess_target,
        candidates: args.candidates,
        guide: grm_sample::Guide {
            order: args.order,
            cover: args.cover,
        },
        threads: args.threads,
        budget: args.budget_ms.map(Duration::from_millis),
        best: args.best,
        max_expansions_per_step: args.max_step_expansions,
        limits: FinishLimits::default(),
        max_bytes: args
            .max_memory
            .map_or(grm_sample::DEFAULT_MAX_BYTES, |m| m << 20),
        cancel: None,
        frames: args.frames,
        ..SampleOptions::default()
    };
    let request = grm_grow::sample::SampleRequest {
        objective,
        // --generation: the one frame asked for, not one per generation.
        generation: args.generation,
        tree: args.tree.is_some(),
        edits: edits.as_ref().map(|(f, _)| f.edits.as_slice()),
        ..grm_grow::sample::SampleRequest::new(&curves, opts.clone())
    };
    let sampled = match grm_grow::sample::sample(loaded.system(), c, &request) {
        Ok(r) => r,
        Err(e) => {
            // What ran before a memory stop: the table shows its growth.
            if args.stats
                && let SampleError::MemoryLimit { generations, .. } = &e
            {
                print_generations(generations);
            }
            if args.frames && matches!(e, SampleError::MemoryLimit { .. }) {
                // The figure counts the frames kept: say so, or "for its
                // particles" sends the user after the wrong setting.
                let d = e.to_diagnostic(c.file, c.span).with_note(
                    "with --frames the models of the generations run so far count too (--stats shows the figure)",
                );
                return report_with(&loaded, &e, d);
            }
            return report(&loaded, &e);
        }
    };
    let result = &sampled.result;
    // What became of the edits (docs/edits.md, "Classes"), classified
    // against the first model reported.
    let edit_problems = edits.as_ref().is_some_and(|(_, problems)| *problems);
    if let Some(reports) = &sampled.edits {
        crate::edits::print_replayed(&c.name, reports);
    }
    // Problems in the edits file (printed above, R09xx) fail the run once
    // it has written what it was asked for, as `grmc derive` does.
    let done = |o: Outcome| crate::edits::after_edit_problems(o, edit_problems);
    let heuristic_text =
        if heuristic && schedule.heuristic_until > 0 && schedule.heuristic_scale > 0.0 {
            format!(
                "heuristic {} -> 0 by generation {}",
                schedule.heuristic_scale, schedule.heuristic_until
            )
        } else {
            "no heuristic".to_string()
        };
    // Candidates and tempering need the curve cost at a finite temperature.
    let guided = args.cost == CostKind::Curves && opts.temperature.is_finite();
    let k = if guided { opts.candidates } else { 1 };
    // At an infinite temperature every particle weighs the same: there is
    // nothing to temper. Either objective is tempered otherwise.
    let weights_text = if opts.ess_target > 0.0 && opts.temperature.is_finite() {
        format!(
            ", {}, ESS >= {} N",
            crate::count(k, "candidate"),
            opts.ess_target
        )
    } else {
        format!(", {}, untempered", crate::count(k, "candidate"))
    };
    outln!(
        "{}: seed {}, {}{}, particles {} -> {}, {heuristic_text}{weights_text}",
        c.name,
        opts.seed,
        crate::count(result.generations.len() as u64, "generation"),
        if result.stopped_early {
            format!(" (of {}; budget reached)", schedule.generations)
        } else {
            String::new()
        },
        schedule.particles_start,
        schedule.particles_end,
    );
    if result.refinements > 0 {
        // docs/sampling.md 4.5: the search's best left a curve under 80%.
        outln!(
            "refined: {} grown again from generation 1 (the search's best model left a curve under 80%)",
            crate::count(u64::from(result.refinements), "round")
        );
    }
    if args.stats {
        print_generations(&result.generations);
    }
    // --generation: that generation's model stands for the result.
    let reported: &[grm_sample::SampledModel] = match sampled.shown() {
        grm_grow::sample::Shown::Models(m) => m,
        grm_grow::sample::Shown::Frame(g, m) => {
            outln!(
                "generation {g} of 0..{} (the model the search returns when stopped after it):",
                result.generations.len().saturating_sub(1)
            );
            std::slice::from_ref(m)
        }
        grm_grow::sample::Shown::FrameFailed(g, e) => return report_frame(&loaded, g, e),
        grm_grow::sample::Shown::NoFrame(k) => {
            eprintln!("error: the sampler kept no model of generation {k}");
            return Outcome::InputErrors;
        }
    };
    for (k, m) in reported.iter().enumerate() {
        let b = &m.cost;
        let (_, skeleton, wrapup, geometry) = m.tree.counts();
        let rank = if reported.len() > 1 {
            format!("model {}: ", k + 1)
        } else {
            String::new()
        };
        outln!(
            "{rank}cost {:.3} = distance {:.3} + alignment {:.3} + utilization {:.3} + density {:.3}",
            b.total(),
            b.distance,
            b.alignment,
            b.utilization,
            b.density
        );
        if let Some(v) = m.volume {
            outln!(
                "{rank}volume cost {:.4} = outside {:.4} + uncovered {:.4} (weight {})",
                v.total(),
                v.outside_fraction,
                v.uncovered_fraction,
                args.volume_weight
            );
        }
        outln!(
            "{rank}bones {} skeleton, {} in all; expansions: {skeleton} skeleton, {wrapup} wrap-up, {geometry} geometry",
            m.skeleton_bones,
            m.interpretation.bones.len()
        );
        if args.stats {
            print_coverage(&curves, m, &rank);
        }
    }
    let ess = result.ess();
    let mean = ess.iter().sum::<f64>() / ess.len().max(1) as f64;
    let min = ess.iter().copied().fold(f64::INFINITY, f64::min);
    let min_share = result
        .generations
        .iter()
        .map(|g| g.ess / g.particles.max(1) as f64)
        .fold(f64::INFINITY, f64::min);
    outln!(
        "time {:.2} ms (expected directions {:.2} ms, sampling {:.2} ms); ESS per generation: mean {mean:.2}, min {min:.2} ({:.0}% of the particles)",
        ms(sampled.prepare + result.elapsed),
        ms(sampled.expected_time),
        ms(result.elapsed),
        100.0 * min_share,
    );
    if let (Some(path), Some(m), Some(tree)) = (&args.tree, reported.first(), &sampled.tree) {
        let o = crate::tree::write(&loaded, tree, Some(&m.interpretation), path);
        if o != Outcome::Ok {
            return o;
        }
    }
    if let Some(path) = &args.output
        && args.frames
    {
        // Every frame or none: a sequence with holes would be numbered
        // wrong, and the framing of pictures needs them all.
        let failed: Vec<(u32, &SampleError)> = result
            .frames
            .iter()
            .filter_map(|(g, f)| f.as_ref().err().map(|e| (*g, e)))
            .collect();
        if let Some(&(g, e)) = failed.first() {
            let o = report_frame(&loaded, g, e);
            let mut which: Vec<String> =
                failed.iter().take(10).map(|(g, _)| g.to_string()).collect();
            if failed.len() > which.len() {
                which.push("...".into());
            }
            eprintln!(
                "error: --frames wrote nothing: {} of {} frames cannot be finished (generations {}); --generation K writes one that can",
                failed.len(),
                result.frames.len(),
                which.join(", ")
            );
            return o;
        }
        let mut models = Vec::with_capacity(result.frames.len());
        // Every frame's model is held until all are written: each is
        // built within what the ones before it leave of the limit.
        let mut options = crate::derive::model_options(args.max_memory, path, &args.image);
        for m in result.frames.iter().filter_map(|(_, f)| f.as_ref().ok()) {
            match m.build(&loaded.program, &options) {
                Ok(model) => {
                    options.held = options.held.saturating_add(model.heap_bytes());
                    models.push(model);
                }
                Err(e) => {
                    emit(
                        &loaded.sources,
                        &e.to_diagnostic(&loaded.program, c.file, c.span),
                    );
                    return Outcome::InputErrors;
                }
            }
        }
        return done(crate::derive::export_frame_models(
            &loaded,
            &models,
            path,
            &args.image,
        ));
    }
    if let Some(path) = &args.output {
        for (k, m) in reported.iter().enumerate() {
            let options = crate::derive::model_options(args.max_memory, path, &args.image);
            let model = match m.build(&loaded.program, &options) {
                Ok(model) => model,
                Err(e) => {
                    emit(
                        &loaded.sources,
                        &e.to_diagnostic(&loaded.program, c.file, c.span),
                    );
                    return Outcome::InputErrors;
                }
            };
            let o = export_model(&loaded, &model, &nth_path(path, k), &args.image);
            if o != Outcome::Ok {
                return o;
            }
        }
    }
    done(Outcome::Ok)
}

/// The `--stats` coverage of each curve by `m`'s bones (`grm_guide::describe_coverage`).
fn print_coverage(curves: &Curves, m: &grm_sample::SampledModel, rank: &str) {
    let bones: Vec<(glam::Vec3, glam::Vec3)> = m
        .interpretation
        .bones
        .iter()
        .map(|b| (b.base, b.tip))
        .collect();
    let options = grm_guide::CoverageOptions::default();
    for line in grm_guide::describe_coverage(curves, &bones, &options) {
        outln!("{rank}{line}");
    }
}

/// The `--stats` table: a row per generation.
fn print_generations(generations: &[grm_sample::GenerationStats]) {
    outln!(
        "{:>10} {:>9} {:>9} {:>8} {:>8} {:>9} {:>10} {:>12} {:>8} {:>9}",
        "generation",
        "particles",
        "expanding",
        "ESS",
        "beta",
        "survivors",
        "heuristic",
        "best cost",
        "bones",
        "MiB"
    );
    for g in generations {
        outln!(
            "{:>10} {:>9} {:>9} {:>8.2} {:>8.5} {:>9} {:>10.5} {:>12.1} {:>8.1} {:>9.2}",
            g.generation,
            g.particles,
            g.expanding,
            g.ess,
            g.beta,
            g.survivors,
            g.heuristic_scale,
            g.best_objective,
            g.mean_bones,
            g.memory_bytes as f64 / f64::from(1u32 << 20)
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_arguments() {
        assert_eq!(positive("0.5"), Ok(0.5));
        assert_eq!(positive("inf"), Ok(f64::INFINITY));
        for bad in ["0", "-1", "nan", "x"] {
            assert!(positive(bad).is_err(), "{bad}");
        }
        assert_eq!(fraction("0"), Ok(0.0));
        assert_eq!(fraction("1"), Ok(1.0));
        for bad in ["1.5", "-0.1", "nan", "inf"] {
            assert!(fraction(bad).is_err(), "{bad}");
        }
        assert_eq!(finite_non_negative("0"), Ok(0.0));
        for bad in ["inf", "nan", "-1"] {
            assert!(finite_non_negative(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn particles_argument() {
        assert_eq!(parse_particles("100..15"), Ok((100, 15)));
        assert_eq!(parse_particles("50"), Ok((50, 50)));
        assert!(parse_particles("0..5").is_err());
        assert!(parse_particles("a..5").is_err());
    }

    #[test]
    fn best_k_paths() {
        let p = Path::new("out/tree.glb");
        assert_eq!(nth_path(p, 0), PathBuf::from("out/tree.glb"));
        assert_eq!(nth_path(p, 2), PathBuf::from("out/tree-3.glb"));
    }
}
