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
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) => {
            let _ = writeln!(err, "error: cannot read {}: {e}", path.display());
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
    } else if formatted != text {
        // Write to a temporary file and rename it over the original so an
        // interrupted write never leaves a truncated grammar.
        let tmp = path.with_extension("grm.fmt-tmp");
        if let Err(e) = std::fs::write(&tmp, &formatted).and_then(|()| std::fs::rename(&tmp, path))
        {
            let _ = std::fs::remove_file(&tmp);
            let _ = writeln!(err, "error: cannot write {}: {e}", path.display());
            return Done::Io;
        }
    }
    Done::Ok
}
