//! Part ids in exported models: which generated part each vertex belongs
//! to, so downstream tools can select parts (issue "Stable identity").
//!
//! A **part** is a module of the final string that made triangles (a
//! bone's tube, an instance, a polygon). Parts are numbered in the order
//! their first triangle appears in the model's parts (materials), from 0.
//! The glb carries, per primitive, a custom vertex attribute `_PART` (one
//! float per vertex, exact below 2^24 parts; valid glTF: application
//! attributes start with `_`, and FLOAT is an allowed component type),
//! and in the root `extras.grm.parts` the table from part id to the module
//! (`module`: its index in the string) and its identity key (`key`, 8 hex
//! digits, where the string carried keys: `Model::module_keys`).
//!
//! A vertex shared by two parts (the ring where a bone's tube joins the
//! next bone's) carries the later part's id: glTF has no per-triangle
//! attribute, and splitting the rings would change the mesh.

use crate::Model;

/// The most parts a `_PART` float numbers exactly.
pub const MAX_PARTS: usize = 1 << 24;

/// Per model part (material) with a non-empty mesh, the part id of every
/// vertex; and the table of parts (module indices).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PartIds {
    pub vertex_ids: Vec<Vec<f32>>,
    pub modules: Vec<u32>,
}

/// Number the parts of `model` and label every vertex; `None` past
/// [`MAX_PARTS`] parts (the export then leaves `_PART` out).
pub fn part_ids(model: &Model) -> Option<PartIds> {
    let mut index: std::collections::HashMap<u32, u32> = std::collections::HashMap::new();
    let mut out = PartIds::default();
    for part in model.parts.iter().filter(|p| !p.mesh.is_empty()) {
        let m = &part.mesh;
        // Vertices no pick's triangle uses stay 0.
        let mut ids = vec![0.0f32; m.positions.len()];
        for pick in &part.picks {
            let next = out.modules.len() as u32;
            let id = *index.entry(pick.module).or_insert_with(|| {
                out.modules.push(pick.module);
                next
            });
            if out.modules.len() > MAX_PARTS {
                return None;
            }
            let a = pick.first_triangle as usize * 3;
            let b = a + pick.triangle_count as usize * 3;
            for &v in m.indices.get(a..b).unwrap_or(&[]) {
                if let Some(slot) = ids.get_mut(v as usize) {
                    *slot = id as f32;
                }
            }
        }
        out.vertex_ids.push(ids);
    }
    Some(out)
}

/// The `extras.grm.parts` table: per part id, its module and key.
pub fn parts_table(model: &Model, ids: &PartIds) -> serde_json::Value {
    let parts: Vec<serde_json::Value> = ids
        .modules
        .iter()
        .map(|&m| match model.module_keys.get(m as usize) {
            Some(k) => serde_json::json!({ "module": m, "key": format!("{k:08x}") }),
            None => serde_json::json!({ "module": m }),
        })
        .collect();
    serde_json::json!({ "grm": { "parts": parts } })
}
