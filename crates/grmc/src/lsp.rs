//! `grmc lsp`: run the language server over stdin/stdout (all the work is
//! in `grm-lsp`).

use crate::Outcome;

#[derive(clap::Args, Debug)]
pub struct LspArgs {
    /// Accepted for editors that pass it; stdio is the only transport.
    #[arg(long)]
    stdio: bool,
}

pub fn run(args: LspArgs) -> Outcome {
    let _ = args.stdio;
    match grm_lsp::run_stdio() {
        Ok(true) => Outcome::Ok,
        // LSP: `exit` without `shutdown` first (or the client vanished)
        // ends with exit code 1.
        Ok(false) => Outcome::InputErrors,
        Err(e) => {
            eprintln!("error: the language server could not start: {e}");
            Outcome::Usage
        }
    }
}
