//! `--max-memory` bounds the whole run, not only the derivation: building
//! the model, pictures, every export format, `forest`, and the guided
//! sampler's search (issue 32). Each case runs `grmc` as a child and reads
//! its peak resident memory (VmHWM, polled from /proc while it runs: the
//! high-water mark only grows, so the last reading is the peak up to a
//! few milliseconds before the end). The bounds are generous (a loaded
//! machine changes the time, not the memory), and far below what the
//! runs took before: 9.4 GB for the Koch island picture at n = 7 under
//! `--max-memory 256`, 1.4 GB for a search whose generations add nothing
//! under `--max-memory 16`.

mod common;

use std::io::Read;
use std::process::{Command, Stdio};

use common::*;

/// Run `grmc args`: exit code, stderr, and peak resident memory in MiB.
fn peak(args: &[&str]) -> (Option<i32>, String, u64) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args(args)
        .env("NO_COLOR", "1")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("grmc runs");
    let mut stderr = child.stderr.take().expect("stderr");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let (code, kib) = wait_peak_kib(&mut child);
    (code, reader.join().unwrap_or_default(), kib >> 10)
}

fn out(name: &str) -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let p = dir.path().join(name).display().to_string();
    (dir, p)
}

#[test]
fn a_picture_over_the_limit_is_refused_before_it_is_drawn() {
    let (_d, png) = out("k6.png");
    let koch = example("koch_island.grm");
    let (code, err, mib) = peak(&["derive", &koch, "-n", "6", "-o", &png, "--max-memory", "64"]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("R0202"), "{err}");
    assert!(err.contains("over the memory limit of 64 MiB"), "{err}");
    assert!(!std::path::Path::new(&png).exists());
    assert!(mib < 192, "peak {mib} MiB under --max-memory 64\n{err}");
}

#[test]
fn a_mesh_export_over_the_limit_is_refused_before_it_is_built() {
    let (_d, obj) = out("k6.obj");
    let koch = example("koch_island.grm");
    // The string and its interpretation fit; the meshes (16 million
    // triangles) do not.
    let (code, err, mib) = peak(&[
        "derive",
        &koch,
        "-n",
        "6",
        "-o",
        &obj,
        "--max-memory",
        "200",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("R0202") && err.contains("writing it as .obj"),
        "{err}"
    );
    assert!(err.contains("16777232 triangles"), "{err}");
    assert!(mib < 300, "peak {mib} MiB under --max-memory 200\n{err}");
}

#[test]
fn a_run_that_fits_stays_under_its_limit() {
    let (_d, png) = out("k5.png");
    let koch = example("koch_island.grm");
    let (code, err, mib) = peak(&[
        "derive",
        &koch,
        "-n",
        "5",
        "-o",
        &png,
        "--max-memory",
        "600",
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(mib <= 600, "peak {mib} MiB under --max-memory 600\n{err}");
    let (_d, glb) = out("k5.glb");
    let (code, err, mib) = peak(&[
        "derive",
        &koch,
        "-n",
        "5",
        "-o",
        &glb,
        "--max-memory",
        "600",
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(mib <= 600, "peak {mib} MiB under --max-memory 600\n{err}");
}

#[test]
fn frames_are_bounded_too() {
    let (_d, obj) = out("k.obj");
    let koch = example("koch_island.grm");
    let (code, err, mib) = peak(&[
        "derive",
        &koch,
        "-n",
        "6",
        "--frames",
        "-o",
        &obj,
        "--max-memory",
        "100",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("R0202"), "{err}");
    assert!(mib < 200, "peak {mib} MiB under --max-memory 100\n{err}");
}

#[test]
fn a_forest_over_the_limit_is_refused_from_its_strings() {
    let (_d, glb) = out("f.glb");
    let tree = example("ternary_tree.grm");
    let (code, err, mib) = peak(&[
        "forest",
        &tree,
        "--trees",
        "512",
        "-n",
        "6",
        "-o",
        &glb,
        "--max-memory",
        "64",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("R0202") && err.contains("took the forest over"),
        "{err}"
    );
    assert!(mib < 256, "peak {mib} MiB under --max-memory 64\n{err}");
}

#[test]
fn a_search_whose_generations_add_nothing_holds_little() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let grm = dir.path().join("s.grm");
    std::fs::write(
        &grm,
        "system S {\n    mode = sample;\n    axiom b;\n    skeleton b;\n    b -> F(1);\n    wrapup b -> ;\n}\n",
    )
    .expect("write");
    std::fs::copy(
        repo().join("examples/calder_tree.curves.json"),
        dir.path().join("s.curves.json"),
    )
    .expect("copy");
    let grm = grm.display().to_string();
    // Before: a `Step` (72 bytes) per particle per generation, uncounted:
    // 140 MiB here, 1.4 GB at 20,000 generations, under --max-memory 16.
    let (code, err, mib) = peak(&[
        "sample",
        &grm,
        "--particles",
        "1000",
        "--generations",
        "2000",
        "--max-memory",
        "16",
    ]);
    assert_eq!(code, Some(0), "{err}");
    assert!(mib < 64, "peak {mib} MiB under --max-memory 16\n{err}");
}
