//! `grm-edits`: persistent direct edits (Lipp, 3.1-3.3), the file that
//! every engine, the CLI and the editor share. docs/edits.md describes it.
//!
//! Role: the artist selects a generated part and changes it; the change is
//! stored outside the grammar, in `NAME.edits.json` beside `NAME.grm`
//! ([`edits_path`]), as an [`Edit`]: an id, a system, a [`Target`] (an
//! exact locator, a semantic query or an identity key) and one [`Op`]
//! (set or offset a value, force an alternative, pin the random draws,
//! replace the material or mesh, remove). The engines replay the edits
//! while they derive; this crate holds no engine code.
//!
//! Inputs: the file's text ([`parse`], or [`read`] for a path). Outputs:
//! an [`EditsFile`] with every valid edit and its byte span, the problems
//! as [`EditsError`]s (codes R0901 to R0911, convertible to
//! `grm_diag` diagnostics in the edits file); the canonical text
//! ([`write`]); which edit applies where ([`scoping`]); the classes an
//! engine gives edits after a derivation ([`EditClass`]). The locator types
//! ([`locator`]) live here so that every engine names parts alike;
//! `grm_shape` re-exports them and resolves them in its trees.
//!
//! Invariants: nothing here panics on any input; a malformed edit is
//! reported and skipped, the valid ones kept; [`write`] is canonical
//! (edits sorted by system and id, fixed key order), `parse(write(f))`
//! gives `f` (sorted) back and `write(parse(t))` is a fixed point; the
//! crate depends on no engine.

pub mod class;
pub mod error;
pub mod file;
pub mod locator;
pub mod rename;
pub mod scoping;

pub use class::EditClass;
pub use error::{EditsError, EditsErrorKind};
pub use file::{
    Edit, EditsFile, Op, OpKind, Parsed, Target, key_text, parcel_text, parse, parse_key,
    parse_parcel, write, write_edit,
};
pub use locator::{Anchor, EdgeRef, ExactLocator, SemanticEntry, SemanticLocator, SemanticQuery};
pub use rename::NameKind;
pub use scoping::{Scoping, Slot, scope};

use std::path::{Path, PathBuf};

/// The newest file format version this crate writes. Version 2 added
/// ordinal edges in exact locators (`#k`) and a semantic edit's
/// `selected` count; version 3 a key edit's `symbol`. A file is written
/// with the oldest version that holds its edits
/// ([`EditsFile::written_version`]), so a file without the newer fields
/// stays readable by a grm that reads only the older versions; a version
/// 1 file reads unchanged (its numbered edges keep their raw meaning).
pub const FORMAT_VERSION: u32 = 3;

/// Every version this crate reads.
pub const READ_VERSIONS: [u32; 3] = [1, 2, 3];

/// The largest edits file read (16 MiB; some 100,000 edits).
pub const MAX_EDITS_BYTES: u64 = 16 << 20;

/// The edits file of a grammar: `x/NAME.grm` -> `x/NAME.edits.json` (a
/// path without the `.grm` extension gets `.edits.json` added to its name).
pub fn edits_path(grammar: &Path) -> PathBuf {
    let stem = if grammar.extension().is_some_and(|e| e == "grm") {
        grammar.file_stem()
    } else {
        grammar.file_name()
    };
    let mut name = stem.map(|s| s.to_os_string()).unwrap_or_default();
    name.push(".edits.json");
    grammar.with_file_name(name)
}

/// The text of the edits file at `path`, read with grm's bounded reader
/// (a regular file of at most [`MAX_EDITS_BYTES`], UTF-8). A missing file
/// is an error too ([`EditsError::is_not_found`]): the caller decides
/// whether that means "no edits" (the default file) or a mistake (a file
/// named on the command line).
pub fn read(path: &Path) -> Result<String, EditsError> {
    grm_diag::input::read_bounded_string(path, MAX_EDITS_BYTES, "an edits file").map_err(|e| {
        let message = if e.kind() == std::io::ErrorKind::NotFound {
            error::NOT_FOUND.to_owned()
        } else {
            e.to_string()
        };
        EditsError {
            kind: EditsErrorKind::Io {
                path: path.display().to_string(),
                message,
            },
            span: grm_diag::Span::default(),
            edit: None,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edits_path_is_beside_the_grammar() {
        assert_eq!(
            edits_path(Path::new("x/tower.grm")),
            Path::new("x/tower.edits.json")
        );
        assert_eq!(
            edits_path(Path::new("tower.grm")),
            Path::new("tower.edits.json")
        );
        assert_eq!(
            edits_path(Path::new("x/a.b.grm")),
            Path::new("x/a.b.edits.json")
        );
        assert_eq!(
            edits_path(Path::new("x/tower")),
            Path::new("x/tower.edits.json")
        );
    }

    #[test]
    fn read_reports_missing_and_unreadable_files() {
        let e = read(Path::new("/nonexistent/dir/t.edits.json")).unwrap_err();
        assert!(e.is_not_found(), "{e}");
        assert_eq!(e.code(), grm_diag::Code::EditsIo);
        let e = read(Path::new("/")).unwrap_err();
        assert!(!e.is_not_found());
        assert!(e.to_string().contains("directory"), "{e}");
    }
}
