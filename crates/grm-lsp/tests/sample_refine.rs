//! The sample preview refines within its budget (issue 30;
//! docs/sampling.md 4.5): where the search's pass leaves a curve, the
//! refinement rounds that finish within `budgetMs` run, and the model
//! shown is the refined one; a budget the pass itself runs out of leaves
//! no time for a round.

mod common;

use common::*;
use serde_json::{Value, json};

/// A trunk and four arms from its top (the coverage bench's fork of four).
const FORK: &str = r#"{ "version": 1, "defaults": { "utilization_scale": 100 }, "curves": [
  { "name": "trunk", "points": [[0, 0, 0], [0, 1, 0], [0, 2, 0], [0, 3, 0]] },
  { "name": "arm_px", "points": [[0, 3, 0], [0.5, 3.5, 0], [1.2, 4, 0], [2, 4.3, 0]] },
  { "name": "arm_nx", "points": [[0, 3, 0], [-0.5, 3.5, 0], [-1.2, 4, 0], [-2, 4.3, 0]] },
  { "name": "arm_pz", "points": [[0, 3, 0], [0, 3.5, 0.5], [0, 4, 1.2], [0, 4.3, 2]] },
  { "name": "arm_nz", "points": [[0, 3, 0], [0, 3.5, -0.5], [0, 4, -1.2], [0, 4.3, -2]] } ] }"#;

fn fractions(r: &Value) -> Vec<f64> {
    r["sample"]["coverage"]
        .as_array()
        .expect("coverage")
        .iter()
        .map(|c| c["fraction"].as_f64().expect("fraction"))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_sample_preview_shows_the_refined_model() {
    let mut c = Client::start().await;
    let p = root().join("examples/calder_tree.grm");
    let text = std::fs::read_to_string(&p).expect("example");
    let u = c.open(&p, &text).await;
    let curves: Value = serde_json::from_str(FORK).expect("curves");
    // Seed 0's pass leaves an arm (grm-sample's tests/coverage.rs); a
    // budget ample for the pass and its rounds.
    let r = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "mode": "sample", "seed": 0,
                    "curves": curves, "budgetMs": 300_000 }),
        )
        .await;
    let s = &r["sample"];
    assert_eq!(s["stoppedEarly"], false);
    let rounds = s["refinements"].as_u64().expect("refinements");
    assert!(rounds > 0, "the pass leaves an arm: {s}");
    let f = fractions(&r);
    assert_eq!(f.len(), 5);
    assert!(
        f.iter().all(|&x| x >= 0.8),
        "the refined model follows every curve: {f:?}"
    );
    // The same request again: the same model (a budget that stops
    // nothing keeps the search deterministic).
    let again = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "mode": "sample", "seed": 0,
                    "curves": curves, "budgetMs": 300_000 }),
        )
        .await;
    assert_eq!(again["sample"]["objective"], s["objective"]);
    assert_eq!(again["sample"]["refinements"], s["refinements"]);
    assert_eq!(again["parts"], r["parts"]);

    // No time for the pass: it stops early and no round runs.
    let short = c
        .ok(
            "grm/preview",
            json!({ "textDocument": { "uri": u }, "mode": "sample", "seed": 0,
                    "curves": curves, "budgetMs": 0 }),
        )
        .await;
    assert_eq!(short["sample"]["stoppedEarly"], true);
    assert_eq!(short["sample"]["refinements"], 0);
}
