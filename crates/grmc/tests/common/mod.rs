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

/// Wait for `child`: its exit code and its peak resident memory in KiB,
/// as the kernel accounts it when the process ends (`wait4`'s
/// `ru_maxrss`). Exact however short the child lives and however busy the
/// machine is (reading VmHWM from /proc while it runs missed the peak of a
/// short run on a loaded machine).
#[allow(unsafe_code)]
pub fn wait_peak_kib(child: &mut std::process::Child) -> (Option<i32>, u64) {
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is plain data that wait4 fills in; `pid` is our own
    // child, not yet waited for (std's `Child` is not waited here), so
    // wait4 reaps exactly it.
    let (r, usage) = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        let r = libc::wait4(pid, &mut status, 0, &mut usage);
        (r, usage)
    };
    assert_eq!(r, pid, "wait4: {}", std::io::Error::last_os_error());
    let code = libc::WIFEXITED(status).then(|| libc::WEXITSTATUS(status));
    (code, usage.ru_maxrss.max(0) as u64)
}

/// `p` as text (the tests' temporary paths are UTF-8).
pub fn path(p: &Path) -> &str {
    p.to_str().expect("utf-8")
}

/// A temporary folder holding examples/calder_tree.grm with its curves
/// file and meshes.
pub fn calder_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    for f in [
        "calder_tree.grm",
        "calder_tree.curves.json",
        "leaf.obj",
        "trunk.obj",
    ] {
        let from = repo().join("examples").join(f);
        if from.exists() {
            std::fs::copy(&from, dir.path().join(f)).expect("copy");
        }
    }
    dir
}
