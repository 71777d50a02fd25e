//! `grmc check` and `grmc fmt` as a user runs them: exit codes, output
//! formats, and hostile input.

use std::path::{Path, PathBuf};

mod common;
use common::*;

fn examples() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("examples/")
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "grm"))
        .map(|p| p.display().to_string())
        .collect();
    v.sort();
    v
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("grmc-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

#[test]
fn examples_check_clean_exit_0() {
    let ex = examples();
    assert!(ex.len() >= 10);
    let args: Vec<&str> = std::iter::once("check")
        .chain(ex.iter().map(String::as_str))
        .collect();
    let out = grmc(&args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(err.contains("0 errors, 0 warnings"), "{err}");
}

#[test]
fn errors_exit_1_with_coded_diagnostics() {
    let d = temp_dir("errors");
    let f = d.join("bad.grm");
    std::fs::write(
        &f,
        "system S {\n    axiom A(1);\n    A(x) -> A(x + true);\n}\n",
    )
    .expect("write");
    let out = grmc(&["check", f.to_str().expect("utf8 path")]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("E0201"), "{err}");
    assert!(err.contains("bad.grm:3:"), "{err}");
}

#[test]
fn json_format_is_machine_readable() {
    let d = temp_dir("json");
    let f = d.join("bad.grm");
    std::fs::write(&f, "system S { axiom A; A -> B(1 + ); }\n").expect("write");
    let out = grmc(&["check", "--format", "json", f.to_str().expect("utf8 path")]);
    assert_eq!(out.status.code(), Some(1));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.trim_start().starts_with('['), "{text}");
    assert!(text.contains("\"code\":\"E0001\""), "{text}");
    assert!(text.contains("\"line\":1"), "{text}");
}

#[test]
fn missing_file_and_bad_usage_exit_2() {
    let out = grmc(&["check", "/nonexistent/x.grm"]);
    assert_eq!(out.status.code(), Some(2));
    let out = grmc(&["check"]);
    assert_eq!(out.status.code(), Some(2));
    let out = grmc(&["frobnicate"]);
    assert_eq!(out.status.code(), Some(2));
    // A device that never ends is refused unread, as no regular file (not
    // "larger than" a size it does not have), with its code.
    if Path::new("/dev/zero").exists() {
        let out = grmc(&["check", "/dev/zero"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("[E0405] Error: cannot read /dev/zero: it is not a regular file"),
            "{err}"
        );
    }
}

/// `grmc ARGS` with a time limit: `None` if it did not finish in time
/// (it is killed).
fn grmc_within(args: &[&str], secs: u64) -> Option<std::process::Output> {
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args(args)
        .env("NO_COLOR", "1")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("grmc runs");
    let start = std::time::Instant::now();
    while start.elapsed() < std::time::Duration::from_secs(secs) {
        if child.try_wait().expect("wait").is_some() {
            return Some(child.wait_with_output().expect("output"));
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

/// Every file grmc reads is read as a regular file with a bound, and
/// anything else is refused with E0405 (or R0501 for curves) at once:
/// `grmc check` on a named pipe blocked forever, `grmc fmt /dev/zero`
/// read 6.5 GB, and `--curves /dev/zero` read without end.
#[cfg(unix)]
#[test]
fn pipes_and_devices_are_refused_unread() {
    let d = temp_dir("fifo");
    let fifo = d.join("pipe.grm");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());
    let fifo = fifo.to_str().expect("utf8 path");
    let mut cases: Vec<(Vec<&str>, &str)> = Vec::new();
    if made {
        for cmd in ["check", "fmt", "derive", "disasm"] {
            cases.push((vec![cmd, fifo], "E0405"));
        }
        cases.push((vec!["fmt", "--check", fifo], "E0405"));
    }
    let calder = example("calder_tree.grm");
    if Path::new("/dev/zero").exists() {
        cases.push((vec!["fmt", "/dev/zero"], "E0405"));
        cases.push((vec!["fmt", "--stdout", "/dev/zero"], "E0405"));
        cases.push((vec!["derive", "/dev/zero"], "E0405"));
        cases.push((
            vec!["sample", &calder, "--curves", "/dev/zero", "-o", "x.glb"],
            "R0501",
        ));
        if made {
            cases.push((
                vec!["sample", &calder, "--curves", fifo, "-o", "x.glb"],
                "R0501",
            ));
        }
    }
    for (args, code) in cases {
        let out = grmc_within(&args, 60)
            .unwrap_or_else(|| panic!("grmc {args:?} did not finish within 60 s"));
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(&format!("[{code}]")), "{args:?}: {err}");
        assert!(err.contains("it is not a regular file"), "{args:?}: {err}");
    }
}

/// A curves file larger than the limit is refused before it is parsed.
#[test]
fn a_curves_file_over_the_limit_is_refused() {
    let d = temp_dir("bigcurves");
    let f = d.join("big.curves.json");
    let file = std::fs::File::create(&f).expect("create");
    // One byte over `grm_guide::MAX_CURVES_BYTES` (16 MiB), sparse.
    file.set_len((16 << 20) + 1).expect("grow");
    let calder = example("calder_tree.grm");
    let out = grmc(&[
        "sample",
        &calder,
        "--curves",
        f.to_str().expect("utf8"),
        "-o",
        "x.glb",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("[R0501]"), "{err}");
    assert!(
        err.contains("it is larger than 16 MiB, the most a curves file may be"),
        "{err}"
    );
}

/// A file that cannot be read is a coded diagnostic (E0405) in both
/// formats: `--format json` printed `[]` for a missing file.
#[test]
fn an_unreadable_file_is_a_coded_diagnostic_in_json_too() {
    let d = temp_dir("unreadable");
    let missing = d.join("missing.grm");
    let missing = missing.to_str().expect("utf8 path");
    let out = grmc(&["check", "--format", "json", missing]);
    assert_eq!(out.status.code(), Some(2));
    let json = String::from_utf8_lossy(&out.stdout);
    assert!(json.contains("\"code\":\"E0405\""), "{json}");
    assert!(json.contains("\"severity\":\"error\""), "{json}");
    assert!(json.contains(&format!("cannot read {missing}")), "{json}");
    let out = grmc(&[
        "check",
        "--format",
        "json",
        d.to_str().expect("utf8"),
        &example("koch_island.grm"),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let json = String::from_utf8_lossy(&out.stdout);
    assert!(json.contains("it is a directory"), "{json}");
    for args in [
        vec!["check", missing],
        vec!["fmt", missing],
        vec!["derive", missing],
        vec!["sample", missing],
        vec!["disasm", missing],
        vec!["forest", missing],
    ] {
        let out = grmc(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(&format!("[E0405] Error: cannot read {missing}")),
            "{args:?}: {err}"
        );
    }
}

/// A file without a system, or `--system` naming none, is R0701 (it was
/// a plain `error:` line without a code).
#[test]
fn no_system_to_run_is_coded() {
    let d = temp_dir("nosystem");
    let f = d.join("empty.grm");
    std::fs::write(&f, "// only a comment\n").expect("write");
    let f = f.to_str().expect("utf8 path");
    for args in [
        vec!["derive", f],
        vec!["disasm", f],
        vec!["sample", f],
        vec!["forest", f],
    ] {
        let out = grmc(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains("[R0701] Error: this file defines no system to run"),
            "{args:?}: {err}"
        );
    }
    let koch = example("koch_island.grm");
    let out = grmc(&["derive", &koch, "--system", "Nope"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("[R0701] Error: this file has no system `Nope`"),
        "{err}"
    );
}

#[test]
fn binary_and_truncated_input_never_panics() {
    let d = temp_dir("binary");
    let mut seed = 0x1234_5678u32;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed
    };
    let calder =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/calder_tree.grm"))
            .expect("example");
    let mut inputs: Vec<Vec<u8>> = vec![
        (0..4096).map(|_| next() as u8).collect(),
        vec![0xff, 0xfe, 0x00, 0x00, b's', b'y', b's'],
        // Cut inside the system block: the system is left open.
        calder[..calder.len() * 3 / 4].to_vec(),
        calder[..calder.len() * 9 / 10].to_vec(),
    ];
    for cut in [calder.len() * 4 / 5, calder.len() - 3] {
        let mut v = calder.clone();
        v.truncate(cut.min(v.len()));
        v.push(0xc3); // a lone UTF-8 lead byte at the end
        inputs.push(v);
    }
    for (i, bytes) in inputs.iter().enumerate() {
        let f = d.join(format!("in{i}.grm"));
        std::fs::write(&f, bytes).expect("write");
        let out = grmc(&["check", f.to_str().expect("utf8 path")]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "input {i}: {err}");
        assert!(
            err.contains("[E0"),
            "input {i} has no coded diagnostic: {err}"
        );
        assert!(!err.contains("panicked"), "input {i}: {err}");
    }
}

#[test]
fn fmt_check_and_rewrite() {
    let d = temp_dir("fmt");
    let f = d.join("messy.grm");
    std::fs::write(&f, "system   S{axiom A;// keep me\nA->F   A;}\n").expect("write");
    let p = f.to_str().expect("utf8 path");
    assert_eq!(grmc(&["fmt", "--check", p]).status.code(), Some(1));
    assert_eq!(grmc(&["fmt", p]).status.code(), Some(0));
    let formatted = std::fs::read_to_string(&f).expect("read");
    assert!(formatted.contains("// keep me"), "{formatted}");
    assert_eq!(grmc(&["fmt", "--check", p]).status.code(), Some(0));
    // A file with syntax errors is left untouched.
    let g = d.join("broken.grm");
    std::fs::write(&g, "system S { A -> ( ; }").expect("write");
    assert_eq!(
        grmc(&["fmt", g.to_str().expect("utf8 path")]).status.code(),
        Some(1)
    );
    assert_eq!(
        std::fs::read_to_string(&g).expect("read"),
        "system S { A -> ( ; }"
    );
}

/// `fmt` writes through a symbolic link (the link stays a link, its
/// target is formatted) and keeps the file's permissions; it leaves no
/// temporary file behind.
#[cfg(unix)]
#[test]
fn fmt_keeps_links_and_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let d = temp_dir("fmt-link");
    let real = d.join("real.grm");
    let link = d.join("link.grm");
    std::fs::write(&real, "system S{axiom F;}\n").expect("write");
    std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o600)).expect("chmod");
    std::os::unix::fs::symlink("real.grm", &link).expect("symlink");
    let out = grmc(&["fmt", link.to_str().expect("utf8 path")]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        std::fs::symlink_metadata(&link)
            .expect("link")
            .file_type()
            .is_symlink()
    );
    assert_eq!(
        std::fs::read_to_string(&real).expect("read"),
        "system S {\n    axiom F;\n}\n"
    );
    let mode = std::fs::metadata(&real).expect("meta").permissions().mode();
    assert_eq!(mode & 0o777, 0o600, "{mode:o}");
    let left: Vec<_> = std::fs::read_dir(&d)
        .expect("dir")
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
}

#[test]
fn examples_are_formatted() {
    let ex = examples();
    let args: Vec<&str> = ["fmt", "--check"]
        .into_iter()
        .chain(ex.iter().map(String::as_str))
        .collect();
    let out = grmc(&args);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
