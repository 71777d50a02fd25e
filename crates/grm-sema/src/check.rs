//! The driver: loading the import closure, the global items (constants,
//! meta-parameters, meshes, materials) and the per-system checks.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use grm_diag::{Code, Diagnostic, FileId, SourceMap, Span};
use grm_syntax::ast::{self, Expr, ExprKind, Item};

use crate::builtins::MaterialProp;
use crate::expr::Scope;
use crate::index::{Def, RefIndex};
use crate::loader::{FileLoader, LoadError, normalize};
use crate::program::*;
use crate::suggest;

/// The body (items) of every system of `files`, in file and source
/// order, each left empty in its tree: [`Checker::systems`] checks them
/// one at a time and drops each after.
pub(crate) fn take_system_bodies(files: &mut [LoadedFile]) -> Vec<Vec<ast::SystemItem>> {
    files
        .iter_mut()
        .flat_map(|f| f.ast.items.iter_mut())
        .filter_map(|item| match item {
            Item::System(s) => Some(std::mem::take(&mut s.items)),
            _ => None,
        })
        .collect()
}

/// How many names `files` write (declared names, module symbols,
/// patterns' parameters, names in expressions): about as many as the
/// references index will hold, which [`crate::check`] makes room for
/// before checking.
pub(crate) fn count_names(files: &[LoadedFile]) -> usize {
    use ast::{ContextItem, SystemItem};
    let mut n = 0usize;
    let mut exprs: Vec<&Expr> = Vec::new();
    for f in files {
        for item in &f.ast.items {
            n += 1;
            match item {
                Item::Import(_) | Item::Mesh(_) | Item::Error(_) => {}
                Item::Const(c) => exprs.push(&c.value),
                Item::Param(p) => {
                    exprs.push(&p.default);
                    if let Some((lo, hi)) = &p.range {
                        exprs.extend([lo, hi]);
                    }
                }
                Item::Material(m) => exprs.extend(m.fields.iter().map(|f| &f.value)),
                Item::Layout(l) => exprs.extend(l.fields.iter().map(|f| &f.value)),
                Item::System(s) => {
                    for si in &s.items {
                        match si {
                            SystemItem::Axiom(a) => {
                                n += a.modules.len();
                                exprs.extend(a.modules.iter().flat_map(|m| &m.args));
                            }
                            SystemItem::Setting(s) => exprs.push(&s.value),
                            SystemItem::Ignore(i) => n += i.symbols.len(),
                            SystemItem::ModuleDecl(d) => {
                                n += d.modules.len();
                            }
                            SystemItem::Production(p) => {
                                let pattern = |p: &ast::Pattern| 1 + p.params.len();
                                n += pattern(&p.pred);
                                for c in p.left.iter().chain(&p.right) {
                                    if let ContextItem::Pattern(p) = c {
                                        n += pattern(p);
                                    }
                                }
                                exprs.extend(p.condition.iter().chain(&p.weight));
                                n += p.successor.len();
                                exprs.extend(p.successor.iter().flat_map(|m| &m.args));
                            }
                            SystemItem::Error(_) => {}
                        }
                    }
                }
            }
            while let Some(e) = exprs.pop() {
                match &e.kind {
                    ExprKind::Name(_) => n += 1,
                    ExprKind::Call { args, .. } => exprs.extend(args),
                    ExprKind::Unary { operand: a, .. }
                    | ExprKind::Field { base: a, .. }
                    | ExprKind::Paren(a) => exprs.push(a),
                    ExprKind::Binary { lhs, rhs, .. } => exprs.extend([&**lhs, &**rhs]),
                    ExprKind::If { cond, then, els } => exprs.extend([&**cond, &**then, &**els]),
                    ExprKind::Number { .. }
                    | ExprKind::Bool(_)
                    | ExprKind::Str(_)
                    | ExprKind::Error => {}
                }
            }
        }
    }
    n
}

/// One parsed file of the import closure.
pub(crate) struct LoadedFile {
    pub id: FileId,
    /// The path used to read files relative to this one.
    pub real: PathBuf,
    pub ast: ast::File,
    /// Files this one imports directly (indices into the loaded files).
    pub imports: Vec<usize>,
    /// Each import that loaded a file: the path's span and the file
    /// (for [`crate::Program::imports`]).
    pub edges: Vec<(Span, FileId)>,
    /// Whether the parser reported errors in it.
    pub broken: bool,
    /// Whether one of its imports could not be read (E0401, E0404): names
    /// it does not know may be defined there, and are not reported.
    pub failed_import: bool,
    /// Primary spans of the parser's diagnostics (to avoid follow-on reports).
    pub error_spans: Vec<Span>,
}

/// Load the root and everything it imports, parsing each file once.
pub(crate) fn load_all(
    sources: &mut SourceMap,
    root: FileId,
    loader: &dyn FileLoader,
    diags: &mut Vec<Diagnostic>,
) -> Vec<LoadedFile> {
    let root_file = sources.get(root);
    let root_display = root_file.path.clone();
    let real = loader.resolve(Path::new(""), &root_display);
    // The root is parsed from the source map's text, not a copy of it
    // (a second copy of a large file while its tree is built: issue 32).
    let parsed = grm_syntax::parse(root, &root_file.text);
    let mut l = Loader {
        sources,
        loader,
        diags,
        files: Vec::new(),
        by_path: HashMap::new(),
        state: Vec::new(),
        stack: Vec::new(),
    };
    l.load(root, real, parsed);
    l.files
}

struct Loader<'a> {
    sources: &'a mut SourceMap,
    loader: &'a dyn FileLoader,
    diags: &'a mut Vec<Diagnostic>,
    files: Vec<LoadedFile>,
    by_path: HashMap<PathBuf, usize>,
    /// Per file: still loading its imports (on the stack).
    state: Vec<bool>,
    stack: Vec<usize>,
}

impl Loader<'_> {
    /// Load a file and, depth first, everything it imports. Iterative (an
    /// explicit stack of open files), so a long import chain cannot
    /// exhaust the call stack.
    fn load(&mut self, id: FileId, real: PathBuf, parsed: grm_syntax::Parsed) -> usize {
        let root = self.open(id, real, parsed);
        // Per open file: its imports and how many of them were handled.
        let mut open = vec![(root, self.imports_of(root), 0usize)];
        while let Some((idx, imports, next)) = open.last_mut() {
            let idx = *idx;
            let Some(imp) = imports.get(*next).cloned() else {
                open.pop();
                self.stack.pop();
                self.state[idx] = false;
                continue;
            };
            *next += 1;
            if let Some(t) = self.import(idx, &imp) {
                open.push((t, self.imports_of(t), 0));
            }
        }
        root
    }

    /// Put a parsed file on the stack of files being loaded.
    fn open(&mut self, id: FileId, real: PathBuf, parsed: grm_syntax::Parsed) -> usize {
        let broken = parsed.has_errors();
        let error_spans = parsed
            .diagnostics
            .iter()
            .map(|d| d.primary().span)
            .collect();
        self.diags.extend(parsed.diagnostics);
        let idx = self.files.len();
        self.files.push(LoadedFile {
            id,
            real: real.clone(),
            ast: parsed.file,
            imports: Vec::new(),
            edges: Vec::new(),
            broken,
            failed_import: false,
            error_spans,
        });
        self.by_path.insert(real, idx);
        self.state.push(true);
        self.stack.push(idx);
        idx
    }

    fn imports_of(&self, idx: usize) -> Vec<ast::Import> {
        self.files[idx]
            .ast
            .items
            .iter()
            .filter_map(|it| match it {
                Item::Import(i) => Some(i.clone()),
                _ => None,
            })
            .collect()
    }

    /// Handle one import of file `idx`. Returns the imported file if it was
    /// newly opened (its imports are to be loaded next).
    fn import(&mut self, idx: usize, imp: &ast::Import) -> Option<usize> {
        let id = self.files[idx].id;
        let real = self.files[idx].real.clone();
        let display = self.sources.get(id).path.clone();
        let written = &imp.path.value;
        if overlaps_any(&self.files[idx].error_spans, imp.path.span) {
            return None; // a garbled path was reported by the parser
        }
        if written.trim().is_empty() {
            // Joined to the importing file's directory, it would name that
            // directory ("it is a directory").
            self.files[idx].failed_import = true;
            self.diags.push(
                Diagnostic::new(
                    Code::ImportNotFound,
                    "the import path is empty",
                    id,
                    imp.path.span,
                    "empty path",
                )
                .with_help("write the path of a `.grm` file, relative to the directory of the importing file, e.g. `import \"common.grm\";`"),
            );
            return None;
        }
        let target_real = self.loader.resolve(&real, written);
        if let Some(&t) = self.by_path.get(&target_real) {
            let to = self.files[t].id;
            self.files[idx].edges.push((imp.path.span, to));
            if self.state[t] {
                // On the stack: a cycle.
                let start = self.stack.iter().position(|&s| s == t).unwrap_or(0);
                let chain: Vec<String> = self.stack[start..]
                    .iter()
                    .chain(std::iter::once(&t))
                    .map(|&f| format!("`{}`", self.sources.get(self.files[f].id).path))
                    .collect();
                self.diags.push(
                    Diagnostic::new(
                        Code::ImportCycle,
                        format!("importing `{written}` here closes an import cycle"),
                        id,
                        imp.path.span,
                        "this import closes a cycle",
                    )
                    .with_note(format!("import chain: {}", chain.join(" -> ")))
                    .with_help("move the shared definitions into a third file that both import"),
                );
                // Names stay visible, so the cycle is the only error.
                self.files[idx].imports.push(t);
            } else if !self.files[idx].imports.contains(&t) {
                self.files[idx].imports.push(t);
            }
            return None;
        }
        let target_display = normalize(
            &Path::new(&display)
                .parent()
                .unwrap_or(Path::new(""))
                .join(written),
        )
        .to_string_lossy()
        .replace('\\', "/");
        let text = match self.sources.find(&target_display) {
            Some(existing) => Ok(self.sources.get(existing).text.clone()),
            None => self.loader.read(&target_real),
        };
        match text {
            Ok(text) => {
                let fid = match self.sources.find(&target_display) {
                    Some(f) => f,
                    None => self.sources.add(target_display, text.clone()),
                };
                let t = self.open(fid, target_real, grm_syntax::parse(fid, &text));
                self.files[idx].imports.push(t);
                self.files[idx].edges.push((imp.path.span, fid));
                Some(t)
            }
            Err(e) => {
                let (code, msg, label) = match e {
                    LoadError::NotFound => (
                        Code::ImportNotFound,
                        format!("cannot find the imported file `{written}`"),
                        "no such file".to_string(),
                    ),
                    LoadError::NotUtf8 => (
                        Code::InvalidEncoding,
                        format!("the imported file `{written}` is not valid UTF-8 text"),
                        "not UTF-8".to_string(),
                    ),
                    LoadError::Other(m) => (
                        Code::ImportNotFound,
                        format!("cannot read the imported file `{written}`"),
                        m,
                    ),
                };
                self.files[idx].failed_import = true;
                let mut d = Diagnostic::new(code, msg, id, imp.path.span, label);
                if code == Code::ImportNotFound {
                    d = d.with_help(
                        "import paths are relative to the directory of the importing file",
                    );
                }
                self.diags.push(d);
                None
            }
        }
    }
}

/// What a global name denotes.
#[derive(Clone, Copy, Debug)]
pub(crate) enum GlobalKind {
    /// A constant or meta-parameter: index into `Checker::values`.
    Value(usize),
    Mesh(MeshId),
    Material(MaterialId),
}

#[derive(Clone, Copy, Debug)]
pub(crate) struct GlobalName {
    pub kind: GlobalKind,
    pub file_idx: usize,
    pub loc: Loc,
}

#[derive(Clone, Copy, Debug)]
pub(crate) enum ValueAst<'a> {
    Const(&'a ast::ConstDecl),
    Param(&'a ast::ParamDecl),
}

/// The checked form of a constant or meta-parameter.
#[derive(Clone, Copy, Debug)]
pub(crate) enum ValueInfo {
    /// Not checked yet (or part of a cycle being checked).
    Pending,
    Const {
        id: ConstId,
        ty: Ty,
        folded: Option<Value>,
        broken: bool,
    },
    Param {
        id: ParamId,
        ty: Ty,
    },
}

pub(crate) struct ValueDecl<'a> {
    pub file_idx: usize,
    pub name: &'a str,
    pub loc: Loc,
    pub ast: ValueAst<'a>,
    pub info: ValueInfo,
    pub uses: u32,
}

/// All checking state.
pub(crate) struct Checker<'a> {
    pub files: &'a [LoadedFile],
    pub loader: &'a dyn FileLoader,
    pub diags: Vec<Diagnostic>,
    pub names: HashMap<&'a str, GlobalName>,
    /// `visible[f][g]`: file f sees the definitions of file g.
    pub visible: Vec<Vec<bool>>,
    /// Per file: its place in load order ([`load_order`]).
    pub load_rank: Vec<usize>,
    /// Per global name: the definition that comes first in load order
    /// (file index, name span); every other one is a duplicate (E0102).
    pub first_defs: HashMap<&'a str, (usize, Span)>,
    /// Per file: the global names it sees, sorted (for suggestions; built
    /// on first use, once the names are complete).
    pub visible_cache: Vec<Option<suggest::Candidates<'a>>>,
    pub values: Vec<ValueDecl<'a>>,
    pub program: Program,
    /// Global values evaluated with the parameters' defaults (by ConstId).
    pub default_globals: Vec<Value>,
    /// Current expression nesting (see `Checker::expr`).
    pub depth: u32,
    pub deep_reported: bool,
}

impl<'a> Checker<'a> {
    pub(crate) fn new(
        files: &'a [LoadedFile],
        loader: &'a dyn FileLoader,
        diags: Vec<Diagnostic>,
    ) -> Self {
        let n = files.len();
        let mut visible = vec![vec![false; n]; n];
        for (f, row) in visible.iter_mut().enumerate() {
            let mut stack = vec![f];
            while let Some(g) = stack.pop() {
                if !row[g] {
                    row[g] = true;
                    stack.extend(files[g].imports.iter().copied());
                }
            }
        }
        Checker {
            files,
            loader,
            diags,
            names: HashMap::new(),
            visible,
            load_rank: load_order(files),
            first_defs: HashMap::new(),
            visible_cache: (0..n).map(|_| None).collect(),
            values: Vec::new(),
            program: Program {
                root: files.first().map(|f| f.id).unwrap_or_default(),
                consts: Vec::new(),
                params: Vec::new(),
                meshes: Vec::new(),
                materials: Vec::new(),
                systems: Vec::new(),
                layouts: Vec::new(),
                index: RefIndex::default(),
                imports: Vec::new(),
            },
            default_globals: Vec::new(),
            depth: 0,
            deep_reported: false,
        }
    }

    pub(crate) fn file_id(&self, file_idx: usize) -> FileId {
        self.files[file_idx].id
    }

    pub(crate) fn error(&mut self, d: Diagnostic) {
        self.diags.push(d);
    }

    /// Give the E0101 reported at `span` since diagnostic `since` the help
    /// its context knows better (`mesh(leaf)`: declare a mesh), unless
    /// `keep_suggestion` and it already suggests a close name.
    pub(crate) fn amend_unknown_name(
        &mut self,
        since: usize,
        span: Span,
        help: String,
        keep_suggestion: bool,
    ) {
        if let Some(d) = self.diags[since..]
            .iter_mut()
            .find(|d| d.code == Code::UnknownName && d.primary().span == span)
            && !(keep_suggestion
                && d.help
                    .as_deref()
                    .is_some_and(|h| h.starts_with("did you mean")))
        {
            d.help = Some(help);
        }
    }

    /// Collect and check the global items of every file.
    pub(crate) fn globals(&mut self) {
        let files = self.files;
        // 0. Which definition of each name comes first in load order.
        for (fi, f) in files.iter().enumerate() {
            for item in &f.ast.items {
                let name = match item {
                    Item::Const(c) => &c.name,
                    Item::Param(p) => &p.name,
                    Item::Mesh(m) => &m.name,
                    Item::Material(m) => &m.name,
                    Item::Import(_) | Item::System(_) | Item::Layout(_) | Item::Error(_) => {
                        continue;
                    }
                };
                let key = (self.load_rank[fi], name.span.start);
                self.first_defs
                    .entry(&name.name)
                    .and_modify(|e| {
                        if key < (self.load_rank[e.0], e.1.start) {
                            *e = (fi, name.span);
                        }
                    })
                    .or_insert((fi, name.span));
            }
        }
        // 1. Names.
        let mut material_asts: Vec<(usize, &'a ast::MaterialDecl)> = Vec::new();
        for (fi, f) in files.iter().enumerate() {
            for item in &f.ast.items {
                match item {
                    Item::Const(c) => {
                        let loc = Loc::new(f.id, c.name.span);
                        if self.define(&c.name, fi, GlobalKind::Value(self.values.len())) {
                            self.values.push(ValueDecl {
                                file_idx: fi,
                                name: &c.name.name,
                                loc,
                                ast: ValueAst::Const(c),
                                info: ValueInfo::Pending,
                                uses: 0,
                            });
                        }
                    }
                    Item::Param(p) => {
                        let loc = Loc::new(f.id, p.name.span);
                        if self.define(&p.name, fi, GlobalKind::Value(self.values.len())) {
                            let id = ParamId(self.program.params.len() as u32);
                            self.program.params.push(MetaParam {
                                name: p.name.name.to_string(),
                                loc,
                                ty: Ty::Float,
                                default: Value::Float(0.0),
                                range: None,
                            });
                            self.program
                                .index
                                .push(f.id, p.name.span, Def::Param(id), true);
                            self.values.push(ValueDecl {
                                file_idx: fi,
                                name: &p.name.name,
                                loc,
                                ast: ValueAst::Param(p),
                                info: ValueInfo::Param { id, ty: Ty::Float },
                                uses: 0,
                            });
                        }
                    }
                    Item::Mesh(m) => {
                        let id = MeshId(self.program.meshes.len() as u32);
                        if self.define(&m.name, fi, GlobalKind::Mesh(id)) {
                            let path = self.loader.resolve(&f.real, &m.path.value);
                            let garbled = overlaps_any(&f.error_spans, m.path.span);
                            if !garbled && m.path.value.trim().is_empty() {
                                self.error(
                                    Diagnostic::new(
                                        Code::MeshNotFound,
                                        "the mesh path is empty",
                                        f.id,
                                        m.path.span,
                                        "empty path",
                                    )
                                    .with_help("write the path of an OBJ file, relative to the directory of the declaring file, e.g. `mesh leaf = \"leaf.obj\";`"),
                                );
                            } else if !garbled && !self.loader.exists(&path) {
                                let why = self.loader.why_missing(&path);
                                // A path that exists but is no file (a
                                // directory, a device) is named as such.
                                let message = if why == "no such file" {
                                    format!("cannot find the mesh file `{}`", m.path.value)
                                } else {
                                    format!(
                                        "the mesh file `{}` cannot be read: {why}",
                                        m.path.value
                                    )
                                };
                                self.error(
                                    Diagnostic::new(
                                        Code::MeshNotFound,
                                        message,
                                        f.id,
                                        m.path.span,
                                        why,
                                    )
                                    .with_help("mesh paths are relative to the directory of the file that declares them"),
                                );
                            }
                            self.program
                                .index
                                .push(f.id, m.name.span, Def::Mesh(id), true);
                            self.program.meshes.push(Mesh {
                                name: m.name.name.to_string(),
                                loc: Loc::new(f.id, m.name.span),
                                written: m.path.value.clone(),
                                path,
                            });
                        }
                    }
                    Item::Material(m) => {
                        let id = MaterialId(self.program.materials.len() as u32);
                        if self.define(&m.name, fi, GlobalKind::Material(id)) {
                            self.program
                                .index
                                .push(f.id, m.name.span, Def::Material(id), true);
                            self.program.materials.push(Material {
                                name: m.name.name.to_string(),
                                loc: Loc::new(f.id, m.name.span),
                                fields: Vec::new(),
                            });
                            material_asts.push((fi, m));
                        }
                    }
                    Item::Import(_) | Item::System(_) | Item::Layout(_) | Item::Error(_) => {}
                }
            }
        }

        // 2. Constants and parameters in dependency order.
        self.check_values();

        // 3. Materials.
        for (i, (fi, m)) in material_asts.into_iter().enumerate() {
            let fields = self.check_material(fi, m);
            self.program.materials[i].fields = fields;
        }
    }

    /// Register a global name; reports a duplicate and returns false. Of
    /// several definitions of a name the first in load order is the one
    /// registered (within a file the first written; across files that of
    /// the imported file, whose definitions come before the importer's),
    /// and each other one is reported as defined again, as it would be if
    /// the imported file's text stood in place of its `import`.
    fn define(&mut self, name: &'a ast::Ident, file_idx: usize, kind: GlobalKind) -> bool {
        let file = self.file_id(file_idx);
        let first = self
            .first_defs
            .get(name.name.as_str())
            .copied()
            .unwrap_or((file_idx, name.span));
        if first != (file_idx, name.span) && !name.name.is_empty() {
            let prev = Loc::new(self.file_id(first.0), first.1);
            self.error(
                Diagnostic::new(
                    Code::DuplicateDefinition,
                    format!("`{}` is defined more than once", name.name),
                    file,
                    name.span,
                    "defined again here",
                )
                .with_label(prev.file, prev.span, "first defined here")
                .with_help("constants, parameters, meshes and materials share one namespace; rename one of them"),
            );
            return false;
        }
        self.visible_cache.iter_mut().for_each(|c| *c = None);
        self.names.insert(
            &name.name,
            GlobalName {
                kind,
                file_idx,
                loc: Loc::new(file, name.span),
            },
        );
        true
    }

    /// Look a global name up as seen from a file.
    pub(crate) fn lookup(&self, file_idx: usize, name: &str) -> Option<GlobalName> {
        let g = self.names.get(name)?;
        self.visible[file_idx][g.file_idx].then_some(*g)
    }

    /// Global names visible from a file, sorted (for suggestions). Built
    /// once per file and check (the names are complete before the first
    /// expression is typed; a later definition would clear the cache).
    pub(crate) fn visible_names(&mut self, file_idx: usize) -> &suggest::Candidates<'a> {
        let names = &self.names;
        let visible = &self.visible[file_idx];
        self.visible_cache[file_idx].get_or_insert_with(|| {
            let mut v: Vec<&'a str> = names
                .iter()
                .filter(|(_, g)| visible[g.file_idx])
                .map(|(n, _)| *n)
                .collect();
            v.sort_unstable();
            suggest::Candidates::new(v)
        })
    }

    fn check_values(&mut self) {
        let n = self.values.len();
        // Dependency edges with the span of the reference.
        let mut edges: Vec<Vec<(usize, Span)>> = vec![Vec::new(); n];
        for (i, edge_list) in edges.iter_mut().enumerate() {
            let v = &self.values[i];
            let fi = v.file_idx;
            let mut names = Vec::new();
            match v.ast {
                ValueAst::Const(c) => collect_names(&c.value, &mut names),
                ValueAst::Param(p) => {
                    collect_names(&p.default, &mut names);
                    if let Some((lo, hi)) = &p.range {
                        collect_names(lo, &mut names);
                        collect_names(hi, &mut names);
                    }
                }
            }
            for id in names {
                if let Some(GlobalName {
                    kind: GlobalKind::Value(j),
                    ..
                }) = self.lookup(fi, &id.name)
                {
                    edge_list.push((j, id.span));
                }
            }
        }
        for e in edges.iter().flatten() {
            self.values[e.0].uses += 1;
        }
        // Iterative DFS: post-order is dependency order; a back edge is a cycle.
        #[derive(Clone, Copy, PartialEq)]
        enum Mark {
            White,
            Gray,
            Black,
        }
        let mut mark = vec![Mark::White; n];
        let mut order = Vec::with_capacity(n);
        let mut cyclic = vec![false; n];
        for start in 0..n {
            if mark[start] != Mark::White {
                continue;
            }
            let mut stack: Vec<(usize, usize)> = vec![(start, 0)];
            mark[start] = Mark::Gray;
            while let Some(&mut (v, ref mut next)) = stack.last_mut() {
                if let Some(&(w, span)) = edges[v].get(*next) {
                    *next += 1;
                    match mark[w] {
                        Mark::White => {
                            mark[w] = Mark::Gray;
                            stack.push((w, 0));
                        }
                        Mark::Gray => {
                            let from = stack.iter().position(|&(s, _)| s == w).unwrap_or(0);
                            let members: Vec<usize> =
                                stack[from..].iter().map(|&(s, _)| s).collect();
                            for &m in &members {
                                cyclic[m] = true;
                            }
                            let chain: Vec<String> = members
                                .iter()
                                .chain(std::iter::once(&w))
                                .map(|&m| format!("`{}`", self.values[m].name))
                                .collect();
                            let file = self.file_id(self.values[v].file_idx);
                            let wl = self.values[w].loc;
                            let d = Diagnostic::new(
                                Code::CyclicConstant,
                                format!("`{}` is defined in terms of itself", self.values[w].name),
                                file,
                                span,
                                "this reference closes the cycle",
                            )
                            .with_label(wl.file, wl.span, "defined here")
                            .with_note(format!("cycle: {}", chain.join(" -> ")))
                            .with_help(
                                "give one of these a value that does not depend on the others",
                            );
                            self.error(d);
                        }
                        Mark::Black => {}
                    }
                } else {
                    mark[v] = Mark::Black;
                    order.push(v);
                    stack.pop();
                }
            }
        }
        for v in order {
            self.check_value(v, cyclic[v]);
        }
        // Values with the parameters' defaults, for settings.
        let params = self.program.default_params();
        let mut globals = Vec::with_capacity(self.program.consts.len());
        for c in &self.program.consts {
            let env = crate::eval::Env {
                params: &params,
                globals: &globals,
                bindings: &[],
            };
            globals.push(crate::eval::eval(&c.value, &env).unwrap_or(Value::zero(c.ty)));
        }
        self.default_globals = globals;
    }

    pub(crate) fn resolve_type(&mut self, file_idx: usize, ann: &ast::TypeAnn) -> Ty {
        match ann.name.name.as_str() {
            "float" => Ty::Float,
            "vec3" => Ty::Vec3,
            "bool" => Ty::Bool,
            other => {
                let mut d = Diagnostic::new(
                    Code::UnknownType,
                    format!("unknown type `{other}`"),
                    self.file_id(file_idx),
                    ann.name.span,
                    "not a type",
                );
                d = match suggest::did_you_mean(other, ["float", "vec3", "bool"]) {
                    Some(h) => d.with_help(h),
                    None if matches!(
                        other,
                        "int" | "integer" | "number" | "double" | "f32" | "f64"
                    ) =>
                    {
                        d.with_help(
                            "numbers are `float` (whole-number settings are checked as floats)",
                        )
                    }
                    None => d.with_help("the types are `float`, `vec3` and `bool`"),
                };
                self.error(d);
                Ty::Error
            }
        }
    }

    fn check_value(&mut self, v: usize, cyclic: bool) {
        let fi = self.values[v].file_idx;
        let file = self.file_id(fi);
        match self.values[v].ast {
            ValueAst::Const(c) => {
                let ann = c.ty.as_ref().map(|t| self.resolve_type(fi, t));
                let mut sc = Scope::global(fi, true, "a constant");
                let mut value = if cyclic {
                    TExpr::error(c.value.span)
                } else {
                    self.expr(&c.value, &mut sc)
                };
                if let Some(t) = ann {
                    value = self.expect(file, value, t, "the declared type");
                }
                let ty = match ann {
                    Some(t) => t,
                    None => value.ty,
                };
                let broken = cyclic || ty == Ty::Error || value.ty == Ty::Error;
                let id = ConstId(self.program.consts.len() as u32);
                self.program
                    .index
                    .push(file, c.name.span, Def::Const(id), true);
                self.values[v].info = ValueInfo::Const {
                    id,
                    ty,
                    folded: value.constant(),
                    broken,
                };
                self.program.consts.push(Const {
                    name: c.name.name.to_string(),
                    loc: Loc::new(file, c.name.span),
                    ty,
                    value,
                });
            }
            ValueAst::Param(p) => {
                let ValueInfo::Param { id, .. } = self.values[v].info else {
                    return;
                };
                let ann = p.ty.as_ref().map(|t| self.resolve_type(fi, t));
                let mut sc = Scope::global(fi, false, "a meta-parameter's default");
                let mut default = if cyclic {
                    TExpr::error(p.default.span)
                } else {
                    self.expr(&p.default, &mut sc)
                };
                if let Some(t) = ann {
                    default = self.expect(file, default, t, "the declared type");
                }
                let ty = ann.unwrap_or(default.ty);
                let dv = default.constant();
                let mut range = None;
                if let Some((lo, hi)) = &p.range {
                    let mut sc = Scope::global(fi, false, "a meta-parameter's range");
                    let tlo = self.expr(lo, &mut sc);
                    let thi = self.expr(hi, &mut sc);
                    if ty == Ty::Error || tlo.ty == Ty::Error || thi.ty == Ty::Error {
                        // already reported
                    } else if ty != Ty::Float {
                        self.error(
                            Diagnostic::new(
                                Code::InvalidParamRange,
                                format!(
                                    "a range needs a `float` parameter, but `{}` is `{ty}`",
                                    p.name.name
                                ),
                                file,
                                lo.span.to(hi.span),
                                "range on a non-float parameter",
                            )
                            .with_help("remove the `in lo .. hi` part"),
                        );
                    } else {
                        let tlo = self.expect(file, tlo, Ty::Float, "a range bound");
                        let thi = self.expect(file, thi, Ty::Float, "a range bound");
                        if let (Some(Value::Float(a)), Some(Value::Float(b))) =
                            (tlo.constant(), thi.constant())
                        {
                            if a.partial_cmp(&b) != Some(std::cmp::Ordering::Less) {
                                self.error(
                                    Diagnostic::new(
                                        Code::InvalidParamRange,
                                        format!("the range of `{}` is empty", p.name.name),
                                        file,
                                        lo.span.to(hi.span),
                                        format!("{a} .. {b} has no room"),
                                    )
                                    .with_help(
                                        "write the smaller bound first: `in lo .. hi` with lo < hi",
                                    ),
                                );
                            } else if let Some(Value::Float(d)) = dv {
                                if !(a <= d && d <= b) {
                                    self.error(
                                        Diagnostic::new(
                                            Code::InvalidParamRange,
                                            format!(
                                                "the default of `{}` is outside its range",
                                                p.name.name
                                            ),
                                            file,
                                            p.default.span,
                                            format!("{d} is not in {a} .. {b}"),
                                        )
                                        .with_label(file, lo.span.to(hi.span), "the range")
                                        .with_help(
                                            "move the default into the range or widen the range",
                                        ),
                                    );
                                } else {
                                    range = Some((a, b));
                                }
                            } else {
                                range = Some((a, b));
                            }
                        }
                    }
                }
                let pm = &mut self.program.params[id.index()];
                pm.ty = ty;
                pm.default = dv.unwrap_or(Value::zero(ty));
                pm.range = range;
                self.values[v].info = ValueInfo::Param { id, ty };
            }
        }
    }

    fn check_material(&mut self, fi: usize, m: &'a ast::MaterialDecl) -> Vec<MaterialField> {
        let file = self.file_id(fi);
        let mut out: Vec<MaterialField> = Vec::new();
        let mut seen: HashMap<MaterialProp, Span> = HashMap::new();
        for f in &m.fields {
            let mut sc = Scope::global(fi, true, "a material property");
            let value = self.expr(&f.value, &mut sc);
            let Some(prop) = MaterialProp::from_name(&f.name.name) else {
                let mut d = Diagnostic::new(
                    Code::UnknownMaterialProperty,
                    format!("materials have no property `{}`", f.name.name),
                    file,
                    f.name.span,
                    "unknown property",
                );
                let names = MaterialProp::ALL.iter().map(|p| p.name());
                d = match suggest::did_you_mean(&f.name.name, names) {
                    Some(h) => d.with_help(h),
                    None => d.with_help(format!(
                        "the properties are {}",
                        MaterialProp::ALL
                            .iter()
                            .map(|p| format!("`{}`", p.name()))
                            .collect::<Vec<_>>()
                            .join(", ")
                    )),
                };
                self.error(d);
                continue;
            };
            if let Some(prev) = seen.get(&prop) {
                let prev = *prev;
                self.error(
                    Diagnostic::new(
                        Code::DuplicateSetting,
                        format!(
                            "`{}` is set twice in material `{}`",
                            prop.name(),
                            m.name.name
                        ),
                        file,
                        f.name.span,
                        "set again here",
                    )
                    .with_label(file, prev, "first set here")
                    .with_help("remove one of them"),
                );
                continue;
            }
            seen.insert(prop, f.name.span);
            let value = self.expect(
                file,
                value,
                prop.ty(),
                &format!("material property `{}`", prop.name()),
            );
            self.check_material_value(file, &m.name.name, prop, &value);
            out.push(MaterialField {
                prop,
                value,
                span: f.span,
            });
        }
        out
    }

    /// A material value must be finite (E0212) and should lie in 0..1
    /// (W0010: the model clamps it, as glTF and MTL allow nothing else).
    /// A value that depends on meta-parameters is checked with their
    /// defaults; one that draws random numbers is not checked here (the
    /// geometry builder falls back to the default property for a
    /// non-finite value at run time).
    fn check_material_value(
        &mut self,
        file: FileId,
        material: &str,
        prop: MaterialProp,
        value: &TExpr,
    ) {
        if value.ty == Ty::Error {
            return;
        }
        let params = self.program.default_params();
        let env = crate::eval::Env {
            params: &params,
            globals: &self.default_globals,
            bindings: &[],
        };
        let Ok(v) = crate::eval::eval(value, &env) else {
            return;
        };
        let xs: Vec<f64> = match v {
            Value::Float(x) => vec![x],
            Value::Vec3(c) => c.to_vec(),
            _ => return,
        };
        let subject = format!("`{}` of material `{material}`", prop.name());
        let d = crate::unit::check(&crate::unit::UnitValue {
            file,
            span: value.span,
            subject: &subject,
            xs: &xs,
            write: &crate::unit::write_value,
            constant: value.constant().is_some(),
            kind: "material values",
        });
        if let Some(d) = d {
            self.error(d);
        }
    }

    /// Check every system of every file. Of several systems with one name
    /// the first in load order is the first definition (as for globals,
    /// see `define`); all of them are checked.
    ///
    /// `bodies` are the systems' items ([`take_system_bodies`]), in the
    /// same order; each is dropped once its system is checked.
    pub(crate) fn systems(&mut self, bodies: Vec<Vec<ast::SystemItem>>) {
        let files = self.files;
        let mut bodies = bodies.into_iter();
        let mut first: HashMap<&str, (usize, Span)> = HashMap::new();
        for (fi, f) in files.iter().enumerate() {
            for item in &f.ast.items {
                if let Item::System(s) = item {
                    let key = (self.load_rank[fi], s.name.span.start);
                    first
                        .entry(&s.name.name)
                        .and_modify(|e| {
                            if key < (self.load_rank[e.0], e.1.start) {
                                *e = (fi, s.name.span);
                            }
                        })
                        .or_insert((fi, s.name.span));
                }
            }
        }
        for (fi, f) in files.iter().enumerate() {
            for item in &f.ast.items {
                if let Item::System(s) = item {
                    let (ffi, fspan) = first[s.name.name.as_str()];
                    // A system whose name did not parse (the parser
                    // reported it) has an empty name: not a duplicate.
                    if (ffi, fspan) != (fi, s.name.span) && !s.name.name.is_empty() {
                        let pl = Loc::new(files[ffi].id, fspan);
                        self.error(
                            Diagnostic::new(
                                Code::DuplicateDefinition,
                                format!("system `{}` is defined more than once", s.name.name),
                                f.id,
                                s.name.span,
                                "defined again here",
                            )
                            .with_label(pl.file, pl.span, "first defined here")
                            .with_help("rename one of the systems"),
                        );
                    }
                    let id = SystemId(self.program.systems.len() as u32);
                    self.program
                        .index
                        .push(f.id, s.name.span, Def::System(id), true);
                    let mut whole = ast::System {
                        name: s.name.clone(),
                        items: bodies.next().unwrap_or_default(),
                        span: s.span,
                    };
                    let sys = crate::system::check_system(self, fi, &mut whole, id);
                    self.program.systems.push(sys);
                }
            }
        }
    }

    /// File-level warnings: unused definitions and a root without systems.
    pub(crate) fn file_warnings(&mut self) {
        let Some(root) = self.files.first() else {
            return;
        };
        // A system of an imported file runs from this one too (`grmc
        // derive FILE` derives it): not "nothing to run".
        let root_has_system = !self.program.systems.is_empty()
            || root.ast.items.iter().any(|i| matches!(i, Item::System(_)));
        let root_has_holes =
            root.broken || root.ast.items.iter().any(|i| matches!(i, Item::Error(_)));
        // A file of shared definitions (constants, parameters, meshes,
        // materials) is a library meant to be imported: no warning.
        let root_defines = root.ast.items.iter().any(|i| {
            matches!(
                i,
                Item::Const(_) | Item::Param(_) | Item::Mesh(_) | Item::Material(_)
            )
        });
        // After an error (an import that failed) the file is to be fixed
        // first: no warning on top.
        let has_errors = self
            .diags
            .iter()
            .any(|d| d.severity == grm_diag::Severity::Error);
        if !root_has_system && !root_defines && !root_has_holes && !has_errors {
            self.diags.push(
                Diagnostic::new(
                    Code::NoSystem,
                    "this file defines no system",
                    root.id,
                    Span::new(0, 0),
                    "no `system NAME { ... }` in this file",
                )
                .with_help("add a `system NAME { ... }` block; see docs/language.md"),
            );
        }
        // A misspelt name is reported once, not also as an unused definition.
        let misspelt = self.diags.iter().any(|d| d.code == Code::UnknownName);
        if root_has_system && !root_has_holes && !misspelt {
            let mut unused = Vec::new();
            for v in &self.values {
                if v.file_idx == 0 && v.uses == 0 && !v.name.starts_with('_') {
                    unused.push((v.loc, v.name, matches!(v.ast, ValueAst::Param(_))));
                }
            }
            for (loc, name, is_param) in unused {
                let what = if is_param {
                    "meta-parameter"
                } else {
                    "constant"
                };
                self.diags.push(
                    Diagnostic::new(
                        Code::UnusedDefinition,
                        format!("{what} `{name}` is never used"),
                        loc.file,
                        loc.span,
                        "defined here, used nowhere",
                    )
                    .with_help(format!(
                        "remove it, or prefix the name with `_` (`_{name}`) to keep it"
                    )),
                );
            }
        }
    }
}

/// Each file's place in load order: a file comes after everything it
/// imports (a depth-first post-order from the root, imports in the order
/// written; in a cycle, the file reached first comes last), as if each
/// `import` were replaced by the imported file's text.
pub(crate) fn load_order(files: &[LoadedFile]) -> Vec<usize> {
    let n = files.len();
    let mut rank = vec![0; n];
    let mut seen = vec![false; n];
    let mut next = 0;
    for start in 0..n {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        let mut stack = vec![(start, 0usize)];
        while let Some((f, i)) = stack.last_mut() {
            let f = *f;
            if let Some(&g) = files[f].imports.get(*i) {
                *i += 1;
                if !seen[g] {
                    seen[g] = true;
                    stack.push((g, 0));
                }
            } else {
                rank[f] = next;
                next += 1;
                stack.pop();
            }
        }
    }
    rank
}

/// Every name referenced by an expression (not function names), down to
/// the checker's nesting limit.
pub(crate) fn collect_names<'e>(e: &'e Expr, out: &mut Vec<&'e ast::Ident>) {
    names_rec(e, out, 0);
}

fn names_rec<'e>(e: &'e Expr, out: &mut Vec<&'e ast::Ident>, depth: u32) {
    if depth >= crate::expr::MAX_DEPTH {
        return;
    }
    let d = depth + 1;
    match &e.kind {
        ExprKind::Name(id) => out.push(id),
        ExprKind::Call { args, .. } => {
            for a in args {
                names_rec(a, out, d);
            }
        }
        ExprKind::Unary { operand, .. } => names_rec(operand, out, d),
        ExprKind::Binary { lhs, rhs, .. } => {
            names_rec(lhs, out, d);
            names_rec(rhs, out, d);
        }
        ExprKind::Field { base, .. } => names_rec(base, out, d),
        ExprKind::If { cond, then, els } => {
            names_rec(cond, out, d);
            names_rec(then, out, d);
            names_rec(els, out, d);
        }
        ExprKind::Paren(inner) => names_rec(inner, out, d),
        ExprKind::Number { .. } | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Error => {}
    }
}

/// Whether an expression contains a parse error hole (or nests beyond the
/// checker's limit, which is reported as an error too).
pub(crate) fn has_error(e: &Expr) -> bool {
    error_rec(e, 0)
}

fn error_rec(e: &Expr, depth: u32) -> bool {
    if depth >= crate::expr::MAX_DEPTH {
        return true;
    }
    let d = depth + 1;
    match &e.kind {
        ExprKind::Error => true,
        ExprKind::Call { args, .. } => args.iter().any(|a| error_rec(a, d)),
        ExprKind::Unary { operand, .. } => error_rec(operand, d),
        ExprKind::Binary { lhs, rhs, .. } => error_rec(lhs, d) || error_rec(rhs, d),
        ExprKind::Field { base, .. } => error_rec(base, d),
        ExprKind::If { cond, then, els } => {
            error_rec(cond, d) || error_rec(then, d) || error_rec(els, d)
        }
        ExprKind::Paren(inner) => error_rec(inner, d),
        ExprKind::Number { .. } | ExprKind::Bool(_) | ExprKind::Str(_) | ExprKind::Name(_) => false,
    }
}

/// Whether `span` overlaps one of `spans` (an empty span counts as one byte).
fn overlaps_any(spans: &[Span], span: Span) -> bool {
    spans
        .iter()
        .any(|s| s.start < span.end.max(span.start + 1) && span.start < s.end.max(s.start + 1))
}
