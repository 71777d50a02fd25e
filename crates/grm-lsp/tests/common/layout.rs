//! What the layout tests share (tests/layout.rs, tests/layout_grm.rs).

use serde_json::Value;

/// A street of the base layer (layer 0) in the merged layout, away from
/// the avenue: every point left of x = 100 and below y = 70.
pub fn base_street(r: &Value) -> Value {
    r["streets"]
        .as_array()
        .unwrap()
        .iter()
        .find(|s| {
            s["layer"] == 0
                && s["points"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .all(|p| p[0].as_f64().unwrap() < 100.0 && p[1].as_f64().unwrap() < 70.0)
        })
        .cloned()
        .expect("a base street near the origin")
}
