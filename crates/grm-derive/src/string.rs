//! The module string: the output of a derivation and the input of turtle
//! interpretation, stored as flat arrays (structure of arrays) so the GPU
//! engine can upload and download it unchanged.
//!
//! The arrays are private: readers go through [`ModuleString::get`],
//! [`ModuleString::sym`], [`ModuleString::iter`] and
//! [`ModuleString::symbols`], and the GPU engine through
//! [`ModuleString::parts`] / [`ModuleString::from_parts`], so the storage
//! can be made more compact without touching them.

use std::borrow::Cow;

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
/// Invariant: `starts.len() == syms.len() + 1`, `starts[0] == 0`, `starts`
/// is non-decreasing and `starts[len] == params.len()`; `keys` is empty or
/// as long as `syms`.
#[derive(Clone, Debug, PartialEq)]
pub struct ModuleString {
    pub(crate) syms: Vec<u32>,
    pub(crate) starts: Vec<u32>,
    pub(crate) params: Vec<f32>,
    pub(crate) keys: Vec<u32>,
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
    pub fn new() -> ModuleString {
        ModuleString {
            syms: Vec::new(),
            starts: vec![0],
            params: Vec::new(),
            keys: Vec::new(),
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
        }
    }

    /// The flat arrays (see [`Parts`]).
    pub fn parts(&self) -> Parts<'_> {
        Parts {
            syms: Cow::Borrowed(&self.syms),
            starts: Cow::Borrowed(&self.starts),
            params: Cow::Borrowed(&self.params),
            keys: &self.keys,
        }
    }

    /// The flat arrays, owned: `(syms, starts, params, keys)` as
    /// [`ModuleString::from_parts`] takes them.
    pub fn into_parts(self) -> (Vec<u32>, Vec<u32>, Vec<f32>, Vec<u32>) {
        (self.syms, self.starts, self.params, self.keys)
    }

    /// Remove every module (the memory is kept).
    pub fn clear(&mut self) {
        self.syms.clear();
        self.starts.clear();
        self.starts.push(0);
        self.params.clear();
        self.keys.clear();
    }

    /// Append a module (to a string without keys).
    pub fn push(&mut self, sym: u32, params: &[f32]) {
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
    pub fn get(&self, i: usize) -> (u32, &[f32]) {
        let s = self.starts[i] as usize;
        let e = self.starts[i + 1] as usize;
        (self.syms[i], &self.params[s..e])
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
        &self.params[self.starts[i] as usize..self.starts[i + 1] as usize]
    }

    /// The modules' symbols, in order.
    pub fn symbols(&self) -> impl ExactSizeIterator<Item = u32> + DoubleEndedIterator + '_ {
        self.syms.iter().copied()
    }

    /// Every module's symbol and parameters, in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = (u32, &[f32])> + '_ {
        self.syms
            .iter()
            .zip(self.starts.windows(2))
            .map(move |(&s, w)| (s, &self.params[w[0] as usize..w[1] as usize]))
    }

    /// Total parameter words over all modules.
    pub fn param_words(&self) -> usize {
        self.params.len()
    }

    /// Append all modules of `other` (keys are kept when both strings carry
    /// them, and dropped otherwise).
    pub fn extend_from(&mut self, other: &ModuleString) {
        if self.has_keys() && other.has_keys() {
            self.keys.extend_from_slice(&other.keys);
        } else {
            self.keys.clear();
        }
        let base = self.params.len() as u32;
        self.syms.extend_from_slice(&other.syms);
        self.params.extend_from_slice(&other.params);
        self.starts
            .extend(other.starts[1..].iter().map(|s| s + base));
    }

    /// Check the invariant (used by tests and after reading GPU buffers).
    pub fn is_well_formed(&self) -> bool {
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
            + self.keys.capacity())
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
