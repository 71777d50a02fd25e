//! `grmc manip parts|provenance|drag|sketch` (issue 28): the parts a drag
//! can move, the numbers that place one, a drag solved and written, a
//! meta-parameter sketched, an unreachable drag refused with its reason.

mod common;

use common::*;

fn path(p: &std::path::Path) -> &str {
    p.to_str().expect("utf-8")
}

/// A copy of the vase in a temporary directory.
fn vase() -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let grm = dir.path().join("vase.grm");
    std::fs::copy(example("vase.grm"), &grm).expect("copy");
    (dir, grm)
}

/// The belly's part: the bone of the largest width (`parts --format json`).
fn belly(grm: &std::path::Path) -> String {
    let out = grmc(&["manip", "parts", path(grm), "--format", "json"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let parts = v["parts"].as_array().expect("parts");
    assert_eq!(parts.len(), 7, "{v}");
    let b = parts
        .iter()
        .max_by(|a, b| {
            a["measures"][6]
                .as_f64()
                .unwrap()
                .total_cmp(&b["measures"][6].as_f64().unwrap())
        })
        .unwrap();
    assert_eq!(b["part"]["kind"], "bone");
    format!("bone:{:08x}", b["part"]["key"].as_u64().unwrap())
}

#[test]
fn a_drag_is_solved_printed_and_written_on_request() {
    let (_dir, grm) = vase();
    let part = belly(&grm);
    let out = grmc(&["manip", "provenance", path(&grm), "--part", &part]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let shown = text(&out.stdout);
    assert!(shown.contains("2.4"), "{shown}");
    let before = std::fs::read_to_string(&grm).unwrap();
    let out = grmc(&[
        "manip",
        "drag",
        path(&grm),
        "--part",
        &part,
        "--to",
        "width:3",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("2.4 -> 3"),
        "{}",
        text(&out.stdout)
    );
    assert!(text(&out.stderr).contains("not written"));
    assert_eq!(std::fs::read_to_string(&grm).unwrap(), before);
    let out = grmc(&[
        "manip",
        "drag",
        path(&grm),
        "--part",
        &part,
        "--to",
        "width:3",
        "--write",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let after = std::fs::read_to_string(&grm).unwrap();
    assert_eq!(after, before.replace("!(2.4)", "!(3)"));
    // The file still checks, and the belly is 3 wide now.
    let out = grmc(&["check", path(&grm)]);
    assert!(out.status.success(), "{}", text(&out.stderr));
}

#[test]
fn a_sketch_adds_a_parameter_and_an_unreachable_drag_says_why() {
    let (_dir, grm) = vase();
    let part = belly(&grm);
    let out = grmc(&[
        "manip",
        "sketch",
        path(&grm),
        "--part",
        &part,
        "--name",
        "belly",
        "--key",
        "1:width:3.4",
        "--write",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("(bit for bit)"),
        "{}",
        text(&out.stdout)
    );
    let after = std::fs::read_to_string(&grm).unwrap();
    assert!(after.contains("param belly = 0 in 0 .. 1;"), "{after}");
    assert!(after.contains("!(mix(2.4, 3.4, belly))"), "{after}");
    let out = grmc(&["derive", path(&grm), "--param", "belly=1"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // A width below zero: no number of the vase gives it.
    let out = grmc(&[
        "manip",
        "drag",
        path(&grm),
        "--part",
        &part,
        "--to",
        "width:-1",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out.stdout));
    assert!(
        text(&out.stderr).contains("error: "),
        "{}",
        text(&out.stderr)
    );
    // Bad parts and targets are usage errors.
    let out = grmc(&[
        "manip",
        "drag",
        path(&grm),
        "--part",
        "bone:zz",
        "--to",
        "width:1",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let out = grmc(&[
        "manip",
        "drag",
        path(&grm),
        "--part",
        &part,
        "--to",
        "girth:1",
    ]);
    assert_eq!(out.status.code(), Some(2));
}
