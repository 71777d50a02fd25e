//! The references index: every name occurrence and what it refers to, for
//! go-to-definition, find-references, rename and hover.

use crate::program::{ConstId, Loc, MaterialId, MeshId, ParamId, SymbolId, SystemId};
use grm_diag::{FileId, Span};

/// What a name refers to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
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

/// One occurrence of a name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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
    pub(crate) fn push(&mut self, file: FileId, span: Span, def: Def, is_def: bool) {
        self.refs.push(Ref {
            loc: Loc::new(file, span),
            def,
            is_def,
        });
    }

    pub(crate) fn finish(&mut self) {
        // At its length before the sort takes its buffer (a list grown by
        // pushes holds up to twice its length: issue 32).
        self.refs.shrink_to_fit();
        self.refs
            .sort_by_key(|r| (r.loc.file, r.loc.span.start, r.loc.span.end));
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
