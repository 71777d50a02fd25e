//! Navigation: go to definition, find references, rename.
//!
//! A definition is identified across files by where it is written (path
//! and span), so references and renames also reach the open documents that
//! import the defining file.

use crate::{Analysis, FileAnalysis, FileEdits, Location, Span, docs};
use grm_diag::FileId;
use grm_sema::{Def, Loc, Program, Ref, SymbolKind};
use grm_syntax::ast::Item;
use grm_syntax::lexer::TokKind;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Why a rename is refused.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenameError(pub String);

impl std::fmt::Display for RenameError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl FileAnalysis {
    /// The name occurrence under a byte offset of the analysed file.
    pub(crate) fn ref_at(&self, offset: u32) -> Option<&Ref> {
        self.checked.program.index.at(self.root, offset)
    }

    /// Whether a definition is something the user wrote (not a built-in
    /// terminal).
    pub(crate) fn is_user_def(&self, def: Def) -> bool {
        match def {
            Def::Symbol(sid, id) => self
                .checked
                .program
                .systems
                .get(sid.index())
                .and_then(|s| s.symbols.get(id.index()))
                .is_some_and(|s| s.kind == SymbolKind::User),
            _ => true,
        }
    }

    /// Where a definition is written, for user definitions.
    pub(crate) fn def_loc(&self, def: Def) -> Option<Loc> {
        if !self.is_user_def(def) {
            return None;
        }
        self.checked.program.index.definition(def)
    }

    fn path_of(&self, file: FileId) -> PathBuf {
        PathBuf::from(&self.sources.get(file).path)
    }

    /// Go to definition: the definition of the name under `offset`, or the
    /// file an `import` under `offset` names.
    pub fn definition(&self, offset: u32) -> Option<Location> {
        if let Some(r) = self.ref_at(offset) {
            let loc = self.def_loc(r.def)?;
            return Some(self.loc(loc.file, loc.span));
        }
        // An import path: jump to the imported file.
        for item in &self.parsed().file.items {
            if let Item::Import(imp) = item
                && (imp.path.span.contains(offset) || imp.path.span.end == offset)
            {
                let dir = Path::new(&self.source().path)
                    .parent()
                    .unwrap_or(Path::new(""))
                    .to_path_buf();
                let target = grm_sema::normalize(&dir.join(&imp.path.value))
                    .to_string_lossy()
                    .replace('\\', "/");
                let fid = self.sources.find(&target)?;
                return Some(self.loc(fid, Span::new(0, 0)));
            }
        }
        None
    }

    /// The definition under `offset` as (path, span) of where it is written.
    fn def_key(&self, offset: u32) -> Option<(Def, PathBuf, Span)> {
        let r = self.ref_at(offset)?;
        let loc = self.def_loc(r.def)?;
        Some((r.def, self.path_of(loc.file), loc.span))
    }

    /// A system of this program as a rename names it.
    fn renamed_system(&self, s: &grm_sema::System) -> RenamedSystem {
        RenamedSystem {
            file: grm_sema::normalize(Path::new(&self.sources.get(s.file).path)),
            name: s.name.clone(),
            shape: s.mode == grm_sema::Mode::Shape,
        }
    }

    /// This program's definition written at (path, span), if it sees it.
    fn def_written_at(&self, path: &Path, span: Span) -> Option<Def> {
        let file = self.sources.find(&path.to_string_lossy())?;
        let prog: &Program = &self.checked.program;
        prog.index
            .refs
            .iter()
            .find(|r| r.is_def && r.loc.file == file && r.loc.span == span)
            .map(|r| r.def)
            .filter(|d| self.is_user_def(*d))
    }

    /// Every occurrence of `def` in this program (including its definition
    /// when `include_decl`).
    fn occurrences(&self, def: Def, include_decl: bool) -> Vec<Location> {
        let def_loc = self.def_loc(def);
        self.checked
            .program
            .index
            .occurrences(def)
            .filter(|r| include_decl || Some(r.loc) != def_loc)
            .map(|r| self.loc(r.loc.file, r.loc.span))
            .collect()
    }

    /// References within this file's program (the file and its imports).
    pub fn references(&self, offset: u32, include_decl: bool) -> Vec<Location> {
        if let Some(v) = self.tag_references(offset) {
            return v;
        }
        let Some(r) = self.ref_at(offset) else {
            return Vec::new();
        };
        if !self.is_user_def(r.def) {
            return Vec::new();
        }
        let mut v = self.occurrences(r.def, include_decl);
        v.sort_by(|a, b| (&a.path, a.span).cmp(&(&b.path, b.span)));
        v.dedup();
        v
    }

    /// Whether the name under `offset` can be renamed: its span and current
    /// text, or why not.
    pub fn prepare_rename(&self, offset: u32) -> Result<(Span, String), RenameError> {
        if let Some((span, _)) = self.tag_at(offset) {
            return Ok((span, self.slice(span).to_string()));
        }
        let Some(r) = self.ref_at(offset) else {
            return Err(RenameError("no renameable name here".into()));
        };
        if !self.is_user_def(r.def) {
            return Err(RenameError(format!(
                "`{}` is a built-in terminal and cannot be renamed",
                self.slice(r.loc.span)
            )));
        }
        if self.def_loc(r.def).is_none() {
            return Err(RenameError("cannot find where this name is defined".into()));
        }
        Ok((r.loc.span, self.slice(r.loc.span).to_string()))
    }

    /// Every place the shape system of the tag under `offset` writes it
    /// (a tag is one name per system: its commands' tags and its rules'
    /// `tagged`, `index` and `count`); `None` when no tag is there.
    fn tag_references(&self, offset: u32) -> Option<Vec<Location>> {
        let (span, sys) = self.tag_at(offset)?;
        let spans = self.tag_occurrences(sys, self.slice(span));
        Some(spans.into_iter().map(|s| self.loc(self.root, s)).collect())
    }

    /// The rename of the tag under `offset` to `new`: its edits in this
    /// file (a system is written in one file), or why not; `None` when no
    /// tag is there. Renaming it to a tag the system already uses would
    /// merge the two.
    fn tag_rename(&self, offset: u32, new: &str) -> Option<Result<Vec<FileEdits>, RenameError>> {
        let (span, sys) = self.tag_at(offset)?;
        let old = self.slice(span);
        if let Err(e) = valid_identifier(new) {
            return Some(Err(e));
        }
        if new != old
            && self
                .shape_tags()
                .iter()
                .any(|(t, sp)| t == new && sys.span.contains(sp.start))
        {
            return Some(Err(RenameError(format!(
                "cannot rename to `{new}`: system `{}` already has a tag `{new}` (the two would become one)",
                sys.name.name
            ))));
        }
        let edits = self
            .tag_occurrences(sys, old)
            .into_iter()
            .map(|s| (self.loc(self.root, s), new.to_string()))
            .collect();
        Some(Ok(vec![FileEdits {
            path: self.path_of(self.root),
            edits,
        }]))
    }

    /// What the rename of the tag under `offset` means for the edits file
    /// beside its system (the semantic queries that name it).
    fn renamed_tag(&self, offset: u32) -> Option<RenamedName> {
        let (span, sys) = self.tag_at(offset)?;
        Some(RenamedName {
            kind: RenamedKind::Tag,
            old: self.slice(span).to_string(),
            systems: vec![RenamedSystem {
                file: grm_sema::normalize(&self.path_of(self.root)),
                name: sys.name.name.to_string(),
                shape: true,
            }],
        })
    }

    /// Why renaming `def` to `new` would change the program's meaning or
    /// break it, if it would.
    fn rename_conflict(&self, def: Def, new: &str) -> Option<String> {
        let p = &self.checked.program;
        let global_taken = p.consts.iter().any(|c| c.name == new)
            || p.params.iter().any(|c| c.name == new)
            || p.meshes.iter().any(|c| c.name == new)
            || p.materials.iter().any(|c| c.name == new);
        match def {
            Def::Symbol(sid, _) => {
                if docs::lookup(new, docs::DocKind::Terminal).is_some() {
                    return Some(format!("`{new}` is a built-in terminal"));
                }
                let sys = p.systems.get(sid.index())?;
                if sys.symbol_by_name(new).is_some() {
                    return Some(format!(
                        "system `{}` already has a symbol `{new}`",
                        sys.name
                    ));
                }
            }
            Def::System(_) => {
                if p.systems.iter().any(|s| s.name == new) {
                    return Some(format!("a system `{new}` already exists"));
                }
            }
            Def::Const(_) | Def::Param(_) | Def::Mesh(_) | Def::Material(_) => {
                if global_taken {
                    return Some(format!("`{new}` is already defined"));
                }
                // A use inside a production that binds `new` would be
                // captured by the binding.
                for r in p.index.occurrences(def) {
                    for sys in p.systems.iter().filter(|s| s.file == r.loc.file) {
                        for g in &sys.groups {
                            for a in &g.alternatives {
                                if a.span.contains(r.loc.span.start)
                                    && a.bindings.iter().any(|b| b.name == new)
                                {
                                    return Some(format!(
                                        "a use is inside a production that binds `{new}`"
                                    ));
                                }
                            }
                        }
                    }
                }
            }
            Def::Binding { binding } => {
                for sys in p.systems.iter().filter(|s| s.file == binding.file) {
                    for g in &sys.groups {
                        for a in &g.alternatives {
                            if !a.bindings.iter().any(|b| b.span == binding.span) {
                                continue;
                            }
                            if a.bindings.iter().any(|b| b.name == new) {
                                return Some(format!("this production already binds `{new}`"));
                            }
                            // A global of that name used in this production
                            // would be shadowed.
                            let shadowed = p.index.refs.iter().any(|r| {
                                r.loc.file == binding.file
                                    && a.span.contains(r.loc.span.start)
                                    && matches!(
                                        r.def,
                                        Def::Const(_)
                                            | Def::Param(_)
                                            | Def::Mesh(_)
                                            | Def::Material(_)
                                    )
                                    && self.sources.get(r.loc.file).text.get(r.loc.span.range())
                                        == Some(new)
                            });
                            if shadowed {
                                return Some(format!(
                                    "this production uses the global `{new}`, which the parameter would hide"
                                ));
                            }
                        }
                    }
                }
            }
        }
        None
    }
}

/// Whether `s` is a plain identifier (and not a reserved word).
pub(crate) fn valid_identifier(s: &str) -> Result<(), RenameError> {
    let lexed = grm_syntax::lexer::lex(FileId(0), s);
    let one_ident = lexed.diagnostics.is_empty()
        && lexed.comments.is_empty()
        && lexed.tokens.len() == 1
        && lexed.tokens[0].kind == TokKind::Ident
        && lexed.tokens[0].span.range() == (0..s.len());
    if docs::is_keyword(s) {
        return Err(RenameError(format!("`{s}` is a reserved word")));
    }
    if !one_ident {
        return Err(RenameError(format!("`{s}` is not a valid name")));
    }
    Ok(())
}

/// The kind of a renamed name, as the edits file beside a grammar uses it
/// (docs/edits.md): a system in an edit's `system`, a symbol in its
/// target's labels, a material or mesh in its operation (a mesh also in
/// an `insert:NAME` label), a meta-parameter or constant in a shape-mode
/// `set` or `offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenamedKind {
    System,
    Symbol,
    Material,
    Mesh,
    Parameter,
    /// A semantic tag of a shape system: the tags its edits' semantic
    /// queries name.
    Tag,
}

/// A system whose edits may name a renamed name: where its edits file is
/// (beside `file`, the file that declares it), its name, its mode.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenamedSystem {
    pub file: PathBuf,
    pub name: String,
    /// `mode = shape;` (a `set` or `offset` names a meta-parameter or a
    /// constant there; in derive mode a module's parameter).
    pub shape: bool,
}

/// What a rename means for the edits files ([`Analysis::renamed_name`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenamedName {
    pub kind: RenamedKind,
    /// The name as it is written now.
    pub old: String,
    /// The systems whose edits may name it (each once, by file and name).
    pub systems: Vec<RenamedSystem>,
}

impl Analysis {
    /// What the rename of the name under `offset` of `path` means for the
    /// edits files beside the grammars ([`RenamedName`]); `None` for a name
    /// no edit uses (a production's binding) or nothing renameable.
    pub fn renamed_name(&mut self, path: &Path, offset: u32) -> Option<RenamedName> {
        let fa = self.analyze(path)?;
        if let Some(tag) = fa.renamed_tag(offset) {
            return Some(tag);
        }
        let (_, old) = fa.prepare_rename(offset).ok()?;
        let (def, dpath, dspan) = fa.def_key(offset)?;
        let kind = match def {
            Def::System(_) => RenamedKind::System,
            Def::Symbol(..) => RenamedKind::Symbol,
            Def::Material(_) => RenamedKind::Material,
            Def::Mesh(_) => RenamedKind::Mesh,
            Def::Param(_) | Def::Const(_) => RenamedKind::Parameter,
            Def::Binding { .. } => return None,
        };
        if let Def::System(sid) | Def::Symbol(sid, _) = def {
            let sys = fa.checked.program.systems.get(sid.index())?;
            return Some(RenamedName {
                kind,
                old,
                systems: vec![fa.renamed_system(sys)],
            });
        }
        // A global: every system that sees it, in this program or another
        // that sees the same definition. A system sees it when the file
        // that declares the system does (an imported file does not see its
        // importer's globals).
        let mut candidates: Vec<RenamedSystem> = fa
            .checked
            .program
            .systems
            .iter()
            .map(|s| fa.renamed_system(s))
            .collect();
        for (_, other, _) in self.others_seeing(path, &dpath, dspan) {
            candidates.extend(
                other
                    .checked
                    .program
                    .systems
                    .iter()
                    .map(|s| other.renamed_system(s)),
            );
        }
        let mut systems: Vec<RenamedSystem> = Vec::new();
        for s in candidates {
            if systems.contains(&s) {
                continue;
            }
            let sees = self
                .analyze(&s.file)
                .is_some_and(|g| g.def_written_at(&dpath, dspan).is_some());
            if sees {
                systems.push(s);
            }
        }
        systems.sort_by(|a, b| (&a.file, &a.name).cmp(&(&b.file, &b.name)));
        Some(RenamedName { kind, old, systems })
    }

    /// References to the name under `offset` of `path`, in every open
    /// document and known workspace file (and their imports) that sees the
    /// same definition.
    pub fn references(&mut self, path: &Path, offset: u32, include_decl: bool) -> Vec<Location> {
        let Some(fa) = self.analyze(path) else {
            return Vec::new();
        };
        // A tag has no declaration: every place its system writes it.
        if let Some(v) = fa.tag_references(offset) {
            return v;
        }
        let Some((def, dpath, dspan)) = fa.def_key(offset) else {
            return Vec::new();
        };
        let mut out: BTreeSet<(PathBuf, u32, u32)> = BTreeSet::new();
        let mut locs = Vec::new();
        let mut push = |v: Vec<Location>, locs: &mut Vec<Location>| {
            for l in v {
                if out.insert((l.path.clone(), l.span.start, l.span.end)) {
                    locs.push(l);
                }
            }
        };
        push(fa.occurrences(def, include_decl), &mut locs);
        if !matches!(def, Def::Binding { .. }) {
            for (_, other, d) in self.others_seeing(path, &dpath, dspan) {
                push(other.occurrences(d, include_decl), &mut locs);
            }
        }
        locs.sort_by(|a, b| (&a.path, a.span).cmp(&(&b.path, b.span)));
        locs
    }

    /// The open documents and known workspace files other than `path` that
    /// see the definition written at (`dpath`, `dspan`), each with its
    /// analysis and its own id of that definition.
    fn others_seeing(
        &mut self,
        path: &Path,
        dpath: &Path,
        dspan: Span,
    ) -> Vec<(PathBuf, std::sync::Arc<FileAnalysis>, Def)> {
        let me = grm_sema::normalize(path);
        let mut out = Vec::new();
        for doc in self.known_files() {
            if doc == me {
                continue;
            }
            if let Some(other) = self.analyze(&doc)
                && let Some(d) = other.def_written_at(dpath, dspan)
            {
                out.push((doc, other, d));
            }
        }
        out
    }

    /// Rename the name under `offset` of `path` to `new_name` everywhere it
    /// is seen (see [`Analysis::references`]).
    pub fn rename(
        &mut self,
        path: &Path,
        offset: u32,
        new_name: &str,
    ) -> Result<Vec<FileEdits>, RenameError> {
        let fa = self
            .analyze(path)
            .ok_or_else(|| RenameError("the file cannot be read".into()))?;
        if let Some(r) = fa.tag_rename(offset, new_name) {
            return r;
        }
        fa.prepare_rename(offset)?;
        valid_identifier(new_name)?;
        let (def, dpath, dspan) = fa
            .def_key(offset)
            .ok_or_else(|| RenameError("no renameable name here".into()))?;
        if let Some(why) = fa.rename_conflict(def, new_name) {
            return Err(RenameError(format!("cannot rename to `{new_name}`: {why}")));
        }
        // Every file that sees the definition (an importer of the file it
        // is in) is checked as this one is: its own globals may already use
        // the name, or its productions bind it.
        if !matches!(def, Def::Binding { .. }) {
            for (doc, other, d) in self.others_seeing(path, &dpath, dspan) {
                if let Some(why) = other.rename_conflict(d, new_name) {
                    return Err(RenameError(format!(
                        "cannot rename to `{new_name}`: {why} (in `{}`)",
                        doc.file_name()
                            .map_or(doc.display(), |n| Path::new(n).display())
                    )));
                }
            }
        }
        let locs = self.references(path, offset, true);
        let mut out: Vec<FileEdits> = Vec::new();
        for l in locs {
            match out.iter_mut().find(|f| f.path == l.path) {
                Some(f) => f.edits.push((l, new_name.to_string())),
                None => out.push(FileEdits {
                    path: l.path.clone(),
                    edits: vec![(l, new_name.to_string())],
                }),
            }
        }
        Ok(out)
    }
}
