//! Growing a preview's model and building its answer: the derivation or
//! the guided search through `grm_grow`, the origins, the focus and the
//! tree, and the parts, materials and statistics of [`PreviewResult`].

use super::*;

#[cfg(test)]
pub(super) fn f32s(xs: &[f32]) -> String {
    crate::b64::words(xs, f32::to_le_bytes)
}

#[cfg(test)]
pub(super) fn u32s(xs: &[u32]) -> String {
    crate::b64::words(xs, u32::to_le_bytes)
}

#[cfg(test)]
pub(super) fn i32s(xs: &[i32]) -> String {
    crate::b64::words(xs, i32::to_le_bytes)
}

#[cfg(test)]
pub(super) fn quad_corners(mesh: &grm_geom::MeshData) -> String {
    crate::b64::quad_corners(&mesh.positions)
}

/// A derived string with provenance.
pub(super) struct Grown {
    pub(super) string: ModuleString,
    pub(super) origin: Option<Vec<u32>>,
    pub(super) focus: Vec<bool>,
    pub(super) tree: Option<grm_grow::Tree>,
    /// What the persistent edits met (with a plan).
    pub(super) edits: Option<grm_derive::EditOutcome>,
}

/// Derive `sys` through `grm_grow`, recording origins, the focus flags
/// and (`tree`) the derivation tree; stops when `cancel` is set.
#[cfg(test)]
pub(super) fn grow(
    sys: &CompiledSystem,
    iterations: u32,
    seed: u32,
    max_modules: u64,
    focus: Option<u32>,
    tree: bool,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Grown, Failure> {
    grow_edited(
        sys,
        iterations,
        seed,
        max_modules,
        focus,
        tree,
        None,
        cancel,
    )
}

/// [`grow`], replaying `edits` (the system's persistent edits, docs/
/// edits.md) while deriving.
#[allow(clippy::too_many_arguments)]
pub(super) fn grow_edited(
    sys: &CompiledSystem,
    iterations: u32,
    seed: u32,
    max_modules: u64,
    focus: Option<u32>,
    tree: bool,
    edits: Option<&grm_derive::EditPlan>,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Grown, Failure> {
    let record = grm_grow::Record {
        tree,
        origins: true,
        keys: true,
        focus: Some(focus.unwrap_or(NO_ORIGIN)),
    };
    let mut grower = grm_grow::Grower::new(sys, 1, record).map_err(|e| e.to_string())?;
    if let Some(plan) = edits {
        grower = grower.with_edits(plan.clone()).map_err(|e| e.to_string())?;
    }
    let opts = grm_derive::DeriveOptions {
        iterations,
        seed,
        limits: DeriveLimits {
            max_modules,
            max_bytes: 1 << 30,
        },
    };
    let stop = || cancel.is_some_and(CancelToken::is_cancelled);
    let g = grower
        .derive_until(&opts, &mut |_| {}, &stop)
        .map_err(|e| e.to_string())?
        .ok_or(Failure::Cancelled)?;
    Ok(Grown {
        focus: g.focus.unwrap_or_default(),
        origin: g.origins,
        tree: g.tree,
        string: g.string,
        edits: g.edits,
    })
}

/// A built model and what the preview reports about its growth.
pub(super) struct Made {
    pub(super) model: grm_geom::Model,
    /// Modules of the final string.
    pub(super) modules: usize,
    /// Per module: grown by the focused production.
    pub(super) focus_flags: Vec<bool>,
    /// The derivation tree (identity and ancestry for `grm/pick`).
    pub(super) tree: Option<grm_grow::Tree>,
    pub(super) derive_ms: f64,
    pub(super) build_ms: f64,
    pub(super) focus_out: Option<FocusOut>,
    pub(super) sample: Option<SampleOut>,
    /// Derive mode: what the persistent edits met.
    pub(super) edits: Option<grm_derive::EditOutcome>,
    /// Sample mode: what became of the persistent edits replayed.
    pub(super) sampled_edits: Option<Vec<grm_grow::edits::EditReport>>,
}

/// Derive mode: the CPU engine through `grm_grow`, exact provenance,
/// focus spread over seeds; `edits` replayed (the spread's seeds too).
#[allow(clippy::too_many_arguments)]
pub(super) fn derive_model(
    prog: &grm_sema::Program,
    sys: &grm_sema::System,
    compiled: &CompiledSystem,
    settings: &grm_sema::Settings,
    p: &PreviewParams,
    focus: Option<u32>,
    edits: Option<&grm_derive::EditPlan>,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Made, Failure> {
    let max_modules = p.max_modules.unwrap_or(2_000_000).min(50_000_000);
    let t0 = Instant::now();
    let grown = grow_edited(
        compiled,
        settings.iterations,
        settings.seed,
        max_modules,
        focus,
        true,
        edits,
        cancel,
    )?;
    let derive_ms = t0.elapsed().as_secs_f64() * 1e3;
    check(cancel)?;
    let t1 = Instant::now();
    // Focus and context: the modules a few levels below the focused one
    // are meshed, the rest left to the skeleton's lines (an unknown key:
    // the whole model).
    let window = p.context.as_ref().and_then(|c| {
        let key = grm_edits::file::parse_key(c.key.trim())?;
        grown.tree.as_ref()?.focus_window(key, c.depth)
    });
    let in_window = |m: u32| {
        window
            .as_ref()
            .is_some_and(|w| w.get(m as usize) == Some(&true))
    };
    let mut model = grm_geom::build_model_drawn(
        prog,
        sys,
        &grown.string,
        settings,
        &compiled.param_values,
        &grm_geom::BuildOptions::limited(PREVIEW_MAX_BYTES, grm_geom::Output::Model),
        window
            .is_some()
            .then_some(&in_window as &dyn Fn(u32) -> bool),
    )
    .map_err(|e| too_large(&e))?;
    if let Some(o) = &grown.origin {
        model.fill_origins(o);
    }
    let build_ms = t1.elapsed().as_secs_f64() * 1e3;
    // Focus spread over seeds: bones grown by the focused production.
    let mut focus_out = None;
    if let Some(fo) = focus {
        let count = |g: &Grown, m: &grm_geom::grm_turtle::Interpretation| {
            let bones = m
                .bones
                .iter()
                .filter(|b| g.focus.get(b.module as usize) == Some(&true))
                .count();
            let inst = m
                .instances
                .iter()
                .filter(|b| g.focus.get(b.module as usize) == Some(&true))
                .count();
            (bones, inst)
        };
        let (bones, instances) = count(&grown, &model.skeleton);
        let n = p.spread_seeds.unwrap_or(8).clamp(1, 64);
        let mut spread = Vec::with_capacity(n as usize);
        for k in 0..n {
            let seed = settings.seed.wrapping_add(k);
            let g = grow_edited(
                compiled,
                settings.iterations,
                seed,
                max_modules,
                focus,
                false,
                edits,
                cancel,
            )?;
            let mut st = settings.clone();
            st.seed = seed;
            let interp =
                grm_geom::grm_turtle::interpret(sys, &st, &g.string).map_err(|e| e.to_string())?;
            spread.push(count(&g, &interp).0);
        }
        focus_out = Some(FocusOut {
            origin: fo,
            bones,
            instances,
            spread_bones: spread,
        });
    }
    Ok(Made {
        modules: grown.string.len(),
        focus_flags: grown.focus,
        tree: grown.tree,
        model,
        derive_ms,
        build_ms,
        focus_out,
        sample: None,
        edits: grown.edits,
        sampled_edits: None,
    })
}

/// Sample mode: the guided sampler through `grm_grow::sample` with the
/// request's curves (or the file's `NAME.curves.json` next to it); the
/// sampler reports provenance itself. Focus marks what the focused
/// production made directly. `edits` (the edits file's, those of other
/// systems skipped) are replayed in the sampler and classified against
/// the model shown.
#[allow(clippy::too_many_arguments)]
pub(super) fn sample_model(
    fa: &FileAnalysis,
    sys: &grm_sema::System,
    compiled: &CompiledSystem,
    settings: &grm_sema::Settings,
    p: &PreviewParams,
    focus: Option<u32>,
    edits: Option<&[grm_edits::Edit]>,
    cancel: Option<&CancelToken>,
) -> std::result::Result<Made, Failure> {
    let prog = &fa.checked.program;
    let (curves, from) = match &p.curves {
        Some(v) => (
            grm_guide::Curves::from_json_str("request", &v.to_string())
                .map_err(|e| e.to_string())?,
            "request".to_string(),
        ),
        None => {
            let path = std::path::Path::new(&fa.source().path).with_extension("curves.json");
            if !path.is_file() {
                return Err(Failure::Msg(format!(
                    "sample mode needs guiding curves: pass `curves`, or put them in {}",
                    path.display()
                )));
            }
            (
                grm_guide::Curves::load(&path).map_err(|e| e.to_string())?,
                path.display().to_string(),
            )
        }
    };
    let t0 = Instant::now();
    let opts = grm_sample::SampleOptions {
        seed: settings.seed,
        schedule: grm_sample::Schedule::from_settings(settings),
        threads: 1,
        budget: Some(std::time::Duration::from_millis(
            p.budget_ms.unwrap_or(5000).min(600_000),
        )),
        cancel: cancel.cloned(),
        ..grm_sample::SampleOptions::default()
    };
    let request = grm_grow::sample::SampleRequest {
        // The one frame shown, not one per generation.
        generation: p.generation,
        tree: true,
        edits,
        ..grm_grow::sample::SampleRequest::new(&curves, opts)
    };
    let mut sampled = grm_grow::sample::sample(sys, compiled, &request).map_err(|e| match e {
        grm_sample::SampleError::Cancelled => Failure::Cancelled,
        e => Failure::Msg(e.to_string()),
    })?;
    // The shown model's tree (identity and ancestry for `grm/pick`).
    let tree = sampled.tree.take();
    let sampled_edits = sampled.edits.take();
    let run = &sampled.result;
    // The frame asked for (the last one past the end: the result).
    let (shown, best) = match sampled.shown() {
        grm_grow::sample::Shown::Frame(g, m) => (Some(g as usize), m),
        grm_grow::sample::Shown::FrameFailed(g, e) => {
            return Err(Failure::Msg(format!(
                "the model of generation {g} cannot be finished: {e} (a search stopped after it ends so; the full search finished)"
            )));
        }
        grm_grow::sample::Shown::NoFrame(k) => {
            return Err(format!("the sampler kept no model of generation {k}").into());
        }
        grm_grow::sample::Shown::Models(m) => {
            (None, m.first().ok_or("the sampler returned no model")?)
        }
    };
    let derive_ms = t0.elapsed().as_secs_f64() * 1e3;
    let t1 = Instant::now();
    let model = best
        .build(
            prog,
            &grm_geom::BuildOptions::limited(PREVIEW_MAX_BYTES, grm_geom::Output::Model),
        )
        .map_err(|e| too_large(&e))?;
    let build_ms = t1.elapsed().as_secs_f64() * 1e3;
    let bones: Vec<(glam::Vec3, glam::Vec3)> = (best.interpretation.bones.iter())
        .map(|b| (b.base, b.tip))
        .collect();
    let coverage = crate::coverage::coverage(&curves, &bones);
    let focus_flags: Vec<bool> = best.origins.iter().map(|&o| Some(o) == focus).collect();
    let focus_out = focus.map(|fo| FocusOut {
        origin: fo,
        bones: model
            .skeleton
            .bones
            .iter()
            .filter(|b| b.origin == fo)
            .count(),
        instances: model
            .skeleton
            .instances
            .iter()
            .filter(|i| i.origin == fo)
            .count(),
        spread_bones: Vec::new(),
    });
    Ok(Made {
        modules: best.string.len(),
        focus_flags,
        tree,
        model,
        derive_ms,
        build_ms,
        focus_out,
        sample: Some(SampleOut {
            objective: best.objective,
            generations: run.generations.len(),
            candidates: run.candidates.len(),
            stopped_early: run.stopped_early,
            refinements: run.refinements,
            curves: from,
            generation: shown,
            coverage,
        }),
        edits: None,
        sampled_edits,
    })
}

/// A model error as the preview says it: over the memory limit, with its
/// code and what to lower.
pub(crate) fn too_large(e: &grm_geom::GeomError) -> Failure {
    match e {
        grm_geom::GeomError::MemoryLimit { .. } => Failure::Msg(format!(
            "{} (R0202): lower `maxModules` or the iterations to preview it",
            e
        )),
        e => Failure::Msg(e.to_string()),
    }
}

/// Build the preview of a checked file. Errors are messages for the user.
pub(crate) fn build(
    fa: &FileAnalysis,
    uri: &Uri,
    uris: &crate::uris::Uris,
    edits: &crate::edits::Source,
    p: &PreviewParams,
    cancel: Option<&CancelToken>,
) -> std::result::Result<(PreviewResult, PickTable), Failure> {
    build_with_model(fa, uri, uris, edits, p, cancel).map(|(r, t, model)| {
        drop_later(model);
        (r, t)
    })
}

/// Free a large value on a thread of its own, off the answer's path (a
/// building's model is tens of thousands of groups: freeing them took
/// as long as encoding its positions).
pub(crate) fn drop_later<T: Send + 'static>(x: T) {
    // A failed spawn (no threads left) drops it here.
    let _ = std::thread::Builder::new()
        .name("grm-drop".into())
        .spawn(move || drop(x));
}

/// The `grm/preview` answer for an analysed file, exactly as the request
/// and `grm/previewUpdated` build it (without the pick table the server
/// keeps): for benchmarks (`benches/shape_regrow.rs`) and tools. An error
/// is the message the client would get. Edits files are read from disk.
pub fn answer(
    fa: &FileAnalysis,
    uri: &Uri,
    params: &PreviewParams,
) -> std::result::Result<PreviewResult, String> {
    let edits = crate::edits::Source::default();
    build(fa, uri, &crate::uris::Uris::default(), &edits, params, None)
        .map(|(r, table)| {
            // The server keeps the table (and frees the one it replaces
            // off the answer's path, `store`).
            drop_later(table);
            r
        })
        .map_err(|f| f.to_string())
}

/// [`build`], and the model it was made from (`grm/picture` draws it).
pub(crate) fn build_with_model(
    fa: &FileAnalysis,
    uri: &Uri,
    uris: &crate::uris::Uris,
    edits: &crate::edits::Source,
    p: &PreviewParams,
    cancel: Option<&CancelToken>,
) -> std::result::Result<(PreviewResult, PickTable, grm_geom::Model), Failure> {
    check(cancel)?;
    if fa.checked.has_errors() {
        let n = fa
            .checked
            .diagnostics
            .iter()
            .filter(|d| d.is_error())
            .count();
        return Err(Failure::Msg(format!(
            "the program has {n} error{}: fix {} to preview",
            if n == 1 { "" } else { "s" },
            if n == 1 { "it" } else { "them" }
        )));
    }
    let prog = &fa.checked.program;
    let sys = match &p.system {
        Some(name) => prog
            .system(name)
            .ok_or_else(|| format!("no system `{name}`"))?,
        None => prog.default_system().ok_or("the file defines no system")?,
    };
    let mode = p.mode.unwrap_or(match sys.mode {
        Mode::Derive => PreviewMode::Derive,
        Mode::Sample => PreviewMode::Sample,
        Mode::Shape => PreviewMode::Shape,
    });
    match (mode, sys.mode) {
        (PreviewMode::Derive, Mode::Sample) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a sample system: derive mode cannot grow it",
                sys.name
            )));
        }
        (PreviewMode::Sample, Mode::Derive) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a derive system: only sample systems are sampled",
                sys.name
            )));
        }
        (PreviewMode::Derive | PreviewMode::Sample, Mode::Shape) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a shape system: only shape mode grows it",
                sys.name
            )));
        }
        (PreviewMode::Shape, Mode::Derive | Mode::Sample) => {
            return Err(Failure::Msg(format!(
                "system `{}` is a {} system: shape mode grows only shape systems",
                sys.name,
                sys.mode.name()
            )));
        }
        _ => {}
    }
    let mut values = prog.default_params();
    for (name, v) in &p.params {
        let id = prog
            .param_by_name(name)
            .ok_or_else(|| format!("no meta-parameter `{name}`"))?;
        let decl = &prog.params[id.index()];
        if decl.ty != grm_sema::Ty::Float {
            return Err(Failure::Msg(format!(
                "meta-parameter `{name}` is not a float"
            )));
        }
        if !v.is_finite() {
            return Err(Failure::Msg(format!(
                "meta-parameter `{name}` must be finite"
            )));
        }
        // As `grmc --param` refuses it: a slider never leaves its range.
        if let Some((lo, hi)) = decl.range
            && !(lo..=hi).contains(v)
        {
            return Err(Failure::Msg(format!(
                "meta-parameter `{name}` = {v} is outside its range {lo} .. {hi}"
            )));
        }
        values[id.index()] = Value::Float(*v);
    }
    if mode == PreviewMode::Shape {
        return crate::shape_preview::build(fa, uri, uris, edits, p, sys, values, cancel);
    }
    let globals = prog.global_values(&values).map_err(|e| e.to_string())?;
    let mut settings = sys.settings_with(&values, &globals)?;
    if let Some(s) = p.seed {
        settings.seed = s;
    }
    if let Some(i) = p.iterations {
        // The checker's bound on the setting holds for the override too.
        if i > grm_sema::MAX_ITERATIONS {
            return Err(Failure::Msg(format!(
                "{i} iterations is more than the {} a preview derives",
                grm_sema::MAX_ITERATIONS
            )));
        }
        settings.iterations = i;
    }
    let compiled = grm_compile::compile(prog, sys, &values).map_err(|e| e.to_string())?;
    let sys_file = fa.sources.get(sys.file);
    let (sys_path, sys_uri) = system_file(fa, sys.file, uri, uris);
    let origin_table: Vec<OriginOut> = compiled
        .alt_spans
        .iter()
        .enumerate()
        .map(|(a, span)| OriginOut {
            uri: sys_uri.clone(),
            range: convert::range(sys_file, *span),
            symbol: if a as u32 == compiled.axiom_alt {
                "axiom".into()
            } else {
                compiled
                    .alts
                    .get(a)
                    .and_then(|alt| compiled.groups.get(alt.group as usize))
                    .and_then(|g| compiled.symbol_names.get(g.pred as usize))
                    .cloned()
                    .unwrap_or_default()
            },
        })
        .collect();
    // The production under the focus position, if any.
    let focus = p.focus.and_then(|pos| {
        if sys.file != fa.root {
            return None;
        }
        let off = convert::offset(sys_file, pos);
        compiled
            .alt_spans
            .iter()
            .position(|s| s.contains(off) || s.end == off)
            .map(|a| a as u32)
    });
    // Derive and sample mode: the edits file beside the system's grammar
    // (its buffer, else the disk), replayed by the CPU engine or the
    // sampler (docs/edits.md).
    let loaded = matches!(mode, PreviewMode::Derive | PreviewMode::Sample)
        .then(|| edits.load(&grm_edits::edits_path(&sys_path)));
    let plan = loaded
        .as_ref()
        .filter(|l| mode == PreviewMode::Derive && l.text.is_some())
        .map(|l| grm_grow::edits::edit_plan(sys, l.parsed.file.of_system(&sys.name)));
    let sample_edits = loaded
        .as_ref()
        .filter(|l| l.text.is_some())
        .map(|l| l.parsed.file.edits.as_slice());
    let made = match mode {
        PreviewMode::Sample => sample_model(
            fa,
            sys,
            &compiled,
            &settings,
            p,
            focus,
            sample_edits,
            cancel,
        )?,
        _ => derive_model(
            prog,
            sys,
            &compiled,
            &settings,
            p,
            focus,
            plan.as_ref(),
            cancel,
        )?,
    };
    check(cancel)?;
    let Made {
        model,
        modules,
        focus_flags,
        tree,
        derive_ms,
        build_ms,
        focus_out,
        sample,
        edits: outcome,
        sampled_edits,
    } = made;
    // What became of each edit (with the tree, the prints and retarget
    // candidates of key edits).
    let grown = tree.as_ref().map(|tree| crate::edits::KeyTree {
        tree,
        symbols: &compiled.symbol_names,
        drawn: &model.skeleton,
    });
    let (edits_out, edits_run) = match (&loaded, uris.uri_of(&grm_edits::edits_path(&sys_path))) {
        (Some(l), Some(edits_uri)) if mode == PreviewMode::Sample => {
            let reports = sampled_edits.unwrap_or_default();
            let (o, r) =
                crate::edits::classify_sampled(edits, l, edits_uri, prog, sys, reports, grown);
            (Some(o), Some(r))
        }
        (Some(l), Some(edits_uri)) => {
            let outcome = outcome.unwrap_or_default();
            let (o, r) = crate::edits::classify_derive(
                edits,
                l,
                edits_uri,
                prog,
                (sys, &compiled),
                &outcome,
                grown,
            );
            (Some(o), Some(r))
        }
        _ => (None, None),
    };
    let params_out = params_out(prog, &values);
    fits_answer(&model, origin_table.len())?;
    let t2 = Instant::now();
    let is_focus = |module: u32| focus_flags.get(module as usize) == Some(&true);
    let origin_of = |o: u32| (o != NO_ORIGIN && (o as usize) < origin_table.len()).then_some(o);
    let mut table = PickTable {
        version: fa.version,
        origins: origin_table.clone(),
        symbols: compiled.symbol_names.clone(),
        tree: tree.map(|t| {
            let mut place = vec![0u32; t.nodes.len()];
            for kids in t.children() {
                for (k, &c) in kids.iter().enumerate() {
                    place[c as usize] = k as u32;
                }
            }
            Arc::new((t, place))
        }),
        edits: edits_run.map(Arc::new),
        ..PickTable::default()
    };
    let enc = encoding(p);
    let parts = parts_out(&model, &origin_of, &is_focus, &mut table.parts, enc);
    let bones = &model.skeleton.bones;
    let mut bone_f = Vec::with_capacity(bones.len() * 8);
    let mut parents = Vec::with_capacity(bones.len());
    let mut bone_o = Vec::with_capacity(bones.len());
    for b in bones {
        bone_f.extend_from_slice(&b.base.to_array());
        bone_f.extend_from_slice(&b.tip.to_array());
        bone_f.push(b.width_base);
        bone_f.push(b.width_tip);
        parents.push(b.parent.map_or(-1, |p| i32::try_from(p).unwrap_or(-1)));
        bone_o.push(origin_of(b.origin).unwrap_or(NO_ORIGIN));
        table.bones.push((b.module, b.origin));
    }
    let skeleton = SkeletonOut {
        bone_count: bones.len(),
        bones: enc.f32s(&bone_f),
        parents: enc.i32s(&parents),
        origins: enc.u32s(&bone_o),
    };
    let materials = materials_out(&model);
    let warnings = WarningOut::all(model.warnings(compiled.file, compiled.span, false));
    let result = PreviewResult {
        uri: uri.clone(),
        version: fa.version,
        system: sys.name.clone(),
        mode,
        seed: settings.seed,
        iterations: settings.iterations,
        encoding: "base64-le".into(),
        blob: None,
        materials,
        parts,
        skeleton,
        origins: origin_table,
        focus: focus_out,
        params: params_out,
        sample,
        stats: stats_out(&model, modules, derive_ms, build_ms, t2),
        warnings,
        shape: None,
        edits: edits_out,
    };
    Ok((result, table, model))
}

/// The meta-parameters with the values of a run (for the sliders).
pub(crate) fn params_out(prog: &grm_sema::Program, values: &[Value]) -> Vec<ParamOut> {
    prog.params
        .iter()
        .zip(values)
        .filter_map(|(m, v)| {
            Some(ParamOut {
                name: m.name.clone(),
                value: v.as_float()?,
                default: m.default.as_float()?,
                min: m.range.map(|r| r.0),
                max: m.range.map(|r| r.1),
            })
        })
        .collect()
}

/// Refuse a model before it is encoded when its answer would be too large:
/// the transport drops a larger message, and the client would wait for
/// its answer forever.
pub(crate) fn fits_answer(
    model: &grm_geom::Model,
    origins: usize,
) -> std::result::Result<(), Failure> {
    let answer = answer_bytes(model, origins);
    if answer > MAX_ANSWER_BYTES {
        let st = &model.stats;
        return Err(Failure::Msg(format!(
            "the model is too large to preview (R0408): its answer would be {} ({} triangles, {} vertices, {} bones), over the limit of {} on a grm/preview answer; lower `maxModules` or the iterations",
            grm_geom::budget::mib(answer),
            st.triangles,
            st.vertices,
            st.bones,
            grm_geom::budget::mib(MAX_ANSWER_BYTES)
        )));
    }
    Ok(())
}

/// A part with at least this many vertices has its vertices encoded on a
/// second thread (spawning one costs some tens of microseconds; encoding
/// 64Ki vertices, about a millisecond).
pub(super) const PARALLEL_VERTICES: usize = 1 << 16;

/// The model's parts on the wire, and for `grm/pick` each part's runs
/// (first triangle, count, module, origin) pushed on `table`.
pub(crate) fn parts_out(
    model: &grm_geom::Model,
    origin_of: &dyn Fn(u32) -> Option<u32>,
    is_focus: &dyn Fn(u32) -> bool,
    table: &mut Vec<Vec<(u32, u32, u32, u32)>>,
    enc: Enc,
) -> Vec<PartOut> {
    model
        .parts
        .iter()
        .map(|part| {
            let mesh = &part.mesh;
            // Parallelogram quads (walls, windows, boxes) go as three
            // corners each, without indices or normals (`layout: "quads"`,
            // `MeshData::is_quads`); other meshes' flat normals are left
            // out (`MeshData::flat_normals`): the client computes both.
            // The index half of the test here, its geometry half with the
            // vertices on a second thread (a large part: a building's
            // walls), the picks and indices here.
            let quad_indices = mesh.quad_indices();
            let vertices = || {
                if quad_indices && mesh.quad_geometry() {
                    return (enc.quad_corners(&mesh.positions), Buf::default(), true);
                }
                let normals = if mesh.flat_normals() {
                    Buf::default()
                } else {
                    enc.f32s(mesh.normals.as_flattened())
                };
                (enc.f32s(mesh.positions.as_flattened()), normals, false)
            };
            let rest = || {
                let mut picks = Vec::with_capacity(part.picks.len() * 4 * PICK_WORDS);
                let mut runs = Vec::with_capacity(part.picks.len());
                for pk in &part.picks {
                    let (kind, index) = match pk.source {
                        grm_geom::PartSource::Bone(i) => (0, i),
                        grm_geom::PartSource::Instance(i) => (1, i),
                        grm_geom::PartSource::Polygon(i) => (2, i),
                        grm_geom::PartSource::Shape(i) => (3, i),
                    };
                    let flags = kind | if is_focus(pk.module) { PICK_FOCUS } else { 0 };
                    let origin = origin_of(pk.origin).unwrap_or(u32::MAX);
                    let words = [
                        pk.first_triangle,
                        pk.triangle_count,
                        flags,
                        index,
                        pk.module,
                        origin,
                    ];
                    // One append of the pick's 24 bytes.
                    let mut bytes = [0u8; 4 * PICK_WORDS];
                    for (d, w) in bytes.chunks_exact_mut(4).zip(words) {
                        d.copy_from_slice(&w.to_le_bytes());
                    }
                    picks.extend_from_slice(&bytes);
                    runs.push((pk.first_triangle, pk.triangle_count, pk.module, pk.origin));
                }
                let picks = enc.bytes(picks);
                // Indices in quad order are left out unless the geometry
                // half says otherwise (then written after the join).
                let indices = (!quad_indices).then(|| enc.u32s(&mesh.indices));
                (indices, picks, runs)
            };
            let ((positions, normals, quads), (indices, picks_b64, runs)) =
                if mesh.positions.len() >= PARALLEL_VERTICES {
                    std::thread::scope(|s| {
                        let h = s.spawn(vertices);
                        let r = rest();
                        (h.join().unwrap_or_else(|_| vertices()), r)
                    })
                } else {
                    (vertices(), rest())
                };
            let indices = match indices {
                Some(b) => b,
                None if quads => Buf::default(),
                None => enc.u32s(&mesh.indices),
            };
            table.push(runs);
            PartOut {
                material: part.material,
                vertex_count: mesh.positions.len(),
                triangle_count: mesh.indices.len() / 3,
                positions,
                normals,
                indices,
                pick_count: part.picks.len(),
                picks: picks_b64,
                layout: quads.then(|| "quads".to_owned()),
            }
        })
        .collect()
}

/// The model's materials on the wire.
pub(crate) fn materials_out(model: &grm_geom::Model) -> Vec<MaterialOut> {
    model
        .materials
        .iter()
        .map(|m| MaterialOut {
            name: m.name.clone(),
            color: m.color,
            roughness: m.roughness,
            metallic: m.metallic,
            emissive: m.emissive,
            opacity: m.opacity,
        })
        .collect()
}

/// The model's figures; `encode` is when encoding began.
pub(crate) fn stats_out(
    model: &grm_geom::Model,
    modules: usize,
    derive_ms: f64,
    build_ms: f64,
    encode: Instant,
) -> StatsOut {
    let st = &model.stats;
    let finite = |v: [f32; 3]| {
        if v.iter().all(|x| x.is_finite()) {
            v
        } else {
            [0.0; 3]
        }
    };
    StatsOut {
        modules,
        vertices: st.vertices,
        triangles: st.triangles,
        bones: st.bones,
        instances: st.instances,
        polygons: st.polygons,
        parts: st.parts,
        dropped: st.dropped,
        bounds_min: finite(st.bounds.min.to_array()),
        bounds_max: finite(st.bounds.max.to_array()),
        ambiguous_origins: 0,
        derive_ms,
        build_ms,
        encode_ms: encode.elapsed().as_secs_f64() * 1e3,
    }
}

/// The path of the file that holds the system in `file` and its URI as
/// the client names it (it may be an imported file: the previewed
/// document's `uri` only when it is this one).
pub(crate) fn system_file(
    fa: &FileAnalysis,
    file: grm_diag::FileId,
    uri: &Uri,
    uris: &crate::uris::Uris,
) -> (PathBuf, Uri) {
    let path = grm_sema::normalize(std::path::Path::new(&fa.sources.get(file).path));
    let file_uri = if path == fa.path {
        uri.clone()
    } else {
        uris.uri_of(&path).unwrap_or_else(|| uri.clone())
    };
    (path, file_uri)
}
