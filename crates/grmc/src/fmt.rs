//! `grmc fmt [--check|--stdout] FILE...`

use crate::Outcome;
use grm_diag::SourceMap;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
pub struct FmtArgs {
    /// Files to format in place.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Do not write; exit 1 if any file is not formatted.
    #[arg(long)]
    pub check: bool,
    /// Print the formatted text to stdout instead of writing the file.
    #[arg(long, conflicts_with = "check")]
    pub stdout: bool,
}

/// What became of one file.
enum Done {
    /// Formatted (or already formatted, or printed).
    Ok,
    /// `--check`: not formatted; or the file has errors (printed).
    Input,
    /// Could not be read or written (printed).
    Io,
}

pub fn run(args: FmtArgs) -> Outcome {
    let color = std::io::stderr().is_terminal() && std::env::var_os("NO_COLOR").is_none();
    // Every file is tried; the worst outcome is the exit code.
    let mut outcome = Outcome::Ok;
    for path in &args.files {
        match one(&args, path, color) {
            Done::Ok => {}
            Done::Input => {
                if outcome == Outcome::Ok {
                    outcome = Outcome::InputErrors;
                }
            }
            Done::Io => outcome = Outcome::Usage,
        }
    }
    outcome
}

fn one(args: &FmtArgs, path: &Path, color: bool) -> Done {
    let mut err = std::io::stderr().lock();
    let bytes = match crate::check::read_source(path) {
        Ok(b) => b,
        Err(e) => {
            let u = crate::check::Unreadable::new(path, &e);
            let _ = write!(err, "{}", u.render(color));
            return Done::Io;
        }
    };
    let mut sources = SourceMap::new();
    let text = match String::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let at = e.utf8_error().valid_up_to();
            let file = sources.add(
                path.display().to_string(),
                String::from_utf8_lossy(e.as_bytes()).into_owned(),
            );
            let d = crate::check::invalid_utf8(file, at)
                .with_note("grm files are UTF-8 text; the file was left as it is");
            let _ = write!(err, "{}", grm_diag::render_human(&d, &sources, color));
            let _ = writeln!(err, "error: {} was not formatted", path.display());
            return Done::Input;
        }
    };
    let formatted = match grm_fmt::format(&text) {
        Ok(f) => f,
        Err(grm_fmt::FormatError::Syntax(diags)) => {
            // The formatter parsed the text as file 0 of its own.
            let _ = sources.add(path.display().to_string(), text);
            for d in &diags {
                let _ = write!(err, "{}", grm_diag::render_human(d, &sources, color));
            }
            let _ = writeln!(
                err,
                "error: {} was not formatted: it has {}",
                path.display(),
                crate::count(diags.len() as u64, "syntax error")
            );
            return Done::Input;
        }
        Err(e) => {
            let _ = writeln!(err, "error: {} was not formatted: {e}", path.display());
            return Done::Input;
        }
    };
    if args.stdout {
        out!("{formatted}");
    } else if args.check {
        if formatted != text {
            let _ = writeln!(err, "{} is not formatted", path.display());
            return Done::Input;
        }
    } else if formatted != text
        && let Err(e) = replace(path, formatted.as_bytes())
    {
        let _ = writeln!(err, "error: cannot write {}: {e}", path.display());
        return Done::Io;
    }
    Done::Ok
}

/// Replace the contents of `path` without ever leaving it truncated: write
/// a temporary file beside the real file (through a symbolic link, so the
/// link stays a link and its target is formatted), give it the file's
/// permissions, and rename it over the file.
fn replace(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    let target = std::fs::canonicalize(path)?;
    let perms = std::fs::metadata(&target)?.permissions();
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // A name no other run or file uses: the process id, and a counter.
    static NEXT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = target.with_file_name(format!(".{name}.fmt-{}-{n}.tmp", std::process::id()));
    let written = (|| {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        std::io::Write::write_all(&mut f, bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::set_permissions(&tmp, perms)?;
        std::fs::rename(&tmp, &target)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}
