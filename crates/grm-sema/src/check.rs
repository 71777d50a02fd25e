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

mod load;
mod values;
pub(crate) use load::{LoadedFile, load_all, load_order};

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
