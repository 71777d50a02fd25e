//! Derive mode's persistent edits (`grm_edits`, docs/edits.md): the edits
//! of a system lowered to the CPU engine's plan ([`edit_plan`], replayed
//! by [`crate::Grower::with_edits`]) and, after the derivation, what each
//! one became ([`classify`]).
//!
//! Derive mode replays **key** targets (`{"key": "0a1b2c3d"}`, the
//! identity key of a module, what a pick in the preview gives): `remove`,
//! `set` and `offset` of a module parameter, `force`, `pin`. A parameter
//! is named as the module's declaration names it (`module A(len: float)`:
//! `len`) or by its position from 1 (`1`, for symbols declared without
//! names, such as `F`); `.x`, `.y` or `.z` after it names one component of
//! a `vec3` (without, a `set` or `offset` applies to all three). `set` and
//! `offset` reach the target's whole subtree: every module made below it
//! whose symbol has a parameter of that name.
//!
//! Classes: a key no module was made with is **structurally invalid**
//! (dormant: it applies again when the module comes back), a key several
//! modules were made with is **ambiguous** (32-bit keys collide; the edit
//! applies to each), an operation that names a parameter no symbol has, or
//! an alternative past every production of the target's symbol, is
//! **stale**. Exact and semantic targets, `material` and `mesh` are not
//! replayed in derive mode: they are reported, never applied silently.
//!
//! Sample mode replays the same key targets and operations inside the
//! guided sampler ([`sample_plan`], [`crate::sample::SampleRequest::
//! edits`]) and classifies them the same way from what the model shown
//! met ([`classify_sampled`]).

use grm_compile::CompiledSystem;
use grm_derive::{EditAction, EditOutcome, EditPlan, SlotTarget, ValueOp};
use grm_edits::{Edit, EditClass, Op, Target};

/// What became of one edit of a derive-mode system.
#[derive(Clone, Debug, PartialEq)]
pub struct EditReport {
    /// The edit's id.
    pub id: u32,
    pub class: EditClass,
    /// How many modules its target named in the derivation (made with its
    /// key; a copied module is one).
    pub modules: u32,
    /// Why, in one line.
    pub detail: String,
    /// Whether the derivation replayed it: a valid edit of a replayed
    /// operation.
    pub replayed: bool,
}

/// Where parameter `name` is in each symbol of `system` (see the module
/// doc for the names); all `words == 0` when no symbol has it.
pub fn parameter_slot(system: &grm_sema::System, name: &str) -> Vec<SlotTarget> {
    let (base, component) = match name.rsplit_once('.') {
        Some((b, c @ ("x" | "y" | "z"))) => (b, Some(c)),
        _ => (name, None),
    };
    let position = base.parse::<usize>().ok().filter(|&k| k >= 1);
    system
        .symbols
        .iter()
        .map(|s| {
            let index = s
                .param_names
                .iter()
                .position(|n| n.as_deref() == Some(base))
                .or_else(|| position.map(|k| k - 1).filter(|&k| k < s.params.len()));
            let Some(index) = index else {
                return SlotTarget::default();
            };
            let word: u32 = s.params[..index]
                .iter()
                .map(|&t| if t == grm_sema::Ty::Vec3 { 3 } else { 1 })
                .sum();
            match (s.params[index], component) {
                (grm_sema::Ty::Vec3, None) => SlotTarget {
                    word,
                    words: 3,
                    boolean: false,
                },
                (grm_sema::Ty::Vec3, Some(c)) => SlotTarget {
                    word: word
                        + if c == "x" {
                            0
                        } else if c == "y" {
                            1
                        } else {
                            2
                        },
                    words: 1,
                    boolean: false,
                },
                (_, Some(_)) => SlotTarget::default(),
                (grm_sema::Ty::Float, None) => SlotTarget {
                    word,
                    words: 1,
                    boolean: false,
                },
                (grm_sema::Ty::Bool, None) => SlotTarget {
                    word,
                    words: 1,
                    boolean: true,
                },
                // Mesh and material names are not numbers to set.
                _ => SlotTarget::default(),
            }
        })
        .collect()
}

/// The CPU engine's replay plan of `edits` (those of `system`; others are
/// skipped): their key targets and replayed operations, parameters named
/// resolved in `system`.
pub fn edit_plan<'e>(
    system: &grm_sema::System,
    edits: impl IntoIterator<Item = &'e Edit>,
) -> EditPlan {
    key_plan(EditPlan::new(), system, edits)
}

/// `edits` of `system` with key targets added to `plan` (others are
/// skipped): `remove`, `force`, `pin`, `set` and `offset` as actions (a
/// value that is not a finite f32 only watched), `material` and `mesh`
/// watched (not replayed by these engines, but their targets classified).
fn key_plan<'e, P: grm_derive::KeyPlan>(
    mut plan: P,
    system: &grm_sema::System,
    edits: impl IntoIterator<Item = &'e Edit>,
) -> P {
    let mut slots: Vec<(String, u32)> = Vec::new();
    for e in edits {
        if e.system != system.name {
            continue;
        }
        let Target::Key(key) = e.target else {
            continue;
        };
        // The recorded symbol: the key names a module of it only (one the
        // system lacks: none).
        if let Some(name) = &e.symbol {
            let symbol = system.symbols.iter().position(|s| s.name == *name);
            plan.restrict(key, symbol.map_or(u32::MAX, |s| s as u32));
        }
        let mut value = |name: &str, op: ValueOp| {
            let slot = match slots.iter().find(|(n, _)| n == name) {
                Some(&(_, s)) => s,
                None => {
                    let s = plan.add_slot(parameter_slot(system, name));
                    slots.push((name.to_owned(), s));
                    s
                }
            };
            EditAction::Value { slot, op }
        };
        let action = match &e.op {
            Op::Remove => EditAction::Remove,
            Op::Force { alternative } => EditAction::Force(*alternative),
            Op::Pin { key } => EditAction::Pin(*key),
            Op::Set { name, value: v } => match finite_f32(*v) {
                Some(v) => value(name, ValueOp::Set(v)),
                None => {
                    plan.watch(key);
                    continue;
                }
            },
            Op::Offset { name, by } => match finite_f32(*by) {
                Some(by) => value(name, ValueOp::Offset(by)),
                None => {
                    plan.watch(key);
                    continue;
                }
            },
            Op::Material { .. } | Op::Mesh { .. } => {
                plan.watch(key);
                continue;
            }
        };
        plan.add(key, e.id, action);
    }
    plan
}

/// `v` as an f32, if it is finite there.
fn finite_f32(v: f64) -> Option<f32> {
    let f = v as f32;
    f.is_finite().then_some(f)
}

/// Classify `edits` (those of one derive-mode system) after a derivation
/// that replayed them: `outcome` is what the engine met
/// ([`grm_derive::Engine::derive_edited`], [`crate::Grown::edits`]);
/// `sys` the compiled system (its productions), `system` the checked one
/// (its parameters' names).
pub fn classify<'e>(
    system: &grm_sema::System,
    sys: &CompiledSystem,
    outcome: &EditOutcome,
    edits: impl IntoIterator<Item = &'e Edit>,
) -> Vec<EditReport> {
    classify_hits(system, sys, "derive", |k| outcome.hits(k), edits)
}

/// The sampler's replay plan of `edits` (those of `system`; others are
/// skipped): as [`edit_plan`], for [`grm_sample::Sampler::with_edits`]
/// (key targets; `remove`, `set`, `offset`, `force`, `pin`; `material`
/// and `mesh` only watched, to be classified).
pub fn sample_plan<'e>(
    system: &grm_sema::System,
    edits: impl IntoIterator<Item = &'e Edit>,
) -> grm_sample::EditPlan {
    key_plan(grm_sample::EditPlan::new(), system, edits)
}

/// Classify `edits` (those of one sample-mode system) after a sampled
/// derivation that replayed them: `hits` is what the model shown met
/// ([`grm_sample::SampledModel::edits`]); as [`classify`] does for derive
/// mode.
pub fn classify_sampled<'e>(
    system: &grm_sema::System,
    sys: &CompiledSystem,
    hits: &grm_sample::EditHits,
    edits: impl IntoIterator<Item = &'e Edit>,
) -> Vec<EditReport> {
    classify_hits(system, sys, "sample", |k| hits.hits(k), edits)
}

/// [`classify`] of a `mode` ("derive", "sample") with the modules made
/// per key given by `hits`.
fn classify_hits<'e>(
    system: &grm_sema::System,
    sys: &CompiledSystem,
    mode: &str,
    hits_of: impl Fn(u32) -> Option<grm_derive::KeyHits>,
    edits: impl IntoIterator<Item = &'e Edit>,
) -> Vec<EditReport> {
    edits
        .into_iter()
        .map(|e| {
            let report = |class, modules, detail: String, replayed| EditReport {
                id: e.id,
                class,
                modules,
                detail,
                replayed,
            };
            let key = match &e.target {
                Target::Key(k) => *k,
                Target::Exact(_) => {
                    return report(
                        EditClass::SemanticallyInvalid,
                        0,
                        format!("not replayed: {mode} mode replays key targets only (pick the part to target it by its key)"),
                        false,
                    );
                }
                Target::Semantic(_) => {
                    return report(
                        EditClass::SemanticallyInvalid,
                        0,
                        "a semantic query names parts of a building (mode = shape); this system derives modules".to_owned(),
                        false,
                    );
                }
            };
            let Some(hits) = hits_of(key) else {
                let what = match &e.symbol {
                    Some(s) if !system.symbols.iter().any(|x| x.name == *s) => {
                        format!("no module has this key now: the system has no `{s}`")
                    }
                    Some(s) => format!("no `{s}` module has this key now"),
                    None => "no module has this key now".to_owned(),
                };
                return report(
                    EditClass::StructurallyInvalid,
                    0,
                    format!("{what} (kept dormant: it applies again when the module comes back)"),
                    false,
                );
            };
            let (class, detail) = if hits.modules > 1 {
                (
                    EditClass::Ambiguous,
                    format!("{} modules have this key", hits.modules),
                )
            } else {
                (EditClass::Valid, String::new())
            };
            if let Some(why) = stale(system, sys, hits.symbol, &e.op) {
                return report(EditClass::Stale, hits.modules, why, false);
            }
            if matches!(e.op, Op::Material { .. } | Op::Mesh { .. }) {
                return report(
                    class,
                    hits.modules,
                    format!(
                        "not replayed: `{}` is not replayed in {mode} mode (modules carry no materials or meshes of their own)",
                        e.op.kind().as_str()
                    ),
                    false,
                );
            }
            report(class, hits.modules, detail, class == EditClass::Valid)
        })
        .collect()
}

/// Why `op` on a module of symbol `symbol` names what is gone, if it does.
fn stale(system: &grm_sema::System, sys: &CompiledSystem, symbol: u32, op: &Op) -> Option<String> {
    let name_of = |s: u32| {
        sys.symbol_names
            .get(s as usize)
            .map_or("?", String::as_str)
            .to_owned()
    };
    match op {
        Op::Set { name, value: v } | Op::Offset { name, by: v } => {
            if finite_f32(*v).is_none() {
                return Some(format!("{v} does not fit a 32-bit float"));
            }
            parameter_slot(system, name)
                .iter()
                .all(|t| t.words == 0)
                .then(|| format!("no module has a number parameter `{name}`"))
        }
        Op::Force { alternative } => {
            let groups = sys.groups_of(symbol);
            let most = groups.iter().map(|g| g.alt_count).max().unwrap_or(0);
            if groups.is_empty() {
                Some(format!("`{}` has no production to force", name_of(symbol)))
            } else {
                (*alternative > most).then(|| {
                    format!(
                        "`{}` has {most} alternative{}, not {alternative}",
                        name_of(symbol),
                        if most == 1 { "" } else { "s" }
                    )
                })
            }
        }
        Op::Pin { .. } | Op::Remove | Op::Material { .. } | Op::Mesh { .. } => None,
    }
}
