//! The layout's problems as coded diagnostics (R10xx in grm-diag's
//! registry; docs/diagnostics.md). A sidecar or GeoJSON file is not grm
//! source, so each diagnostic is labelled at a place in the grammar the
//! caller gives (the `layout` item, or the system the parcels grow) and
//! names the file, and the element or JSON path, in its message, as the
//! run-time codes do for curves and meshes.

use grm_diag::{Diagnostic, FileId, Span};

use crate::building_edits::EditIssue;
use crate::city::BuildingIssue;
use crate::layers::LayerIssue;
use crate::sidecar::SidecarError;

/// A sidecar problem (R1021-R1026) at its JSON path in `file_name`.
pub fn sidecar_diagnostic(e: &SidecarError, file_name: &str, at: FileId, span: Span) -> Diagnostic {
    let path = if e.path.is_empty() { "$" } else { &e.path };
    Diagnostic::new(
        e.kind.diag_code(),
        format!("{file_name}: {path}: {}", e.message),
        at,
        span,
        "laid out by this file",
    )
    .with_help("docs/layout.md section 4 gives the sidecar's format")
}

/// A layer's problem (R1001-R1015) naming the layer and its element.
pub fn layer_diagnostic(i: &LayerIssue, file_name: &str, at: FileId, span: Span) -> Diagnostic {
    let help = match i {
        LayerIssue::Element { .. } => {
            "the element is left out and the rest of the layer loads (docs/layout.md section 2)"
        }
        LayerIssue::MissingFile { .. } => {
            "a layer's file is relative to the layout file; the other layers still merge"
        }
        LayerIssue::Params { .. } => "docs/layout.md section 2 gives each generator's ranges",
        LayerIssue::MoveRejected { .. } => {
            "a move may not make streets cross; move less far or move the crossing streets too"
        }
        LayerIssue::UnknownElement { .. } => {
            "the layer no longer has this element (its source changed); remove the entry"
        }
        LayerIssue::Merge { .. } => {
            "internal: the layer is left out of the merge; please report it"
        }
    };
    Diagnostic::new(
        i.diag_code(),
        format!("{file_name}: {}", i.describe()),
        at,
        span,
        "laid out by this file",
    )
    .with_help(help)
}

/// A parcel without a building (R1031, or the shape engine's code).
pub fn building_diagnostic(b: &BuildingIssue, at: FileId, span: Span) -> Diagnostic {
    Diagnostic::new(b.diag_code(), b.describe(), at, span, "grown on the parcel")
        .with_help("the parcel keeps its ground; the other parcels grow")
}

/// A building edit applied to no building (R1032) in `file_name` (the
/// edits file), naming the edit and its parcel.
pub fn edit_diagnostic(e: &EditIssue, file_name: &str, at: FileId, span: Span) -> Diagnostic {
    Diagnostic::new(
        e.diag_code(),
        format!("{file_name}: {}", e.describe()),
        at,
        span,
        "grown on the parcels",
    )
    .with_help("a building edit applies only to its own parcel; the other edits still apply")
}
