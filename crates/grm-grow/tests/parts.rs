//! Exported glb models name their parts: every vertex has a `_PART` id,
//! and `extras.grm.parts` maps each id to the module that made it and that
//! module's identity key, the key the derivation tree gives it.

use std::path::Path;

use grm_derive::{DeriveLimits, DeriveOptions};
use grm_grow::{Grower, Record};

#[test]
fn every_vertex_of_a_glb_names_its_part_and_identity() {
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/ternary_tree.grm"
    ));
    let text = std::fs::read_to_string(path).expect("example");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    let p = &checked.program;
    let sys = p.default_system().expect("system");
    let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
    assert!(
        !c.draws_randomly(),
        "keys asked for, not needed by the draws"
    );
    let record = Record {
        tree: true,
        keys: true,
        ..Record::default()
    };
    let opts = DeriveOptions {
        iterations: 4,
        seed: 0,
        limits: DeriveLimits::default(),
    };
    let g = Grower::new(&c, 1, record)
        .expect("engine")
        .derive(&opts, &mut |_| {})
        .expect("derives");
    let model =
        grm_geom::build_model(p, sys, &g.string, &c.settings, &c.param_values).expect("model");
    assert_eq!(model.module_keys, g.string.keys());
    let bytes = grm_geom::export::glb_bytes(&model).expect("fits");
    // `from_slice` validates the document, the custom attribute included.
    let gltf = gltf::Gltf::from_slice(&bytes).expect("valid glb");
    let blob = gltf.blob.clone().expect("BIN chunk");
    // The JSON chunk, read as plain JSON (the custom attribute and the
    // extras are ours).
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().expect("len")) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).expect("json");
    let parts = doc["extras"]["grm"]["parts"]
        .as_array()
        .expect("parts table");
    assert!(parts.len() > 10);
    let tree = g.tree.as_ref().expect("tree");
    for part in parts {
        let m = part["module"].as_u64().expect("module") as u32;
        let key = u32::from_str_radix(part["key"].as_str().expect("key"), 16).expect("hex");
        assert_eq!(key, g.string.keys()[m as usize]);
        let node = tree.node_of_module(m).expect("a node");
        assert_eq!(tree.nodes[node as usize].key, key);
    }
    let prims = doc["meshes"][0]["primitives"]
        .as_array()
        .expect("primitives");
    assert_eq!(prims.len(), model.parts.len());
    let mut labelled = 0usize;
    for (prim, part) in prims.iter().zip(&model.parts) {
        let a = prim["attributes"]["_PART"]
            .as_u64()
            .expect("_PART attribute") as usize;
        let acc = &doc["accessors"][a];
        assert_eq!(acc["componentType"], 5126);
        assert_eq!(acc["type"], "SCALAR");
        let count = acc["count"].as_u64().expect("count") as usize;
        assert_eq!(count, part.mesh.positions.len());
        let view = &doc["bufferViews"][acc["bufferView"].as_u64().expect("view") as usize];
        let start = view["byteOffset"].as_u64().expect("offset") as usize;
        let ids: Vec<f32> = blob[start..start + 4 * count]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        // The declared bounds are the data's (glTF: a declared min/max
        // must match; the Khronos validator refused 0..all-parts).
        let lo = ids.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = ids.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        assert_eq!(acc["min"][0].as_f64(), Some(f64::from(lo)));
        assert_eq!(acc["max"][0].as_f64(), Some(f64::from(hi)));
        // Each pick's triangles' vertices carry its module's part id, but
        // for the rings a tube shares with the next bone's (a shared vertex
        // is the later part's): every pick owns a vertex, and every vertex's
        // id is that of a pick using it.
        let mut users: Vec<Vec<f32>> = vec![Vec::new(); count];
        for pick in &part.picks {
            let want = parts
                .iter()
                .position(|x| x["module"].as_u64() == Some(u64::from(pick.module)))
                .expect("listed") as f32;
            let a = pick.first_triangle as usize * 3;
            let b = a + pick.triangle_count as usize * 3;
            let mut owns = false;
            for &v in &part.mesh.indices[a..b] {
                users[v as usize].push(want);
                owns |= ids[v as usize] == want;
            }
            assert!(owns, "part {want} labels none of its vertices");
            labelled += 1;
        }
        for (v, u) in users.iter().enumerate() {
            if !u.is_empty() {
                assert!(
                    u.contains(&ids[v]),
                    "vertex {v}: {} not among {u:?}",
                    ids[v]
                );
            }
        }
    }
    assert!(labelled > 0);
}

/// A model of several materials (one glb primitive each): each `_PART`
/// accessor declares its own primitive's range of ids, not 0 to the
/// model's last (which the Khronos validator refuses).
#[test]
fn each_primitive_declares_its_own_range_of_part_ids() {
    let src = "material red { color = rgb(1, 0, 0); }\n\
               material green { color = rgb(0, 1, 0); }\n\
               system S {\n    iterations = 2;\n    axiom A;\n    \
               A -> material(red) F [ + F ] material(green) F [ - F ] A;\n}\n";
    let (_, checked) = grm_sema::check_with("two.grm", src, &grm_sema::MemLoader::new());
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = p.default_system().expect("system");
    let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
    let record = Record {
        keys: true,
        ..Record::default()
    };
    let opts = DeriveOptions {
        iterations: 2,
        seed: 0,
        limits: DeriveLimits::default(),
    };
    let g = Grower::new(&c, 1, record)
        .expect("engine")
        .derive(&opts, &mut |_| {})
        .expect("derives");
    let model =
        grm_geom::build_model(p, sys, &g.string, &c.settings, &c.param_values).expect("model");
    let bytes = grm_geom::export::glb_bytes(&model).expect("fits");
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().expect("len")) as usize;
    let doc: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).expect("json");
    let blob = &bytes[20 + json_len + 8..];
    let prims = doc["meshes"][0]["primitives"]
        .as_array()
        .expect("primitives");
    assert!(prims.len() >= 2, "one primitive per material");
    for prim in prims {
        let acc = &doc["accessors"][prim["attributes"]["_PART"].as_u64().expect("_PART") as usize];
        let view = &doc["bufferViews"][acc["bufferView"].as_u64().expect("view") as usize];
        let start = view["byteOffset"].as_u64().expect("offset") as usize;
        let count = acc["count"].as_u64().expect("count") as usize;
        let ids: Vec<f32> = blob[start..start + 4 * count]
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        let lo = ids.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = ids.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        assert_eq!(acc["min"][0].as_f64(), Some(f64::from(lo)));
        assert_eq!(acc["max"][0].as_f64(), Some(f64::from(hi)));
    }
}
