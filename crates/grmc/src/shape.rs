//! `grmc derive FILE` of a shape system (`mode = shape`): grown on the
//! one road (`grm_grow::shape`: lower, derive, build the model), the tree
//! written with `--tree` (`grm_grow::shape::json`), the model with `-o`.
//! Shape systems have no iterations, string or GPU path: those flags are
//! refused (exit 2); `--max-modules` bounds the tree's nodes.

use std::path::Path;
use std::time::Instant;

use grm_grow::shape::{ShapeGrowError, ShapeOptions};

use crate::Outcome;
use crate::derive::{Checked, DeriveArgs, check_output_at, emit, export_model_at, model_options};

/// Grow a checked shape system as `args` say.
pub fn run(args: &DeriveArgs, mut checked: Checked) -> Outcome {
    let edits = match edits_of(&args.edits, &mut checked) {
        Ok(e) => e,
        Err(o) => return o,
    };
    let sys = checked.system();
    let refused = [
        (args.iterations.is_some(), "-n/--iterations"),
        (args.gpu, "--gpu"),
        (args.frames, "--frames"),
        (args.print, "--print"),
    ];
    if let Some((_, flag)) = refused.iter().find(|(given, _)| *given) {
        eprintln!(
            "error: {flag} does not apply to system `{}`: it is a shape system (mode = shape), grown whole from its lot",
            sys.name
        );
        return Outcome::Usage;
    }
    let (file, span) = (sys.file, sys.loc.span);
    if let Some(o) = check_output_at(
        &checked.sources,
        file,
        span,
        args.output.as_deref(),
        &args.image,
    ) {
        return o;
    }
    if let Some(o) = args
        .tree
        .as_deref()
        .and_then(|p| crate::tree::check_path_at(&checked.sources, file, span, p))
    {
        return o;
    }
    let mut options = ShapeOptions {
        seed: args.seed,
        threads: args.threads,
        ..ShapeOptions::default()
    };
    if let Some(m) = args.max_modules {
        options.limits.max_nodes = usize::try_from(m).unwrap_or(usize::MAX);
    }
    let fail = |e: &ShapeGrowError| {
        emit(
            &checked.sources,
            &e.to_diagnostic(&checked.program, file, span),
        );
        match e {
            ShapeGrowError::Lower(grm_grow::shape::LowerError::NotShape { .. }) => Outcome::Usage,
            _ => Outcome::InputErrors,
        }
    };
    let start = Instant::now();
    let lowered = match grm_grow::shape::lower(&checked.program, sys, &checked.values) {
        Ok(l) => l,
        Err(e) => return fail(&e.into()),
    };
    let seed = options.seed.unwrap_or(lowered.seed);
    let plan = edits
        .as_ref()
        .map(|(f, _)| grm_grow::shape::edit_plan(&lowered, f));
    let tree = match grm_grow::shape::derive_with_edits(&lowered, seed, &options, plan.as_ref()) {
        Ok(t) => t,
        Err(e) => return fail(&e),
    };
    let elapsed = start.elapsed();
    // What became of the edits (docs/edits.md, "Classes").
    let mut edit_problems = false;
    if let Some((f, problems)) = &edits {
        let mine: Vec<&grm_edits::Edit> = f.of_system(&sys.name).collect();
        let reports = grm_grow::shape::edits::classify(
            &checked.program,
            &lowered,
            &tree,
            mine.iter().copied(),
        );
        crate::edits::print_replayed(&sys.name, &reports);
        edit_problems = *problems;
    }
    let done = |o: Outcome| crate::edits::after_edit_problems(o, edit_problems);
    let shapes = tree.nodes().iter().filter(|n| n.is_shape()).count();
    let leaves = tree.leaves().count();
    eprintln!(
        "{}: {} ({} terminal, {} nodes in all) in {:.3} ms",
        sys.name,
        crate::count(shapes as u64, "shape"),
        leaves,
        tree.len(),
        elapsed.as_secs_f64() * 1e3
    );
    if args.stats {
        let depth = tree.nodes().iter().map(|n| n.depth).max().unwrap_or(0);
        let inserts = tree.inserts().count();
        outln!(
            "{:>10} {:>10} {:>10} {:>8} {:>8} {:>10}",
            "nodes",
            "shapes",
            "terminal",
            "inserts",
            "depth",
            "ms"
        );
        outln!(
            "{:>10} {:>10} {:>10} {:>8} {:>8} {:>10.3}",
            tree.len(),
            shapes,
            leaves,
            inserts,
            depth,
            elapsed.as_secs_f64() * 1e3
        );
    }
    if let Some(path) = &args.tree {
        match grm_grow::shape::json::write(path, &lowered, &tree, seed, file, &checked.sources) {
            Ok(()) => eprintln!("wrote {} ({} nodes)", path.display(), tree.len()),
            Err(e) => {
                emit(&checked.sources, &e.to_diagnostic(file, span));
                return Outcome::Usage;
            }
        }
    }
    if let Some(path) = &args.output {
        let dir = Path::new(checked.sources.get(file).path.as_str())
            .parent()
            .map(Path::to_path_buf);
        let build = model_options(args.max_memory, path, &args.image);
        let model = match grm_grow::shape::model(
            &checked.program,
            &checked.values,
            &lowered,
            &tree,
            dir.as_deref(),
            &build,
        ) {
            Ok(m) => m,
            Err(e) => return fail(&e),
        };
        drop(tree);
        return done(export_model_at(
            &checked.sources,
            file,
            span,
            &model,
            path,
            &args.image,
            None,
        ));
    }
    done(Outcome::Ok)
}

/// The edits file to replay (`--edits`, else NAME.edits.json beside the
/// grammar; none with `--no-edits` or when the default file is missing),
/// its problems printed (coded R09xx, in the file) and whether it had any.
/// `Err`: a named file that cannot be read (exit 2). Derive mode
/// (`crate::derive::run`) and sample mode (`crate::sample::run`) read
/// them here too.
pub(crate) fn edits_of(
    args: &crate::derive::EditsArgs,
    checked: &mut Checked,
) -> Result<Option<(grm_edits::EditsFile, bool)>, Outcome> {
    if args.no_edits {
        return Ok(None);
    }
    let sys = checked.system();
    let (file, span) = (sys.file, sys.loc.span);
    let (path, named) = match &args.edits {
        Some(p) => (p.clone(), true),
        None => {
            let grammar = Path::new(checked.sources.get(file).path.as_str());
            (grm_edits::edits_path(grammar), false)
        }
    };
    let text = match grm_edits::read(&path) {
        Ok(t) => t,
        Err(e) if e.is_not_found() && !named => return Ok(None),
        Err(e) => {
            emit(&checked.sources, &e.to_diagnostic_at(file, span));
            return Err(Outcome::Usage);
        }
    };
    let id = checked
        .sources
        .add(path.to_string_lossy().replace('\\', "/"), text.clone());
    let parsed = grm_edits::parse(&text);
    for e in &parsed.errors {
        emit(&checked.sources, &e.to_diagnostic(id));
    }
    Ok(Some((parsed.file, !parsed.errors.is_empty())))
}
