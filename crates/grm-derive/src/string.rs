//! The module string: the output of a derivation and the input of turtle
//! interpretation, stored as flat arrays (structure of arrays).
//!
//! The arrays are private: readers go through [`ModuleString::get`],
//! [`ModuleString::sym`], [`ModuleString::iter`] and
//! [`ModuleString::symbols`], and the GPU engine through
//! [`ModuleString::parts`] (the flat layout it uploads, built where the
//! string is compact) and [`ModuleString::from_parts`], so a derivation's
//! strings can leave constant words unstored ("Compact storage" below).

use std::borrow::Cow;
use std::sync::{Arc, OnceLock};

/// Modules per mark of a walked string (see [`ModuleString`], "Walked
/// words").
const MARK: usize = 16;

/// A parametric module string.
///
/// Module `i` has symbol `syms[i]` (a `grm_sema::SymbolId` index of the
/// derived system) and parameters `params[starts[i] as usize..starts[i + 1]
/// as usize]`. A `vec3` parameter takes three consecutive floats, a `bool`
/// one float (0.0 or 1.0).
///
/// Module `i`'s identity key is `keys[i]` (`grm_compile::rng`, "Identity
/// keys") when the string carries keys: a derivation carries them when its
/// system draws random numbers (the draws are keyed by them) or when they
/// are asked for ([`crate::Engine::with_keys`]); otherwise `keys` is empty.
///
/// Compact storage (a derivation's strings; [`Implicit`]): the words of a
/// symbol that every production writes as the same constants (a turn's
/// default angle, a default `F` length) are not stored per module but
/// recovered from the table the string shares with its engine, and a
/// string whose modules then store no word at all keeps no `starts`
/// either: the bracketed plant's 11.2 bytes a module become 4.
///
/// Walked words (the strings of an engine whose every symbol is rewritten
/// without a decision, [`Implicit::widths`]): every module of a symbol
/// stores the same number of words, so a string that stores words keeps
/// no `starts` either; module `i`'s words begin where the widths of the
/// modules before it add up to. [`ModuleString::iter`] adds them up as it
/// goes; random access ([`ModuleString::get`]) builds one mark every 16
/// modules on first use and walks at most 15 widths from the mark. The row
/// of trees' 9.7 bytes a module become 5.7.
///
/// Invariant: `starts` is empty and `params` too (no module stores a
/// word), or `starts` is empty, the implicit table has widths for every
/// symbol and they add up to `params.len()` (walked), or `starts.len() == syms.len() + 1`, `starts[0] == 0`, `starts`
/// is non-decreasing and `starts[len] == params.len()`; a module whose
/// symbol has implicit words stores none; `keys` is empty or as long as
/// `syms`.
#[derive(Clone, Debug)]
pub struct ModuleString {
    pub(crate) syms: Vec<u32>,
    pub(crate) starts: Vec<u32>,
    pub(crate) params: Vec<f32>,
    pub(crate) keys: Vec<u32>,
    /// The implicit words, shared with the engine that derived the string
    /// (`None`: every module stores its words).
    pub(crate) implicit: Option<Arc<Implicit>>,
    /// The implicit words of all modules together (so
    /// [`ModuleString::param_words`] costs nothing).
    pub(crate) implicit_words: usize,
    /// A walked string's marks: where the stored words of module
    /// `k * MARK` begin, for every `k * MARK <= len` (built on the first
    /// random access; reset by every change).
    pub(crate) marks: OnceLock<Vec<u32>>,
}

/// Per symbol, the words its modules carry without storing them: the
/// constants every production writes for it (see [`ModuleString`]).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Implicit {
    /// Per symbol: its words' range in `words` (`lo == hi`: the symbol
    /// stores its words, or has none).
    pub(crate) at: Vec<(u32, u32)>,
    pub(crate) words: Vec<f32>,
    /// Per symbol, the words its modules store, where strings walk them
    /// instead of keeping `starts` (empty: they keep `starts`).
    pub(crate) widths: Vec<u32>,
}

impl Implicit {
    /// The implicit words of symbol `s`, `None` where it stores them.
    #[inline]
    pub(crate) fn of(&self, s: u32) -> Option<&[f32]> {
        match self.at.get(s as usize) {
            Some(&(lo, hi)) if lo < hi => Some(&self.words[lo as usize..hi as usize]),
            _ => None,
        }
    }

    /// Whether strings walk their words (see [`ModuleString`], "Walked
    /// words").
    #[inline]
    pub(crate) fn walks(&self) -> bool {
        !self.widths.is_empty()
    }

    /// The words a module of symbol `s` stores, in a walked string.
    #[inline]
    pub(crate) fn stored_width(&self, s: u32) -> usize {
        self.widths.get(s as usize).map_or(0, |&w| w as usize)
    }

    /// How many implicit words symbol `s` has (0 where it stores them).
    #[inline]
    pub(crate) fn width(&self, s: u32) -> usize {
        self.at
            .get(s as usize)
            .map_or(0, |&(lo, hi)| (hi - lo) as usize)
    }
}

/// The same words, bit for bit (`-0.0` is not `0.0`: it prints
/// differently).
pub(crate) fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

/// Strings are equal when their modules are (symbols, parameters compared
/// as `f32`) and so are their keys, however each is stored.
impl PartialEq for ModuleString {
    fn eq(&self, other: &ModuleString) -> bool {
        if self.implicit == other.implicit && self.starts.len() == other.starts.len() {
            return self.syms == other.syms
                && self.starts == other.starts
                && self.params == other.params
                && self.keys == other.keys;
        }
        self.len() == other.len()
            && self.keys == other.keys
            && self.iter().zip(other.iter()).all(|(a, b)| a == b)
    }
}

/// A string's flat arrays in the layout the GPU engine uploads (see
/// [`ModuleString`]): borrowed where the string stores them so, built
/// where it stores them more compactly.
#[derive(Clone, Debug)]
pub struct Parts<'a> {
    pub syms: Cow<'a, [u32]>,
    pub starts: Cow<'a, [u32]>,
    pub params: Cow<'a, [f32]>,
    /// Empty when the string carries no keys.
    pub keys: &'a [u32],
}

impl Default for ModuleString {
    fn default() -> Self {
        ModuleString::new()
    }
}

impl ModuleString {
    /// Its arrays as mutable slices, for cutting into each chunk's or
    /// piece's part of an output of `m` modules: symbols, starts (empty
    /// where the string keeps none), parameter words, keys.
    pub(crate) fn parts_mut(
        &mut self,
        m: usize,
    ) -> (&mut [u32], &mut [u32], &mut [f32], &mut [u32]) {
        let with_starts = !self.starts.is_empty();
        (
            &mut self.syms[..],
            &mut self.starts[..if with_starts { m } else { 0 }],
            &mut self.params[..],
            &mut self.keys[..],
        )
    }

    pub fn new() -> ModuleString {
        ModuleString {
            syms: Vec::new(),
            starts: vec![0],
            params: Vec::new(),
            keys: Vec::new(),
            implicit: None,
            implicit_words: 0,
            marks: OnceLock::new(),
        }
    }

    pub fn with_capacity(modules: usize, params: usize) -> ModuleString {
        let mut starts = Vec::with_capacity(modules + 1);
        starts.push(0);
        ModuleString {
            syms: Vec::with_capacity(modules),
            starts,
            params: Vec::with_capacity(params),
            keys: Vec::new(),
            implicit: None,
            implicit_words: 0,
            marks: OnceLock::new(),
        }
    }

    /// A string from its flat arrays (the layout of [`Parts`]; `keys`
    /// empty or one per module). Not checked: a GPU download or a test's
    /// deliberately broken string is checked with
    /// [`ModuleString::is_well_formed`], and the engine checks its input.
    pub fn from_parts(
        syms: Vec<u32>,
        starts: Vec<u32>,
        params: Vec<f32>,
        keys: Vec<u32>,
    ) -> ModuleString {
        ModuleString {
            syms,
            starts,
            params,
            keys,
            implicit: None,
            implicit_words: 0,
            marks: OnceLock::new(),
        }
    }

    /// Whether every module stores its words (the layout of [`Parts`]).
    fn is_flat(&self) -> bool {
        self.implicit.is_none() && !self.starts.is_empty()
    }

    /// Whether the string walks its stored words (see [`ModuleString`],
    /// "Walked words").
    #[inline]
    pub(crate) fn walks(&self) -> bool {
        self.starts.is_empty() && !self.params.is_empty()
    }

    /// The words a module of symbol `sym` stores in a walked string.
    #[inline]
    fn stored_width(&self, sym: u32) -> usize {
        self.implicit.as_ref().map_or(0, |t| t.stored_width(sym))
    }

    /// Where module `i`'s stored words begin in a walked string (`i` up
    /// to `len`).
    fn walk_start(&self, i: usize) -> usize {
        let marks = self.marks.get_or_init(|| {
            let mut marks = Vec::with_capacity(self.len() / MARK + 1);
            let mut at = 0usize;
            for (k, &s) in self.syms.iter().enumerate() {
                if k.is_multiple_of(MARK) {
                    marks.push(at as u32);
                }
                at += self.stored_width(s);
            }
            if self.len().is_multiple_of(MARK) {
                marks.push(at as u32);
            }
            marks
        });
        let k = i / MARK;
        let mut at = marks.get(k).map_or(0, |&m| m as usize);
        for &s in self.syms.get(k * MARK..i).unwrap_or(&[]) {
            at += self.stored_width(s);
        }
        at
    }

    /// A walked string's `starts`.
    fn walked_starts(&self) -> Vec<u32> {
        let mut starts = Vec::with_capacity(self.len() + 1);
        let mut at = 0usize;
        starts.push(0);
        for &s in &self.syms {
            at += self.stored_width(s);
            starts.push(at as u32);
        }
        starts
    }

    /// The flat `(syms, starts, params)` of a compact string.
    fn flatten(&self) -> (Vec<u32>, Vec<f32>) {
        let mut starts = Vec::with_capacity(self.len() + 1);
        let mut params = Vec::with_capacity(self.param_words());
        starts.push(0);
        for (_, p) in self.iter() {
            params.extend_from_slice(p);
            starts.push(params.len() as u32);
        }
        (starts, params)
    }

    /// Store every module's words (the layout of [`Parts`]).
    pub(crate) fn make_flat(&mut self) {
        if !self.is_flat() {
            let (starts, params) = self.flatten();
            self.starts = starts;
            self.params = params;
            self.implicit = None;
            self.implicit_words = 0;
            self.marks = OnceLock::new();
        }
    }

    /// The flat arrays (see [`Parts`]).
    pub fn parts(&self) -> Parts<'_> {
        if self.is_flat() {
            return Parts {
                syms: Cow::Borrowed(&self.syms),
                starts: Cow::Borrowed(&self.starts),
                params: Cow::Borrowed(&self.params),
                keys: &self.keys,
            };
        }
        let (starts, params) = self.flatten();
        Parts {
            syms: Cow::Borrowed(&self.syms),
            starts: Cow::Owned(starts),
            params: Cow::Owned(params),
            keys: &self.keys,
        }
    }

    /// The flat arrays, owned: `(syms, starts, params, keys)` as
    /// [`ModuleString::from_parts`] takes them.
    pub fn into_parts(mut self) -> (Vec<u32>, Vec<u32>, Vec<f32>, Vec<u32>) {
        self.make_flat();
        (self.syms, self.starts, self.params, self.keys)
    }

    /// Remove every module (the memory is kept).
    pub fn clear(&mut self) {
        self.syms.clear();
        self.starts.clear();
        self.starts.push(0);
        self.params.clear();
        self.keys.clear();
        self.implicit = None;
        self.implicit_words = 0;
        self.marks = OnceLock::new();
    }

    /// Append a module (to a string without keys).
    pub fn push(&mut self, sym: u32, params: &[f32]) {
        self.marks = OnceLock::new();
        if let Some(t) = &self.implicit
            && let Some(w) = t.of(sym)
            && same_bits(w, params)
        {
            self.syms.push(sym);
            self.implicit_words += w.len();
            if !self.starts.is_empty() {
                self.starts.push(self.params.len() as u32);
            }
            return;
        }
        if self.implicit.as_ref().is_some_and(|t| t.of(sym).is_some()) {
            // Other words than the implicit ones: store every word.
            self.make_flat();
        }
        if self.starts.is_empty() {
            if self.implicit.as_ref().is_some_and(|t| t.walks())
                && self.stored_width(sym) == params.len()
            {
                // Walked (or no word stored yet): stays so.
                self.syms.push(sym);
                self.params.extend_from_slice(params);
                return;
            }
            self.starts = if self.params.is_empty() {
                vec![0; self.syms.len() + 1]
            } else {
                self.walked_starts()
            };
        }
        self.syms.push(sym);
        self.params.extend_from_slice(params);
        self.starts.push(self.params.len() as u32);
    }

    /// Append a module with its identity key (to a string with keys, or
    /// an empty one).
    pub fn push_keyed(&mut self, sym: u32, params: &[f32], key: u32) {
        self.push(sym, params);
        self.keys.push(key);
    }

    /// Whether the string carries identity keys (an empty string does).
    pub fn has_keys(&self) -> bool {
        self.keys.len() == self.syms.len()
    }

    /// Drop the identity keys (a string without keys, as an engine that
    /// is not keyed derives).
    pub fn clear_keys(&mut self) {
        self.keys.clear();
    }

    /// The identity keys, one per module (empty when the string carries
    /// none).
    pub fn keys(&self) -> &[u32] {
        if self.has_keys() { &self.keys } else { &[] }
    }

    /// The identity key of module `i`, if the string carries keys.
    pub fn key(&self, i: usize) -> Option<u32> {
        if self.has_keys() {
            self.keys.get(i).copied()
        } else {
            None
        }
    }

    /// Number of modules.
    pub fn len(&self) -> usize {
        self.syms.len()
    }

    pub fn is_empty(&self) -> bool {
        self.syms.is_empty()
    }

    /// The symbol and parameters of module `i`.
    #[inline]
    pub fn get(&self, i: usize) -> (u32, &[f32]) {
        let sym = self.syms[i];
        (sym, self.words_of(sym, i))
    }

    /// The words of module `i`, whose symbol is `sym`.
    #[inline]
    fn words_of(&self, sym: u32, i: usize) -> &[f32] {
        if let Some(t) = &self.implicit
            && let Some(w) = t.of(sym)
        {
            return w;
        }
        if self.starts.is_empty() {
            if self.params.is_empty() {
                // No module stores a word.
                return &[];
            }
            let a = self.walk_start(i);
            return self
                .params
                .get(a..a + self.stored_width(sym))
                .unwrap_or(&[]);
        }
        &self.params[self.starts[i] as usize..self.starts[i + 1] as usize]
    }

    /// The range of module `i`'s stored words in `params` (empty for
    /// implicit words).
    #[inline]
    pub(crate) fn stored(&self, i: usize) -> std::ops::Range<usize> {
        if self.walks() {
            let a = self.walk_start(i);
            return a..a + self.syms.get(i).map_or(0, |&s| self.stored_width(s));
        }
        match self.starts.get(i..i + 2) {
            Some(&[a, b]) => a as usize..b as usize,
            _ => 0..0,
        }
    }

    /// Where module `i`'s stored words begin in `params` (0 for a string
    /// that stores none).
    #[inline]
    pub(crate) fn start(&self, i: usize) -> usize {
        if self.walks() {
            return self.walk_start(i);
        }
        self.starts.get(i).map_or(0, |&s| s as usize)
    }

    /// The symbol of module `i`.
    pub fn sym(&self, i: usize) -> u32 {
        self.syms[i]
    }

    /// The symbol of module `i`, `None` past the end.
    pub fn sym_at(&self, i: usize) -> Option<u32> {
        self.syms.get(i).copied()
    }

    /// The parameters of module `i`.
    pub fn params_of(&self, i: usize) -> &[f32] {
        self.get(i).1
    }

    /// The modules' symbols, in order.
    pub fn symbols(&self) -> impl ExactSizeIterator<Item = u32> + DoubleEndedIterator + '_ {
        self.syms.iter().copied()
    }

    /// Every module's symbol and parameters, in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = (u32, &[f32])> + '_ {
        // A walked string's words are added up on the way.
        let walk = self.walks().then_some(self.implicit.as_deref()).flatten();
        let mut at = 0usize;
        (0..self.len()).map(move |i| match walk {
            Some(t) => {
                let sym = self.syms[i];
                if let Some(w) = t.of(sym) {
                    return (sym, w);
                }
                let a = at;
                at += t.stored_width(sym);
                (sym, self.params.get(a..at).unwrap_or(&[]))
            }
            None => self.get(i),
        })
    }

    /// Total parameter words over all modules (stored or implicit).
    pub fn param_words(&self) -> usize {
        self.params.len() + self.implicit_words
    }

    /// Append all modules of `other` (keys are kept when both strings carry
    /// them, and dropped otherwise).
    pub fn extend_from(&mut self, other: &ModuleString) {
        if self.has_keys() && other.has_keys() {
            self.keys.extend_from_slice(&other.keys);
        } else {
            self.keys.clear();
        }
        if !self.is_flat() || !other.is_flat() {
            self.make_flat();
            let (_, starts, params, _) = other.clone().into_parts();
            let base = self.params.len() as u32;
            self.syms.extend_from_slice(&other.syms);
            self.params.extend_from_slice(&params);
            self.starts.extend(starts[1..].iter().map(|s| s + base));
            return;
        }
        let base = self.params.len() as u32;
        self.syms.extend_from_slice(&other.syms);
        self.params.extend_from_slice(&other.params);
        self.starts
            .extend(other.starts[1..].iter().map(|s| s + base));
    }

    /// Check the invariant (used by tests and after reading GPU buffers).
    pub fn is_well_formed(&self) -> bool {
        if self.starts.is_empty() {
            let keys = self.keys.is_empty() || self.keys.len() == self.syms.len();
            if self.params.is_empty() {
                return keys;
            }
            // Walked: every symbol has a width, and they add up.
            let Some(t) = self.implicit.as_deref().filter(|t| t.walks()) else {
                return false;
            };
            let mut at = 0usize;
            for &s in &self.syms {
                match t.widths.get(s as usize) {
                    Some(&w) => at += w as usize,
                    None => return false,
                }
            }
            return keys && at == self.params.len();
        }
        self.starts.len() == self.syms.len() + 1
            && self.starts.first() == Some(&0)
            && self.starts.windows(2).all(|w| w[0] <= w[1])
            && self.starts.last().map(|&l| l as usize) == Some(self.params.len())
            && (self.keys.is_empty() || self.keys.len() == self.syms.len())
    }

    /// The invariant as far as the modules in `range` need it: the parameter
    /// slice of every module in `range` is in bounds (`starts` has one
    /// entry more than `syms`, is non-decreasing over the range and ends
    /// within `params`). Costs the range's length, not the string's: for
    /// callers that walk a growing string piece by piece. `false` for a
    /// range past the end.
    pub fn is_well_formed_in(&self, range: std::ops::Range<usize>) -> bool {
        if self.starts.is_empty() {
            // Walked words are in bounds where the string is well formed
            // (their slices are checked, never out of bounds).
            return (self.params.is_empty() || self.implicit.as_ref().is_some_and(|t| t.walks()))
                && range.start <= range.end
                && range.end <= self.len();
        }
        self.starts.len() == self.syms.len() + 1
            && range.start <= range.end
            && range.end <= self.syms.len()
            && self.starts[range.start..=range.end]
                .windows(2)
                .all(|w| w[0] <= w[1])
            && self.starts[range.end] as usize <= self.params.len()
    }

    /// Bytes used by the three arrays (for memory limits and statistics).
    pub fn heap_bytes(&self) -> usize {
        (self.syms.capacity()
            + self.starts.capacity()
            + self.params.capacity()
            + self.keys.capacity()
            + self.marks.get().map_or(0, Vec::capacity))
            * 4
    }

    /// The string as grm source text: modules separated by one space,
    /// parameters in parentheses without spaces before them (`F(1) +(90)
    /// [ A ]`), with `names` giving each symbol's name.
    pub fn to_text<S: AsRef<str>>(&self, names: &[S]) -> String {
        let mut out = String::with_capacity(self.len() * 4);
        self.write_text(names, &mut out);
        out
    }

    /// Append [`ModuleString::to_text`] to `out`.
    pub fn write_text<S: AsRef<str>>(&self, names: &[S], out: &mut String) {
        use std::fmt::Write;
        for (i, (sym, params)) in self.iter().enumerate() {
            if i > 0 {
                out.push(' ');
            }
            match names.get(sym as usize) {
                Some(n) => out.push_str(n.as_ref()),
                None => {
                    let _ = write!(out, "#{sym}");
                }
            }
            grm_compile::text::write_numbers(params, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn push_get_extend() {
        let mut a = ModuleString::new();
        a.push(1, &[1.0, 2.0]);
        a.push(2, &[]);
        let mut b = ModuleString::new();
        b.push(3, &[3.0]);
        a.extend_from(&b);
        assert_eq!(a.len(), 3);
        assert_eq!(a.get(0), (1, &[1.0, 2.0][..]));
        assert_eq!(a.get(1), (2, &[][..]));
        assert_eq!(a.get(2), (3, &[3.0][..]));
        assert!(a.is_well_formed());
        assert_eq!(a.to_text(&["x", "A", "B", "C"]), "A(1, 2) B C(3)");
    }

    #[test]
    fn well_formed_in_checks_only_the_range() {
        let mut a = ModuleString::new();
        a.push(1, &[1.0]);
        a.push(2, &[2.0, 3.0]);
        a.push(3, &[]);
        a.push(4, &[4.0]);
        for r in [0..0, 0..4, 1..3, 4..4] {
            assert!(a.is_well_formed_in(r.clone()), "{r:?}");
        }
        assert!(!a.is_well_formed_in(3..5), "past the end");
        // Module 1's parameters end before they start: ranges holding
        // module 1 fail; the others slice in bounds and pass.
        a.starts[2] = 0;
        assert!(!a.is_well_formed());
        assert!(!a.is_well_formed_in(0..2));
        assert!(!a.is_well_formed_in(1..2));
        assert!(!a.is_well_formed_in(1..4));
        assert!(a.is_well_formed_in(0..1));
        assert!(a.is_well_formed_in(2..4));
        // A range ending past the parameters.
        let mut b = ModuleString::new();
        b.push(1, &[1.0]);
        b.params.clear();
        assert!(!b.is_well_formed_in(0..1));
        assert!(b.is_well_formed_in(0..0));
        // A start array of the wrong length.
        let mut c = ModuleString::new();
        c.push(1, &[]);
        c.starts.pop();
        assert!(!c.is_well_formed_in(0..0));
    }
}
