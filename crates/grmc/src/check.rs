//! `grmc check FILE...`

use crate::{Outcome, OutputFormat};
use grm_diag::{Diagnostic, Severity, SourceMap};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;

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
/// `MAX_SOURCE_BYTES` (`grmc check /dev/zero` read until memory ran out).
fn read_source(path: &std::path::Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let max = grm_sema::MAX_SOURCE_BYTES;
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(std::io::Error::other("it is a directory"));
    }
    let too_big = || {
        std::io::Error::other(format!(
            "it is larger than {} MiB, the most a grammar file may be",
            max >> 20
        ))
    };
    if meta.is_file() && meta.len() > max {
        return Err(too_big());
    }
    // Not a regular file (a pipe, `/dev/stdin`, process substitution): read
    // it, but no more than a file may hold.
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(max + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max {
        return Err(std::io::Error::other(format!(
            "it is not a regular file, and it gave more than {} MiB, the most a grammar file may be",
            max >> 20
        )));
    }
    Ok(bytes)
}

/// Load and check one file. `Err` is an I/O problem with the file itself.
pub fn load_and_check(path: &std::path::Path) -> Result<(SourceMap, grm_sema::Checked), String> {
    let bytes = read_source(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
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
            Err(msg) => {
                let _ = writeln!(stderr.lock(), "error: {msg}");
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
