//! `grm-sema`: the checker of the `.grm` language.
//!
//! Role: the second phase of the pipeline (docs/language.md is the
//! contract). It takes the syntax trees of a file and of everything it
//! imports, resolves every name, infers and checks types, enforces the phase
//! rules of guided (sample) systems, runs the whole-grammar analyses
//! (termination, reachability, shadowing) and produces a typed, resolved
//! [`Program`] that later stages lower without checking anything again.
//!
//! Inputs: a [`SourceMap`] holding the root file, its [`FileId`], and a
//! [`FileLoader`] that reads imported grammars and answers whether mesh files
//! exist ([`FsLoader`] for the file system, [`MemLoader`] for tests and
//! editors). Imported files are parsed with [`grm_syntax::parse`] and added
//! to the source map (a file already in the map under the same path is
//! used as it is there, so an editor can supply unsaved buffers).
//!
//! Outputs: [`Checked`]: the [`Program`] and every diagnostic of the run,
//! parse diagnostics included, sorted by file and position.
//!
//! Invariants:
//! - Checking never panics and never stops early: the parser's `Error`
//!   nodes are skipped silently (they were reported once already), and an
//!   error in one item does not hide the others. Work is linear in the size
//!   of the input (plus hash lookups), with no recursion on data other than
//!   the expression nesting written in the text.
//! - Every diagnostic has a stable code from [`grm_diag::Code`], a primary
//!   label on the exact span, and a help line where a fix is known
//!   (including "did you mean" suggestions by edit distance).
//! - If no diagnostic is an error, the program is complete: no
//!   [`Ty::Error`] or [`TExprKind::Error`] anywhere, every module carries
//!   exactly its symbol's arity of arguments of the symbol's parameter
//!   types, every weight and condition has its type, and all constant
//!   subexpressions are folded. With errors the program is best-effort
//!   (for the language server) and must not be lowered.
//! - Floats are 32-bit: constants are folded by [`eval`] with the f32
//!   operations of [`scalar`], which the engines' bytecode VM calls too, so
//!   a folded value has the bits the same expression has at run time.
//!
//! Decisions the language spec leaves open (the diagnostics they lead to are
//! in `docs/diagnostics.md`):
//! - Scope: one namespace for constants, meta-parameters, meshes and
//!   materials across the whole import closure (duplicates are E0102); a
//!   file sees its own definitions and those of the files it imports,
//!   transitively. A production's parameters shadow global names.
//! - Constants may depend on meta-parameters (they are then
//!   [`TExprKind::Global`], evaluated once per run); meta-parameter defaults
//!   and ranges may not (they define the sliders). Nothing outside
//!   productions and the axiom may draw random numbers.
//! - Built-in terminals are normalized to one symbol per meaning with a
//!   fixed parameter list ([`Terminal::params`]): `F` is `F(step)`, `+` is
//!   `+(angle)`, `translate(x, y, z)` is `translate(vec3(x, y, z))`, `push`
//!   is `[`. `!` and `'` without an argument are distinct terminals
//!   (`ShrinkWidth`, `NextColor`), as is uniform `scale(s)`. A pattern on a
//!   terminal binds all of its parameters or none (`F -> F F` rewrites every
//!   `F(l)`).
//! - A user symbol's arity is fixed by its declaration or first use in the
//!   system; parameter types are inferred by unification over all uses,
//!   defaulting to `float` (see the private `infer` module).
//! - Generic built-ins (`abs min max clamp mix step smoothstep spline ...`)
//!   take the type of their first generic argument; a `float` may stand for
//!   a `vec3` in the other generic positions (broadcast).
//! - Mesh and material names are only values as the argument of the `mesh`
//!   and `material` terminals ([`Value::Mesh`], [`Value::Material`]).
//! - Groups: productions with the same predecessor symbol and binding count,
//!   the same context shapes and structurally equal conditions (parameter
//!   names do not matter) form one [`Group`], in order of first appearance;
//!   wrap-up productions form their own groups.
//! - Setting defaults are [`Settings::default`]; `seed` is a `u32` (the
//!   random draws hash 32-bit words).
//! - In sample systems a user symbol that is neither declared nor rewritten
//!   is reported as unknown (E0101): it would stay in the model unexpanded,
//!   and is nearly always a misspelling.

mod builtins;
mod check;
pub mod eval;
mod expr;
mod index;
mod infer;
pub mod layout;
mod loader;
pub mod phases;
mod program;
pub mod scalar;
pub mod shape;
mod suggest;
mod system;
mod unit;

pub use builtins::{
    Builtin, MAX_GENERATIONS, MAX_ITERATIONS, MAX_PARTICLES, MaterialProp, RandomFn, SettingKey,
    Terminal,
};
pub use grm_diag::{Diagnostic, FileId, SourceMap, Span};
pub use index::{Def, Ref, RefIndex};
pub use loader::{FileLoader, FsLoader, LoadError, MAX_SOURCE_BYTES, MemLoader, normalize};
pub use program::*;
pub use shape::{ShapeQuery, ShapeSystem, ShapeValue};

/// The result of checking: the program and all diagnostics.
#[derive(Clone, Debug)]
pub struct Checked {
    pub program: Program,
    /// Parse and check diagnostics of the root and every imported file,
    /// sorted by file, position and code.
    pub diagnostics: Vec<Diagnostic>,
}

impl Checked {
    /// Whether any diagnostic is an error (then the program must not be lowered).
    pub fn has_errors(&self) -> bool {
        self.diagnostics.iter().any(Diagnostic::is_error)
    }
}

/// Check the file `root` of `sources` and everything it imports.
pub fn check(sources: &mut SourceMap, root: FileId, loader: &dyn FileLoader) -> Checked {
    let mut diags = Vec::new();
    let mut files = check::load_all(sources, root, loader, &mut diags);
    // The systems' bodies are taken out of the trees, and each is dropped
    // once its system is checked: the file's syntax tree and its checked
    // program are never both whole in memory (issue 32).
    let names = check::count_names(&files);
    let bodies = check::take_system_bodies(&mut files);
    let mut cx = check::Checker::new(&files, loader, diags);
    cx.program.index.reserve(names);
    cx.program.root = root;
    cx.program.imports = files
        .iter()
        .flat_map(|f| f.edges.iter().map(|&(span, to)| (Loc::new(f.id, span), to)))
        .collect();
    cx.globals();
    cx.systems(bodies);
    cx.layouts();
    cx.file_warnings();
    let mut program = cx.program;
    let mut diagnostics = cx.diags;
    drop(files);
    program.index.finish();
    grm_diag::sort(&mut diagnostics);
    diagnostics.dedup();
    Checked {
        program,
        diagnostics,
    }
}

/// Check one file's text, reading its imports and meshes from the file
/// system relative to `path`'s directory.
pub fn check_text(path: &str, text: &str) -> (SourceMap, Checked) {
    let mut sources = SourceMap::new();
    let root = sources.add(path, text);
    let checked = check(&mut sources, root, &FsLoader);
    (sources, checked)
}

/// Check one file's text with a given loader (tests, editors).
pub fn check_with(path: &str, text: &str, loader: &dyn FileLoader) -> (SourceMap, Checked) {
    let mut sources = SourceMap::new();
    let root = sources.add(path, text);
    let checked = check(&mut sources, root, loader);
    (sources, checked)
}
