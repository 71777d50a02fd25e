//! `--tree FILE.json` (`grmc derive`, `grmc sample`): the derivation tree of
//! the model, every part's identity and ancestry (grm_grow::json).

use std::path::Path;

use grm_geom::grm_turtle::Interpretation;
use grm_grow::Tree;

use crate::Outcome;
use crate::derive::{Loaded, emit};

/// Refuse a tree path that cannot be written before any work: a folder in
/// its place, or a folder that does not exist (R0407, exit 2).
pub fn check_path(loaded: &Loaded, path: &Path) -> Option<Outcome> {
    let c = &loaded.compiled;
    check_path_at(&loaded.sources, c.file, c.span, path)
}

/// [`check_path`], the error pointing at `span` of `file`.
pub fn check_path_at(
    sources: &grm_diag::SourceMap,
    file: grm_diag::FileId,
    span: grm_diag::Span,
    path: &Path,
) -> Option<Outcome> {
    let source = if path.is_dir() {
        std::io::ErrorKind::IsADirectory.into()
    } else {
        let dir = path
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => return None,
            Ok(_) => std::io::Error::other(format!("{} is not a directory", dir.display())),
            Err(e) => e,
        }
    };
    let e = grm_geom::ExportError::Io {
        path: path.to_path_buf(),
        source,
    };
    emit(sources, &e.to_diagnostic(file, span));
    Some(Outcome::Usage)
}

/// Write `tree` to `path` (whole or not at all); `interp` is the final
/// string's interpretation (for each node's bones and instances).
pub fn write(
    loaded: &Loaded,
    tree: &Tree,
    interp: Option<&Interpretation>,
    path: &Path,
) -> Outcome {
    let c = &loaded.compiled;
    match grm_grow::json::write(path, tree, c, &loaded.sources, interp) {
        Ok(()) => {
            eprintln!("wrote {} ({} nodes)", path.display(), tree.nodes.len());
            Outcome::Ok
        }
        Err(e) => {
            emit(&loaded.sources, &e.to_diagnostic(c.file, c.span));
            Outcome::Usage
        }
    }
}
