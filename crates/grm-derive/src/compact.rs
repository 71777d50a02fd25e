//! Compact strings: the words a symbol's modules carry without storing
//! them ([`Implicit`]), which symbols have them, and strings brought into an
//! engine's layout.

use grm_compile::CompiledSystem;
use grm_compile::table::*;

use crate::engine::Engine;
use crate::error::DeriveError;
use crate::string::{Implicit, ModuleString, same_bits};

/// The symbols whose words can be implicit ([`Implicit`]): every module
/// of the symbol that any production (the axiom included) writes has the
/// same constant words, and nothing reads them while deriving (no group
/// of the symbol binds its parameters, and the system has no context,
/// which could). The turtle and every other reader still get them, from
/// the table.
pub(crate) fn implicit_words(sys: &CompiledSystem) -> Option<Implicit> {
    if sys.has_context() {
        return None;
    }
    let n = sys.symbols.len();
    // Per symbol: `None` not seen yet, `Some(Some(w))` always `w`,
    // `Some(None)` not implicit.
    let mut seen: Vec<Option<Option<Vec<f32>>>> = vec![None; n];
    for (s, e) in sys.symbols.iter().enumerate() {
        let bound = sys
            .groups_of(s as u32)
            .iter()
            .any(|g| g.pred_bind_words != 0 || g.bind_words != 0);
        if e.param_words == 0 || bound {
            seen[s] = Some(None);
        }
    }
    let mut w = Vec::new();
    for a in &sys.alts {
        for m in sys.successor(a) {
            let s = m.symbol as usize;
            if matches!(seen.get(s), Some(Some(None)) | None) {
                continue;
            }
            w.clear();
            let mut constant = true;
            for p in sys.module_params(m) {
                let (lo, hi) = (p.a as usize, p.a as usize + p.words as usize);
                match sys.consts.get(lo..hi) {
                    Some(c) if p.kind == PARAM_CONST => w.extend_from_slice(c),
                    _ => constant = false,
                }
            }
            seen[s] = match &seen[s] {
                _ if !constant || w.len() != sys.symbols[s].param_words as usize => Some(None),
                None => Some(Some(w.clone())),
                Some(Some(v)) if crate::string::same_bits(v, &w) => Some(Some(w.clone())),
                _ => Some(None),
            };
        }
    }
    let mut t = Implicit {
        at: vec![(0, 0); n],
        words: Vec::new(),
        widths: Vec::new(),
    };
    for (s, v) in seen.into_iter().enumerate() {
        if let Some(Some(v)) = v {
            let lo = t.words.len() as u32;
            t.words.extend_from_slice(&v);
            t.at[s] = (lo, t.words.len() as u32);
        }
    }
    (!t.words.is_empty()).then_some(t)
}

impl<'a> Engine<'a> {
    /// Whether this engine's strings leave implicit words unstored.
    pub(crate) fn compact(&self) -> bool {
        self.implicit.is_some()
    }

    /// Whether this engine's strings walk their stored words (see
    /// [`ModuleString`], "Walked words").
    pub(crate) fn walks(&self) -> bool {
        self.implicit.as_ref().is_some_and(|t| t.walks())
    }

    /// Leave the words that every production writes as the same constants
    /// unstored (`true`, the default of [`Engine::new`]; see
    /// [`ModuleString`], "Compact storage"), or store every module's
    /// words (`false`; an engine with edits does). The strings read the
    /// same either way. Recycled buffers are dropped.
    pub fn with_implicit_words(mut self, on: bool) -> Engine<'a> {
        if on == self.compact() {
            return self;
        }
        // The same system, already validated, on one thread: nothing can
        // fail (the pool and the settings are kept).
        if let Ok(mut e) = Engine::build(self.sys, 1, on) {
            e.threads = self.threads;
            e.pool = self.pool.take();
            e.min_chunk = self.min_chunk;
            e.keyed = self.keyed;
            e.edits = self.edits.take();
            self = e;
        }
        self
    }

    /// `s` (well-formed) in this engine's layout, checked module by module.
    #[cold]
    pub(crate) fn relayout(&self, s: &ModuleString) -> Result<ModuleString, DeriveError> {
        let keyed = s.has_keys();
        let mut out = ModuleString::with_capacity(s.len(), s.param_words());
        out.implicit = self.implicit.clone();
        for (i, (sym, p)) in s.iter().enumerate() {
            let Some(e) = self.sys.symbols.get(sym as usize) else {
                return Err(DeriveError::InvalidInput(format!(
                    "module {i} has unknown symbol {sym}"
                )));
            };
            let w = e.param_words;
            if p.len() != w as usize {
                return Err(DeriveError::InvalidInput(format!(
                    "module {i} (`{}`) has {} parameter words, not {w}",
                    self.sys.symbol_names[sym as usize],
                    p.len()
                )));
            }
            if let Some(t) = &self.implicit
                && let Some(c) = t.of(sym)
                && !same_bits(c, p)
            {
                return Err(DeriveError::InvalidInput(format!(
                    "module {i} (`{}`) has other parameters than the constants every production of this system writes for it",
                    self.sys.symbol_names[sym as usize],
                )));
            }
            if keyed {
                out.push_keyed(sym, p, s.keys[i]);
            } else {
                out.push(sym, p);
            }
        }
        Ok(out)
    }
}
