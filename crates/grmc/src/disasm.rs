//! `grmc disasm FILE`: print the compiled tables and bytecode of a system.

use std::path::PathBuf;

use crate::Outcome;
use crate::derive::load;

#[derive(clap::Args, Debug)]
pub struct DisasmArgs {
    /// The .grm file.
    pub file: PathBuf,
    /// The system (default: the file's first system).
    #[arg(long)]
    pub system: Option<String>,
    /// Override a meta-parameter: `NAME=VALUE` (repeatable).
    #[arg(long = "param", value_name = "NAME=VALUE")]
    pub params: Vec<String>,
}

pub fn run(args: DisasmArgs) -> Outcome {
    let loaded = match load(&args.file, args.system.as_deref(), &args.params) {
        Ok(l) => l,
        Err(o) => return o,
    };
    let text = &loaded.sources.get(loaded.compiled.file).text;
    out!("{}", grm_compile::disassemble(&loaded.compiled, Some(text)));
    Outcome::Ok
}
