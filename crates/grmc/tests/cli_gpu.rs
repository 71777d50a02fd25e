//! `grmc derive --gpu` and `grmc bench gpu` as a user runs them (on
//! lavapipe where there is no GPU; without any adapter these tests fail
//! with grmc's message saying so, they never skip).

mod common;
use common::*;

fn ok(args: &[&str]) -> String {
    let out = grmc_at_root(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "grmc {}: {err}", args.join(" "));
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The GPU prints the same string as the CPU (text rounds parameters to
/// the shortest f32 that reads back, so small GPU differences would show:
/// these scenes' parameters are exact on both).
#[test]
fn derive_gpu_prints_the_cpu_string() {
    for (file, n) in [
        ("examples/bracketed_plant.grm", "3"),
        ("examples/context_plant_a.grm", "12"),
        ("examples/stochastic_plant.grm", "4"),
        ("examples/ternary_tree.grm", "3"),
    ] {
        let cpu = ok(&["derive", file, "-n", n, "--print"]);
        assert!(!cpu.trim().is_empty());
        // Every iteration on the GPU, the default (small strings on the
        // CPU first), and the first string only on the CPU.
        for prefix in ["0", "32768", "1"] {
            let gpu = ok(&[
                "derive",
                file,
                "-n",
                n,
                "--print",
                "--gpu",
                "--cpu-prefix",
                prefix,
            ]);
            assert_eq!(gpu, cpu, "{file} --cpu-prefix {prefix}");
        }
    }
}

/// `--stats` says which engine derived each string; the summary too.
#[test]
fn derive_gpu_stats_name_each_strings_engine() {
    let out = grmc_at_root(&[
        "derive",
        "examples/hilbert3d.grm",
        "-n",
        "4",
        "--gpu",
        "--stats",
        "--cpu-prefix",
        "300",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    let engines: Vec<&str> = stdout
        .lines()
        .skip(1)
        .filter_map(|l| l.split_whitespace().last())
        .collect();
    // Strings 0-2 (1, 29 and 271 modules) on the CPU, 3-4 on the GPU.
    assert_eq!(engines, ["CPU", "CPU", "CPU", "GPU", "GPU"], "{stdout}");
    assert!(
        err.contains("4 iterations (1-2 on the CPU, 3-4 on the GPU)"),
        "{err}"
    );
}

#[test]
fn derive_gpu_reports_a_production_error_with_its_span() {
    let dir = std::env::temp_dir().join(format!("grmc-cli-gpu-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let f = dir.join("bad.grm");
    std::fs::write(
        &f,
        "system S { axiom A(2) A(3); A(x) -> A(x - 1) F(1 / (x - 1)); }\n",
    )
    .expect("write");
    let out = grmc_at_root(&["derive", &f.display().to_string(), "-n", "3", "--gpu"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("R0204") && err.contains("1 / (x - 1)"),
        "{err}"
    );
}

#[test]
fn derive_gpu_limits_are_errors_not_crashes() {
    let out = grmc_at_root(&[
        "derive",
        "examples/koch_island.grm",
        "-n",
        "5",
        "--gpu",
        "--max-modules",
        "1000",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("over the limit of 1000"), "{err}");
}

#[test]
fn bench_gpu_checks_against_the_cpu() {
    let out = ok(&[
        "bench",
        "gpu",
        "--scene",
        "koch_island",
        "-n",
        "2",
        "--runs",
        "1",
    ]);
    assert!(
        out.contains("check: the GPU string equals the CPU string"),
        "{out}"
    );
    assert!(out.contains("modules/us"), "{out}");
}

/// `--forest N` adds the forest of N seeds, one derivation, against the
/// CPU deriving them one after the other.
#[test]
fn bench_gpu_times_a_forest() {
    let out = ok(&[
        "bench",
        "gpu",
        "--scene",
        "stochastic_plant",
        "-n",
        "3",
        "--runs",
        "1",
        "--forest",
        "3",
    ]);
    assert!(
        out.contains(
            "forest stochastic_plant (StochasticPlant): 3 seeds x 3 iterations in one derivation"
        ),
        "{out}"
    );
    assert!(out.contains("one job after the other"), "{out}");
}

/// The part table of a glb (`extras.grm.parts`: each part's module and
/// identity key).
fn glb_parts(path: &std::path::Path) -> serde_json::Value {
    let bytes = std::fs::read(path).expect("glb written");
    let len = u32::from_le_bytes(bytes[12..16].try_into().expect("length")) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + len]).expect("json");
    doc["extras"]["grm"]["parts"].clone()
}

/// `--gpu -o x.glb` names the parts by the CPU's identity keys, a system
/// that draws nothing too (the GPU is asked to carry keys; before, its
/// glb had none), on every path.
#[test]
fn derive_gpu_glb_names_parts_by_the_cpus_keys() {
    let dir = tempfile::tempdir().expect("temp dir");
    for (file, n) in [
        ("examples/ternary_tree.grm", "3"),
        ("examples/stochastic_plant.grm", "4"),
    ] {
        let cpu = dir.path().join("cpu.glb");
        ok(&["derive", file, "-n", n, "-o", &cpu.display().to_string()]);
        let want = glb_parts(&cpu);
        let parts = want.as_array().expect("a part table");
        assert!(!parts.is_empty(), "{file}");
        assert!(
            parts
                .iter()
                .all(|p| p["key"].as_str().is_some_and(|k| k.len() == 8)),
            "{file}: every part keyed"
        );
        for prefix in ["0", "32768"] {
            let gpu = dir.path().join(format!("gpu-{prefix}.glb"));
            ok(&[
                "derive",
                file,
                "-n",
                n,
                "--gpu",
                "--cpu-prefix",
                prefix,
                "-o",
                &gpu.display().to_string(),
            ]);
            assert_eq!(glb_parts(&gpu), want, "{file} --cpu-prefix {prefix}");
        }
    }
}

/// `grmc args` from the repository root with no adapter to be had
/// (`WGPU_ADAPTER_NAME` names none).
fn without_adapter(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args(args)
        .current_dir(repo())
        .env("NO_COLOR", "1")
        .env("WGPU_ADAPTER_NAME", "no adapter is named like this")
        .output()
        .expect("grmc runs")
}

/// Without a GPU, `--gpu` stops with R0601 (exit 2); with
/// `--cpu-fallback` it says so and the CPU derives the same string (one
/// tree and a forest), its `--stats` table the CPU's.
#[test]
fn without_a_gpu_cpu_fallback_derives_on_the_cpu() {
    let file = "examples/stochastic_plant.grm";
    let out = without_adapter(&["derive", file, "-n", "4", "--print", "--gpu"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("R0601"), "{err}");
    assert!(out.stdout.is_empty());
    for what in ["derive", "forest"] {
        let cpu = ok(&[what, file, "-n", "4", "--print"]);
        let out = without_adapter(&[what, file, "-n", "4", "--print", "--gpu", "--cpu-fallback"]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{what}: {err}");
        assert!(
            err.contains("note: GPU: ") && err.contains("deriving on the CPU (--cpu-fallback)"),
            "{what}: {err}"
        );
        assert_eq!(String::from_utf8_lossy(&out.stdout), cpu, "{what}");
    }
    let out = without_adapter(&[
        "derive",
        file,
        "-n",
        "2",
        "--stats",
        "--gpu",
        "--cpu-fallback",
    ]);
    let table = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0));
    assert!(
        table
            .lines()
            .next()
            .is_some_and(|h| h.trim_end().ends_with("ms")),
        "the CPU's table, without the engine column: {table}"
    );
    assert_eq!(table.lines().count(), 4, "{table}");
}
