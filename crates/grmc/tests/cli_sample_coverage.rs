//! `grmc sample --stats` reports how much of each guiding curve the model
//! follows: the covered share, the gaps, a curve the model does not reach,
//! and a grammar whose bones are too few to cover the curves at all.

mod common;
use common::*;

/// The coverage block of `--stats` (from its heading to the time line).
fn coverage_block(stdout: &str) -> String {
    stdout
        .lines()
        .skip_while(|l| !l.starts_with("coverage ("))
        .take_while(|l| !l.starts_with("time "))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn stats_report_coverage_gaps_and_unreachable_curves() {
    let dir = tempfile::tempdir().expect("tempdir");
    let curves = dir.path().join("t.curves.json");
    // The trunk of the Calder tree and a curve six units to its side: six
    // generations grow six bones, one chain that covers the trunk and
    // could not cover 80% of both curves even laid along them (its length
    // and the covering radius at its two free ends); four grow fewer
    // still.
    std::fs::write(
        &curves,
        r#"{ "version": 1, "defaults": { "utilization_scale": 100 }, "curves": [
  { "name": "trunk", "points": [[0, 0, 0], [0, 1.3, 0], [0, 2.7, 0], [0, 4, 0]] },
  { "name": "far_away", "points": [[6, 0, 0], [6, 1, 0], [6, 2, 0], [6, 3, 0]] } ] }"#,
    )
    .expect("write curves");
    let tree = example("calder_tree.grm");
    let run = |extra: &[&str]| {
        let mut args = vec![
            "sample",
            &tree,
            "--curves",
            curves.to_str().expect("utf-8"),
            "--seed",
            "2",
            "--generations",
            "6",
            "--particles",
            "10",
        ];
        args.extend_from_slice(extra);
        grmc(&args)
    };
    let o = run(&["--stats"]);
    let stdout = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{stdout}\n{}", text(&o.stderr));
    // A snapshot: it changes when the default search does (update it then,
    // deliberately).
    let expected = "\
coverage (share of each curve's length with a bone within its thickness + 0.15):
  `trunk`    100.0%  no gaps
  `far_away`   0.0%  not reached: the nearest bone stays 5.99 from it (covering radius 0.15); too few bones for it
  too few bones: 6 bones, 3.88 long in all, cannot cover 80% of the curves' 7.00 even laid along them (with the covering radius at their 2 free ends: more generations grow more bones; fewer curves need fewer)";
    assert_eq!(coverage_block(&stdout), expected, "{stdout}");
    // The search's best model leaves `far_away` (and every round's does):
    // the refinement rounds (docs/sampling.md 4.5) ran, all five, and say so.
    assert!(
        stdout.contains("\nrefined: 5 rounds grown again from generation 1 (the search's best model left a curve under 80%)\n"),
        "{stdout}"
    );
    // Four generations: four bones, too few for the curves at all.
    let o = grmc(&[
        "sample",
        &tree,
        "--curves",
        curves.to_str().expect("utf-8"),
        "--seed",
        "2",
        "--generations",
        "4",
        "--particles",
        "10",
        "--stats",
    ]);
    let block = coverage_block(&text(&o.stdout));
    assert!(
        block.contains(
            "too few bones: 4 bones, 3.07 long in all, cannot cover 80% of the curves' 7.00"
        ),
        "{block}"
    );
    // Without --stats: no coverage block.
    let o = run(&[]);
    assert_eq!(coverage_block(&text(&o.stdout)), "");
}

#[test]
fn stats_report_coverage_per_model_and_thick_curves_widen_the_radius() {
    let vine = example("vine_wall.grm");
    let curves = example("vine_wall.curves.json");
    let o = grmc(&[
        "sample",
        &vine,
        "--curves",
        &curves,
        "--seed",
        "3",
        "--generations",
        "10",
        "--particles",
        "20..10",
        "--best",
        "2",
        "--stats",
    ]);
    let stdout = text(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{stdout}\n{}", text(&o.stderr));
    // Each model's block names every curve; the vine's curves are 0.15
    // thick, so a point is covered by a bone within 0.30.
    for rank in ["model 1: ", "model 2: "] {
        let head = format!("{rank}coverage (");
        assert!(stdout.contains(&head), "missing `{head}` in:\n{stdout}");
        for curve in ["`main_stem`", "`left_sweep`", "`right_trail`"] {
            assert!(
                stdout
                    .lines()
                    .any(|l| l.starts_with(rank) && l.contains(curve) && l.contains('%')),
                "no line for {curve} of {rank} in:\n{stdout}"
            );
        }
    }
    assert!(
        stdout.contains("covering radius 0.30") || !stdout.contains("not reached"),
        "{stdout}"
    );
}
