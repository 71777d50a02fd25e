//! Lowering a checked system to a [`CompiledSystem`].

use std::collections::HashMap;

use grm_diag::{Code, Diagnostic, FileId, Span};
use grm_sema::{
    BinaryOp, Builtin, Group, Program, RandomFn, SymbolKind, System, TContextItem, TExpr,
    TExprKind, TModule, TPattern, Terminal, Ty, UnaryOp, Value,
};

use crate::compiled::CompiledSystem;
use crate::op::{MAX_OPERAND, Op};
use crate::table::*;
use crate::verify::{VerifyErrorKind, verify_expr};

/// Why a system could not be compiled. Every error names a place in the
/// system's file.
#[derive(Clone, Debug, PartialEq)]
pub struct CompileError {
    pub kind: CompileErrorKind,
    pub file: FileId,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum CompileErrorKind {
    /// The program still has checker errors (it must not be lowered).
    HasErrors,
    /// The meta-parameter values do not fit the program (count or type), or
    /// a constant could not be evaluated with them.
    Params(String),
    /// A setting is invalid for the given meta-parameter values.
    Settings(String),
    /// A constant module parameter that is NaN or infinite in f32.
    NonFiniteConstant { value: f64 },
    /// A constant weight that is not a positive finite number.
    BadWeight { value: f64 },
    /// An expression that needs more stack than [`crate::op::STACK_SIZE`].
    TooDeep { depth: u32 },
    /// A table or index beyond what the 24-bit operands or 32-bit offsets hold.
    TooLarge { what: &'static str },
    /// `[` or `]` in a left context (not supported).
    LeftContextBracket,
    /// The axiom refers to a module parameter.
    AxiomBinding,
    /// A shape system (`mode = shape`): it has no bytecode; `grm_grow::
    /// shape` grows it.
    ShapeSystem,
}

impl CompileError {
    /// The stable code of this error (`R01xx`: lowering).
    pub fn code(&self) -> Code {
        match self.kind {
            CompileErrorKind::HasErrors => Code::CompiledWithErrors,
            CompileErrorKind::Params(_) => Code::ParamValues,
            CompileErrorKind::Settings(_) => Code::SettingForParams,
            CompileErrorKind::NonFiniteConstant { .. } => Code::NonFiniteConstant,
            CompileErrorKind::BadWeight { .. } => Code::InvalidConstantWeight,
            CompileErrorKind::TooDeep { .. } => Code::ExprNeedsTooMuchStack,
            CompileErrorKind::TooLarge { .. } => Code::TablesTooLarge,
            CompileErrorKind::LeftContextBracket => Code::LeftContextBracket,
            CompileErrorKind::AxiomBinding => Code::AxiomBinding,
            CompileErrorKind::ShapeSystem => Code::NotShapeRunnable,
        }
    }

    /// The error as a diagnostic: its code, the message, the primary label
    /// on the span it names and a help line.
    pub fn to_diagnostic(&self) -> Diagnostic {
        let (label, help) = match &self.kind {
            CompileErrorKind::HasErrors => ("this has errors", INTERNAL),
            CompileErrorKind::Params(_) => ("in this system", INTERNAL),
            CompileErrorKind::Settings(_) => (
                "invalid for these meta-parameter values",
                "choose meta-parameter values (`--param`) for which the setting is valid",
            ),
            CompileErrorKind::NonFiniteConstant { value } if value.is_nan() => (
                "this is not a number (NaN)",
                "a function was given an argument outside its domain (`sqrt` or `log` of a negative number, `acos` or `asin` beyond -1..1, `0 * inf`): change the argument",
            ),
            CompileErrorKind::NonFiniteConstant { value } if value.is_infinite() => (
                "this is infinite",
                "the value is past the largest 32-bit float (about 3.4e38), or infinite (a division by zero, `ln(0)` or `log10(0)`): change the expression",
            ),
            CompileErrorKind::NonFiniteConstant { .. } => (
                "this is not finite in 32-bit float",
                "32-bit floats hold magnitudes up to about 3.4e38: scale the value down",
            ),
            CompileErrorKind::BadWeight { .. } => (
                "this weight",
                "weights must be positive finite 32-bit numbers (at most about 3.4e38)",
            ),
            CompileErrorKind::TooDeep { .. } => (
                "this expression",
                "nest it less deeply on the right: `((a + b) + c) + d` needs less stack than `a + (b + (c + d))`",
            ),
            CompileErrorKind::TooLarge { .. } => (
                "in this system",
                "split the system, or use fewer spline controls or `choose` alternatives in one call",
            ),
            CompileErrorKind::LeftContextBracket => ("this bracket", INTERNAL),
            CompileErrorKind::AxiomBinding => ("this refers to a module parameter", INTERNAL),
            CompileErrorKind::ShapeSystem => (
                "a shape system",
                "grow it with `grmc derive FILE -o model.glb` (shape systems are run by the shape engine, not as bytecode)",
            ),
        };
        Diagnostic::new(self.code(), self.to_string(), self.file, self.span, label).with_help(help)
    }
}

/// The help line of errors that only a bug in grm can cause.
const INTERNAL: &str =
    "this is an internal error of grm; please report it with the file that caused it";

impl std::fmt::Display for CompileError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.kind {
            CompileErrorKind::HasErrors => {
                f.write_str("the program has errors and cannot be compiled")
            }
            CompileErrorKind::Params(m) => write!(f, "meta-parameters: {m}"),
            CompileErrorKind::Settings(m) => write!(f, "setting: {m}"),
            CompileErrorKind::NonFiniteConstant { value } if value.is_nan() => {
                f.write_str("module parameter is NaN (not a number)")
            }
            CompileErrorKind::NonFiniteConstant { value } if value.is_infinite() => {
                write!(f, "module parameter is {}", number(*value))
            }
            CompileErrorKind::NonFiniteConstant { value } => write!(
                f,
                "module parameter {} is not finite in 32-bit float",
                number(*value)
            ),
            CompileErrorKind::BadWeight { value } => write!(
                f,
                "weight {} is not a positive finite 32-bit number",
                number(*value)
            ),
            CompileErrorKind::TooDeep { depth } => write!(
                f,
                "expression needs {depth} stack slots; at most {} are available",
                crate::op::STACK_SIZE
            ),
            CompileErrorKind::TooLarge { what } => write!(f, "too many {what} for the tables"),
            CompileErrorKind::LeftContextBracket => {
                f.write_str("brackets in a left context are not supported")
            }
            CompileErrorKind::AxiomBinding => f.write_str("the axiom refers to a module parameter"),
            CompileErrorKind::ShapeSystem => {
                f.write_str("a shape system (`mode = shape`) has no bytecode")
            }
        }
    }
}

impl std::error::Error for CompileError {}

/// A number as a message shows it: very large or small magnitudes in
/// exponent form (`1e60`, not sixty digits).
fn number(v: f64) -> String {
    if v.is_finite() && v != 0.0 && !(1e-6..1e16).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// The errors compiling finds in a program checked without errors: every
/// system of the checked file (not of its imports: they are reported when
/// those files are checked) compiled with the meta-parameters' defaults,
/// as diagnostics
/// (`grmc check` and the editor report them beside the checker's). Empty
/// for a program with errors (it cannot be compiled; its errors say why).
pub fn check(checked: &grm_sema::Checked) -> Vec<Diagnostic> {
    if checked.has_errors() {
        return Vec::new();
    }
    let program = &checked.program;
    let params = program.default_params();
    program
        .systems
        .iter()
        .filter(|s| s.file == program.root && s.mode != grm_sema::Mode::Shape)
        .filter_map(|s| compile_reporting_all(program, s, &params).err())
        .flatten()
        .map(|e| e.to_diagnostic())
        .collect()
}

/// Compile `system` of `program` with the meta-parameter values `params`
/// (indexed by `grm_sema::ParamId`; [`Program::default_params`] gives the
/// defaults). The program must have been checked without errors.
pub fn compile(
    program: &Program,
    system: &System,
    params: &[Value],
) -> Result<CompiledSystem, CompileError> {
    compile_reporting_all(program, system, params).map_err(|mut es| es.swap_remove(0))
}

/// [`compile`], with every module parameter that is not finite (R0104)
/// reported rather than the first only: lowering goes on past them (each
/// stands for a NaN in the pool, never used since the result is an
/// error), and stops at any other error. `Err` is never empty; its first
/// error is the first in the source's lowering order.
fn compile_reporting_all(
    program: &Program,
    system: &System,
    params: &[Value],
) -> Result<CompiledSystem, Vec<CompileError>> {
    let mut deferred = Vec::new();
    let out = lower(program, system, params, &mut deferred).map_err(|e| {
        let mut all = std::mem::take(&mut deferred);
        all.push(e);
        all
    })?;
    if deferred.is_empty() {
        Ok(out)
    } else {
        Err(deferred)
    }
}

fn lower(
    program: &Program,
    system: &System,
    params: &[Value],
    deferred: &mut Vec<CompileError>,
) -> Result<CompiledSystem, CompileError> {
    let file = system.file;
    let err = |kind, span| CompileError { kind, file, span };
    if system.mode == grm_sema::Mode::Shape {
        return Err(err(CompileErrorKind::ShapeSystem, system.loc.span));
    }
    if params.len() != program.params.len() {
        return Err(err(
            CompileErrorKind::Params(format!(
                "{} values given for {} meta-parameters",
                params.len(),
                program.params.len()
            )),
            system.loc.span,
        ));
    }
    for (p, v) in program.params.iter().zip(params) {
        if p.ty != v.ty() {
            return Err(err(
                CompileErrorKind::Params(format!(
                    "`{}` is `{}`, the value given is `{}`",
                    p.name,
                    p.ty,
                    v.ty()
                )),
                system.loc.span,
            ));
        }
    }
    let globals = program
        .global_values(params)
        .map_err(|e| err(CompileErrorKind::Params(e.to_string()), system.loc.span))?;
    let settings = system
        .settings_at(params, &globals)
        .map_err(|(m, at)| err(CompileErrorKind::Settings(m), at))?;

    let mut lw = Lowerer {
        system,
        params,
        globals: &globals,
        file,
        out: CompiledSystem {
            name: system.name.clone(),
            file,
            span: system.loc.span,
            settings,
            param_values: params.to_vec(),
            symbols: Vec::with_capacity(system.symbols.len()),
            symbol_names: system.symbols.iter().map(|s| s.name.clone()).collect(),
            groups: Vec::new(),
            alts: Vec::new(),
            context: Vec::new(),
            succ: Vec::new(),
            params: Vec::new(),
            code: Vec::new(),
            consts: Vec::new(),
            spans: Vec::new(),
            param_spans: Vec::new(),
            group_spans: Vec::new(),
            weight_spans: Vec::new(),
            alt_spans: Vec::new(),
            axiom_alt: 0,
            draws: 1,
            max_bind_words: 0,
        },
        const_index: HashMap::new(),
        slot_words: Vec::new(),
        bind_words: 0,
        deferred,
        group_ordinal: 0,
        local_draw: 1,
    };
    lw.symbols();
    for (i, sym) in system.symbols.iter().enumerate() {
        let first = lw.out.groups.len() as u32;
        for g in &sym.groups {
            lw.group_ordinal = lw.out.groups.len() as u32 - first;
            lw.group(g.index(), &system.groups[g.index()])?;
        }
        let count = lw.out.groups.len() as u32 - first;
        let first_wrapup = lw.out.groups.len() as u32;
        for g in &sym.wrapup_groups {
            lw.group_ordinal = lw.out.groups.len() as u32 - first;
            lw.group(g.index(), &system.groups[g.index()])?;
        }
        let wrapups = lw.out.groups.len() as u32 - first_wrapup;
        let e = &mut lw.out.symbols[i];
        e.first_group = first;
        e.group_count = count;
        e.first_wrapup = first_wrapup;
        e.wrapup_count = wrapups;
    }
    // The axiom: one more alternative, with no bindings; its draws are
    // ordinal 0 of the root key.
    lw.slot_words.clear();
    lw.bind_words = 0;
    lw.group_ordinal = 0;
    lw.local_draw = 1;
    let axiom_span = system
        .axiom
        .first()
        .map(|m| m.span.to(system.axiom.last().map_or(m.span, |l| l.span)))
        .unwrap_or(system.loc.span);
    let (succ_offset, succ_len, succ_words, no_code) = lw.successor(&system.axiom, true, 0)?;
    lw.out.axiom_alt = lw.out.alts.len() as u32;
    lw.out.alts.push(AltHeader {
        group: NONE,
        weight_code: NONE,
        weight: 1.0,
        cum_weight: 1.0,
        succ_offset,
        succ_len,
        succ_words,
        flags: if no_code { ALT_NO_CODE } else { 0 },
    });
    lw.out.weight_spans.push(axiom_span);
    lw.out.alt_spans.push(axiom_span);
    let out = lw.out;
    if out.code.len() > u32::MAX as usize / 2 || out.succ.len() > u32::MAX as usize / 2 {
        return Err(err(
            CompileErrorKind::TooLarge { what: "code words" },
            system.span,
        ));
    }
    debug_assert!(out.validate().is_ok(), "{:?}", out.validate());
    Ok(out)
}

fn width(ty: Ty) -> u32 {
    if ty == Ty::Vec3 { 3 } else { 1 }
}

struct Lowerer<'a> {
    system: &'a System,
    params: &'a [Value],
    globals: &'a [Value],
    file: FileId,
    out: CompiledSystem,
    /// Scalar constants already in the pool, by bit pattern.
    const_index: HashMap<u32, u32>,
    /// For the group being lowered: binding word offset of each slot.
    slot_words: Vec<u32>,
    bind_words: u32,
    /// Errors that do not stop lowering (module parameters that are not
    /// finite), in the order found.
    deferred: &'a mut Vec<CompileError>,
    /// The group being lowered: its ordinal among its symbol's groups and
    /// its next local draw index (`crate::rng::draw_index`).
    group_ordinal: u32,
    local_draw: u32,
}

impl Lowerer<'_> {
    fn err(&self, kind: CompileErrorKind, span: Span) -> CompileError {
        CompileError {
            kind,
            file: self.file,
            span,
        }
    }

    fn symbols(&mut self) {
        let mut ignored = vec![false; self.system.symbols.len()];
        for id in &self.system.ignore {
            if let Some(x) = ignored.get_mut(id.index()) {
                *x = true;
            }
        }
        for (i, s) in self.system.symbols.iter().enumerate() {
            let words: u32 = s.params.iter().map(|t| width(*t)).sum();
            let mut flags = 0;
            if let SymbolKind::Terminal(t) = s.kind {
                flags |= SYM_TERMINAL;
                if t == Terminal::Push {
                    flags |= SYM_PUSH;
                }
                if t == Terminal::Pop {
                    flags |= SYM_POP;
                }
            }
            if ignored[i] {
                flags |= SYM_IGNORED;
            }
            self.out.symbols.push(SymbolEntry {
                first_group: 0,
                group_count: 0,
                first_wrapup: 0,
                wrapup_count: 0,
                param_words: words,
                flags,
            });
        }
    }

    /// Lay out the binding slots of a pattern; returns (words bound, offset).
    fn bind_pattern(&mut self, p: &TPattern) -> (u32, u32) {
        let offset = self.bind_words;
        if p.binds == 0 {
            return (0, offset);
        }
        let sym = &self.system.symbols[p.symbol.index()];
        for (k, ty) in sym.params.iter().enumerate() {
            let slot = p.first_slot as usize + k;
            if self.slot_words.len() <= slot {
                self.slot_words.resize(slot + 1, 0);
            }
            self.slot_words[slot] = self.bind_words;
            self.bind_words += width(*ty);
        }
        (self.bind_words - offset, offset)
    }

    fn context(&mut self, items: &[TContextItem], left: bool) -> Result<(u32, u32), CompileError> {
        let offset = self.out.context.len() as u32;
        for it in items {
            let rec = match it {
                TContextItem::Pattern(p) => {
                    let (bind_words, bind_offset) = self.bind_pattern(p);
                    ContextItem {
                        kind: CTX_SYMBOL,
                        symbol: p.symbol.0,
                        bind_words,
                        bind_offset,
                    }
                }
                TContextItem::Push(s) | TContextItem::Pop(s) => {
                    if left {
                        return Err(self.err(CompileErrorKind::LeftContextBracket, *s));
                    }
                    let kind = if matches!(it, TContextItem::Push(_)) {
                        CTX_PUSH
                    } else {
                        CTX_POP
                    };
                    ContextItem {
                        kind,
                        symbol: 0,
                        bind_words: 0,
                        bind_offset: 0,
                    }
                }
            };
            self.out.context.push(rec);
        }
        Ok((offset, items.len() as u32))
    }

    fn group(&mut self, sema_index: usize, g: &Group) -> Result<(), CompileError> {
        self.slot_words.clear();
        self.bind_words = 0;
        self.local_draw = 1;
        let (left_offset, left_len) = self.context(&g.left, true)?;
        let (pred_bind_words, pred_bind_offset) = self.bind_pattern(&g.pred);
        let (right_offset, right_len) = self.context(&g.right, false)?;
        let first_span = g.alternatives.first().map_or(g.pred.span, |a| a.span);
        let cond_code = match &g.condition {
            Some(c) => self.expr_entry(c, Some(1))?,
            None => NONE,
        };
        let first_alt = self.out.alts.len() as u32;
        let group_index = self.out.groups.len() as u32;
        let mut all_const = true;
        let mut total = 0.0f32;
        for (alt_index, alt) in g.alternatives.iter().enumerate() {
            let (weight_code, weight) = match alt.weight.constant() {
                Some(v) => {
                    let w = v.as_float().unwrap_or(f64::NAN);
                    let wf = w as f32;
                    if !(wf.is_finite() && wf > 0.0) {
                        return Err(
                            self.err(CompileErrorKind::BadWeight { value: w }, alt.weight.span)
                        );
                    }
                    (NONE, wf)
                }
                None => {
                    all_const = false;
                    (self.expr_entry(&alt.weight, Some(1))?, 0.0)
                }
            };
            total += weight;
            let (succ_offset, succ_len, succ_words, no_code) =
                self.successor(&alt.successor, false, alt_index as u32)?;
            self.out.alts.push(AltHeader {
                group: group_index,
                weight_code,
                weight,
                cum_weight: if all_const { total } else { 0.0 },
                succ_offset,
                succ_len,
                succ_words,
                flags: if no_code { ALT_NO_CODE } else { 0 },
            });
            self.out.weight_spans.push(if alt.weight_written {
                alt.weight.span
            } else {
                alt.span
            });
            self.out.alt_spans.push(alt.span);
        }
        if !all_const {
            for a in &mut self.out.alts[first_alt as usize..] {
                a.cum_weight = 0.0;
            }
            total = 0.0;
        } else if !total.is_finite() {
            // The weights add up past f32: the same draw on weights scaled
            // by an exact power of two (`table::WEIGHT_SCALE`).
            total = 0.0;
            for a in &mut self.out.alts[first_alt as usize..] {
                total += a.weight * crate::table::WEIGHT_SCALE;
                a.cum_weight = total;
            }
        }
        let mut flags = 0;
        if g.has_context() {
            flags |= GROUP_CONTEXT;
        }
        if all_const {
            flags |= GROUP_CONST_WEIGHTS;
        }
        if g.wrapup {
            flags |= GROUP_WRAPUP;
        }
        self.out.max_bind_words = self.out.max_bind_words.max(self.bind_words);
        self.out.groups.push(GroupHeader {
            pred: g.pred.symbol.0,
            flags,
            left_offset,
            left_len,
            right_offset,
            right_len,
            bind_words: self.bind_words,
            pred_bind_offset,
            pred_bind_words,
            cond_code,
            first_alt,
            alt_count: g.alternatives.len() as u32,
            total_weight: total,
            sema_group: sema_index as u32,
        });
        self.out
            .group_spans
            .push(g.condition.as_ref().map_or(first_span, |c| c.span));
        Ok(())
    }

    /// Lower a successor (or the axiom), the `alternative`-th of its group
    /// (0 for the axiom): (offset, modules, words, no code).
    fn successor(
        &mut self,
        modules: &[TModule],
        axiom: bool,
        alternative: u32,
    ) -> Result<(u32, u32, u32, bool), CompileError> {
        let offset = self.out.succ.len() as u32;
        let mut words = 0u32;
        let mut no_code = true;
        // Per symbol: modules of it seen so far in this successor.
        let mut seen: HashMap<u32, u32> = HashMap::new();
        for m in modules {
            let occurrence = seen.entry(m.symbol.0).or_insert(0);
            let name = self
                .system
                .symbols
                .get(m.symbol.index())
                .map_or("", |s| s.name.as_str());
            let salt = crate::rng::salt(crate::rng::name_hash(name), *occurrence, alternative);
            *occurrence += 1;
            let first_param = self.out.params.len() as u32;
            let word_offset = words;
            for arg in &m.args {
                if axiom && has_binding(arg) {
                    return Err(self.err(CompileErrorKind::AxiomBinding, arg.span));
                }
                let pe = self.param(arg)?;
                no_code &= pe.kind != PARAM_CODE;
                words += pe.words;
                self.out.params.push(pe);
            }
            self.out.succ.push(SuccModule {
                symbol: m.symbol.0,
                first_param,
                param_count: m.args.len() as u32,
                word_offset,
                salt,
            });
        }
        Ok((offset, modules.len() as u32, words, no_code))
    }

    /// One successor parameter.
    fn param(&mut self, e: &TExpr) -> Result<ParamExpr, CompileError> {
        let w = width(e.ty);
        let span_index = self.out.param_spans.len() as u32;
        self.out.param_spans.push(e.span);
        let value = match &e.kind {
            TExprKind::Lit(v) => Some(*v),
            TExprKind::Param(p) => self.params.get(p.index()).copied(),
            TExprKind::Global(c) => self.globals.get(c.index()).copied(),
            _ => None,
        };
        if let Some(v) = value.or_else(|| self.fold(e)) {
            let a = self.constant(&v, e.span, true)?;
            return Ok(ParamExpr {
                kind: PARAM_CONST,
                a,
                words: w,
                span: span_index,
            });
        }
        if let TExprKind::ModuleParam(slot) = e.kind
            && let Some(&word) = self.slot_words.get(slot as usize)
        {
            return Ok(ParamExpr {
                kind: PARAM_COPY,
                a: word,
                words: w,
                span: span_index,
            });
        }
        let entry = self.expr_entry(e, Some(w))?;
        Ok(ParamExpr {
            kind: PARAM_CODE,
            a: entry,
            words: w,
            span: span_index,
        })
    }

    /// The value of an expression that reads neither module parameters nor
    /// random draws (meta-parameters and constants are fixed for one
    /// compilation), folded in f64 with the checker's semantics.
    fn fold(&self, e: &TExpr) -> Option<Value> {
        if matches!(e.kind, TExprKind::ModuleParam(_) | TExprKind::Random(..)) {
            return None;
        }
        let env = grm_sema::eval::Env {
            params: self.params,
            globals: self.globals,
            bindings: &[],
        };
        grm_sema::eval::eval(e, &env).ok()
    }

    /// Put a constant value in the pool; returns its index. With `finite`,
    /// a value that is NaN or infinite in f32 is an error (module
    /// parameters); inside code it is a legal operand.
    fn constant(&mut self, v: &Value, span: Span, finite: bool) -> Result<u32, CompileError> {
        let xs: Vec<f64> = match *v {
            Value::Float(x) => vec![x],
            Value::Vec3(xs) => xs.to_vec(),
            Value::Bool(b) => vec![if b { 1.0 } else { 0.0 }],
            Value::Mesh(m) => vec![f64::from(m.0)],
            Value::Material(m) => vec![f64::from(m.0)],
        };
        // Reported, and lowering goes on to find the others (the result
        // is an error anyway: see `compile_reporting_all`).
        if finite && let Some(&x) = xs.iter().find(|x| !(**x as f32).is_finite()) {
            let e = self.err(CompileErrorKind::NonFiniteConstant { value: x }, span);
            self.deferred.push(e);
        }
        if let [x] = xs[..] {
            let bits = (x as f32).to_bits();
            if let Some(&i) = self.const_index.get(&bits) {
                return Ok(i);
            }
            let i = self.out.consts.len() as u32;
            self.out.consts.push(x as f32);
            self.const_index.insert(bits, i);
            return self.check_operand(i, span);
        }
        let i = self.out.consts.len() as u32;
        self.out.consts.extend(xs.iter().map(|&x| x as f32));
        self.check_operand(i, span)
    }

    fn check_operand(&self, x: u32, span: Span) -> Result<u32, CompileError> {
        if x > MAX_OPERAND - 3 {
            Err(self.err(
                CompileErrorKind::TooLarge {
                    what: "constants or draws",
                },
                span,
            ))
        } else {
            Ok(x)
        }
    }

    /// Emit a whole expression ending in `ret`, verify it, return its entry.
    fn expr_entry(&mut self, e: &TExpr, want: Option<u32>) -> Result<u32, CompileError> {
        let entry = self.out.code.len() as u32;
        self.expr(e)?;
        self.emit(Op::Ret, 0, e.span);
        match verify_expr(
            &self.out.code,
            entry,
            self.out.consts.len(),
            self.bind_words,
            want,
        ) {
            Ok(_) => Ok(entry),
            Err(v) => Err(match v.kind {
                VerifyErrorKind::StackOverflow { depth } => {
                    self.err(CompileErrorKind::TooDeep { depth }, e.span)
                }
                // Anything else is a lowering bug or a program with errors.
                _ => self.err(CompileErrorKind::HasErrors, e.span),
            }),
        }
    }

    fn emit(&mut self, op: Op, operand: u32, span: Span) {
        let at = self.out.code.len() as u32;
        let same = self
            .out
            .spans
            .last()
            .is_some_and(|s| s.start == span.start && s.end == span.end);
        if !same {
            self.out.spans.push(SpanEntry {
                code_offset: at,
                start: span.start,
                end: span.end,
            });
        }
        self.out.code.push(op.encode(operand));
    }

    /// Emit `e`, widened to `w` words if it is narrower.
    fn expr_to(&mut self, e: &TExpr, w: u32) -> Result<(), CompileError> {
        let got = self.expr(e)?;
        if got < w {
            self.emit(Op::Splat, 0, e.span);
        }
        Ok(())
    }

    /// The next `n` draw indices of the group being lowered
    /// ([`crate::rng::draw_index`]: local to the group, above its ordinal).
    fn draw(&mut self, n: u32, span: Span) -> Result<u32, CompileError> {
        if self.local_draw + n > 0x1_0000 || self.group_ordinal > 0xFF {
            return Err(self.err(
                CompileErrorKind::TooLarge {
                    what: "random draws",
                },
                span,
            ));
        }
        let d = crate::rng::draw_index(self.group_ordinal, self.local_draw);
        let d = self.check_operand(d, span)?;
        self.local_draw += n;
        self.out.draws = self.out.draws.max(d + n);
        Ok(d)
    }

    /// Emit code leaving the value of `e`; returns its width.
    fn expr(&mut self, e: &TExpr) -> Result<u32, CompileError> {
        let span = e.span;
        let w = width(e.ty);
        if let Some(v) = self.fold(e) {
            let i = self.constant(&v, span, false)?;
            self.emit(if w == 3 { Op::Const3 } else { Op::Const }, i, span);
            return Ok(w);
        }
        match &e.kind {
            TExprKind::Lit(_) | TExprKind::Param(_) | TExprKind::Global(_) => {
                // `fold` evaluates these; failing, the program has errors.
                return Err(self.err(CompileErrorKind::HasErrors, span));
            }
            TExprKind::ModuleParam(slot) => {
                let Some(&word) = self.slot_words.get(*slot as usize) else {
                    return Err(self.err(CompileErrorKind::HasErrors, span));
                };
                self.emit(if w == 3 { Op::Load3 } else { Op::Load }, word, span);
            }
            TExprKind::Unary(op, a) => {
                let aw = self.expr(a)?;
                match op {
                    UnaryOp::Neg => self.emit(Op::Neg, aw, span),
                    UnaryOp::Not => self.emit(Op::Not, 0, span),
                }
            }
            TExprKind::Binary(op, a, b) => {
                use BinaryOp::*;
                let (wa, wb) = (width(a.ty), width(b.ty));
                match op {
                    Add | Sub | Mul | Div | Rem => {
                        let ow = wa.max(wb);
                        self.expr_to(a, ow)?;
                        self.expr_to(b, ow)?;
                        let o = match op {
                            Add => Op::Add,
                            Sub => Op::Sub,
                            Mul => Op::Mul,
                            Div => Op::Div,
                            _ => Op::Rem,
                        };
                        self.emit(o, ow, span);
                    }
                    Eq | Ne => {
                        self.expr(a)?;
                        self.expr(b)?;
                        self.emit(if *op == Eq { Op::Eq } else { Op::Ne }, wa, span);
                    }
                    Lt | Le | Gt | Ge | And | Or => {
                        self.expr(a)?;
                        self.expr(b)?;
                        let o = match op {
                            Lt => Op::Lt,
                            Le => Op::Le,
                            Gt => Op::Gt,
                            Ge => Op::Ge,
                            And => Op::And,
                            _ => Op::Or,
                        };
                        self.emit(o, 0, span);
                    }
                }
            }
            TExprKind::Field(a, i) => {
                self.expr(a)?;
                self.emit(Op::Pick, u32::from(*i), span);
            }
            TExprKind::If(c, a, b) => {
                self.expr(c)?;
                self.expr_to(a, w)?;
                self.expr_to(b, w)?;
                self.emit(Op::Select, w, span);
            }
            TExprKind::Call(f, args) => self.call(*f, args, w, span)?,
            TExprKind::Random(r, args) => self.random(*r, args, w, span)?,
            // Shape values exist only in shape systems, which are never
            // lowered to bytecode.
            TExprKind::Shape(_) | TExprKind::Error => {
                return Err(self.err(CompileErrorKind::HasErrors, span));
            }
        }
        Ok(w)
    }

    fn call(&mut self, f: Builtin, args: &[TExpr], w: u32, span: Span) -> Result<(), CompileError> {
        use Builtin as B;
        let simple = |f| match f {
            B::Sin => Some(Op::Sin),
            B::Cos => Some(Op::Cos),
            B::Tan => Some(Op::Tan),
            B::Asin => Some(Op::Asin),
            B::Acos => Some(Op::Acos),
            B::Atan => Some(Op::Atan),
            B::Atan2 => Some(Op::Atan2),
            B::Sqrt => Some(Op::Sqrt),
            B::Exp => Some(Op::Exp),
            B::Ln => Some(Op::Ln),
            B::Log10 => Some(Op::Log10),
            B::Pow => Some(Op::Pow),
            B::Dot => Some(Op::Dot),
            B::Cross => Some(Op::Cross),
            B::Length => Some(Op::Length),
            B::Normalize => Some(Op::Normalize),
            B::Distance => Some(Op::Distance),
            _ => None,
        };
        let elementwise = |f| match f {
            B::Abs => Some(Op::Abs),
            B::Floor => Some(Op::Floor),
            B::Ceil => Some(Op::Ceil),
            B::Round => Some(Op::Round),
            B::Fract => Some(Op::Fract),
            B::Sign => Some(Op::Sign),
            B::Min => Some(Op::Min),
            B::Max => Some(Op::Max),
            B::Step => Some(Op::Step),
            B::Clamp => Some(Op::Clamp),
            B::Mix => Some(Op::Mix),
            B::Smoothstep => Some(Op::Smoothstep),
            _ => None,
        };
        if let Some(op) = simple(f) {
            for a in args {
                self.expr(a)?;
            }
            self.emit(op, 0, span);
        } else if let Some(op) = elementwise(f) {
            for a in args {
                self.expr_to(a, w)?;
            }
            self.emit(op, w, span);
        } else if matches!(f, B::Vec3 | B::Rgb) {
            // Three floats on the stack are a vec3.
            for a in args {
                self.expr(a)?;
            }
        } else {
            // Spline: t, then the control values widened to the result.
            let Some((t, controls)) = args.split_first() else {
                return Err(self.err(CompileErrorKind::HasErrors, span));
            };
            self.expr(t)?;
            for c in controls {
                self.expr_to(c, w)?;
            }
            let n = controls.len() as u32;
            if n > 0xFFFF {
                return Err(self.err(
                    CompileErrorKind::TooLarge {
                        what: "spline controls",
                    },
                    span,
                ));
            }
            self.emit(Op::Spline, n | w << 16, span);
        }
        Ok(())
    }

    fn random(
        &mut self,
        r: RandomFn,
        args: &[TExpr],
        w: u32,
        span: Span,
    ) -> Result<(), CompileError> {
        match r {
            RandomFn::Choose => {
                for (i, a) in args.iter().enumerate() {
                    if i % 2 == 0 {
                        self.expr_to(a, w)?;
                    } else {
                        self.expr(a)?;
                    }
                }
                let n = (args.len() / 2) as u32;
                if n > 0xFFFF {
                    return Err(self.err(CompileErrorKind::TooLarge { what: "choices" }, span));
                }
                let d = self.draw(1, span)?;
                self.emit(Op::RandChoose, n | w << 16, span);
                // The extra word: the draw index (no span entry needed: it
                // belongs to the instruction before it).
                self.out.code.push(d);
            }
            _ => {
                for a in args {
                    self.expr(a)?;
                }
                let (op, draws) = match r {
                    RandomFn::Uniform => (Op::RandUniform, 1),
                    RandomFn::Normal => (Op::RandNormal, 2),
                    RandomFn::RandInt => (Op::RandInt, 1),
                    _ => (Op::RandChance, 1),
                };
                let d = self.draw(draws, span)?;
                self.emit(op, d, span);
            }
        }
        Ok(())
    }
}

fn has_binding(e: &TExpr) -> bool {
    let mut found = false;
    e.walk(&mut |x| found |= matches!(x.kind, TExprKind::ModuleParam(_)));
    found
}
