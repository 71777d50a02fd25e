//! Edit survival (issue 27): 50 random edits on a building, the grammar
//! then changed by scripted mutations, the building regrown with the edits
//! replayed; per mutation class, the fraction of edits still applied to
//! the part they were made on, and how many were applied to a wrong part
//! without a word (target: 100% for parameter changes, at least 90% for
//! insertions and wrappings, zero silently wrong). Shape mode only: derive
//! and sample mode do not replay edits yet.
//!
//! The building: `benches/survival_townhouse.grm` (examples/townhouse.grm:
//! three houses, a ground floor with door and shop, upper floors of
//! windows, one window in five bricked up by its own draw; 639 shapes),
//! then the same with its back facades blank (`back: Side`, 318 shapes):
//! front and back facades are both `facade = 1/1` (a component's tag
//! counts within its case), so in the first building no semantic query
//! names a part of one facade alone, in the second one can.
//!
//! **Ground truth by construction**, independent of every locator: a part
//! is its symbol and its world-space box (the bounding box of its scope's
//! corners). Each mutation says what it does to the building's geometry,
//! by construction of its text: which symbols are renamed, which parts
//! move up by how much (a part whose own or an ancestor's symbol is named,
//! in the unmutated tree), which grow at the top. The part an edit was made
//! on is, after the mutation, the shape of the renamed symbol whose box is
//! the moved box (within 1 mm); none: the mutation took it away (a floor
//! fewer, a window now bricked up). For every mutation but `floors 4 -> 3`
//! the bench checks that every shape outside the windows is found so (the
//! mapping is right); a window's inside is its random draw's, and a
//! mutation that changes the window's identity key (an edge number or a
//! name above it), the seed or the order of its alternatives may brick it
//! up or open it: the bench prints how many windows were drawn otherwise.
//!
//! **What the engine did**, read from the edited tree, not from the
//! classification: each edit gives its target a marker material of its
//! own (`m1` ... `m50`, declared by the bench, used by no rule); replay
//! gives the target's subtree the marker over the rules, so the parts an
//! edit was applied to are the nodes that carry its marker and whose
//! parent does not. The classification (`grm_grow::shape::edits::classify`)
//! says what is reported.
//!
//! Each edit is then:
//!
//! - **right**: applied to the intended part only, and classified valid
//!   with that part;
//! - **reported, gone**: not applied and reported (not valid), its part
//!   gone (dormant, as it should be);
//! - **reported, lost**: not applied and reported, but its part is there
//!   (a miss, not an error);
//! - **wrong, silent**: applied to another part (or to more parts), and
//!   classified valid: the error the issue forbids;
//! - **wrong, reported**: applied elsewhere, but not classified valid;
//! - **inconsistent**: classified valid but not applied, or applied but
//!   classified otherwise (replay and classification disagree).
//!
//! Of the lost, the bench also counts those whose **retarget quick fix**
//! (`grm_grow::shape::retarget::candidates`, what the editor offers on
//! the edit's diagnostic, ranked by the part's print in the unmutated
//! tree, as the editor keeps it) names the intended part alone: the first
//! candidate (`rt1st`), or one of the four (`rtany`).
//!
//! Targets, as the preview makes them from the unedited tree:
//!
//! - `exact`: the part's exact locator (what a pick gives);
//! - `semantic`: its semantic locator as a query (every entry counted from
//!   the start, its symbol), only where it fits: where that query selects
//!   the part alone in the unedited tree (a wall beside a window shares
//!   its tags with the wall on the other side: no query names it alone),
//!   with its `selected` count, 1 (a query that selects more after the
//!   mutation is classified ambiguous);
//! - `key`: its identity key;
//! - `sem|exact`: the semantic query where it fits, the exact locator
//!   otherwise.
//!
//! Draws: `--draws N` sets of 50 parts (default 20; set `d` is seeded
//! `grm_testkit::Rng::new(d)`), parts drawn among the shapes.
//!
//! Run: `cargo bench -p grm-grow --bench edits_survival [-- --draws N]
//! [--verbose]`.

use glam::Vec3;
use grm_edits::{Anchor, EditClass, EditsFile, Op, SemanticQuery, Target};
use grm_grow::shape::{
    Lowered, ShapeOptions, derive, derive_with_edits, edit_plan, edits, lower, retarget,
};
use grm_shape::{NodeId, NodeKind, ShapeTree};
use grm_testkit::Rng;
use std::collections::HashMap;
use std::path::Path;

const EDITS: usize = 50;
const SYSTEM: &str = "Townhouse";
/// How far apart two boxes may be and still be one part (metres).
const TOLERANCE: f32 = 1e-3;

/// A part of the unmutated tree: its identity and its targets.
struct Part {
    id: NodeId,
    symbol: String,
    /// The shapes above it, root first.
    ancestors: Vec<String>,
    min: Vec3,
    max: Vec3,
}

/// A symbol whose parts (and their subtrees) move up by this much.
type Shift = (&'static str, f32);
/// A symbol (with this parent shape, if given) whose parts grow at the top
/// by this much.
type Grow = (&'static str, Option<&'static str>, f32);

/// What a mutation does to the building, by construction.
struct Mutation {
    class: &'static str,
    name: &'static str,
    /// Text replacements (each must match exactly once).
    replace: Vec<(&'static str, &'static str)>,
    /// Symbols renamed (whole identifiers, everywhere).
    rename: Vec<(&'static str, &'static str)>,
    /// Parts of these symbols and their subtrees move up by this much.
    shift: Vec<Shift>,
    /// Parts of these symbols (with this parent shape, if given) grow at
    /// the top by this much.
    grow: Vec<Grow>,
    /// Whether every part of the building outside the windows is still
    /// there after it (a window's inside is its random draw's: a mutation
    /// that changes a window's identity key, or the seed, or the order of
    /// its alternatives, may brick it up or open it).
    keeps_all: bool,
    /// Upper floors of another height: (where they start, their height,
    /// how much taller): a part on floor k (from 0) moves up k times the
    /// difference, and grows by it when it reaches the floor's top.
    storey: Option<(f32, f32, f32)>,
}

fn mutations() -> Vec<Mutation> {
    let m = |class, name| Mutation {
        class,
        name,
        replace: Vec::new(),
        rename: Vec::new(),
        shift: Vec::new(),
        grow: Vec::new(),
        keeps_all: true,
        storey: None,
    };
    // What a taller block does: the roof moves up, the block, its facades
    // and side walls grow.
    let taller = |dz: f32| -> (Vec<Shift>, Vec<Grow>) {
        (
            vec![("Top", dz)],
            vec![
                ("Block", None, dz),
                ("Facade", None, dz),
                ("Side", None, dz),
                ("Wall", Some("Side"), dz),
            ],
        )
    };
    let mut out = Vec::new();

    let mut p = m("parameter values", "floors 4 -> 5");
    p.replace = vec![("param floors = 4 in", "param floors = 5 in")];
    (p.shift, p.grow) = taller(3.2);
    p.grow.push(("Upper", None, 3.2));
    out.push(p);

    let mut p = m("parameter values", "floors 4 -> 3");
    p.replace = vec![("param floors = 4 in", "param floors = 3 in")];
    (p.shift, p.grow) = taller(-3.2);
    p.grow.push(("Upper", None, -3.2));
    p.keeps_all = false;
    out.push(p);

    let mut p = m("parameter values", "seed 1 -> 2");
    p.replace = vec![("seed = 1;", "seed = 2;")];
    out.push(p);

    // Upper floors 3.5 m instead of 3.2: floor k (from 0) moves up by
    // 0.3 k, and what reaches its top grows by 0.3.
    let mut p = m("parameter values", "STOREY 3.2 -> 3.5");
    p.replace = vec![("const STOREY = 3.2;", "const STOREY = 3.5;")];
    (p.shift, p.grow) = taller(0.9);
    p.grow.push(("Upper", None, 0.9));
    p.storey = Some((4.0, 3.2, 0.3));
    out.push(p);

    let mut p = m("new floor type", "attic above the upper floors");
    p.replace = vec![
        (
            "extrude(4 + (floors - 1) * STOREY)",
            "extrude(4 + (floors - 1) * STOREY + 2.5)",
        ),
        (
            "split(y) { 4: Ground | ~1: Upper };",
            "split(y) { 4: Ground | ~1: Upper | 2.5: Attic };\n    Attic -> repeat(x, column) { ~2: Tile };",
        ),
    ];
    (p.shift, p.grow) = taller(2.5);
    out.push(p);

    let mut p = m("new floor type", "mezzanine between ground and upper");
    p.replace = vec![
        (
            "extrude(4 + (floors - 1) * STOREY)",
            "extrude(4 + (floors - 1) * STOREY + 3.6)",
        ),
        (
            "split(y) { 4: Ground | ~1: Upper };",
            "split(y) { 4: Ground | 3.6: Mezzanine | ~1: Upper };\n    Mezzanine -> repeat(x, column) { ~2: Tile };",
        ),
    ];
    (p.shift, p.grow) = taller(3.6);
    p.shift.push(("Upper", 3.6));
    out.push(p);

    let mut p = m(
        "split wrapped",
        "upper floors' repeat in a split with a cornice",
    );
    p.replace = vec![
        (
            "extrude(4 + (floors - 1) * STOREY)",
            "extrude(4 + (floors - 1) * STOREY + 0.6)",
        ),
        (
            "Upper -> repeat(y, floor) { STOREY: Floor };",
            "Upper -> split(y) { ~1: Floors | 0.6: Cornice };\n    Floors -> repeat(y, floor) { STOREY: Floor };\n    Cornice -> material(brick) Wall;",
        ),
    ];
    (p.shift, p.grow) = taller(0.6);
    p.grow.push(("Upper", None, 0.6));
    out.push(p);

    let mut p = m(
        "split wrapped",
        "ground floor's split in a split with a band",
    );
    p.replace = vec![
        (
            "extrude(4 + (floors - 1) * STOREY)",
            "extrude(4.3 + (floors - 1) * STOREY)",
        ),
        ("{ 4: Ground | ~1: Upper }", "{ 4.3: Ground | ~1: Upper }"),
        (
            "Ground -> split(x) { ~1: Wall | 1.2: Door | ~2: Shop };",
            "Ground -> split(y) { ~1: GroundRow | 0.3: Band };\n    GroundRow -> split(x) { ~1: Wall | 1.2: Door | ~2: Shop };\n    Band -> material(wood) Wall;",
        ),
    ];
    (p.shift, p.grow) = taller(0.3);
    p.shift.push(("Upper", 0.3));
    p.grow.push(("Ground", None, 0.3));
    out.push(p);

    let mut p = m("split wrapped", "tile's split in a one-part split");
    p.replace = vec![(
        "Tile -> split(x) { ~1: Wall | 1.2: Window | ~1: Wall };",
        "Tile -> split(y) { ~1: TileRow };\n    TileRow -> split(x) { ~1: Wall | 1.2: Window | ~1: Wall };",
    )];
    out.push(p);

    let mut p = m(
        "alternatives reordered",
        "Window's two alternatives swapped",
    );
    p.replace = vec![(
        "    Window -> (1) material(brick) Wall;\n    Window -> (4) split(y) { 0.9: Wall | 0.1: Sill | 1.5: Frame | ~1: Wall };",
        "    Window -> (4) split(y) { 0.9: Wall | 0.1: Sill | 1.5: Frame | ~1: Wall };\n    Window -> (1) material(brick) Wall;",
    )];
    out.push(p);

    let mut p = m("rule renamed", "Tile -> Bay");
    p.rename = vec![("Tile", "Bay")];
    out.push(p);
    let mut p = m("rule renamed", "Floor -> Storey");
    p.rename = vec![("Floor", "Storey")];
    out.push(p);
    let mut p = m("rule renamed", "Post -> Mullion");
    p.rename = vec![("Post", "Mullion")];
    out.push(p);
    out
}

/// `text` with the identifier `from` renamed `to` (whole words only).
fn rename(text: &str, from: &str, to: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        out.push_str(if word == from { to } else { word });
        word.clear();
    };
    for c in text.chars() {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

impl Mutation {
    fn apply(&self, text: &str) -> String {
        let mut t = text.to_owned();
        for (from, to) in &self.replace {
            assert_eq!(t.matches(from).count(), 1, "{}: `{from}`", self.name);
            t = t.replace(from, to);
        }
        for (from, to) in &self.rename {
            t = rename(&t, from, to);
        }
        t
    }

    /// The symbol and box a part has after the mutation.
    fn expected(&self, p: &Part) -> (String, Vec3, Vec3) {
        let symbol = self
            .rename
            .iter()
            .find(|(f, _)| *f == p.symbol)
            .map_or(p.symbol.clone(), |(_, t)| (*t).to_owned());
        let (mut min, mut max) = (p.min, p.max);
        let in_subtree = |s: &str| p.symbol == s || p.ancestors.iter().any(|a| a == s);
        for &(s, dz) in &self.shift {
            if in_subtree(s) {
                min.z += dz;
                max.z += dz;
            }
        }
        for &(s, parent, dz) in &self.grow {
            if p.symbol == s && parent.is_none_or(|q| p.ancestors.last().is_some_and(|a| a == q)) {
                max.z += dz;
            }
        }
        if let Some((start, height, more)) = self.storey
            && (p.symbol == "Floor" || p.ancestors.iter().any(|a| a == "Floor"))
        {
            let k = ((p.min.z - start) / height + 1e-3).floor();
            let top = start + (k + 1.0) * height;
            min.z += k * more;
            max.z += k * more;
            if (p.max.z - top).abs() < TOLERANCE {
                max.z += more;
            }
        }
        (symbol, min, max)
    }
}

/// A grown building: its program and tree.
struct Grown {
    checked: grm_sema::Checked,
    lowered: Lowered,
    tree: ShapeTree,
}

fn check(text: &str) -> (grm_sema::Checked, Lowered) {
    let (_, checked) = grm_sema::check_text("survival_townhouse.grm", text);
    assert!(
        !checked.has_errors(),
        "{:?}\n{text}",
        checked
            .diagnostics
            .iter()
            .map(|d| d.message.clone())
            .collect::<Vec<_>>()
    );
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    let lowered = lower(p, sys, &p.default_params()).expect("lowers");
    (checked, lowered)
}

fn grow(text: &str, file: Option<&EditsFile>) -> Grown {
    let (checked, lowered) = check(text);
    let tree = match file {
        Some(f) => {
            let plan = edit_plan(&lowered, f);
            derive_with_edits(
                &lowered,
                lowered.seed,
                &ShapeOptions::default(),
                Some(&plan),
            )
        }
        None => derive(&lowered, lowered.seed, &ShapeOptions::default()),
    }
    .expect("derives");
    Grown {
        checked,
        lowered,
        tree,
    }
}

impl Grown {
    fn symbol(&self, id: NodeId) -> Option<&str> {
        match self.tree.node(id)?.kind {
            NodeKind::Shape { symbol, .. } => Some(self.lowered.program.symbol_name(symbol)),
            _ => None,
        }
    }

    fn bounds(&self, id: NodeId) -> (Vec3, Vec3) {
        let c = self.tree.node(id).expect("a node").scope.corners();
        let min = c.iter().fold(Vec3::splat(f32::MAX), |a, &b| a.min(b));
        let max = c.iter().fold(Vec3::splat(f32::MIN), |a, &b| a.max(b));
        (min, max)
    }

    fn parts(&self) -> Vec<Part> {
        (0..self.tree.len() as u32)
            .map(NodeId)
            .filter_map(|id| {
                let symbol = self.symbol(id)?.to_owned();
                let path = self.tree.path(id);
                let ancestors = path[..path.len() - 1]
                    .iter()
                    .filter_map(|&a| self.symbol(a).map(str::to_owned))
                    .collect();
                let (min, max) = self.bounds(id);
                Some(Part {
                    id,
                    symbol,
                    ancestors,
                    min,
                    max,
                })
            })
            .collect()
    }

    /// The shapes of `symbol` whose box is (min, max).
    fn find(
        &self,
        by_symbol: &HashMap<String, Vec<NodeId>>,
        want: &(String, Vec3, Vec3),
    ) -> Vec<NodeId> {
        let (symbol, min, max) = want;
        by_symbol
            .get(symbol)
            .into_iter()
            .flatten()
            .copied()
            .filter(|&id| {
                let (a, b) = self.bounds(id);
                a.abs_diff_eq(*min, TOLERANCE) && b.abs_diff_eq(*max, TOLERANCE)
            })
            .collect()
    }

    fn by_symbol(&self) -> HashMap<String, Vec<NodeId>> {
        let mut m: HashMap<String, Vec<NodeId>> = HashMap::new();
        for i in 0..self.tree.len() as u32 {
            if let Some(s) = self.symbol(NodeId(i)) {
                m.entry(s.to_owned()).or_default().push(NodeId(i));
            }
        }
        m
    }

    /// Per marker material `m1`.. (index 0..), the nodes that carry it and
    /// whose parent does not.
    fn marked(&self) -> HashMap<usize, Vec<NodeId>> {
        let names = self.lowered.program.materials();
        let marker = |id: NodeId| -> Option<usize> {
            let m = self.tree.attributes(id).material?;
            let name = names.get(m.0 as usize)?;
            name.strip_prefix('m')?.parse::<usize>().ok().map(|k| k - 1)
        };
        let mut out: HashMap<usize, Vec<NodeId>> = HashMap::new();
        for i in 0..self.tree.len() as u32 {
            let id = NodeId(i);
            let Some(k) = marker(id) else { continue };
            if self.tree.parent(id).and_then(marker) != Some(k) {
                out.entry(k).or_default().push(id);
            }
        }
        out
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Outcome {
    Right,
    Gone,
    Lost,
    WrongSilent,
    WrongReported,
    Inconsistent,
}

const OUTCOMES: [Outcome; 6] = [
    Outcome::Right,
    Outcome::Gone,
    Outcome::Lost,
    Outcome::WrongSilent,
    Outcome::WrongReported,
    Outcome::Inconsistent,
];

#[derive(Clone, Default)]
struct Tally {
    n: [usize; 6],
    /// Of the lost, per class reported.
    lost_by: HashMap<&'static str, usize>,
    /// Of the lost: those whose first retarget candidate names the
    /// intended part alone, and those where one of the candidates does.
    lost_first: usize,
    lost_any: usize,
}

impl Tally {
    fn add(&mut self, o: Outcome) {
        self.n[OUTCOMES.iter().position(|&x| x == o).expect("an outcome")] += 1;
    }
    fn merge(&mut self, o: &Tally) {
        for i in 0..6 {
            self.n[i] += o.n[i];
        }
        for (k, v) in &o.lost_by {
            *self.lost_by.entry(k).or_default() += v;
        }
        self.lost_first += o.lost_first;
        self.lost_any += o.lost_any;
    }
    fn total(&self) -> usize {
        self.n.iter().sum()
    }
    /// Right over the edits whose part is still there.
    fn survival(&self) -> f64 {
        let there = self.total() - self.n[1];
        if there == 0 {
            f64::NAN
        } else {
            self.n[0] as f64 / there as f64
        }
    }
    fn row(&self) -> String {
        format!(
            "{:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}   {:>6.1}%   {:>6} {:>6}",
            self.total(),
            self.n[0],
            self.n[1],
            self.n[2],
            self.n[3],
            self.n[4],
            self.n[5],
            100.0 * self.survival(),
            self.lost_first,
            self.lost_any
        )
    }
}

const KINDS: [&str; 4] = ["exact", "semantic", "key", "sem|exact"];

/// Targets of each kind for `parts` of the unmutated building (`None`:
/// the kind does not fit the part).
fn targets(base: &Grown, parts: &[&Part]) -> Vec<[Option<Target>; 4]> {
    let program = &base.lowered.program;
    parts
        .iter()
        .map(|p| {
            let exact = Target::Exact(base.tree.exact_locator(program, p.id));
            let loc = base.tree.semantic_locator(program, p.id);
            let query = SemanticQuery {
                entries: loc
                    .entries
                    .iter()
                    .map(|e| (e.tag.clone(), Anchor::Start, e.index as i64))
                    .collect(),
                label: Some(loc.label.clone()),
            };
            let semantic =
                (base.tree.select(program, &query) == [p.id]).then_some(Target::Semantic(query));
            let key = Target::Key(base.tree.node(p.id).expect("a node").key);
            let best = semantic.clone().unwrap_or_else(|| exact.clone());
            [Some(exact), semantic, Some(key), Some(best)]
        })
        .collect()
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let draws: u64 = args
        .iter()
        .position(|a| a == "--draws")
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(20);
    let verbose = args.iter().any(|a| a == "--verbose");
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/survival_townhouse.grm");
    let source = std::fs::read_to_string(&path).expect("survival_townhouse.grm");
    let mut text = source.clone();
    for k in 1..=EDITS {
        text.push_str(&format!(
            "\nmaterial m{k} {{\n    color = rgb(1, 0, 1);\n}}\n"
        ));
    }
    survival("survival_townhouse.grm", &text, draws, verbose);
    // The same building with one facade per house (its back a blank
    // wall): the front and back facades are both `facade = 1/1` (a
    // component's tag counts within its case), so no semantic query names
    // a part of one of them alone; here one can.
    let one_facade = text.replace("back: Facade", "back: Side");
    assert_ne!(one_facade, text);
    println!();
    survival(
        "survival_townhouse.grm, back facades blank (back: Side)",
        &one_facade,
        draws,
        verbose,
    );
}

/// The survival tables of the building `text`.
fn survival(title: &str, text: &str, draws: u64, verbose: bool) {
    let base = grow(text, None);
    let all = base.parts();
    let base_by = base.by_symbol();
    // Parts whose identity (symbol and box) is theirs alone.
    let unique: Vec<&Part> = all
        .iter()
        .filter(|p| base.find(&base_by, &(p.symbol.clone(), p.min, p.max)).len() == 1)
        .collect();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "edit survival: {title}: {} shapes ({} with an identity of their own: symbol and box), {draws} draws of {EDITS} parts; load average {}",
        all.len(),
        unique.len(),
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
    let mutations = mutations();
    // The mutations' ground truth checked: every part found after those
    // that keep them all; the parts gone after the others counted.
    let mut grown = Vec::new();
    for m in &mutations {
        let g = grow(&m.apply(text), None);
        let by = g.by_symbol();
        let gone = unique
            .iter()
            .filter(|p| g.find(&by, &m.expected(p)).len() != 1)
            .count();
        let outside = |p: &&&Part| !p.ancestors.iter().any(|a| a == "Window");
        let missed: Vec<String> = unique
            .iter()
            .filter(outside)
            .filter(|p| g.find(&by, &m.expected(p)).len() != 1)
            .map(|p| format!("{} {} {} -> {:?}", p.symbol, p.min, p.max, m.expected(p)))
            .collect();
        if m.keeps_all && !missed.is_empty() {
            panic!(
                "{}: the mapping misses {} parts: {}",
                m.name,
                missed.len(),
                missed[..missed.len().min(8)].join("; ")
            );
        }
        // Windows whose draw changed: bricked up (a Wall) or open (a split).
        let bricked = |g: &Grown, id: NodeId| {
            g.tree
                .children(id)
                .next()
                .and_then(|c| g.symbol(c))
                .is_some()
        };
        let windows: Vec<&&Part> = unique.iter().filter(|p| p.symbol == "Window").collect();
        let flipped = windows
            .iter()
            .filter(|p| match g.find(&by, &m.expected(p))[..] {
                [w] => bricked(&g, w) != bricked(&base, p.id),
                _ => false,
            })
            .count();
        println!(
            "  {:<24} {:<48} {:>4} shapes after; {gone:>3} of the {} parts gone; {flipped:>2} of {} windows drawn otherwise",
            m.class,
            m.name,
            g.parts().len(),
            unique.len(),
            windows.len()
        );
        grown.push((g, by));
    }

    // Per mutation, per kind of target: the tally.
    let mut tallies: Vec<[Tally; 4]> = vec![Default::default(); mutations.len()];
    let mut fits = 0usize;
    for d in 1..=draws {
        let mut rng = Rng::new(d);
        let mut pool = unique.clone();
        rng.shuffle(&mut pool);
        let parts: Vec<&Part> = pool.into_iter().take(EDITS).collect();
        let targets = targets(&base, &parts);
        // What the editor keeps of each part while its edit is valid.
        let prints: Vec<retarget::PartPrint> = {
            let mut o = retarget::Orderings::new(&base.lowered, &base.tree);
            parts.iter().map(|p| o.print(p.id)).collect()
        };
        fits += targets.iter().filter(|t| t[1].is_some()).count();
        for (mi, m) in mutations.iter().enumerate() {
            let mutated = m.apply(text);
            let (after, by) = &grown[mi];
            // The intended part after the mutation, by identity.
            let truth: Vec<Option<NodeId>> = parts
                .iter()
                .map(|p| match after.find(by, &m.expected(p))[..] {
                    [one] => Some(one),
                    _ => None,
                })
                .collect();
            for (k, kind) in KINDS.iter().enumerate() {
                let mut file = EditsFile {
                    version: 3,
                    edits: Vec::new(),
                };
                // Edit id i + 1 gives part i marker m{i + 1}.
                let mut ids = Vec::new();
                for (i, t) in targets.iter().enumerate() {
                    let Some(target) = t[k].clone() else { continue };
                    file.edits.push(grm_edits::Edit {
                        id: i as u32 + 1,
                        system: SYSTEM.into(),
                        parcel: None,
                        // A query made where it selects the part alone.
                        selected: matches!(target, Target::Semantic(_)).then_some(1),
                        // A key picked records its part's symbol.
                        symbol: matches!(target, Target::Key(_))
                            .then(|| base.tree.label(&base.lowered.program, parts[i].id)),
                        target,
                        op: Op::Material {
                            name: format!("m{}", i + 1),
                        },
                        note: None,
                        span: Default::default(),
                    });
                    ids.push(i);
                }
                let edited = grow(&mutated, Some(&file));
                let marked = edited.marked();
                let reports = edits::classify(
                    &edited.checked.program,
                    &edited.lowered,
                    &edited.tree,
                    &file.edits,
                );
                for (e, &i) in ids.iter().enumerate() {
                    let r = &reports[e];
                    let applied = marked.get(&i).cloned().unwrap_or_default();
                    let valid = r.class == EditClass::Valid;
                    let outcome = if applied.is_empty() && !valid {
                        if let Some(t) = truth[i] {
                            *tallies[mi][k].lost_by.entry(r.class.as_str()).or_default() += 1;
                            // The retarget quick fixes the editor offers.
                            if retarget::wants_candidates(r.class) {
                                let c = retarget::candidates(
                                    &edited.lowered,
                                    &edited.tree,
                                    &file.edits[e],
                                    &prints[i],
                                    &r.parts,
                                    4,
                                );
                                if c.first().is_some_and(|c| c.parts == [t]) {
                                    tallies[mi][k].lost_first += 1;
                                }
                                if c.iter().any(|c| c.parts == [t]) {
                                    tallies[mi][k].lost_any += 1;
                                }
                            }
                            Outcome::Lost
                        } else {
                            Outcome::Gone
                        }
                    } else if applied.is_empty()
                        || (!valid && truth[i].is_some() && applied == [truth[i].unwrap()])
                    {
                        Outcome::Inconsistent
                    } else {
                        let only_truth = |v: &[NodeId]| truth[i].is_some_and(|t| v == [t]);
                        match (only_truth(&applied), valid, only_truth(&r.parts)) {
                            (true, true, true) => Outcome::Right,
                            (true, true, false) => Outcome::Inconsistent,
                            (false, true, _) => Outcome::WrongSilent,
                            (_, false, _) => Outcome::WrongReported,
                        }
                    };
                    if verbose && !matches!(outcome, Outcome::Right | Outcome::Gone) {
                        println!(
                            "    draw {d} {} {kind} part {} ({}): {outcome:?}, {} {}",
                            m.name,
                            parts[i].id.0,
                            parts[i].symbol,
                            r.class.as_str(),
                            r.detail
                        );
                    }
                    tallies[mi][k].add(outcome);
                }
            }
        }
    }
    println!(
        "  semantic queries fit (select the part alone) for {fits} of the {} parts drawn ({:.0}%)",
        draws as usize * EDITS,
        100.0 * fits as f64 / (draws as usize * EDITS) as f64
    );
    let header = format!(
        "    {:<10} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}   {:>7}   {:>6} {:>6}",
        "target",
        "edits",
        "right",
        "gone",
        "lost",
        "wrong!",
        "wrongR",
        "incons",
        "survive",
        "rt1st",
        "rtany"
    );
    println!(
        "\nper mutation (right: applied to the intended part; gone: reported, the part is gone; lost: reported, the part is there; wrong!: applied to another part, classified valid; wrongR: applied elsewhere, reported; incons: replay and classification disagree; survive: right / edits whose part is there; rt1st, rtany: of the lost, those whose first retarget quick fix, or one of the four, names the intended part alone, ranked by the part's print in the unmutated tree)"
    );
    let classes: Vec<&str> = {
        let mut c: Vec<&str> = mutations.iter().map(|m| m.class).collect();
        c.dedup();
        c
    };
    for (mi, m) in mutations.iter().enumerate() {
        println!("  {} / {}", m.class, m.name);
        println!("{header}");
        for (k, kind) in KINDS.iter().enumerate() {
            println!("    {kind:<10} {}", tallies[mi][k].row());
        }
        let lost: Vec<String> = KINDS
            .iter()
            .enumerate()
            .filter(|(k, _)| !tallies[mi][*k].lost_by.is_empty())
            .map(|(k, kind)| {
                let mut v: Vec<_> = tallies[mi][k].lost_by.iter().collect();
                v.sort();
                format!(
                    "{kind}: {}",
                    v.iter()
                        .map(|(c, n)| format!("{n} {c}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
            .collect();
        if !lost.is_empty() {
            println!("    lost, as reported: {}", lost.join("; "));
        }
    }
    println!("\nper class (all its mutations)");
    for class in classes {
        println!("  {class}");
        println!("{header}");
        for (k, kind) in KINDS.iter().enumerate() {
            let mut t = Tally::default();
            for (mi, m) in mutations.iter().enumerate() {
                if m.class == class {
                    t.merge(&tallies[mi][k]);
                }
            }
            println!("    {kind:<10} {}", t.row());
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "load average at the end {}",
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" ")
    );
}
