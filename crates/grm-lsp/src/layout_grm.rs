//! The layout view of a `.grm` file's `layout` item (docs/layout.md, "The
//! layout item"; docs/lsp-extensions.md, "City layouts"): `grm/layout`,
//! `grm/layoutEdit` and `grm/layoutCity` name either a sidecar
//! `NAME.layout.json` or a grammar `NAME.grm` ([`Target`]).
//!
//! A grammar's first `layout` item is made into the document on the one
//! road `grmc layout NAME.grm` takes (`grm_layout::program::document`):
//! the item's layers (grid, radial, L-system, GeoJSON, edited) with the
//! artist's edits from the sidecar `NAME.layout.json` beside it (the
//! client's buffer when it is open, else the file; none without one). An
//! operator changes that document; [`FromGrm::to_sidecar`] writes the
//! change back into the sidecar only (the item's generated sources stay
//! in the grammar): each of the item's layers keeps the sidecar's own
//! source, the sidecar's layers stay in its order, and a layer new to it
//! (an item layer edited for the first time, a cut) is added at its end.

use crate::layout::{Caches, Evaluated, evaluate_doc, evaluate_text, layout_path};
use crate::{Shared, convert, failed};
use grm_layout::layers::{Document, Source};
use grm_layout::sidecar;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use tower_lsp_server::jsonrpc::Result;
use tower_lsp_server::ls_types::Uri;

/// What a layout request names.
#[derive(Clone, Debug)]
pub(crate) enum Target {
    /// A sidecar, `NAME.layout.json`.
    Sidecar(PathBuf),
    /// A grammar whose first `layout` item is shown.
    Grm(PathBuf),
}

impl Target {
    /// The file the request names (its caches are kept under it).
    pub(crate) fn path(&self) -> &Path {
        match self {
            Target::Sidecar(p) | Target::Grm(p) => p,
        }
    }

    /// The sidecar the edits go to.
    pub(crate) fn sidecar(&self) -> PathBuf {
        match self {
            Target::Sidecar(p) => p.clone(),
            Target::Grm(p) => sidecar_of(p),
        }
    }
}

/// Whether `path` names a grammar.
pub fn is_grm_path(path: &Path) -> bool {
    path.extension().is_some_and(|e| e == "grm")
}

/// The sidecar beside a grammar: `NAME.layout.json` for `NAME.grm`.
pub fn sidecar_of(grm: &Path) -> PathBuf {
    grm.with_extension("layout.json")
}

/// The file a request names: a sidecar or a grammar (InvalidParams for
/// another file).
pub(crate) fn target(uri: &Uri) -> Result<Target> {
    if let Some(p) = convert::path_of(uri).filter(|p| is_grm_path(p)) {
        return Ok(Target::Grm(p));
    }
    layout_path(uri).map(Target::Sidecar)
}

/// A grammar's layout: where its edits go.
#[derive(Clone, Debug)]
pub(crate) struct FromGrm {
    /// The grammar.
    pub(crate) grm: PathBuf,
    /// `NAME.layout.json` beside it.
    pub(crate) sidecar: PathBuf,
    /// The sidecar as read (empty without one).
    pub(crate) side: Document,
    /// The item's layers, bottom to top.
    pub(crate) item_layers: Vec<String>,
    /// The item's name.
    pub(crate) item: String,
}

impl FromGrm {
    /// The sidecar after an operator changed the item's document from
    /// `before` to `doc`: each of `doc`'s layers replaces the sidecar's
    /// layer of its name (the first one), an item layer keeping the
    /// sidecar's source (empty for a layer the sidecar did not have);
    /// layers new to the sidecar (one the operator changed, a cut) go at
    /// its end, in `doc`'s order. An item layer the sidecar lacks and the
    /// operator left alone is not written.
    pub(crate) fn to_sidecar(&self, before: &Document, doc: &Document) -> Document {
        let mut out = self.side.clone();
        let mut added = Vec::new();
        for l in &doc.layers {
            let at = out.layers.iter().position(|o| o.name == l.name);
            if at.is_none() && before.layers.iter().any(|b| b == l) {
                continue;
            }
            let mut l = l.clone();
            if self.item_layers.contains(&l.name) {
                l.source = at.map_or(Source::Empty, |i| out.layers[i].source.clone());
            }
            match at {
                Some(i) => out.layers[i] = l,
                None => added.push(l),
            }
        }
        out.layers.extend(added);
        out
    }
}

impl Shared {
    /// A sidecar's text: the client's buffer (with its version), else the
    /// file; none when there is neither.
    pub(crate) fn layout_text_if_any(
        &self,
        path: &Path,
    ) -> Result<Option<(Option<i32>, Arc<str>)>> {
        if std::fs::metadata(path).is_err() && !self.layout_is_open(path) {
            return Ok(None);
        }
        self.layout_text(path).map(Some)
    }
}

/// Evaluates what `t` names: the sidecar's layers, or the grammar's
/// layout item with its sidecar. The version is the buffer's (the
/// sidecar's, or the grammar's).
pub(crate) fn evaluate(
    shared: &Shared,
    t: &Target,
    cache: &mut Caches,
) -> Result<(Option<i32>, Evaluated)> {
    match t {
        Target::Sidecar(path) => {
            let (version, text) = shared.layout_text(path)?;
            Ok((version, evaluate_text(path, &text, cache)))
        }
        Target::Grm(grm) => Ok((shared.version(grm), evaluate_grm(shared, grm, cache)?)),
    }
}

/// The grammar's first `layout` item with the artist's sidecar, built and
/// merged. A grammar with errors, or without a layout item, is an error
/// (its message says which).
pub(crate) fn evaluate_grm(shared: &Shared, grm: &Path, cache: &mut Caches) -> Result<Evaluated> {
    let fa = shared
        .analyze(grm)
        .ok_or_else(|| failed(format!("cannot read {}", grm.display())))?;
    let prog = &fa.checked.program;
    let def = prog.layouts.first().ok_or_else(|| {
        failed(format!(
            "{} has no `layout NAME {{ ... }}` item (docs/layout.md)",
            grm.display()
        ))
    })?;
    if let Some(d) = fa.checked.diagnostics.iter().find(|d| d.is_error()) {
        return Err(failed(format!(
            "{} has errors (the first: error[{}]: {}): the layout is shown once they are fixed",
            grm.display(),
            d.code.as_str(),
            d.message
        )));
    }
    let values = grm_compile::param_values(prog, &[]).map_err(failed)?;
    let sidecar_path = sidecar_of(grm);
    let side_text = shared.layout_text_if_any(&sidecar_path)?;
    let name = sidecar_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (side, mut errors) = match &side_text {
        Some((_, t)) => sidecar::read(t),
        None => (Document::default(), Vec::new()),
    };
    // The sidecar's problems name it (the view lists them with the grammar's).
    for e in &mut errors {
        e.path = format!("{name}: {}", e.path);
    }
    let (doc, issues) = grm_layout::program::document(prog, def, &values, Some(&side));
    let mut ev = evaluate_doc(grm, doc, errors, cache);
    ev.issues.splice(0..0, issues);
    ev.grm = Some(FromGrm {
        grm: grm.to_path_buf(),
        sidecar: sidecar_path,
        side,
        item_layers: def.layers.iter().map(|l| l.name.clone()).collect(),
        item: def.name.clone(),
    });
    Ok(ev)
}

#[cfg(test)]
mod tests {
    use super::*;
    use grm_layout::layers::LayerSpec;

    fn from(side: Document, item: &[&str]) -> FromGrm {
        FromGrm {
            grm: PathBuf::from("/c/city.grm"),
            sidecar: PathBuf::from("/c/city.layout.json"),
            side,
            item_layers: item.iter().map(|s| s.to_string()).collect(),
            item: "City".into(),
        }
    }

    /// An operator's change goes to the sidecar's layer of its name, the
    /// item's generated source left out; the sidecar's order is kept and
    /// a layer new to it goes at its end.
    #[test]
    fn a_change_goes_back_to_the_sidecar_without_the_items_sources() {
        let mut side = Document::default();
        side.layers.push(LayerSpec::new("old town", Source::Empty));
        side.layers.push(LayerSpec::new("avenue", Source::Empty));
        let f = from(side, &["base", "avenue"]);
        let mut doc = Document::default();
        let mut base = LayerSpec::new("base", Source::Features("{}".into()));
        base.protected.push(grm_layout::id::Id::mint("x").finish());
        let mut avenue = LayerSpec::new("avenue", Source::Features("{\"a\":1}".into()));
        avenue.visible = false;
        doc.layers = vec![
            base,
            avenue,
            LayerSpec::new("old town", Source::Empty),
            LayerSpec::new("base (cut)", Source::Features("{\"b\":2}".into())),
        ];
        let mut before = doc.clone();
        before.layers[0].protected.clear();
        before.layers.pop(); // the cut is new
        // Left alone and not in the sidecar: not written.
        before.layers.push(LayerSpec::new("park", Source::Empty));
        doc.layers.push(LayerSpec::new("park", Source::Empty));
        let out = f.to_sidecar(&before, &doc);
        let names: Vec<&str> = out.layers.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names, ["old town", "avenue", "base", "base (cut)"]);
        assert!(!out.layers[1].visible, "the avenue's change kept");
        assert_eq!(
            out.layers[1].source,
            Source::Empty,
            "not the L-system's streets"
        );
        assert_eq!(out.layers[2].source, Source::Empty);
        assert_eq!(out.layers[2].protected.len(), 1);
        assert_eq!(
            out.layers[3].source,
            Source::Features("{\"b\":2}".into()),
            "a cut keeps its streets"
        );
    }
}
