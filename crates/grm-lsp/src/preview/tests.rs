use super::*;

fn compiled(text: &str) -> (grm_sema::Program, CompiledSystem) {
    let (_, checked) = grm_sema::check_with("t.grm", text, &grm_sema::MemLoader::new());
    assert!(!checked.has_errors(), "{:?}", checked.diagnostics);
    let prog = checked.program;
    let sys = prog.systems[0].clone();
    let c = grm_compile::compile(&prog, &sys, &prog.default_params()).expect("compiles");
    (prog, c)
}

/// The production (by its predecessor and first successor symbol) that
/// made each module.
fn makers(c: &CompiledSystem, g: &Grown) -> Vec<String> {
    let o = g.origin.as_ref().expect("origins");
    g.string
        .symbols()
        .zip(o)
        .map(|(s, &a)| {
            let alt = &c.alts[a as usize];
            let first = c.successor(alt).first().map_or("ε".to_string(), |m| {
                c.symbol_names[m.symbol as usize].clone()
            });
            let pred = if a == c.axiom_alt {
                "axiom".to_string()
            } else {
                c.symbol_names[c.groups[alt.group as usize].pred as usize].clone()
            };
            format!("{}<{pred}:{first}", c.symbol_names[s as usize])
        })
        .collect()
}

#[test]
fn origins_follow_each_step() {
    // A -> F B; B -> G | f (stochastic); F is never rewritten and keeps
    // its maker; X is copied from the axiom.
    let (_, c) =
        compiled("system S { iterations = 2; axiom X A; A -> F B; B -> (1) G; B -> (1) f; }");
    let g = grow(&c, 2, 3, 1000, None, true, None).unwrap();
    let m = makers(&c, &g);
    assert_eq!(m.len(), 3);
    assert_eq!(m[0], "X<axiom:X");
    assert_eq!(m[1], "F<A:F");
    assert!(m[2] == "G<B:G" || m[2] == "f<B:f", "{m:?}");
}

#[test]
fn origins_are_the_decisions_even_when_alternatives_tie() {
    // `C -> (1) G; C -> (1) G;` write the same symbols: the origin is
    // the alternative the engine chose (the tree's record of it), not
    // a guess; both are chosen over the seeds.
    let (_, c) = compiled(
        "system S { iterations = 3; axiom A C; A -> (1) F; A -> (1) F A; C -> (1) G; C -> (1) G; }",
    );
    let mut seen = std::collections::BTreeSet::new();
    for seed in 0..20 {
        let g = grow(&c, 3, seed, 1000, None, true, None).unwrap();
        let tree = g.tree.as_ref().expect("tree");
        let o = g.origin.as_ref().expect("origins");
        for (m, &a) in o.iter().enumerate() {
            let n = tree.node_of_module(m as u32).expect("node");
            let parent = tree.nodes[n as usize].parent.expect("parent");
            assert_eq!(
                tree.nodes[parent as usize].production,
                Some(a),
                "seed {seed}"
            );
            if c.symbol_names[g.string.sym(m) as usize] == "G" {
                seen.insert(a);
            }
        }
    }
    assert_eq!(seen.len(), 2, "both tied alternatives are told apart");
}

#[test]
fn focus_marks_descendants() {
    // Focus on `B -> C D`: C and D, and what they become, are marked.
    let text = "system S { iterations = 3; axiom A; A -> F B; B -> C D; C -> G; D -> G G; }";
    let (_, c) = compiled(text);
    let b_alt = (0..c.alts.len() as u32)
        .find(|&a| {
            let g = &c.groups[c.alts[a as usize].group as usize];
            a != c.axiom_alt && c.symbol_names[g.pred as usize] == "B"
        })
        .unwrap();
    let g = grow(&c, 3, 0, 1000, Some(b_alt), false, None).unwrap();
    let names: Vec<&str> = g
        .string
        .symbols()
        .map(|s| c.symbol_names[s as usize].as_str())
        .collect();
    assert_eq!(names, ["F", "G", "G", "G"]);
    assert_eq!(g.focus, [false, true, true, true]);
}

#[test]
fn a_live_ticket_supersedes_the_one_before_and_dropping_one_cancels_it() {
    let shared = Arc::new(Shared::new(crate::Config::default()));
    let path = std::path::Path::new("/t/tree.grm");
    let other = std::path::Path::new("/t/other.grm");
    let a = Ticket::begin(&shared, path, true);
    let elsewhere = Ticket::begin(&shared, other, true);
    assert!(!a.token.is_cancelled());
    // A request that is not live neither supersedes nor is superseded.
    let once = Ticket::begin(&shared, path, false);
    assert!(!a.token.is_cancelled());
    let b = Ticket::begin(&shared, path, true);
    assert!(a.token.is_cancelled(), "superseded");
    assert!(!b.token.is_cancelled());
    assert!(!once.token.is_cancelled());
    assert!(!elsewhere.token.is_cancelled(), "another document");
    // The superseded ticket ending does not unregister the newer one.
    drop(a);
    assert_eq!(shared.running().get(path).map(|r| r.0), Some(b.id));
    // A ticket dropped before its answer (`$/cancelRequest`) stops its work.
    let (tb, tonce) = (b.token.clone(), once.token.clone());
    drop(b);
    drop(once);
    assert!(tb.is_cancelled() && tonce.is_cancelled());
    assert!(shared.running().get(path).is_none());
    assert!(shared.running().get(other).is_some());
}

#[test]
fn a_clients_older_live_request_arriving_late_supersedes_nothing() {
    let shared = Arc::new(Shared::new(crate::Config::default()));
    let path = std::path::Path::new("/t/tree.grm");
    let params = |client: &str, order: u64, seed: u32| -> PreviewParams {
        serde_json::from_value(serde_json::json!({
            "textDocument": { "uri": "file:///t/tree.grm" }, "live": true,
            "client": client, "order": order, "seed": seed,
        }))
        .expect("params")
    };
    // The page sent 1 then 2; 2 arrives first.
    let newer = Ticket::begin_preview(&shared, path, &params("page", 2, 2));
    let older = Ticket::begin_preview(&shared, path, &params("page", 1, 1));
    assert!(
        older.token.is_cancelled(),
        "the older one is answered superseded"
    );
    assert!(!newer.token.is_cancelled(), "and supersedes nothing");
    // previewUpdated keeps the newer one's options.
    assert_eq!(shared.previews().get(path).and_then(|p| p.seed), Some(2));
    drop(older);
    assert_eq!(shared.running().get(path).map(|r| r.0), Some(newer.id));
    // Even after the newer one was answered.
    drop(newer);
    let late = Ticket::begin_preview(&shared, path, &params("page", 1, 1));
    assert!(late.token.is_cancelled());
    assert_eq!(shared.previews().get(path).and_then(|p| p.seed), Some(2));
    // Another client's requests, and requests without an order, are taken as they come.
    let other = Ticket::begin_preview(&shared, path, &params("other", 1, 3));
    assert!(!other.token.is_cancelled());
    let next = Ticket::begin_preview(&shared, path, &params("page", 3, 4));
    assert!(
        other.token.is_cancelled(),
        "a later request supersedes another client's"
    );
    assert!(!next.token.is_cancelled());
    let plain: PreviewParams = serde_json::from_value(serde_json::json!({
        "textDocument": { "uri": "file:///t/tree.grm" }, "live": true,
    }))
    .expect("params");
    let unordered = Ticket::begin_preview(&shared, path, &plain);
    assert!(next.token.is_cancelled() && !unordered.token.is_cancelled());
}

#[test]
fn quads_go_as_three_corners_each() {
    use base64::Engine as _;
    let mut m = grm_geom::MeshData::default();
    let o = glam::Vec3::new(3.0, -1.0, 2.5);
    let (u, v) = (
        glam::Vec3::new(2.0, 0.0, 0.5),
        glam::Vec3::new(0.0, 1.5, 0.0),
    );
    m.quad([o, o + u, o + u + v, o + v], u.cross(v).normalize());
    m.quad(
        [o + v, o + u + v, o + u + 2.0 * v, o + 2.0 * v],
        u.cross(v).normalize(),
    );
    assert!(m.is_quads());
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(quad_corners(&m))
        .unwrap();
    let floats: Vec<f32> = bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    assert_eq!(floats.len(), 18);
    for (q, c) in floats.chunks_exact(9).enumerate() {
        let corner = |k: usize| glam::Vec3::new(c[3 * k], c[3 * k + 1], c[3 * k + 2]);
        // The fourth corner, rebuilt as the client does.
        let d = corner(0) + corner(2) - corner(1);
        assert!((d - glam::Vec3::from_array(m.positions[4 * q + 3])).length() < 1e-5);
        for k in 0..3 {
            assert_eq!(corner(k).to_array(), m.positions[4 * q + k]);
        }
    }
}

#[test]
fn base64_is_little_endian() {
    assert_eq!(f32s(&[1.0]), "AACAPw==");
    assert_eq!(u32s(&[1, 2]), "AQAAAAIAAAA=");
    assert_eq!(i32s(&[-1]), "/////w==");
    // Across blocks: the same text as the bytes encoded at once.
    let xs: Vec<u32> = (0..2_000u32)
        .map(|i| i.wrapping_mul(2_654_435_761))
        .collect();
    for n in [0, 1, 2, 3, 767, 768, 769, 1536, 2000] {
        let bytes: Vec<u8> = xs[..n].iter().flat_map(|x| x.to_le_bytes()).collect();
        assert_eq!(
            u32s(&xs[..n]),
            base64::engine::general_purpose::STANDARD.encode(bytes)
        );
    }
}
