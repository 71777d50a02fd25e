//! Applying one production to one non-terminal: choose the group and the
//! alternative (weights drawn with draw index 0, as in the derivation
//! engine), evaluate the successor's parameters with the VM, and interpret
//! the successor from the non-terminal's saved turtle frame (frame
//! locality), recording its bones and the frames of the non-terminals it
//! emits.

use glam::Vec3;
use grm_compile::CompiledSystem;
use grm_compile::rng::DrawCtx;
use grm_compile::select::{self, AltError};
use grm_compile::table::*;
use grm_compile::vm::Vm;
use grm_derive::ModuleString;
use grm_sema::{Phase, SymbolKind, System, Terminal};
use grm_turtle::{Interpreter, Turtle, TurtleConfig};

use crate::error::{ExpandError, ExpandErrorKind, SampleError};

/// Which productions of a symbol apply.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Which {
    /// The normal groups (skeleton and geometry phases).
    Normal,
    /// The wrap-up groups (closing open skeleton symbols).
    Wrapup,
}

/// The compiled system with the per-symbol facts the sampler needs.
#[derive(Debug)]
pub(crate) struct Grammar<'a> {
    pub sys: &'a CompiledSystem,
    /// Per symbol: its terminal, or `None` for a non-terminal.
    pub ops: Vec<Option<Terminal>>,
    /// Per symbol: its declared phase.
    pub phase: Vec<Phase>,
    /// Per symbol: parameter words.
    pub words: Vec<u32>,
    /// Per symbol: whether one of its normal productions' successors holds
    /// a bone-drawing terminal (`F`, `G`): the symbols whose expansions
    /// are drawn as several candidates (`SampleOptions::candidates`).
    pub can_bone: Vec<bool>,
    /// Per symbol: a skeleton symbol with productions none of which can
    /// ever lead to a bone or finish ([`System::skeleton_grows`], W0015).
    /// A particle whose open symbols are all such is done searching.
    pub dead: Vec<bool>,
    pub cfg: TurtleConfig,
}

/// Per-thread scratch space: reused for every expansion, so expanding
/// allocates only what the result keeps.
#[derive(Debug)]
pub(crate) struct Worker {
    pub vm: Vm,
    pub interp: Interpreter,
    /// The successor being interpreted.
    pub scratch: ModuleString,
    /// Binding words of the group being tried.
    pub bind: Vec<f32>,
    /// Cumulative weights.
    pub cum: Vec<f32>,
    /// The successor's parameter words.
    pub params: Vec<f32>,
    /// The parameters of the non-terminal being expanded.
    pub input: Vec<f32>,
    /// Non-terminals met while interpreting: (module offset, frame).
    pub users: Vec<(u32, Turtle)>,
    /// Bones made while interpreting: (base, tip).
    pub bones: Vec<(Vec3, Vec3)>,
    /// Whether a bone had a non-finite end (dropped by the interpreter).
    pub non_finite: bool,
    /// Candidate expansions of one step (`Sampler::advance`): per
    /// candidate its alternative, parameter words and planned bones.
    pub cand_alt: Vec<u32>,
    pub cand_params: Vec<Vec<f32>>,
    pub cand_plans: Vec<Vec<grm_guide::BonePlan>>,
    /// Per candidate: its successor's non-terminal frames and bones (as
    /// `users`, `bones` and `non_finite`).
    pub cand_users: Vec<Vec<(u32, Turtle)>>,
    pub cand_bones: Vec<Vec<(Vec3, Vec3)>>,
    pub cand_non_finite: Vec<bool>,
    /// Per candidate: its log selection weight.
    pub cand_logv: Vec<f64>,
    /// Whether an expansion's new open symbols all go to the end of the
    /// open list (the expanded one's slot is removed), so that the newest
    /// are last (`Reach::recent`); otherwise the first takes the slot.
    pub append_spawns: bool,
    /// The covering tubes at open symbols' positions, remembered
    /// (`crate::tubes_memo`).
    pub tubes: crate::tubes_memo::TubesMemo,
    /// The persistent edits' view of the successor being written
    /// (`crate::edits::Replay::successor`; untouched without a plan).
    pub succ: crate::edits::SuccEdits,
}

/// The terminal of symbol `sym`, if it is one.
fn ops_of(system: &System, sym: u32) -> Option<Terminal> {
    match system.symbols.get(sym as usize)?.kind {
        SymbolKind::Terminal(t) => Some(t),
        SymbolKind::User => None,
    }
}

impl<'a> Grammar<'a> {
    pub fn new(system: &System, sys: &'a CompiledSystem) -> Grammar<'a> {
        let ops = system.terminals();
        let phase = system.symbols.iter().map(|s| s.phase).collect();
        let words = sys.symbols.iter().map(|s| s.param_words).collect();
        let can_bone = sys
            .symbols
            .iter()
            .map(|s| {
                let first = s.first_group as usize;
                let groups = sys
                    .groups
                    .get(first..first + s.group_count as usize)
                    .unwrap_or(&[]);
                groups.iter().any(|g| {
                    let a0 = g.first_alt as usize;
                    let alts = sys.alts.get(a0..a0 + g.alt_count as usize).unwrap_or(&[]);
                    alts.iter().any(|a| {
                        sys.successor(a).iter().any(|m| {
                            matches!(
                                ops_of(system, m.symbol),
                                Some(Terminal::Forward | Terminal::ForwardNoVertex)
                            )
                        })
                    })
                })
            })
            .collect();
        let grows = system.skeleton_grows();
        let dead = system
            .symbols
            .iter()
            .zip(&grows)
            .map(|(s, g)| s.phase == Phase::Skeleton && !s.groups.is_empty() && !g)
            .collect();
        Grammar {
            sys,
            ops,
            phase,
            words,
            can_bone,
            dead,
            cfg: TurtleConfig::from_settings(&sys.settings),
        }
    }

    pub fn worker(&self) -> Worker {
        Worker {
            vm: Vm::new(),
            interp: Interpreter::from_parts(self.ops.clone(), self.cfg),
            scratch: ModuleString::new(),
            bind: Vec::new(),
            cum: Vec::new(),
            params: Vec::new(),
            input: Vec::new(),
            users: Vec::new(),
            bones: Vec::new(),
            non_finite: false,
            cand_alt: Vec::new(),
            cand_params: Vec::new(),
            cand_plans: Vec::new(),
            cand_users: Vec::new(),
            cand_bones: Vec::new(),
            cand_non_finite: Vec::new(),
            cand_logv: Vec::new(),
            append_spawns: false,
            tubes: crate::tubes_memo::TubesMemo::new(),
            succ: crate::edits::SuccEdits::default(),
        }
    }

    /// The initial turtle (identity frame, the system's width).
    pub fn initial_turtle(&self) -> Turtle {
        Turtle::new(&self.cfg)
    }

    pub fn is_skeleton(&self, sym: u32) -> bool {
        self.phase.get(sym as usize) == Some(&Phase::Skeleton)
    }

    pub fn is_geometry(&self, sym: u32) -> bool {
        self.phase.get(sym as usize) == Some(&Phase::Geometry)
    }

    pub fn symbol_name(&self, sym: u32) -> String {
        self.sys
            .symbol_names
            .get(sym as usize)
            .cloned()
            .unwrap_or_else(|| format!("#{sym}"))
    }

    /// The parameter words of module `module` of alternative `alt`'s
    /// successor, within `params` (the successor's words).
    pub fn module_params<'p>(&self, alt: u32, module: u32, params: &'p [f32]) -> &'p [f32] {
        let Some(a) = self.sys.alts.get(alt as usize) else {
            return &[];
        };
        let Some(m) = self.sys.succ.get(a.succ_offset as usize + module as usize) else {
            return &[];
        };
        let w = self.words.get(m.symbol as usize).copied().unwrap_or(0) as usize;
        let s = m.word_offset as usize;
        params.get(s..s + w).unwrap_or(&[])
    }

    pub(crate) fn error(
        &self,
        phase: &'static str,
        sym: u32,
        kind: ExpandErrorKind,
        span: grm_diag::Span,
    ) -> SampleError {
        SampleError::Runtime(ExpandError {
            phase,
            symbol: self.symbol_name(sym),
            kind,
            file: self.sys.file,
            span,
        })
    }

    fn fault(&self, phase: &'static str, sym: u32, e: grm_compile::vm::VmError) -> SampleError {
        let span = self.sys.span_at(e.pc).unwrap_or(self.sys.span);
        self.error(phase, sym, ExpandErrorKind::Fault(e), span)
    }

    /// The first group (normal or wrap-up) of non-terminal `sym` with
    /// parameters `params` whose condition holds, its bindings left in
    /// `w.bind`; `None` when none applies.
    fn group(
        &self,
        w: &mut Worker,
        sym: u32,
        params: &[f32],
        which: Which,
        draws: &DrawCtx,
        phase: &'static str,
    ) -> Result<Option<&'a GroupHeader>, SampleError> {
        let sys: &'a CompiledSystem = self.sys;
        let Some(s) = sys.symbols.get(sym as usize) else {
            return Ok(None);
        };
        let (first, count) = match which {
            Which::Normal => (s.first_group, s.group_count),
            Which::Wrapup => (s.first_wrapup, s.wrapup_count),
        };
        let groups = sys
            .groups
            .get(first as usize..first as usize + count as usize)
            .unwrap_or(&[]);
        for g in groups {
            // Sample systems have no contexts: the bindings are the
            // predecessor's parameters.
            w.bind.clear();
            w.bind.resize(g.bind_words as usize, 0.0);
            if g.pred_bind_words > 0 {
                let o = g.pred_bind_offset as usize;
                let n = (g.pred_bind_words as usize).min(params.len());
                if let Some(dst) = w.bind.get_mut(o..o + n) {
                    dst.copy_from_slice(&params[..n]);
                }
            }
            if g.cond_code != NONE {
                let c =
                    w.vm.run1(&sys.code, &sys.consts, g.cond_code, &w.bind, draws)
                        .map_err(|e| self.fault(phase, sym, e))?;
                if c == 0.0 {
                    continue;
                }
            }
            return Ok(Some(g));
        }
        Ok(None)
    }

    /// Among group `g`'s alternatives, the one drawn with draw index 0
    /// (with the group's bindings in `w.bind`).
    fn draw(
        &self,
        w: &mut Worker,
        sym: u32,
        g: &GroupHeader,
        draws: &DrawCtx,
        phase: &'static str,
    ) -> Result<u32, SampleError> {
        let sys = self.sys;
        if g.alt_count == 1 {
            return Ok(g.first_alt);
        }
        select::choose_alternative(sys, g, &mut w.vm, &w.bind, draws, &mut w.cum).map_err(|e| {
            match e {
                AltError::Fault(e) => self.fault(phase, sym, e),
                AltError::BadWeight { value, alt } => self.error(
                    phase,
                    sym,
                    ExpandErrorKind::BadWeight { value },
                    sys.weight_spans[alt as usize],
                ),
            }
        })
    }

    /// Choose the production for non-terminal `sym` with parameters
    /// `params`: the first group (normal or wrap-up) whose condition holds,
    /// and among its alternatives the one drawn with draw index 0. Leaves
    /// the group's bindings in `w.bind`. `None` when no group applies (the
    /// module stays as it is).
    pub fn choose(
        &self,
        w: &mut Worker,
        sym: u32,
        params: &[f32],
        which: Which,
        draws: &DrawCtx,
        phase: &'static str,
    ) -> Result<Option<u32>, SampleError> {
        match self.group(w, sym, params, which, draws, phase)? {
            Some(g) => self.draw(w, sym, g, draws, phase).map(Some),
            None => Ok(None),
        }
    }

    /// [`Self::choose`] with the `force`-th alternative (from 1) of the
    /// group that applies imposed by a persistent edit: the group's
    /// condition as written, its weights and the draw ignored; a group
    /// with fewer alternatives is drawn as written (the edit is stale).
    #[allow(clippy::too_many_arguments)]
    pub fn choose_forced(
        &self,
        w: &mut Worker,
        sym: u32,
        params: &[f32],
        which: Which,
        draws: &DrawCtx,
        phase: &'static str,
        force: u32,
    ) -> Result<Option<u32>, SampleError> {
        match self.group(w, sym, params, which, draws, phase)? {
            Some(g) if force <= g.alt_count => Ok(Some(g.first_alt + force - 1)),
            Some(g) => self.draw(w, sym, g, draws, phase).map(Some),
            None => Ok(None),
        }
    }

    /// Evaluate alternative `alt`'s successor parameters into `w.params`,
    /// with the bindings `choose` left in `w.bind`.
    pub fn eval_successor(
        &self,
        w: &mut Worker,
        sym: u32,
        alt: u32,
        draws: &DrawCtx,
        phase: &'static str,
    ) -> Result<(), SampleError> {
        let sys = self.sys;
        w.params.clear();
        let Some(a) = sys.alts.get(alt as usize) else {
            return Ok(());
        };
        w.params.reserve(a.succ_words as usize);
        for m in sys.successor(a) {
            for p in sys.module_params(m) {
                let n = p.words as usize;
                let at = w.params.len();
                match p.kind {
                    PARAM_CONST => {
                        let c = sys
                            .consts
                            .get(p.a as usize..p.a as usize + n)
                            .unwrap_or(&[]);
                        w.params.extend_from_slice(c);
                    }
                    PARAM_COPY => {
                        let c = w.bind.get(p.a as usize..p.a as usize + n).unwrap_or(&[]);
                        w.params.extend_from_slice(c);
                    }
                    _ => {
                        let v =
                            w.vm.run(&sys.code, &sys.consts, p.a, &w.bind, draws)
                                .map_err(|e| self.fault(phase, sym, e))?;
                        w.params.extend_from_slice(&v[..n.min(v.len())]);
                    }
                }
                // Keep the layout even if a table was short.
                w.params.resize(at + n, 0.0);
                if let Some(&bad) = w.params[at..].iter().find(|x| !x.is_finite()) {
                    let span = sys
                        .param_spans
                        .get(p.span as usize)
                        .copied()
                        .unwrap_or(sys.span);
                    return Err(self.error(
                        phase,
                        sym,
                        ExpandErrorKind::NonFinite { value: bad },
                        span,
                    ));
                }
            }
        }
        Ok(())
    }

    /// Interpret alternative `alt`'s successor with the parameter words in
    /// `w.params` from the frame `start`: fills `w.bones` and `w.users`, and
    /// sets `w.non_finite` when a bone was not finite.
    pub fn interpret(&self, w: &mut Worker, alt: u32, start: &Turtle) -> Result<(), SampleError> {
        let sys = self.sys;
        w.bones.clear();
        w.users.clear();
        w.non_finite = false;
        let Some(a) = sys.alts.get(alt as usize) else {
            return Ok(());
        };
        let s = &mut w.scratch;
        s.clear();
        // Modules a persistent edit removed are not interpreted (set by
        // `Replay::successor` for this successor only).
        let removing = std::mem::take(&mut w.succ.removing);
        for (j, m) in sys.successor(a).iter().enumerate() {
            if removing && w.succ.mods.get(j).is_some_and(|e| e.removed) {
                continue;
            }
            let n = self.words.get(m.symbol as usize).copied().unwrap_or(0) as usize;
            let o = m.word_offset as usize;
            s.push(m.symbol, w.params.get(o..o + n).unwrap_or(&[]));
        }
        let out = &mut w.interp.collector.out;
        out.bones.clear();
        out.instances.clear();
        out.polygons.clear();
        out.polygon_vertices.clear();
        out.warnings = Default::default();
        let users = &mut w.users;
        w.interp
            .run_range(*start, &w.scratch, 0..w.scratch.len(), &mut |i, t| {
                users.push((i as u32, *t));
            })
            .map_err(|e| SampleError::Turtle(e.to_string()))?;
        if removing {
            // Back to successor positions.
            for u in &mut w.users {
                u.0 = w.succ.kept.get(u.0 as usize).copied().unwrap_or(u.0);
            }
        }
        let out = &w.interp.collector.out;
        w.bones.extend(out.bones.iter().map(|b| (b.base, b.tip)));
        w.non_finite = out.warnings.non_finite > 0;
        Ok(())
    }
}
