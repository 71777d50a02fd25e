//! The compiled system: the tables, the code and everything needed to map a
//! run-time fault back to source.

use bytemuck::Zeroable;
use grm_diag::{FileId, Span};
use grm_sema::{Settings, Value};

use crate::op::Op;
use crate::table::*;
use crate::verify::{VerifyError, verify_expr};

/// One system lowered for the engines (see the crate documentation and
/// [`crate::table`] for the layout). Built by [`crate::compile`]; tables
/// built any other way should pass [`CompiledSystem::validate`] before an
/// engine reads them.
#[derive(Clone, Debug)]
pub struct CompiledSystem {
    /// The system's name.
    pub name: String,
    /// The file all spans below are in.
    pub file: FileId,
    /// The system's name in its file (where whole-derivation errors point).
    pub span: Span,
    /// The settings evaluated for the meta-parameter values it was compiled with.
    pub settings: Settings,
    /// The meta-parameter values it was compiled with, by
    /// `grm_sema::ParamId` (the model builder evaluates materials with them).
    pub param_values: Vec<Value>,
    /// By symbol id (`grm_sema::SymbolId`).
    pub symbols: Vec<SymbolEntry>,
    /// Symbol names, by symbol id (for printing strings and disassembly).
    pub symbol_names: Vec<String>,
    /// Production groups: each symbol's normal groups are contiguous and in
    /// try order, followed by its wrap-up groups.
    pub groups: Vec<GroupHeader>,
    /// Alternatives; the last one is the axiom (see `axiom_alt`).
    pub alts: Vec<AltHeader>,
    /// Context items of all groups.
    pub context: Vec<ContextItem>,
    /// Successor modules of all alternatives (and of the axiom).
    pub succ: Vec<SuccModule>,
    /// Successor parameter expressions.
    pub params: Vec<ParamExpr>,
    /// Expression bytecode ([`crate::op`]).
    pub code: Vec<u32>,
    /// The constant pool.
    pub consts: Vec<f32>,
    /// Code offset -> source span, sorted by offset.
    pub spans: Vec<SpanEntry>,
    /// The source span of each parameter expression (`ParamExpr::span`).
    pub param_spans: Vec<Span>,
    /// Per group: the span of its condition, or of its first production.
    pub group_spans: Vec<Span>,
    /// Per alternative: the span of its weight (or of the production).
    pub weight_spans: Vec<Span>,
    /// Per alternative: the span of the whole production (the axiom's for
    /// the axiom).
    pub alt_spans: Vec<Span>,
    /// The alternative whose successor is the axiom.
    pub axiom_alt: u32,
    /// Draw indices used: 0 (the choice) and `1 .. draws`.
    pub draws: u32,
    /// The largest binding array of any group, in words.
    pub max_bind_words: u32,
}

/// Why a compiled system's tables are inconsistent.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InvalidTables(pub String);

impl std::fmt::Display for InvalidTables {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "invalid compiled tables: {}", self.0)
    }
}

impl std::error::Error for InvalidTables {}

impl CompiledSystem {
    /// Whether any group has a context (then the engines need the bracket
    /// structure of the string).
    pub fn has_context(&self) -> bool {
        self.groups.iter().any(|g| g.flags & GROUP_CONTEXT != 0)
    }

    /// The root key of a derivation with `seed` ([`crate::rng::root_key`]
    /// of the system's name): the parent key of the axiom's modules.
    pub fn root_key(&self, seed: u32) -> u32 {
        crate::rng::root_key(seed, crate::rng::name_hash(&self.name))
    }

    /// Whether a derivation draws random numbers at all: a group with
    /// several alternatives, or a random call in the code. A system that
    /// draws nothing derives the same string whatever its modules' keys,
    /// so the engines may skip carrying keys for it.
    pub fn draws_randomly(&self) -> bool {
        if self.groups.iter().any(|g| g.alt_count > 1) {
            return true;
        }
        let mut pc = 0usize;
        while let Some(&w) = self.code.get(pc) {
            let op = Op::from_code(w & 0xFF);
            if op.is_some_and(|o| o.is_random()) {
                return true;
            }
            pc += 1 + op.map_or(0, |o| o.extra_words() as usize);
        }
        false
    }

    /// Whether any module can carry parameters.
    pub fn has_params(&self) -> bool {
        self.symbols.iter().any(|s| s.param_words > 0)
    }

    /// The source span of the code at `pc` (the innermost expression that
    /// emitted it).
    pub fn span_at(&self, pc: u32) -> Option<Span> {
        let i = self.spans.partition_point(|e| e.code_offset <= pc);
        let e = self.spans.get(i.checked_sub(1)?)?;
        Some(Span::new(e.start, e.end))
    }

    /// The groups of a symbol, in try order.
    pub fn groups_of(&self, symbol: u32) -> &[GroupHeader] {
        let Some(s) = self.symbols.get(symbol as usize) else {
            return &[];
        };
        let a = s.first_group as usize;
        self.groups
            .get(a..a + s.group_count as usize)
            .unwrap_or(&[])
    }

    /// The successor modules of an alternative.
    pub fn successor(&self, alt: &AltHeader) -> &[SuccModule] {
        let a = alt.succ_offset as usize;
        self.succ.get(a..a + alt.succ_len as usize).unwrap_or(&[])
    }

    /// The parameter expressions of a successor module.
    pub fn module_params(&self, m: &SuccModule) -> &[ParamExpr] {
        let a = m.first_param as usize;
        self.params
            .get(a..a + m.param_count as usize)
            .unwrap_or(&[])
    }

    /// Check every cross-reference, word count and expression, so an engine
    /// can index the tables without further checks.
    pub fn validate(&self) -> Result<(), InvalidTables> {
        let bad = |m: String| Err(InvalidTables(m));
        let nsym = self.symbols.len();
        if self.symbol_names.len() != nsym {
            return bad("symbol names do not match symbols".into());
        }
        let in_range = |off: u32, len: u32, total: usize| (off as usize + len as usize) <= total;
        for (i, s) in self.symbols.iter().enumerate() {
            if !in_range(s.first_group, s.group_count, self.groups.len())
                || !in_range(s.first_wrapup, s.wrapup_count, self.groups.len())
            {
                return bad(format!("symbol {i}: group range out of bounds"));
            }
            for g in &self.groups[s.first_group as usize..][..s.group_count as usize] {
                if g.pred as usize != i || g.flags & GROUP_WRAPUP != 0 {
                    return bad(format!("symbol {i}: group for another predecessor"));
                }
            }
        }
        let verify = |entry: u32, bind: u32, width: u32, what: &str| {
            verify_expr(&self.code, entry, self.consts.len(), bind, Some(width))
                .map(|_| ())
                .map_err(|e: VerifyError| InvalidTables(format!("{what}: {e}")))
        };
        for (gi, g) in self.groups.iter().enumerate() {
            let Some(pred) = self.symbols.get(g.pred as usize) else {
                return bad(format!("group {gi}: predecessor out of range"));
            };
            if g.alt_count == 0 || !in_range(g.first_alt, g.alt_count, self.alts.len()) {
                return bad(format!("group {gi}: alternatives out of range"));
            }
            if !in_range(g.left_offset, g.left_len, self.context.len())
                || !in_range(g.right_offset, g.right_len, self.context.len())
            {
                return bad(format!("group {gi}: context out of range"));
            }
            if (g.pred_bind_words != 0 && g.pred_bind_words != pred.param_words)
                || g.pred_bind_offset + g.pred_bind_words > g.bind_words
                || g.bind_words > self.max_bind_words
            {
                return bad(format!("group {gi}: predecessor binding out of range"));
            }
            let ctx = self.context[g.left_offset as usize..][..g.left_len as usize]
                .iter()
                .chain(&self.context[g.right_offset as usize..][..g.right_len as usize]);
            for c in ctx {
                match c.kind {
                    CTX_SYMBOL => {
                        let Some(s) = self.symbols.get(c.symbol as usize) else {
                            return bad(format!("group {gi}: context symbol out of range"));
                        };
                        if (c.bind_words != 0 && c.bind_words != s.param_words)
                            || c.bind_offset + c.bind_words > g.bind_words
                        {
                            return bad(format!("group {gi}: context binding out of range"));
                        }
                    }
                    CTX_PUSH | CTX_POP => {}
                    k => return bad(format!("group {gi}: context kind {k}")),
                }
            }
            if g.cond_code != NONE {
                verify(
                    g.cond_code,
                    g.bind_words,
                    1,
                    &format!("group {gi} condition"),
                )?;
            }
            for ai in g.first_alt..g.first_alt + g.alt_count {
                let alt = &self.alts[ai as usize];
                if alt.group as usize != gi {
                    return bad(format!("alternative {ai}: wrong group"));
                }
                if alt.weight_code != NONE {
                    verify(
                        alt.weight_code,
                        g.bind_words,
                        1,
                        &format!("alternative {ai} weight"),
                    )?;
                }
                self.validate_successor(ai, g.bind_words)?;
            }
        }
        if self.axiom_alt as usize >= self.alts.len() {
            return bad("axiom alternative out of range".into());
        }
        self.validate_successor(self.axiom_alt, 0)?;
        if self.param_spans.len() < self.params.len()
            || self.group_spans.len() != self.groups.len()
            || self.weight_spans.len() != self.alts.len()
            || self.alt_spans.len() != self.alts.len()
        {
            return bad("span tables do not match".into());
        }
        Ok(())
    }

    fn validate_successor(&self, ai: u32, bind_words: u32) -> Result<(), InvalidTables> {
        let bad = |m: String| Err(InvalidTables(m));
        let alt = &self.alts[ai as usize];
        if (alt.succ_offset as usize + alt.succ_len as usize) > self.succ.len() {
            return bad(format!("alternative {ai}: successor out of range"));
        }
        let mut words = 0u32;
        let mut no_code = true;
        for m in self.successor(alt) {
            let Some(s) = self.symbols.get(m.symbol as usize) else {
                return bad(format!("alternative {ai}: successor symbol out of range"));
            };
            if m.word_offset != words
                || (m.first_param as usize + m.param_count as usize) > self.params.len()
            {
                return bad(format!("alternative {ai}: successor layout"));
            }
            let mut mw = 0;
            for p in self.module_params(m) {
                if !matches!(p.words, 1 | 3) || p.span as usize >= self.param_spans.len() {
                    return bad(format!("alternative {ai}: parameter width"));
                }
                let ok = match p.kind {
                    PARAM_CONST => (p.a as usize + p.words as usize) <= self.consts.len(),
                    PARAM_COPY => p.a + p.words <= bind_words,
                    PARAM_CODE => {
                        no_code = false;
                        verify_expr(
                            &self.code,
                            p.a,
                            self.consts.len(),
                            bind_words,
                            Some(p.words),
                        )
                        .is_ok()
                    }
                    _ => false,
                };
                if !ok {
                    return bad(format!("alternative {ai}: parameter expression"));
                }
                mw += p.words;
            }
            if mw != s.param_words {
                return bad(format!("alternative {ai}: parameter words of a module"));
            }
            words += mw;
        }
        if words != alt.succ_words {
            return bad(format!("alternative {ai}: successor words"));
        }
        if alt.flags & ALT_NO_CODE != 0 && !no_code {
            return bad(format!(
                "alternative {ai}: flagged without code but runs code"
            ));
        }
        Ok(())
    }

    /// All tables in one `u32` buffer, as a GPU uploads them: a
    /// [`PackedHeader`] (22 words) followed by the symbol, group,
    /// alternative, context, successor, parameter, code and constant
    /// sections and the race's logarithm table ([`crate::rng::LOG2_TABLE`]); the header gives each section's word offset and record
    /// count. Constants are stored as their f32 bits.
    pub fn pack(&self) -> Vec<u32> {
        let mut h = PackedHeader::zeroed();
        h.magic = PACKED_MAGIC;
        let mut words: Vec<u32> = vec![0; size_of::<PackedHeader>() / 4];
        fn section<T: bytemuck::Pod>(words: &mut Vec<u32>, items: &[T]) -> (u32, u32) {
            let off = words.len() as u32;
            words.extend_from_slice(bytemuck::cast_slice(items));
            (off, items.len() as u32)
        }
        (h.symbols_offset, h.symbols_count) = section(&mut words, &self.symbols);
        (h.groups_offset, h.groups_count) = section(&mut words, &self.groups);
        (h.alts_offset, h.alts_count) = section(&mut words, &self.alts);
        (h.context_offset, h.context_count) = section(&mut words, &self.context);
        (h.succ_offset, h.succ_count) = section(&mut words, &self.succ);
        (h.params_offset, h.params_count) = section(&mut words, &self.params);
        (h.code_offset, h.code_count) = section(&mut words, &self.code);
        (h.consts_offset, h.consts_count) = section(&mut words, &self.consts);
        (h.log2_offset, h.log2_count) = section(&mut words, &crate::rng::LOG2_TABLE);
        h.axiom_alt = self.axiom_alt;
        h.seed = self.settings.seed;
        h.iterations = self.settings.iterations;
        words[..size_of::<PackedHeader>() / 4].copy_from_slice(bytemuck::cast_slice(&[h]));
        words
    }

    /// Number of instructions (not words) in the code.
    pub fn instruction_count(&self) -> usize {
        let mut n = 0;
        let mut pc = 0usize;
        while let Some(&w) = self.code.get(pc) {
            n += 1;
            let extra = Op::from_code(w & 0xFF).map_or(0, |o| o.extra_words() as usize);
            pc += 1 + extra;
        }
        n
    }
}
