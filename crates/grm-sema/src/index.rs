//! The references index: every name occurrence and what it refers to, for
//! go-to-definition, find-references, rename and hover.

use crate::program::{ConstId, Loc, MaterialId, MeshId, ParamId, SymbolId, SystemId};
use grm_diag::{FileId, Span};

/// What a name refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Def {
    Const(ConstId),
    Param(ParamId),
    Mesh(MeshId),
    Material(MaterialId),
    System(SystemId),
    /// A module symbol of a system.
    Symbol(SystemId, SymbolId),
    /// A parameter bound by a pattern; `binding` is where it was bound.
    Binding {
        binding: Loc,
    },
}

/// One occurrence of a name. Ordered by where it is written (file,
/// start, end), then by what it refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Ref {
    /// Where the name is written.
    pub loc: Loc,
    pub def: Def,
    /// Whether this occurrence is the definition itself.
    pub is_def: bool,
}

/// All occurrences, sorted by file and position once checking is done.
#[derive(Clone, Debug, Default)]
pub struct RefIndex {
    pub refs: Vec<Ref>,
}

impl RefIndex {
    /// Room for `n` occurrences, made before checking: a list grown by
    /// pushes is copied each time it doubles, and glibc leaves the old
    /// block as a hole in the heap (the 4 MB grammar's `grmc check` peaked
    /// 3 bytes per source byte higher when its last doubling came late).
    pub(crate) fn reserve(&mut self, n: usize) {
        self.refs.reserve_exact(n);
    }

    pub(crate) fn push(&mut self, file: FileId, span: Span, def: Def, is_def: bool) {
        self.refs.push(Ref {
            loc: Loc::new(file, span),
            def,
            is_def,
        });
    }

    pub(crate) fn finish(&mut self) {
        // Sorted in place: a stable sort takes a buffer of half the list
        // (2.5 bytes per source byte at the end of checking a large file,
        // issue 32). The order is total (a name's place, then what it
        // refers to), so the result does not depend on the pushes' order.
        self.refs.sort_unstable();
        self.refs.dedup();
        self.refs.shrink_to_fit();
    }

    /// The occurrence under a byte offset, if any.
    pub fn at(&self, file: FileId, offset: u32) -> Option<&Ref> {
        let i = self
            .refs
            .partition_point(|r| (r.loc.file, r.loc.span.start) <= (file, offset));
        // The candidate is the last occurrence starting at or before `offset`.
        let r = self.refs.get(i.checked_sub(1)?)?;
        (r.loc.file == file && (r.loc.span.contains(offset) || r.loc.span.end == offset))
            .then_some(r)
    }

    /// Every occurrence of a definition (including the definition itself).
    pub fn occurrences(&self, def: Def) -> impl Iterator<Item = &Ref> {
        self.refs.iter().filter(move |r| r.def == def)
    }

    /// Where a definition is written.
    pub fn definition(&self, def: Def) -> Option<Loc> {
        if let Def::Binding { binding } = def {
            return Some(binding);
        }
        self.refs
            .iter()
            .find(|r| r.def == def && r.is_def)
            .map(|r| r.loc)
    }
}
