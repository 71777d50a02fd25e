//! `grmc check FILE...`

use crate::{Outcome, OutputFormat};
use grm_diag::{Diagnostic, Severity, SourceMap};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Files to check.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// How to print diagnostics.
    #[arg(long, value_enum, default_value = "human")]
    pub format: OutputFormat,
    /// Treat warnings as errors (exit 1 when any warning is reported).
    #[arg(long)]
    pub deny_warnings: bool,
}

/// The bytes of a grammar file named on the command line, by the rules
/// imports follow (`grm_sema::FsLoader`): a regular file of at most
/// `MAX_SOURCE_BYTES`, read through the one bounded reader
/// (`grm_diag::input`): `grmc check /dev/zero` read until memory ran out,
/// `grmc fmt /dev/zero` 6.5 GB, and `grmc check FIFO` waited forever.
pub fn read_source(path: &Path) -> std::io::Result<Vec<u8>> {
    grm_diag::input::read_bounded(path, grm_sema::MAX_SOURCE_BYTES, "a grammar file")
}

/// A grammar file named on the command line that could not be read: its
/// E0405 diagnostic, in a source map of its own (the file, empty).
#[derive(Debug)]
pub struct Unreadable {
    pub sources: SourceMap,
    pub diagnostic: Diagnostic,
}

impl Unreadable {
    pub fn new(path: &Path, e: &std::io::Error) -> Unreadable {
        let mut sources = SourceMap::new();
        let file = sources.add(path.display().to_string(), String::new());
        let mut d = Diagnostic::new(
            grm_diag::Code::FileUnreadable,
            format!("cannot read {}: {e}", path.display()),
            file,
            grm_diag::Span::new(0, 0),
            "named on the command line",
        );
        d = match e.kind() {
            std::io::ErrorKind::NotFound => d.with_help("check the path"),
            std::io::ErrorKind::IsADirectory | std::io::ErrorKind::InvalidInput => d.with_help(
                "name a .grm file: grm reads only regular files (not a directory, device or pipe)",
            ),
            std::io::ErrorKind::FileTooLarge => d.with_note(format!(
                "grm reads grammar files of at most {} MiB",
                grm_sema::MAX_SOURCE_BYTES >> 20
            )),
            _ => d,
        };
        Unreadable {
            sources,
            diagnostic: d,
        }
    }

    /// The diagnostic as `grmc` prints it on stderr.
    pub fn render(&self, color: bool) -> String {
        grm_diag::render_human(&self.diagnostic, &self.sources, color)
    }

    /// The diagnostic as one JSON object (`--format json`).
    pub fn json(&self) -> String {
        grm_diag::render_json(&self.diagnostic, &self.sources)
    }
}

/// Load and check one file. `Err` is an I/O problem with the file itself
/// (E0405).
pub fn load_and_check(path: &Path) -> Result<(SourceMap, grm_sema::Checked), Box<Unreadable>> {
    let bytes = read_source(path).map_err(|e| Box::new(Unreadable::new(path, &e)))?;
    let mut sources = SourceMap::new();
    let (text, bad_utf8) = match String::from_utf8(bytes) {
        Ok(t) => (t, None),
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            (String::from_utf8_lossy(e.as_bytes()).into_owned(), Some(at))
        }
    };
    let root = sources.add(path.display().to_string(), text);
    let mut checked = grm_sema::check(&mut sources, root, &grm_sema::FsLoader);
    if let Some(at) = bad_utf8 {
        // The replacement characters are the E0404 below, not also E0003
        // "invalid character".
        let text = &sources.get(root).text;
        checked.diagnostics.retain(|d| {
            let p = d.primary();
            !(d.code == grm_diag::Code::InvalidCharacter
                && p.file == root
                && text
                    .get(p.span.start as usize..p.span.end as usize)
                    .is_some_and(|t| t.chars().all(|c| c == '\u{FFFD}')))
        });
        checked.diagnostics.push(invalid_utf8(root, at).with_note(
            "grm files are UTF-8 text; invalid bytes were replaced with U+FFFD for checking",
        ));
        grm_diag::sort(&mut checked.diagnostics);
    }
    Ok((sources, checked))
}

/// The E0404 report of the first invalid UTF-8 byte, at byte `at` (the
/// same offset in the decoded text, whose prefix is the file's): the label
/// covers the U+FFFD that stands for it there (3 bytes), so it is neither
/// zero-width nor ends inside a character.
pub fn invalid_utf8(file: grm_diag::FileId, at: usize) -> Diagnostic {
    let at = at as u32;
    Diagnostic::new(
        grm_diag::Code::InvalidEncoding,
        "file is not valid UTF-8",
        file,
        grm_diag::Span::new(at, at + '\u{FFFD}'.len_utf8() as u32),
        "invalid byte sequence here",
    )
}

pub fn run(args: CheckArgs) -> Outcome {
    let color = std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none();
    let mut errors = 0usize;
    let mut warnings = 0usize;
    let mut unreadable = 0usize;
    let mut json_items: Vec<String> = Vec::new();
    let stderr = std::io::stderr();
    for path in &args.files {
        let (sources, mut checked) = match load_and_check(path) {
            Ok(r) => r,
            Err(u) => {
                match args.format {
                    OutputFormat::Human => {
                        let _ = write!(stderr.lock(), "{}", u.render(color));
                    }
                    OutputFormat::Json => json_items.push(u.json()),
                }
                unreadable += 1;
                continue;
            }
        };
        // What compiling finds (R01xx) is reported by `check` too, as the
        // editor does: `derive` would stop on it.
        checked.diagnostics.extend(grm_compile::check(&checked));
        let mut human = grm_diag::HumanRenderer::new(&sources, color);
        for d in &checked.diagnostics {
            match d.severity {
                Severity::Error => errors += 1,
                Severity::Warning => warnings += 1,
            }
            match args.format {
                OutputFormat::Human => {
                    let _ = write!(stderr.lock(), "{}", human.render(d));
                }
                OutputFormat::Json => json_items.push(grm_diag::render_json(d, &sources)),
            }
        }
    }
    match args.format {
        OutputFormat::Json => outln!("[{}]", json_items.join(",\n")),
        OutputFormat::Human => {
            // Files that could not be read were not checked: say so, not
            // "0 errors" for them.
            let n = (args.files.len() - unreadable) as u64;
            let not_read = if unreadable > 0 {
                format!("; {unreadable} could not be read")
            } else {
                String::new()
            };
            let _ = writeln!(
                stderr.lock(),
                "checked {}: {}, {}{not_read}",
                crate::count(n, "file"),
                crate::count(errors as u64, "error"),
                crate::count(warnings as u64, "warning"),
            );
        }
    }
    if unreadable > 0 {
        Outcome::Usage
    } else if errors > 0 || (args.deny_warnings && warnings > 0) {
        Outcome::InputErrors
    } else {
        Outcome::Ok
    }
}
