//! `grmc fmt [--check] FILE...`

use crate::Outcome;
use std::io::Write;
use std::path::PathBuf;

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

pub fn run(args: FmtArgs) -> Outcome {
    let mut outcome = Outcome::Ok;
    let mut err = std::io::stderr().lock();
    for path in &args.files {
        let text = match std::fs::read_to_string(path) {
            Ok(t) => t,
            Err(e) => {
                let _ = writeln!(err, "error: cannot read {}: {e}", path.display());
                return Outcome::Usage;
            }
        };
        let formatted = match grm_fmt::format(&text) {
            Ok(f) => f,
            Err(e) => {
                let _ = writeln!(err, "error: {} was not formatted: {e}", path.display());
                outcome = Outcome::InputErrors;
                continue;
            }
        };
        if args.stdout {
            print!("{formatted}");
        } else if args.check {
            if formatted != text {
                let _ = writeln!(err, "{} is not formatted", path.display());
                outcome = Outcome::InputErrors;
            }
        } else if formatted != text {
            // Write to a temporary file and rename it over the original so an
            // interrupted write never leaves a truncated grammar.
            let tmp = path.with_extension("grm.fmt-tmp");
            if let Err(e) =
                std::fs::write(&tmp, &formatted).and_then(|()| std::fs::rename(&tmp, path))
            {
                let _ = std::fs::remove_file(&tmp);
                let _ = writeln!(err, "error: cannot write {}: {e}", path.display());
                return Outcome::Usage;
            }
        }
    }
    outcome
}
