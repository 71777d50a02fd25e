//! Persistent edits replayed on several threads (issue 27; docs/edits.md,
//! "Replay"): each parallel job starts from its root's replay state and
//! reads the tagged commands above its root from its ancestry, so a tree
//! grown with edits on any number of threads is the one-thread tree, byte
//! for byte (nodes, attributes, removed shapes and what each edit named).

mod common;

use common::*;
use grm_edits::{EditsFile, Op, Target};
use grm_grow::shape::{ShapeOptions, derive, derive_with_edits, edit_plan, lower};
use grm_shape::{NodeId, NodeKind, ShapeTree};

/// The edits benchmark's tower (crates/grm-lsp/benches/tower_10k.grm),
/// smaller: 6 floors, facades of 12 columns.
const TOWER: &str = r#"
material concrete { color = rgb(0.62, 0.62, 0.6); }
material glass { color = rgb(0.25, 0.38, 0.48); }
material steel { color = rgb(0.3, 0.32, 0.35); }

system Tower {
    mode = shape;
    seed = 1;
    lot = rect(24, 24);
    axiom Lot;

    Lot -> extrude(21) Mass;
    Mass -> comp(faces, facade) { side: Facade | top: Roof | bottom: nil };
    Facade -> repeat(y, floor) { 3.5: Floor };
    Floor -> repeat(x, column) { 2: Tile };
    Tile -> split(x) { ~0.4: Wall | 1.2: WinStrip | ~0.4: Wall };
    WinStrip -> split(y) { ~1: Wall | 1.6: Window | ~0.9: Wall };
    Window -> split(y) { 0.08: Frame | ~1: Sash | 0.08: Frame };
    Sash -> split(x) { 0.08: Frame | ~1: Glass | 0.08: Frame };
    Frame -> material(steel) Metal;
    Glass -> material(glass) Pane;
    Wall -> material(concrete) Panel;
    Roof -> material(concrete) Deck;
}
"#;

fn shapes(lowered: &grm_grow::shape::Lowered, tree: &ShapeTree, symbol: &str) -> Vec<NodeId> {
    let s = lowered.program.symbol(symbol).expect("a symbol");
    (0..tree.len() as u32)
        .map(NodeId)
        .filter(|&id| {
            matches!(tree.node(id).map(|n| n.kind), Some(NodeKind::Shape { symbol, .. }) if symbol == s)
        })
        .collect()
}

#[test]
fn a_parallel_replay_is_the_one_thread_replay_byte_for_byte() {
    let checked = inline(TOWER);
    let p = &checked.program;
    let lowered = lower(
        p,
        p.default_system().expect("a system"),
        &p.default_params(),
    )
    .expect("lowers");
    let one = |threads: usize, plan: Option<&grm_shape::EditPlan>| {
        let options = ShapeOptions {
            threads,
            ..ShapeOptions::default()
        };
        derive_with_edits(&lowered, lowered.seed, &options, plan).expect("derives")
    };
    let plain = derive(&lowered, lowered.seed, &ShapeOptions::default()).expect("derives");
    let exact = |id: NodeId| Target::Exact(plain.exact_locator(&lowered.program, id));
    let key = |id: NodeId| Target::Key(plain.node(id).expect("a node").key);
    let material = |name: &str| Op::Material { name: name.into() };
    let query = |s: &str| Target::Semantic(s.parse().expect(s));
    let facades = shapes(&lowered, &plain, "Facade");
    let floors = shapes(&lowered, &plain, "Floor");
    let windows = shapes(&lowered, &plain, "Window");
    let tiles = shapes(&lowered, &plain, "Tile");
    let glass = shapes(&lowered, &plain, "Glass");
    assert_eq!(windows.len(), 4 * 6 * 12);
    let edits: Vec<(Target, Op)> = vec![
        // Job roots and the top: a facade removed, one pinned, the mass's
        // material.
        (exact(facades[3]), Op::Remove),
        (exact(facades[2]), Op::Pin { key: 99 }),
        (
            exact(shapes(&lowered, &plain, "Mass")[0]),
            material("glass"),
        ),
        // Floors, windows and leaves by exact locator; a deeper material
        // over a floor's.
        (exact(floors[1]), material("steel")),
        (exact(floors[8]), Op::Pin { key: 7 }),
        (exact(windows[13]), material("concrete")),
        (exact(windows[14]), Op::Remove),
        (exact(windows[15]), Op::Force { alternative: 1 }),
        (exact(windows[90]), Op::Pin { key: 5 }),
        (exact(glass[30]), material("steel")),
        // Keys.
        (key(windows[40]), Op::Remove),
        (key(windows[41]), material("steel")),
        (key(tiles[20]), material("glass")),
        // Semantic queries across the jobs' roots.
        (query("(floor = 2, column = 3) Window"), material("steel")),
        (
            query("(facade = 1, floor = 4, column = end 2) Window"),
            Op::Remove,
        ),
        (query("(facade = 2, floor = 3) Floor"), material("glass")),
        (query("(column = 5) Window"), material("concrete")),
        (query("(floor = end 1) Tile"), material("steel")),
    ];
    let mut file = EditsFile {
        version: 1,
        edits: Vec::new(),
    };
    for (t, o) in edits {
        file.add("Tower", t, o).expect("an id");
    }
    let plan = edit_plan(&lowered, &file);
    let serial = one(1, Some(&plan));
    // The edits did something, and each named what it should.
    assert_ne!(serial, plain);
    assert!(serial.removed().len() >= 4, "{:?}", serial.removed());
    for e in &file.edits {
        let hits = serial.edit_hits(e.id).expect("replayed");
        assert!(!hits.is_empty(), "edit {} named nothing", e.id);
    }
    for threads in [2, 3, 4, 8] {
        let parallel = one(threads, Some(&plan));
        assert_eq!(parallel, serial, "{threads} threads");
        for e in &file.edits {
            assert_eq!(parallel.edit_hits(e.id), serial.edit_hits(e.id));
        }
        assert_eq!(parallel.removed(), serial.removed());
    }
    // No edits on several threads: the plain tree.
    assert_eq!(one(4, Some(&grm_shape::EditPlan::default())), plain);
}
