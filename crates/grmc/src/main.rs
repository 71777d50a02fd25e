//! `grmc`: the grm command-line front-end.
//!
//! Role: a thin shell over the library crates. Each subcommand reads files,
//! calls one library entry point, prints the result and picks the exit code.
//! No language logic lives here.
//!
//! Exit codes (all subcommands): 0 success (warnings allowed), 1 the input
//! had errors (diagnostics were printed), 2 usage or I/O problems.

/// `println!` for the report on stdout, which a user may pipe into `head`:
/// a closed pipe ends the program quietly with success, as for any Unix
/// filter (`println!` panicked there), any other write error exits with 2.
macro_rules! outln {
    ($($t:tt)*) => {
        $crate::write_stdout(format_args!("{}\n", format_args!($($t)*)))
    };
}

/// `print!` for the report on stdout (see [`outln!`]).
macro_rules! out {
    ($($t:tt)*) => {
        $crate::write_stdout(format_args!($($t)*))
    };
}

mod bench;
mod check;
mod derive;
mod disasm;
mod edits;
mod fmt;
mod forest;
mod gpu;
mod layout;
mod lsp;
mod manip;
mod sample;
mod shape;
mod tree;
mod view;

use clap::{Parser, Subcommand, ValueEnum};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "grmc",
    version,
    about = "The grm procedural-modelling toolchain"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OutputFormat {
    Human,
    Json,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Check .grm files and report diagnostics.
    Check(check::CheckArgs),
    /// Format .grm files in place (or check that they are formatted).
    Fmt(fmt::FmtArgs),
    /// Run the language server (LSP over stdio).
    Lsp(lsp::LspArgs),
    /// Serve the live preview page for a .grm file (or the layout view of a
    /// NAME.layout.json) on localhost.
    View(view::ViewArgs),
    /// Derive a system: statistics, the string, or an exported model.
    Derive(derive::DeriveArgs),
    /// Derive many trees at once (on the GPU: one derivation) and plant
    /// them on a grid in one model.
    Forest(forest::ForestArgs),
    /// Grow a sample-mode system guided by curves (SOSMC) and export it.
    Sample(sample::SampleArgs),
    /// Print a system's compiled tables and bytecode.
    Disasm(disasm::DisasmArgs),
    /// The grammar's persistent edits (NAME.edits.json): `check`
    /// classifies each against the model, `list` prints them.
    Edits(edits::EditsArgs),
    /// Direct manipulation: list the parts a drag can move, the source
    /// numbers that place one, solve a drag, sketch a meta-parameter.
    Manip(manip::ManipArgs),
    /// A city layout merged from its layers (a .grm's `layout` item or
    /// NAME.layout.json), written
    /// as GeoJSON or an SVG plan, or as a model or picture (glb, obj,
    /// ply, png) with a building grown on every parcel.
    Layout(layout::LayoutArgs),
    /// Benchmarks (`grmc bench derive`, `grmc bench gpu`, `grmc bench render`).
    Bench(bench::BenchArgs),
}

/// The most worker threads `--threads` accepts: what the engines start
/// (`grm_derive::MAX_THREADS`, which the sampler shares). Far more threads
/// than cores only costs memory, and tens of thousands exhaust it.
pub const MAX_THREADS: usize = grm_derive::MAX_THREADS;

/// `--threads N`: 0 (all cores) to [`MAX_THREADS`].
pub fn parse_threads(s: &str) -> Result<usize, String> {
    let n: usize = s
        .parse()
        .map_err(|_| format!("`{s}` is not a whole number >= 0"))?;
    if n > MAX_THREADS {
        return Err(format!(
            "{n} threads is more than the {MAX_THREADS} grmc starts (0 uses all cores)"
        ));
    }
    Ok(n)
}

/// `1 iteration`, `2 iterations`.
pub fn count(n: impl Into<u64>, one: &str) -> String {
    let n = n.into();
    if n == 1 {
        format!("1 {one}")
    } else {
        format!("{n} {one}s")
    }
}

/// A rate for a summary line: whole numbers from 10 up, three significant
/// digits below (a slow adapter's 0.04 modules/us must not read as 0).
pub fn rate(x: f64) -> String {
    if !x.is_finite() || x >= 10.0 {
        format!("{x:.0}")
    } else if x >= 1.0 {
        format!("{x:.2}")
    } else {
        format!("{x:.3}")
    }
}

/// The outcome of a subcommand, mapped to the process exit code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Ok,
    InputErrors,
    Usage,
}

/// Large buffers (a derivation's strings) in whole huge pages: a one-shot
/// `grmc derive` spent most of its time faulting them in 4 KiB at a time
/// (`grm_derive::HugePageAlloc`; docs/benchmarks.md).
#[global_allocator]
static ALLOC: grm_derive::HugePageAlloc = grm_derive::HugePageAlloc;

fn main() -> ExitCode {
    quiet_headless_vulkan();
    // `--seed -1` is a value to refuse with its range, not a flag `-1`
    // (whose "use `-- -1`" tip would make it the FILE argument).
    let cmd = <Cli as clap::CommandFactory>::command()
        .mut_subcommands(|c| c.allow_negative_numbers(true));
    let parsed = cmd
        .try_get_matches()
        .and_then(|m| <Cli as clap::FromArgMatches>::from_arg_matches(&m));
    let cli = match parsed {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    let outcome = match cli.command {
        Command::Check(a) => check::run(a),
        Command::Fmt(a) => fmt::run(a),
        // Servers grow models again and again: the system allocator, which
        // reuses what they free (`HugePageAlloc::serve`).
        Command::Lsp(a) => {
            grm_derive::HugePageAlloc::serve();
            lsp::run(a)
        }
        Command::View(a) => {
            grm_derive::HugePageAlloc::serve();
            view::run(a)
        }
        Command::Derive(a) => derive::run(a),
        Command::Forest(a) => forest::run(a),
        Command::Sample(a) => sample::run(a),
        Command::Edits(a) => edits::run(a),
        Command::Manip(a) => manip::run(a),
        Command::Layout(a) => layout::run(a),
        Command::Disasm(a) => disasm::run(a),
        Command::Bench(a) => bench::run(a),
    };
    ExitCode::from(match outcome {
        Outcome::Ok => 0,
        Outcome::InputErrors => 1,
        Outcome::Usage => 2,
    })
}

/// Write to stdout for [`outln!`] and [`out!`].
pub fn write_stdout(args: std::fmt::Arguments<'_>) {
    use std::io::Write;
    let mut o = std::io::stdout().lock();
    if let Err(e) = o.write_fmt(args).and_then(|()| o.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("error: cannot write to stdout: {e}");
        std::process::exit(2);
    }
}

/// Mesa's Vulkan loader layer `VK_LAYER_MESA_device_select` (which orders
/// the devices by the display they drive) connects to a Wayland display
/// while the GPU is opened; on a machine without one (CI, ssh, a server)
/// that prints "error: XDG_RUNTIME_DIR is invalid or not set in the
/// environment." twice on stderr for every `--gpu` run that succeeds. Where
/// there is no runtime directory there is no display to order by, so the
/// layer is switched off (`NODEVICE_SELECT=1`, unless the user set it);
/// wgpu picks the adapter itself either way.
fn quiet_headless_vulkan() {
    if std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("NODEVICE_SELECT").is_none()
    {
        // SAFETY: the first call of `main`, before any thread exists (the
        // runtime, the thread pools and the GPU are all started later), so
        // nothing reads or writes the environment concurrently.
        #[allow(unsafe_code)]
        unsafe {
            std::env::set_var("NODEVICE_SELECT", "1");
        }
    }
}
