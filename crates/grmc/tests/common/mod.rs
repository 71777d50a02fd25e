//! What the CLI tests share: the built `grmc`, run as a user runs it.
// Each test file uses some of these.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root (`examples/` is there).
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Run `grmc args` without colour, in the test's own folder.
pub fn grmc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args(args)
        .env("NO_COLOR", "1")
        .output()
        .expect("grmc runs")
}

/// Run `grmc args` without colour from the repository root, as the README's
/// commands are run.
pub fn grmc_at_root(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args(args)
        .current_dir(repo())
        .env("NO_COLOR", "1")
        .output()
        .expect("grmc runs")
}

/// The path of `examples/NAME`.
pub fn example(name: &str) -> String {
    repo().join("examples").join(name).display().to_string()
}

/// Output bytes as text.
pub fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Wait for `child`, reading its peak resident memory (`VmHWM` in
/// /proc/PID/status) every millisecond while it runs: its exit code and
/// the highest peak read, in KiB.
pub fn wait_peak_kib(child: &mut std::process::Child) -> (Option<i32>, u64) {
    let status = format!("/proc/{}/status", child.id());
    let mut kib = 0u64;
    let code = loop {
        if let Ok(text) = std::fs::read_to_string(&status)
            && let Some(line) = text.lines().find(|l| l.starts_with("VmHWM:"))
        {
            let n = line
                .split_whitespace()
                .nth(1)
                .and_then(|n| n.parse().ok())
                .unwrap_or(0);
            kib = kib.max(n);
        }
        if let Some(s) = child.try_wait().expect("wait") {
            break s.code();
        }
        std::thread::sleep(std::time::Duration::from_millis(1));
    };
    (code, kib)
}
