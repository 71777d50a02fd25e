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
    // A device that never ends is read up to the limit, and said to be
    // no regular file (not "larger than" a size it does not have).
    if Path::new("/dev/zero").exists() {
        let out = grmc(&["check", "/dev/zero"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains(
                "cannot read /dev/zero: it is not a regular file, and it gave more than 16 MiB"
            ),
            "{err}"
        );
    }
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
