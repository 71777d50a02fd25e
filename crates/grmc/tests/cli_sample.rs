//! `grmc sample` as a user runs it: the cost by term, bone count and time;
//! export; the same seed giving the same file; typed errors and exit codes.

mod common;
use common::*;

#[test]
fn samples_the_calder_tree_and_exports_it() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("tree.glb");
    let tree = example("calder_tree.grm");
    let curves = example("calder_tree.curves.json");
    let run = |threads: &str, out: &std::path::Path| {
        grmc(&[
            "sample",
            &tree,
            "--curves",
            &curves,
            "--seed",
            "4",
            "--generations",
            "20",
            "--particles",
            "20..5",
            "--threads",
            threads,
            "--best",
            "2",
            "--stats",
            "-o",
            out.to_str().expect("utf-8"),
        ])
    };
    let o = run("1", &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{stdout}\n{stderr}");
    for needle in [
        "CalderTree: seed 4, 20 generations, particles 20 -> 5",
        "distance",
        "alignment",
        "utilization",
        "density",
        "bones 20 skeleton",
        "time ",
        "ESS per generation",
        "model 2:",
    ] {
        assert!(stdout.contains(needle), "missing `{needle}` in:\n{stdout}");
    }
    // --stats prints one row per generation.
    assert_eq!(
        stdout
            .lines()
            .filter(|l| l
                .split_whitespace()
                .next()
                .is_some_and(|w| w.parse::<u32>().is_ok()))
            .count(),
        20,
        "{stdout}"
    );
    let a = std::fs::read(&out).expect("glb written");
    assert!(a.starts_with(b"glTF"));
    assert!(dir.path().join("tree-2.glb").exists());
    // Same seed, other thread count: the same bytes.
    let out3 = dir.path().join("tree3.glb");
    let o = run("2", &out3);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(std::fs::read(&out3).expect("written"), a);
}

#[test]
fn ess_target_tempers_the_weights() {
    let tree = example("calder_tree.grm");
    let curves = example("calder_tree.curves.json");
    let run = |target: &str| {
        let o = grmc(&[
            "sample",
            &tree,
            "--curves",
            &curves,
            "--generations",
            "10",
            "--particles",
            "20",
            "--ess-target",
            target,
            "--stats",
        ]);
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        assert_eq!(o.status.code(), Some(0), "{stdout}");
        assert!(stdout.contains(" beta "), "{stdout}");
        // Column 4 is the ESS, column 5 beta.
        stdout
            .lines()
            .filter(|l| {
                l.split_whitespace()
                    .next()
                    .is_some_and(|w| w.parse::<u32>().is_ok())
            })
            .map(|l| {
                let f: Vec<f64> = l
                    .split_whitespace()
                    .map(|w| w.parse().unwrap_or(f64::NAN))
                    .collect();
                (f[3], f[4])
            })
            .collect::<Vec<_>>()
    };
    let on = run("0.5");
    assert_eq!(on.len(), 10);
    assert!(on.iter().all(|&(ess, _)| ess >= 9.99), "{on:?}");
    assert!(on.iter().any(|&(_, beta)| beta < 1.0), "{on:?}");
    // 0: untempered (the default is 0.1: sampling.md section 4.2).
    let off = run("0");
    assert!(off.iter().all(|&(_, beta)| beta == 1.0), "{off:?}");
    // The default keeps a tenth of the particles (20 here): ESS >= 2.
    let default = run("0.1");
    assert!(default.iter().all(|&(ess, _)| ess >= 1.999), "{default:?}");
}

/// `grmc sample` of the Calder tree with its curves, 10 generations of
/// `particles`, and `extra` flags.
fn calder(particles: &str, extra: &[&str]) -> std::process::Output {
    let (tree, curves) = (
        example("calder_tree.grm"),
        example("calder_tree.curves.json"),
    );
    let mut args = vec![
        "sample",
        tree.as_str(),
        "--curves",
        curves.as_str(),
        "--generations",
        "10",
        "--particles",
        particles,
    ];
    args.extend_from_slice(extra);
    grmc(&args)
}

/// The `cost` line's figure of a successful run's output.
fn cost(o: &std::process::Output) -> f64 {
    let s = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{s}");
    s.lines()
        .find_map(|l| l.strip_prefix("cost "))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|w| w.parse().ok())
        .unwrap_or(f64::NAN)
}

/// The search's expansion order and coverage term are options: the
/// defaults spelt out give the same model; Calder's uniform order without
/// the coverage term gives another; an order of 0 is refused.
#[test]
fn the_search_guide_is_an_option() {
    let default = cost(&calder("4", &[]));
    let spelt = cost(&calder("4", &["--order", "4", "--cover", "150"]));
    assert_eq!(default, spelt);
    let paper = cost(&calder("4", &["--order", "1", "--cover", "0"]));
    assert!(paper.is_finite() && default.is_finite());
    assert_ne!(paper, default);
    assert_eq!(calder("4", &["--order", "0"]).status.code(), Some(2));
    assert_eq!(calder("4", &["--cover", "-1"]).status.code(), Some(2));
}

#[test]
fn candidates_are_an_option() {
    let run = |extra: &[&str]| {
        let o = calder("20", extra);
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        assert_eq!(o.status.code(), Some(0), "{stdout}");
        (stdout, cost(&o))
    };
    let (default, default_cost) = run(&[]);
    // The default is 12 candidates (3 before the curve-coverage work).
    assert!(default.contains("12 candidates, ESS >= 0.1 N"), "{default}");
    let (_, twelve) = run(&["--candidates", "12"]);
    assert_eq!(default_cost, twelve);
    let (one, one_cost) = run(&["--candidates", "1", "--ess-target", "0"]);
    assert!(one.contains("1 candidate, untempered"), "{one}");
    assert!(one_cost.is_finite() && default_cost.is_finite());
    assert_ne!(one_cost, default_cost, "{one}\n{default}");
    // The volume baseline has no candidates, and is tempered as the
    // curves are (the summary said "untempered" while it was not).
    let (volume, volume_cost) = run(&["--cost", "volume"]);
    assert!(volume.contains("1 candidate, ESS >= 0.1 N"), "{volume}");
    let (untempered, untempered_cost) = run(&["--cost", "volume", "--ess-target", "0"]);
    assert!(
        untempered.contains("1 candidate, untempered"),
        "{untempered}"
    );
    assert_ne!(volume_cost, untempered_cost, "tempering changes the run");
    // 0 candidates is a usage error, not a silent 1.
    let o = calder("20", &["--candidates", "0"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--candidates"), "{stderr}");
}

#[test]
fn curves_default_to_the_file_beside_the_grammar() {
    let o = grmc(&[
        "sample",
        &example("calder_tree.grm"),
        "--generations",
        "3",
        "--particles",
        "4",
        "--cost",
        "volume",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("volume cost"), "{stdout}");
    assert!(stdout.contains("no heuristic"), "{stdout}");
}

#[test]
fn errors_and_exit_codes() {
    // A derive system: R0301, exit 1.
    let o = grmc(&[
        "sample",
        &example("koch_island.grm"),
        "--curves",
        &example("calder_tree.curves.json"),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("R0301"));
    // The same without curves: still R0301 (a derive system needs no
    // curves; "cannot read koch_island.curves.json" would mislead).
    let o = grmc(&["sample", &example("koch_island.grm")]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("R0301") && !err.contains("R0501"), "{err}");
    // A sample system with no curves file beside it: exit 2 with a hint.
    let dir = tempfile::tempdir().expect("tempdir");
    let grammar = dir.path().join("tree.grm");
    std::fs::write(
        &grammar,
        "system T {\n    mode = sample;\n    axiom b;\n    skeleton b;\n    b -> F b;\n    wrapup b -> ;\n}\n",
    )
    .expect("write");
    let o = grmc(&["sample", &grammar.to_string_lossy()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("R0501") && err.contains("--curves"), "{err}");
    // A bad --particles: exit 2.
    let o = grmc(&["sample", &example("calder_tree.grm"), "--particles", "0..3"]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn frames_write_a_model_per_generation_and_the_last_is_the_result() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tree = example("calder_tree.grm");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "sample",
            tree.as_str(),
            "--seed",
            "2",
            "--generations",
            "12",
            "--particles",
            "12..4",
        ];
        args.extend_from_slice(extra);
        grmc(&args)
    };
    let framed = dir.path().join("t.glb");
    let o = run(&["--frames", "-o", framed.to_str().expect("utf-8")]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let want: Vec<String> = (0..12).map(|k| format!("t-{k:02}.glb")).collect();
    assert_eq!(names, want);
    // The last frame is the model a run without --frames writes.
    let plain = dir.path().join("plain.glb");
    let o = run(&["-o", plain.to_str().expect("utf-8")]);
    assert_eq!(o.status.code(), Some(0));
    let last = std::fs::read(dir.path().join("t-11.glb")).expect("last frame");
    assert_eq!(last, std::fs::read(&plain).expect("plain"));
    // The search moved: the first frame is another model.
    assert_ne!(
        std::fs::read(dir.path().join("t-00.glb")).expect("first frame"),
        last
    );

    // --generation K writes frame K; past the last, the result.
    let g0 = dir.path().join("g0.glb");
    let o = run(&["--generation", "0", "-o", g0.to_str().expect("utf-8")]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}");
    assert!(out.contains("generation 0 of 0..11"), "{out}");
    assert_eq!(
        std::fs::read(&g0).expect("g0"),
        std::fs::read(dir.path().join("t-00.glb")).expect("first frame")
    );
    std::fs::remove_file(&g0).expect("rm");
    let past = dir.path().join("past.glb");
    let o = run(&["--generation", "50", "-o", past.to_str().expect("utf-8")]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(std::fs::read(&past).expect("past"), last);
    std::fs::remove_file(&past).expect("rm");

    // Pictures: one per generation, all the same size.
    let pics = dir.path().join("pics");
    std::fs::create_dir(&pics).expect("mkdir");
    let o = run(&[
        "--frames",
        "--image-size",
        "64x48",
        "-o",
        pics.join("t.png").to_str().expect("utf-8"),
    ]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(std::fs::read_dir(&pics).expect("dir").count(), 12);

    // Refused before any work: with --best, without -o, over 1,000 files.
    for (extra, says) in [
        (
            vec!["--frames", "--best", "2", "-o", "x.glb"],
            "use one of them",
        ),
        (vec!["--frames"], "--output <OUTPUT>"),
        (
            vec!["--generation", "1", "--frames", "-o", "x.glb"],
            "cannot be used with",
        ),
        (
            vec!["--generation", "1", "--best", "2"],
            "cannot be used with",
        ),
    ] {
        let o = run(&extra);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {err}");
        assert!(err.contains(says), "{extra:?}: {err}");
        assert!(!err.contains("cost"), "nothing sampled: {err}");
    }
    let o = grmc(&[
        "sample",
        &tree,
        "--generations",
        "1001",
        "--frames",
        "-o",
        "x.glb",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("at most 1000 files"), "{err}");
}

/// A sample system whose early generations' particles cannot be wrapped
/// up (the frames tests' shared fixture).
const SHOOT: &str = include_str!("../../../tests/lsp/shoot.grm");

/// Frames that cannot be finished do not fail the search: it finishes and
/// reports its result; --generation K of such a frame is that frame's
/// error (R0302, saying which generation), of another one its model;
/// --frames writes every frame or none, and says which cannot be made.
#[test]
fn frames_that_cannot_be_finished_leave_the_search_alone() {
    let dir = tempfile::tempdir().expect("tempdir");
    let grammar = dir.path().join("shoot.grm");
    std::fs::write(&grammar, SHOOT).expect("write");
    let curves = example("calder_tree.curves.json");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "sample",
            grammar.to_str().expect("utf-8"),
            "--curves",
            &curves,
        ];
        args.extend_from_slice(extra);
        grmc(&args)
    };
    let out = dir.path().join("out");
    std::fs::create_dir(&out).expect("mkdir");
    let path = |name: &str| out.join(name).to_str().expect("utf-8").to_string();

    let plain = run(&["-o", &path("plain.glb")]);
    assert_eq!(plain.status.code(), Some(0), "{}", text(&plain.stderr));
    let result_cost = text(&plain.stdout)
        .lines()
        .find(|l| l.starts_with("cost "))
        .expect("a cost line")
        .to_string();

    // --generation 1: generation 1's particles cannot be wrapped up.
    let o = run(&["--generation", "1", "-o", &path("g1.glb")]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("R0302"), "{err}");
    assert!(err.contains("in the model of generation 1"), "{err}");
    assert!(!out.join("g1.glb").exists());
    // --generation 3: they can.
    let o = run(&["--generation", "3", "-o", &path("g3.glb")]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("generation 3 of 0..7"));
    assert!(out.join("g3.glb").is_file());

    // --frames: the search finished (its result is reported), but
    // generations 0 and 1 have no model: nothing is written.
    let o = run(&["--frames", "-o", &path("f.glb")]);
    let (stdout, err) = (text(&o.stdout), text(&o.stderr));
    assert_eq!(o.status.code(), Some(1), "{stdout}\n{err}");
    assert!(stdout.contains(&result_cost), "{stdout}");
    assert!(err.contains("R0302"), "{err}");
    assert!(
        err.contains("2 of 8 frames cannot be finished (generations 0, 1)"),
        "{err}"
    );
    let mut names: Vec<String> = std::fs::read_dir(&out)
        .expect("dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["g3.glb", "plain.glb"]);
}

/// The frames kept count towards --max-memory: a bound the search alone
/// stays within stops the run with frames (R0310, saying why), before
/// any file is written.
#[test]
fn frames_count_towards_the_memory_bound() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tree = example("calder_tree.grm");
    let out = dir.path().join("t.glb");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "sample",
            tree.as_str(),
            "--generations",
            "60",
            "--max-memory",
            "3",
        ];
        args.extend_from_slice(extra);
        grmc(&args)
    };
    let o = run(&[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let o = run(&["--frames", "-o", out.to_str().expect("utf-8")]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("R0310"), "{err}");
    assert!(err.contains("with --frames the models"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).expect("dir").count(), 0);
}

/// --generation K where the search ran fewer generations (a budget
/// stop, or a run of one): the last one run, the result, said so.
#[test]
fn generation_past_the_generations_run_is_the_result() {
    let tree = example("calder_tree.grm");
    let run = |extra: &[&str]| {
        let mut args = vec!["sample", tree.as_str(), "--particles", "6"];
        args.extend_from_slice(extra);
        grmc(&args)
    };
    for extra in [
        vec![
            "--generations",
            "12",
            "--budget-ms",
            "0",
            "--generation",
            "5",
        ],
        vec!["--generations", "1", "--generation", "0"],
        vec!["--generations", "1", "--generation", "4294967295"],
    ] {
        let o = run(&extra);
        let out = text(&o.stdout);
        assert_eq!(o.status.code(), Some(0), "{extra:?}: {}", text(&o.stderr));
        assert!(out.contains("generation 0 of 0..0"), "{extra:?}: {out}");
        let plain: Vec<&str> = extra[..extra.len() - 2].to_vec();
        let p = run(&plain);
        let cost = |s: &str| {
            s.lines()
                .find(|l| l.starts_with("cost "))
                .map(str::to_string)
        };
        assert_eq!(cost(&out), cost(&text(&p.stdout)), "{extra:?}");
    }
    // Not a whole number from 0 to 2^32 - 1: a usage error.
    for bad in ["-1", "4294967296", "x"] {
        let o = run(&["--generation", bad]);
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert!(text(&o.stdout).is_empty(), "{bad}");
    }
}
