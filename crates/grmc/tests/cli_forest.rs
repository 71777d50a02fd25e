//! `grmc forest` as a user runs it: every tree is the system derived on
//! its own with its seed and drawn parameters, on the CPU and on the GPU
//! (lavapipe where there is no GPU; without any adapter the GPU tests fail
//! with grmc's message saying so, they never skip); the model holds every
//! tree; bad flags are refused with a reason.

mod common;
use common::*;

fn ok(args: &[&str]) -> (String, String) {
    let out = grmc_at_root(args);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "grmc {}: {err}", args.join(" "));
    (text(&out.stdout), err)
}

fn refused(args: &[&str], code: i32, says: &str) {
    let out = grmc_at_root(args);
    let err = text(&out.stderr);
    assert_eq!(
        out.status.code(),
        Some(code),
        "grmc {}: {err}",
        args.join(" ")
    );
    assert!(err.contains(says), "grmc {}: {err}", args.join(" "));
}

/// `derive FILE --system S --seed N [--param ...] --print`, trimmed.
fn derived_alone(file: &str, system: &str, seed: u32, params: &[String]) -> String {
    let seed = seed.to_string();
    let mut args = vec![
        "derive", file, "--system", system, "--seed", &seed, "--print",
    ];
    for p in params {
        args.extend(["--param", p]);
    }
    ok(&args).0.trim_end().to_string()
}

/// The `--stats` table: (system, seed, iterations, modules, bones, x, z,
/// drawn values as text).
type Row = (String, u32, u32, u64, u64, f32, f32, Vec<String>);

fn table(stdout: &str) -> Vec<Row> {
    stdout
        .lines()
        .skip_while(|l| !l.trim_start().starts_with("tree "))
        .skip(1)
        .map(|l| {
            let w: Vec<&str> = l.split_whitespace().collect();
            assert!(w.len() >= 8, "{l}");
            (
                w[1].to_string(),
                w[2].parse().expect("seed"),
                w[3].parse().expect("iterations"),
                w[4].parse().expect("modules"),
                w[5].parse().expect("bones"),
                w[6].parse().expect("x"),
                w[7].parse().expect("z"),
                w[8..].iter().map(|s| s.to_string()).collect(),
            )
        })
        .collect()
}

/// A stochastic forest: tree k is the plant with seed SEED + k, whichever
/// engine derives it, and the model's bones are every tree's.
#[test]
fn stochastic_trees_are_the_plant_with_successive_seeds() {
    let file = "examples/stochastic_plant.grm";
    for engine in [&[][..], &["--gpu", "--cpu-prefix", "0"][..]] {
        let mut args = vec![file, "--trees", "5", "--seed", "40", "--print", "-n", "4"];
        args.insert(0, "forest");
        args.extend_from_slice(engine);
        let (stdout, err) = ok(&args);
        let lines: Vec<&str> = stdout.lines().collect();
        assert_eq!(lines.len(), 5, "{stdout}");
        let mut distinct = std::collections::HashSet::new();
        for (k, line) in lines.iter().enumerate() {
            let alone = ok(&[
                "derive",
                file,
                "-n",
                "4",
                "--seed",
                &(40 + k).to_string(),
                "--print",
            ])
            .0;
            assert_eq!(*line, alone.trim_end(), "tree {k} {engine:?}");
            distinct.insert(*line);
        }
        // Five seeds of a stochastic plant: not five copies of one tree.
        assert!(distinct.len() >= 4, "{stdout}");
        assert!(
            err.contains("5 trees of StochasticPlant (seeds 40-44)"),
            "{err}"
        );
        if engine.is_empty() {
            assert!(err.contains("on the CPU"), "{err}");
        } else {
            assert!(err.contains("on the GPU in one derivation"), "{err}");
        }
    }
}

/// A mixed forest (systems in turn, their own iteration counts) with a
/// parameter drawn per tree: each tree is its system derived alone with
/// the drawn value, the draws are inside the range, differ, and repeat on
/// the next run; the GPU forest is the CPU one.
#[test]
fn a_mixed_forest_with_drawn_parameters_is_each_tree_alone() {
    let file = "examples/ternary_tree.grm";
    let args = |engine: &[&'static str]| {
        let mut a = vec![
            "forest",
            file,
            "--system",
            "TernaryTree",
            "--system",
            "TernaryTreeD",
            "--trees",
            "4",
            "--vary",
            "a=14..24",
            "--vary",
            "lr=1.05..1.2",
            "--stats",
            "--print",
        ];
        a.extend_from_slice(engine);
        a
    };
    let (cpu, _) = ok(&args(&[]));
    let (again, _) = ok(&args(&[]));
    assert_eq!(cpu, again, "a forest is the same on every run");
    let (gpu, err) = ok(&args(&["--gpu", "--cpu-prefix", "0"]));
    assert_eq!(gpu, cpu, "the GPU forest is the CPU one");
    assert!(err.contains("on the GPU in one derivation"), "{err}");
    // Small enough for the CPU prefix: the CPU derives it, and says so.
    let (prefixed, err) = ok(&args(&["--gpu"]));
    assert_eq!(prefixed, cpu);
    assert!(
        err.contains("on the CPU (every string within --cpu-prefix"),
        "{err}"
    );

    let rows = table(&cpu);
    assert_eq!(rows.len(), 4, "{cpu}");
    let strings: Vec<&str> = cpu.lines().take(4).collect();
    let mut drawn_a = Vec::new();
    for (k, (row, string)) in rows.iter().zip(&strings).enumerate() {
        let system = if k % 2 == 0 {
            "TernaryTree"
        } else {
            "TernaryTreeD"
        };
        assert_eq!(row.0, system);
        assert_eq!(row.1, k as u32, "seeds 0 + k");
        assert_eq!(row.2, 6, "both systems' own iterations");
        let [a, lr] = [&row.7[0], &row.7[1]];
        let (av, lrv): (f64, f64) = (a.parse().expect("a"), lr.parse().expect("lr"));
        assert!((14.0..=24.0).contains(&av), "{a}");
        assert!((1.05..=1.2).contains(&lrv), "{lr}");
        drawn_a.push(av);
        let alone = derived_alone(
            file,
            system,
            k as u32,
            &[format!("a={a}"), format!("lr={lr}")],
        );
        assert_eq!(*string, alone, "tree {k}");
    }
    drawn_a.sort_by(f64::total_cmp);
    drawn_a.dedup();
    assert_eq!(drawn_a.len(), 4, "every tree draws its own value");
}

/// Lipp's "produced" figure counts what each tree produced over its own
/// iterations: a tree that has done its iterations is carried along in the
/// combined GPU string but produces nothing more (the GPU summed the
/// combined strings: 70 here instead of 30 + 10).
#[test]
fn trees_of_different_iteration_counts_count_what_they_produced() {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("two.grm");
    std::fs::write(
        &file,
        "system Long { iterations = 4; axiom A; A -> A A; }\n\
         system Short { iterations = 1; axiom B B B B B B B B B B; B -> B; }\n",
    )
    .expect("write");
    let file = file.to_str().expect("utf-8 path");
    let base = [
        "forest", file, "--system", "Long", "--system", "Short", "--trees", "2",
    ];
    for engine in [&[][..], &["--gpu"][..], &["--gpu", "--cpu-prefix", "0"][..]] {
        let args: Vec<&str> = base.iter().chain(engine).copied().collect();
        let (_, err) = ok(&args);
        // Long: 2 + 4 + 8 + 16 = 30; Short: 10.
        assert!(
            err.contains("26 modules (40 produced in all)"),
            "{engine:?}: {err}"
        );
        assert!(err.contains("(seeds 0-1)"), "{engine:?}: {err}");
    }
}

/// The model holds every tree: its bone count is the sum of the trees'
/// (each derived alone), and neighbours are placed apart.
#[test]
fn the_model_holds_every_tree_on_a_grid() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("forest.glb");
    let out = out.display().to_string();
    let (stdout, err) = ok(&[
        "forest",
        "examples/bracketed_plant.grm",
        "--trees",
        "6",
        "--columns",
        "3",
        "--stats",
        "-o",
        &out,
    ]);
    let rows = table(&stdout);
    assert_eq!(rows.len(), 6);
    let mut bones = 0;
    for (k, row) in rows.iter().enumerate() {
        let one = dir
            .path()
            .join(format!("tree{k}.glb"))
            .display()
            .to_string();
        let (_, e) = ok(&[
            "derive",
            "examples/bracketed_plant.grm",
            "--seed",
            &row.1.to_string(),
            "-o",
            &one,
        ]);
        assert!(e.contains(&format!("{} bones)", row.4)), "tree {k}: {e}");
        bones += row.4;
    }
    assert!(err.contains(&format!("{bones} bones)")), "{err}");
    assert!(err.contains("3 x 2 grid"), "{err}");
    // Columns three apart in x, rows apart in z, centred on the origin.
    let xs: Vec<f32> = rows.iter().map(|r| r.5).collect();
    let zs: Vec<f32> = rows.iter().map(|r| r.6).collect();
    assert!(xs[0] < xs[1] && xs[1] < xs[2], "{xs:?}");
    assert_eq!(xs[0], xs[3]);
    assert!(zs[0] < zs[3], "{zs:?}");
    assert!((xs[0] + xs[2]).abs() < 1e-3 && (zs[0] + zs[3]).abs() < 1e-3);
    let bytes = std::fs::metadata(dir.path().join("forest.glb"))
        .expect("written")
        .len();
    assert!(bytes > 1000);
}

#[test]
fn bad_forests_are_refused_with_the_reason() {
    let f = "examples/ternary_tree.grm";
    refused(&["forest", f, "--trees", "0"], 2, "--trees");
    refused(&["forest", f, "--trees", "4097"], 2, "--trees");
    refused(
        &["forest", f, "--vary", "a=30..20"],
        2,
        "the range is empty",
    );
    refused(&["forest", f, "--vary", "a"], 2, "NAME=LO..HI");
    refused(
        &["forest", f, "--vary", "a=10..100"],
        2,
        "`--vary a=10..100`: 100 is outside its range",
    );
    refused(
        &["forest", f, "--vary", "nope=1..2"],
        2,
        "unknown meta-parameter `nope`",
    );
    refused(
        &["forest", f, "--vary", "a=15..20", "--param", "a=16"],
        2,
        "also given by `--param`",
    );
    refused(
        &["forest", f, "--vary", "a=15..20", "--vary", "a=16..17"],
        2,
        "another `--vary`",
    );
    refused(
        &["forest", f, "--param", "a=15", "--param", "a=16"],
        2,
        "given twice",
    );
    refused(
        &["forest", f, "--system", "TernaryTree", "--system", "Nope"],
        2,
        "has no system `Nope`",
    );
    refused(
        &["forest", f, "--spacing", "-1"],
        2,
        "is not a distance from 0",
    );
    refused(&["forest", f, "-o", "forest.xyz"], 2, "R0406");
    refused(&["forest", "examples/calder_tree.grm"], 1, "R0210");
    refused(&["forest", f, "--cpu-fallback"], 2, "--gpu");
}

/// A limit on one tree stops the forest with the CPU's error and names
/// the tree.
#[test]
fn a_tree_over_the_module_limit_stops_the_forest() {
    let out = grmc_at_root(&[
        "forest",
        "examples/stochastic_plant.grm",
        "--trees",
        "3",
        "--max-modules",
        "500",
    ]);
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("error: tree 0 (seed 1):"), "{err}");
    assert!(err.contains("R0201"), "{err}");
}

/// Trees each under the limit but over it together stop the forest on
/// both engines (on the GPU the forest is one string).
#[test]
fn the_limit_bounds_the_forest_together() {
    let args = [
        "forest",
        "examples/stochastic_plant.grm",
        "--trees",
        "5",
        "--max-modules",
        "5000",
    ];
    refused(&args, 1, "[R0201]");
    refused(&args, 1, "more than the limit of 5000");
    refused(&args, 1, "took the forest over the limit");
    let mut gpu = args.to_vec();
    gpu.push("--gpu");
    refused(&gpu, 1, "R0201");
    // One tree alone is within it.
    let mut one = args.to_vec();
    one[3] = "1";
    ok(&one);
}

/// A GPU forest that stays on the device is interpreted there: its bone
/// count is the model's (built from the strings by the CPU turtle).
#[test]
fn the_gpus_bones_are_the_models() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("f.glb").display().to_string();
    let base = [
        "forest",
        "examples/stochastic_plant.grm",
        "--trees",
        "6",
        "-n",
        "4",
        "--gpu",
        "--cpu-prefix",
        "0",
    ];
    let (_, on_device) = ok(&base);
    let there = on_device
        .split(" bones there")
        .next()
        .and_then(|s| s.rsplit('(').next())
        .and_then(|n| n.trim().parse::<u64>().ok())
        .unwrap_or_else(|| panic!("{on_device}"));
    let mut with_model = base.to_vec();
    with_model.extend(["-o", &out]);
    let (_, built) = ok(&with_model);
    assert!(
        built.contains(&format!(", {there} bones)")),
        "{there}: {built}"
    );
    assert!(there > 0);
}

/// A GPU run on a machine without a display says nothing on stderr
/// about one: Mesa's device-select layer, which would connect to Wayland
/// and print "XDG_RUNTIME_DIR is invalid" twice, is switched off there.
#[test]
fn a_headless_gpu_run_prints_no_display_errors() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_grmc"))
        .args([
            "forest",
            "examples/koch_island.grm",
            "--trees",
            "2",
            "-n",
            "5",
            "--gpu",
        ])
        .current_dir(repo())
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("NODEVICE_SELECT")
        .output()
        .expect("grmc runs");
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("XDG_RUNTIME_DIR"), "{err}");
    assert!(err.contains("on the GPU in one derivation"), "{err}");
}
