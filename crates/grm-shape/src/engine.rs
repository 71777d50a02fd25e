//! The derivation: from a lot and a program to the whole tree.
//!
//! Shapes are expanded depth-first with an explicit stack (no recursion,
//! so a deep grammar costs heap, not call stack). Expanding a shape runs
//! its rule once: it picks an alternative (the race of `grm_compile::rng`
//! keyed by the shape's identity), runs its operations in order and
//! appends what they make, the shape's **block**, to the node array in one
//! go: each node is written once, where it stays (a shape whose rule made
//! nothing then takes the scope and geometry its rule left, its final
//! state: docs/shapes.md, "The tree"). A command's children
//! follow it in the block; parents are backward offsets and blocks forward
//! offsets, so the blocks of a subtree form a self-contained slice. With
//! several threads the top of the tree is derived first, down to a depth
//! where there are enough shapes to share out; each worker derives whole
//! subtrees, and the slices are spliced in where the one-thread derivation
//! would have written them. The result is the same bytes for any thread
//! count.
//!
//! Errors (docs/shapes.md, "Limits and errors"): a rule that fails stops
//! at the failing operation (what it made before stays) and the
//! derivation goes on elsewhere, so every part of the tree is derived the
//! same way whatever the scheduling; at the end the error reported is
//! [`ShapeError::TooManyShapes`] if the tree passed the node limit, else
//! the failure of the first failing shape in the tree's order.
//!
//! Here the derivation loop; in submodules the rule run (`expand`), the
//! parallel derivation (`parallel`) and the loop's replay hook (`hook`).

use crate::attributes::{AttrId, AttrTable, Attributes, MAX_ATTRIBUTES};
use crate::component::{NotApplicable, components};
use crate::error::{ShapeError, SizeError};
use crate::expr::{SITE_CONDITION, SITE_OPS, SITE_WEIGHT, Shape, Site};
use crate::geometry::{Geom, Geometry, Outline, OutlineId};
use crate::ir::{Axis, CompTarget, Op, Param, Program, SymbolId, TagId};
use crate::query::Queries;
use crate::replay::{self, EditPlan, Forced, Own};
use crate::scope::Scope;
use crate::split::{RepeatLayout, SplitSize, repeat_into, split_into};
use crate::tree::{Command, Node, NodeKind, ShapeTree};
use glam::Vec3;
use grm_compile::rng::{
    child_key, child_key_premixed, choice_draw, hash, premix, race_earlier, race_time, root_key,
    salt,
};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

mod expand;
mod hook;
mod parallel;

use hook::{Carried, FLAGGED, Hook, LEAVE, QBEGIN, QEND, Replay};

/// Bounds on a derivation's work and memory.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// The most nodes (shapes, commands and inserts) the tree may hold.
    pub max_nodes: usize,
    /// The deepest a node may be (the axiom is at depth 0).
    pub max_depth: u32,
}

impl Default for Limits {
    /// One million nodes (about 150 MB of tree) and depth 1,000.
    fn default() -> Self {
        Limits {
            max_nodes: 1_000_000,
            max_depth: 1_000,
        }
    }
}

/// How to derive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// The seed of every random draw.
    pub seed: u32,
    /// Worker threads: 1 derives on the calling thread; 0 uses the
    /// machine's parallelism.
    pub threads: usize,
    pub limits: Limits,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            seed: 0,
            threads: 1,
            limits: Limits::default(),
        }
    }
}

/// The initial shape: its scope and geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Lot {
    pub scope: Scope,
    pub geometry: Geom,
}

impl Lot {
    /// A footprint polygon in the world's xy plane (z = 0), as a face:
    /// its scope is the polygon's bounding box, world-aligned.
    pub fn footprint(points: &[[f64; 2]]) -> Result<Lot, ShapeError> {
        let outline = Outline::from_ring(points).map_err(|why| ShapeError::BadLot { why })?;
        let (lo, hi) = outline.bounds().ok_or_else(|| ShapeError::BadLot {
            why: "empty polygon".into(),
        })?;
        let local = outline.translated(-lo[0], -lo[1]);
        let size = Vec3::new((hi[0] - lo[0]) as f32, (hi[1] - lo[1]) as f32, 0.0);
        Ok(Lot {
            scope: Scope::new(Vec3::new(lo[0] as f32, lo[1] as f32, 0.0), size),
            geometry: Geom::from_outline(local, size.x, size.y, false),
        })
    }

    /// A `width` by `depth` rectangular footprint at the origin.
    pub fn rectangle(width: f32, depth: f32) -> Lot {
        Lot {
            scope: Scope::new(Vec3::ZERO, Vec3::new(width, depth, 0.0)),
            geometry: Geom::Rect,
        }
    }

    /// A rectangular face filling `scope`'s xy (a facade, say).
    pub fn face(scope: Scope) -> Lot {
        Lot {
            scope,
            geometry: Geom::Rect,
        }
    }

    fn check(&self) -> Result<(), ShapeError> {
        let s = &self.scope;
        let finite = s.origin.is_finite()
            && s.rotation().is_finite()
            && s.rotation().is_normalized()
            && s.size.is_finite();
        if !finite || s.size.min_element() < 0.0 {
            return Err(ShapeError::BadLot {
                why: "the lot's scope is not finite and non-negative".into(),
            });
        }
        Ok(())
    }
}

/// Derive the tree of `program` from `lot`.
pub fn derive(program: &Program, lot: &Lot, options: &Options) -> Result<ShapeTree, ShapeError> {
    derive_with_edits(program, lot, options, None)
}

/// [`derive`], replaying a system's persistent edits while deriving
/// (`crate::replay`, docs/edits.md), on `options.threads` like `derive`:
/// each parallel job starts from its root's replay state (trie state and
/// forcing) and reads the tagged commands above its root from its
/// ancestry, so the tree is the one-thread tree, byte for byte.
pub fn derive_with_edits(
    program: &Program,
    lot: &Lot,
    options: &Options,
    edits: Option<&EditPlan>,
) -> Result<ShapeTree, ShapeError> {
    let tree = derive_once(program, lot, options, edits)?;
    // Exact targets a wrapping put out of the replay's reach (crate::rewrap).
    match edits.and_then(|p| p.rewrapped(program, &tree)) {
        Some(plan) => derive_once(program, lot, options, Some(&plan)),
        None => Ok(tree),
    }
}

/// One derivation of [`derive_with_edits`].
fn derive_once(
    program: &Program,
    lot: &Lot,
    options: &Options,
    edits: Option<&EditPlan>,
) -> Result<ShapeTree, ShapeError> {
    lot.check()?;
    let edits = edits.filter(|p| !p.is_empty());
    let threads = match options.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    let salts = op_salts(program);
    let simple = simple_rules(program, &salts);
    let engine = |queries| Engine {
        program,
        salts: &salts,
        simple: &simple,
        seed: options.seed,
        limits: options.limits,
        attrs: Mutex::new(AttrTable::default()),
        queries,
        edits,
    };
    let root = engine(None).axiom(lot);
    let outline = lot.geometry.table_entry().cloned();
    let max = options.limits.max_nodes;
    let pass = |engine: &Engine| {
        if threads <= 1 {
            engine
                .run(
                    root,
                    outline.clone(),
                    None,
                    max,
                    &AtomicBool::new(false),
                    &Ancestry::default(),
                    None,
                )
                .map_err(|Overflow| ShapeError::TooManyShapes { max })
        } else {
            engine.parallel(root, outline.clone(), threads)
        }
    };
    // Context queries (docs/shapes.md): a first pass answers them all
    // false; the second answers them against the first's shapes. The first
    // pass's failures are not reported (the second pass's are).
    let queries = if program.exprs.uses.queried.is_empty() {
        None
    } else {
        let first = pass(&engine(None))?;
        Some(Queries::build(program, &first.nodes))
    };
    let engine = engine(queries.as_ref());
    let (mut nodes, outlines, removed, hits) = finish(pass(&engine)?)?;
    let attrs = engine.attrs.into_inner().unwrap_or_else(|e| e.into_inner());
    if attrs.full {
        return Err(ShapeError::TooManyAttributes {
            max: MAX_ATTRIBUTES,
        });
    }
    let attributes = attrs.canonical(nodes.iter_mut().map(|n| &mut n.attrs));
    Ok(ShapeTree {
        nodes,
        outlines,
        attributes,
        seed: options.seed,
        removed,
        edit_hits: edits.map(|_| hits),
    })
}

/// A derived slice of the tree: its root (index 0) and the blocks of its
/// subtree in expansion order, the failures by node index, and (top phase
/// only) the shapes left for other jobs, `(index in nodes, position of the
/// slice in nodes)`.
struct Job {
    nodes: Vec<Node>,
    /// The shapes an edit removed (ascending).
    removed: Vec<u32>,
    /// (edit id, shape) for every shape an edit's target named.
    hits: Vec<(u32, u32)>,
    /// With a plan of edits, the replay state of each shape in `cut`.
    cut_carried: Vec<Carried>,
    /// One outline per node with one, in node order.
    outlines: Vec<Arc<Outline>>,
    failures: Vec<(u32, ShapeError)>,
    cut: Vec<(u32, u32)>,
    /// The root's kind and block length, kept when its slice is spliced.
    roots_kind: (NodeKind, u32),
    /// The root's attributes, kept likewise (a rule that makes nothing
    /// sets its shape's).
    root_attrs: AttrId,
    /// The root's key, kept likewise (an edit may pin it).
    root_key: u32,
    /// Whether `outlines` is one entry per node with one, in node order
    /// (false when a shape whose rule made nothing took an outline where
    /// it had none, or gave one up: [`finish`] orders it again).
    ordered: bool,
}

/// What expressions read of a job root's ancestors (the root's own
/// path within its job stops at the root): the tagged commands above it,
/// `(tag, index, count)`, and the ancestors' keys, innermost first.
#[derive(Clone, Debug, Default)]
struct Ancestry {
    tags: Vec<(TagId, u32, u32)>,
    keys: Vec<u32>,
}

/// Walk up from node `at` of `nodes` to node 0, adding the tagged
/// commands crossed (with the index and count of the child below) and the
/// keys of the ancestors.
fn ancestry(nodes: &[Node], at: usize, tags: &mut Vec<(TagId, u32, u32)>, keys: &mut Vec<u32>) {
    walk_up(nodes, at, |p, child| {
        if let NodeKind::Command { tag: Some(t), .. } = nodes[p].kind {
            tags.push((t, nodes[child].index, nodes[child].count));
        }
        keys.push(nodes[p].key);
    });
}

/// Visit each (parent, child) pair on the path from node `at` of `nodes`
/// up to node 0 (or to the first node whose parent is not in `nodes`),
/// innermost first.
#[inline]
pub(crate) fn walk_up(nodes: &[Node], at: usize, mut f: impl FnMut(usize, usize)) {
    let mut cur = at;
    while cur > 0 {
        let up = nodes[cur].parent_offset as usize;
        if up == 0 || up > cur {
            break;
        }
        let p = cur - up;
        f(p, cur);
        cur = p;
    }
}

/// The premixed salt (`premix(salt(label hash, ordinal, alternative))`)
/// of the child node each operation of each rule alternative makes, by
/// symbol, alternative and operation (0 for an operation that makes
/// none). A child's ordinal among its rule run's children with its label
/// depends on the operations before it alone, so it is counted here once
/// per program instead of once per node (docs/shapes.md, "Identity").
fn op_salts(program: &Program) -> Vec<Vec<Box<[u32]>>> {
    program
        .symbols
        .iter()
        .map(|info| {
            let Some(rule) = &info.rule else {
                return Vec::new();
            };
            (0u32..)
                .zip(&rule.alternatives)
                .map(|(alt, a)| {
                    let mut seen: Vec<(u32, u32)> = Vec::new();
                    a.ops
                        .iter()
                        .map(|op| {
                            let label = match op {
                                Op::Insert(asset) => program.assets[asset.0 as usize].1,
                                Op::Emit(sym) => program.symbols[sym.0 as usize].name_hash,
                                Op::Split(_) => program.commands.split,
                                Op::Repeat(_) => program.commands.repeat,
                                Op::Comp(_) => program.commands.comp,
                                _ => return 0,
                            };
                            let ordinal = match seen.iter_mut().find(|e| e.0 == label) {
                                Some(e) => {
                                    e.1 += 1;
                                    e.1
                                }
                                None => {
                                    seen.push((label, 0));
                                    0
                                }
                            };
                            premix(salt(label, ordinal, alt))
                        })
                        .collect()
                })
                .collect()
        })
        .collect()
}

/// The children of a [`simple_rules`] rule: each one's kind and premixed salt.
type SimpleRule = Box<[(NodeKind, u32)]>;

/// By symbol, for a rule that is one plain alternative (no condition, a
/// constant weight) of inserts and successors only: the kind and premixed
/// salt of each child it makes, in order. Such a rule (a window's, a
/// wall's: most shapes of a building) reads nothing of its shape but its
/// key, scope and geometry, and [`Engine::run`] writes its block without
/// [`Engine::expand`]'s set-up.
fn simple_rules(program: &Program, salts: &[Vec<Box<[u32]>>]) -> Vec<Option<SimpleRule>> {
    program
        .symbols
        .iter()
        .zip(salts)
        .map(|(info, salts)| {
            let [alt] = info.rule.as_ref()?.alternatives.as_slice() else {
                return None;
            };
            if !alt.is_plain() || alt.ops.is_empty() {
                return None;
            }
            alt.ops
                .iter()
                .zip(salts.first()?.iter())
                .map(|(op, &salt)| match *op {
                    Op::Insert(asset) => Some((NodeKind::Insert { asset }, salt)),
                    Op::Emit(symbol) => Some((
                        NodeKind::Shape {
                            symbol,
                            alternative: None,
                        },
                        salt,
                    )),
                    _ => None,
                })
                .collect()
        })
        .collect()
}

/// The marker of "over the node limit" inside a job.
struct Overflow;

struct Engine<'p> {
    program: &'p Program,
    /// [`op_salts`] of the program.
    salts: &'p [Vec<Box<[u32]>>],
    /// [`simple_rules`] of the program.
    simple: &'p [Option<SimpleRule>],
    /// The first pass's shapes, in the second pass of a program with
    /// context queries (`None`: every query is false).
    queries: Option<&'p Queries>,
    /// The persistent edits replayed (`None`: none; then one job only).
    edits: Option<&'p EditPlan>,
    seed: u32,
    limits: Limits,
    /// The distinct attribute sets, shared by the workers (numbered again
    /// in node order at the end, so the ids do not depend on scheduling).
    attrs: Mutex<AttrTable>,
}

/// How many attribute operations [`Scratch::attr_memo`] keeps.
const ATTR_MEMO: usize = 8;

/// How many layouts [`Scratch::memo`] keeps.
const MEMO: usize = 8;

/// One remembered layout.
#[derive(Default)]
struct Memo {
    op: usize,
    extent: u32,
    sizes: Vec<SplitSize>,
    layout: RepeatLayout,
    /// The shapes the layout makes (its spans with a target).
    kids: Vec<Kid>,
}

/// A shape a split or repeat makes, as far as the layout decides it.
#[derive(Clone, Copy)]
struct Kid {
    /// Its interval along the axis.
    start: f32,
    len: f32,
    target: SymbolId,
    /// Its edge number, semantic index and count.
    number: u32,
    index: u32,
    count: u32,
    /// `premix(salt(target's name hash, number, 0))`.
    salt: u32,
}

/// A rule run's scratch space, reused from shape to shape.
#[derive(Default)]
struct Scratch {
    sizes: Vec<SplitSize>,
    stack: Vec<(Scope, Geom)>,
    /// Recent split and repeat layouts by (op, extent, sizes): a facade's
    /// thousand equal tiles are divided once.
    memo: Vec<Memo>,
    memo_next: usize,
    /// The attributes saved by `push`.
    attr_stack: Vec<AttrId>,
    /// The rule run's attributes so far (those its shape inherited until
    /// it sets one).
    attrs: AttrId,
    /// The outgoing edges the rule run has numbered so far.
    edge: u32,
    counts: Vec<u32>,
    /// The expression machine's stack.
    eval: Vec<f32>,
    /// The shape's tagged commands and path keys (for programs whose
    /// expressions read them), innermost first.
    tags: Vec<(TagId, u32, u32)>,
    path: Vec<u32>,
    /// The job root's ancestors.
    prefix: Ancestry,
    /// Set when a shape whose rule made nothing changed whether it has an
    /// outline ([`Job::ordered`]).
    unordered: bool,
    /// The alternative a persistent edit forces on the shape being
    /// expanded (from 0).
    force: Option<u32>,
    /// Whether a persistent edit forces the material of the shape being
    /// expanded (its attributes carry it): its rule's `material` is
    /// skipped, so the block inherits the forced one (crate::replay).
    keep_material: bool,
    /// Recent attribute operations: (the attributes before, the operation
    /// (kind, value bits), the attributes after), at most [`ATTR_MEMO`]
    /// (the attribute table only grows, so an entry stays true).
    attr_memo: Vec<(AttrId, (u8, [u32; 3]), AttrId)>,
    attr_memo_next: usize,
}

/// A node as the rule run makes it: `attrs`, the attributes set before it
/// was made (a block's nodes take them as they are made, so no pass over
/// the block gives them out afterwards).
#[allow(clippy::too_many_arguments)]
#[inline]
fn node(
    kind: NodeKind,
    scope: Scope,
    geometry: Geometry,
    key: u32,
    edge: u32,
    depth: u32,
    parent_offset: u32,
    attrs: AttrId,
) -> Node {
    Node {
        kind,
        scope,
        geometry,
        key,
        edge,
        case: 0,
        selector: None,
        attrs,
        index: edge,
        count: 0,
        depth,
        parent_offset,
        children_offset: 0,
        children_len: 0,
    }
}

impl Engine<'_> {
    fn axiom(&self, lot: &Lot) -> Node {
        let axiom = self.program.axiom;
        let info = &self.program.symbols[axiom.0 as usize];
        let root = root_key(self.seed, self.program.name_hash);
        node(
            NodeKind::Shape {
                symbol: axiom,
                alternative: None,
            },
            lot.scope,
            match lot.geometry {
                Geom::Box => Geometry::Box,
                Geom::Rect => Geometry::Rect,
                Geom::Prism(_) => Geometry::Prism(OutlineId(0)),
                Geom::Polygon(_) => Geometry::Polygon(OutlineId(0)),
                Geom::Edge => Geometry::Edge,
                Geom::Roof(_) => Geometry::Roof(OutlineId(0)),
            },
            child_key(root, salt(info.name_hash, 0, 0)),
            0,
            0,
            0,
            AttrId(0),
        )
    }

    /// Derive the subtree of `root`. With `cut = Some(d)`, shapes at depth
    /// `d` or deeper (but the root) are not expanded: they are listed in
    /// `Job::cut` for other jobs, with the position their slice goes to.
    /// Stops with `Overflow` past `budget` nodes or when `stop` is set.
    /// `carried`: the root's replay state, when a parallel job's (`None`:
    /// the axiom's).
    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        root: Node,
        root_outline: Option<Arc<Outline>>,
        cut: Option<u32>,
        budget: usize,
        stop: &AtomicBool,
        prefix: &Ancestry,
        carried: Option<Carried>,
    ) -> Result<Job, Overflow> {
        match self.edits {
            // The plain loop: `()` hooks compile to nothing.
            None => self.run_with(root, root_outline, cut, budget, stop, prefix, || ()),
            Some(plan) => {
                let state = plan.root_state(&root);
                // Node indices below the stack's flag bit and the
                // markers' indices.
                let budget = budget.min(FLAGGED as usize - 3);
                self.run_with(root, root_outline, cut, budget, stop, prefix, || {
                    Replay::new(
                        plan,
                        carried.unwrap_or(Carried {
                            state,
                            forced: Forced::default(),
                        }),
                    )
                })
            }
        }
    }

    /// [`Engine::run`] with the replay hook `start` makes (`()`: no
    /// edits): a local of the loop, its state addressed from the loop's
    /// frame rather than through a pointer kept across the rule run.
    #[allow(clippy::too_many_arguments)]
    fn run_with<'r, H: Hook<'r>>(
        &self,
        mut root: Node,
        root_outline: Option<Arc<Outline>>,
        cut: Option<u32>,
        budget: usize,
        stop: &AtomicBool,
        prefix: &Ancestry,
        start: impl FnOnce() -> H,
    ) -> Result<Job, Overflow> {
        let mut hook = start();
        let hook = &mut hook;
        let roots_kind = (root.kind, 0);
        root.geometry = match (root.geometry, &root_outline) {
            (Geometry::Prism(_), Some(_)) => Geometry::Prism(OutlineId(0)),
            (Geometry::Polygon(_), Some(_)) => Geometry::Polygon(OutlineId(0)),
            (Geometry::Roof(_), Some(_)) => Geometry::Roof(OutlineId(0)),
            (g, _) => g,
        };
        let mut job = Job {
            outlines: root_outline.into_iter().collect(),
            nodes: vec![root],
            removed: Vec::new(),
            hits: Vec::new(),
            cut_carried: Vec::new(),
            failures: Vec::new(),
            cut: Vec::new(),
            roots_kind,
            root_attrs: AttrId(0),
            root_key: 0,
            ordered: true,
        };
        // The root has its trie state on the hook's stack (flagged).
        let mut stack: Vec<u32> = vec![H::FLAG];
        let mut scratch = Scratch {
            prefix: prefix.clone(),
            ..Scratch::default()
        };
        // The root's forcing (a parallel job's, carried).
        if let Some(r) = hook.get() {
            scratch.keep_material = r.forced.material.is_some();
        }
        while let Some(entry) = stack.pop() {
            if stop.load(Ordering::Relaxed) {
                return Err(Overflow);
            }
            // The shape's replay state: its forcing, the innermost forced
            // region's it is in, and its trie state, popped in step with
            // the stack when it has one (flagged: on an exact target's
            // path; the others are off every path). A flagged entry may
            // be a region's end instead (`LEAVE`) or a quiet subtree's
            // bounds (`QBEGIN`, `QEND`): one test for all.
            let at = entry & !H::FLAG;
            let mut state = replay::NONE;
            if entry & H::FLAG != 0
                && let Some(r) = hook.get()
            {
                if entry >= QBEGIN {
                    match entry {
                        LEAVE => {
                            r.leave();
                            scratch.keep_material = r.forced.material.is_some();
                        }
                        QEND => r.set_quiet(false),
                        _ => r.set_quiet(true),
                    }
                    continue;
                }
                state = r.stack.pop().unwrap_or(replay::NONE);
            }
            let shape = &job.nodes[at as usize];
            let NodeKind::Shape { symbol, .. } = shape.kind else {
                continue;
            };
            if at > 0 && cut.is_some_and(|d| shape.depth >= d) {
                job.cut.push((at, job.nodes.len() as u32));
                if let Some(r) = hook.get() {
                    job.cut_carried.push(Carried {
                        state,
                        forced: r.forced,
                    });
                }
                continue;
            }
            // The replay's work on this shape, only where it is on a
            // target's path, in a forced mesh's region, or may be named by
            // key or query, out of line (its rule run with it): the other
            // shapes cost the tests alone (their forcing is the region's,
            // already in `scratch`), and nothing of the replay is live
            // across their rule run.
            if let Some(r) = hook.get()
                && (state != replay::NONE || r.attends(symbol, shape.key))
            {
                self.replayed(
                    r,
                    &mut job,
                    at,
                    symbol,
                    state,
                    budget,
                    &mut scratch,
                    &mut stack,
                )?;
                continue;
            }
            self.rule_run(&mut job, at, symbol, budget, &mut scratch, &mut stack)?;
        }
        job.ordered = !scratch.unordered;
        Ok(job)
    }

    /// The rule of the shape `job.nodes[at]` (of `symbol`) run: its block
    /// made, closed and its shapes pushed on `stack` (last first, above
    /// the returned length). A failure is recorded in `job.failures`;
    /// `Overflow` past the budget.
    #[inline(always)]
    fn rule_run(
        &self,
        job: &mut Job,
        at: u32,
        symbol: SymbolId,
        budget: usize,
        scratch: &mut Scratch,
        stack: &mut Vec<u32>,
    ) -> Result<usize, Overflow> {
        let start = job.nodes.len();
        let shape = &job.nodes[at as usize];
        let inherited = job.nodes[at as usize].attrs;
        scratch.attrs = inherited;
        scratch.edge = 0;
        let simple = self.simple[symbol.0 as usize].as_deref();
        let result = match simple {
            // A rule of inserts and successors on a shape without an
            // outline, within the depth limit: its children, each
            // with the shape's scope and geometry (what expand writes).
            Some(children)
                if shape.geometry.outline_id().is_none()
                    && shape.depth < self.limits.max_depth
                    && scratch.force.is_none() =>
            {
                let (key, depth, scope, geometry) =
                    (shape.key, shape.depth, shape.scope, shape.geometry);
                job.nodes[at as usize].kind = NodeKind::Shape {
                    symbol,
                    alternative: Some(0),
                };
                for (edge, &(kind, salt)) in (1..).zip(children) {
                    let here = job.nodes.len() as u32;
                    job.nodes.push(node(
                        kind,
                        scope,
                        geometry,
                        child_key_premixed(key, salt),
                        edge,
                        depth + 1,
                        here - at,
                        inherited,
                    ));
                }
                scratch.edge = children.len() as u32;
                Ok(())
            }
            _ => self.expand(
                &mut job.nodes,
                &mut job.outlines,
                at,
                symbol,
                budget,
                scratch,
            ),
        };
        close_block(&mut job.nodes, start, at, inherited, scratch);
        match result {
            Ok(()) => {}
            Err(Some(e)) => job.failures.push((at, e)),
            Err(None) => return Err(Overflow),
        }
        if job.nodes.len() > budget {
            return Err(Overflow);
        }
        let end = job.nodes.len();
        let n = &mut job.nodes[at as usize];
        if end > start {
            n.children_offset = (start - at as usize) as u32;
            n.children_len = (end - start) as u32;
        }
        let before = stack.len();
        for j in (start..end).rev() {
            if job.nodes[j].is_shape() {
                stack.push(j as u32);
            }
        }
        Ok(before)
    }
}

impl Engine<'_> {
    /// The attributes `current` with the attribute `op` sets (`rgb`: a
    /// colour's channels, evaluated), interned in the shared table.
    #[cold]
    #[inline(never)]
    fn set_attribute(
        &self,
        op: &Op,
        rgb: Option<[f32; 3]>,
        current: AttrId,
    ) -> Result<AttrId, ShapeError> {
        let mut table = self.attrs.lock().unwrap_or_else(|e| e.into_inner());
        let mut a: Attributes = table.get(current);
        match op {
            Op::Material(m) => a.material = Some(*m),
            Op::Texture(t) => a.texture = Some(*t),
            _ => a.color = rgb.map(|c| c.map(|x| x.clamp(0.0, 1.0))),
        }
        table.intern(a).ok_or(ShapeError::TooManyAttributes {
            max: MAX_ATTRIBUTES,
        })
    }
}

/// What the derivation loop does after a rule run, whether it failed or
/// not, with the block `out[block..]` it wrote for the shape at `at`
/// (`inherited`: the shape's attributes before the run).
#[inline(always)]
fn close_block(out: &mut [Node], block: usize, at: u32, inherited: AttrId, s: &Scratch) {
    // Attributes (crate::attributes): each node of the block was made with
    // those set before it (`Scratch::attrs` then); a shape whose rule made
    // nothing keeps those its rule left.
    if out.len() == block
        && s.attrs != inherited
        && let Some(n) = out.get_mut(at as usize)
    {
        n.attrs = s.attrs;
    }
    // A shape's direct children count its edges, for counting from the end.
    let mut j = block;
    while j < out.len() {
        out[j].count = s.edge;
        j += 1 + out[j].children_len as usize
            * usize::from(matches!(out[j].kind, NodeKind::Command { .. }));
    }
}

/// Move a node's outline from a job's table to the final one (the next
/// entry: one per node, in node order).
fn renumber(n: &mut Node, from: &[Arc<Outline>], to: &mut Vec<Arc<Outline>>) {
    if let Some(o) = n.geometry.outline_id()
        && let Some(a) = from.get(o.0 as usize)
    {
        n.geometry = intern(
            to,
            &match n.geometry {
                Geometry::Prism(_) => Geom::Prism(Arc::clone(a)),
                Geometry::Roof(_) => Geom::Roof(Arc::clone(a)),
                _ => Geom::Polygon(Arc::clone(a)),
            },
        );
    }
}

/// A stored geometry with its outline in hand.
#[inline]
fn resolve(outlines: &[Arc<Outline>], g: Geometry) -> Geom {
    let get = |o: OutlineId| outlines.get(o.0 as usize).cloned();
    match g {
        Geometry::Box => Geom::Box,
        Geometry::Rect => Geom::Rect,
        Geometry::Edge => Geom::Edge,
        Geometry::Prism(o) => get(o).map_or(Geom::Box, Geom::Prism),
        Geometry::Polygon(o) => get(o).map_or(Geom::Rect, Geom::Polygon),
        Geometry::Roof(o) => get(o).map_or(Geom::Box, Geom::Roof),
    }
}

/// The geometry to store for a node written now: an outline gets the next
/// entry of the table (one per node, in node order).
#[inline(always)]
fn intern(outlines: &mut Vec<Arc<Outline>>, g: &Geom) -> Geometry {
    match plain(g) {
        Some(g) => g,
        None => intern_outline(outlines, g),
    }
}

/// The stored form of a geometry without an outline (a box, rectangle or
/// edge), which takes no entry of the outline table.
#[inline(always)]
fn plain(g: &Geom) -> Option<Geometry> {
    match g {
        Geom::Box => Some(Geometry::Box),
        Geom::Rect => Some(Geometry::Rect),
        Geom::Edge => Some(Geometry::Edge),
        _ => None,
    }
}

/// [`intern`] of a geometry with an outline.
#[inline(never)]
fn intern_outline(outlines: &mut Vec<Arc<Outline>>, g: &Geom) -> Geometry {
    match g {
        Geom::Box => Geometry::Box,
        Geom::Rect => Geometry::Rect,
        Geom::Edge => Geometry::Edge,
        Geom::Prism(o) => {
            outlines.push(Arc::clone(o));
            Geometry::Prism(OutlineId(outlines.len() as u32 - 1))
        }
        Geom::Polygon(o) => {
            outlines.push(Arc::clone(o));
            Geometry::Polygon(OutlineId(outlines.len() as u32 - 1))
        }
        Geom::Roof(o) => {
            outlines.push(Arc::clone(o));
            Geometry::Roof(OutlineId(outlines.len() as u32 - 1))
        }
    }
}

/// A job's nodes and outlines (in node order), or its first failure in
/// the tree's order.
/// A finished derivation: its nodes, outlines and removed shapes.
type Finished = (Vec<Node>, Vec<Arc<Outline>>, Vec<u32>, Vec<(u32, u32)>);

fn finish(job: Job) -> Result<Finished, ShapeError> {
    let mut removed = job.removed;
    removed.sort_unstable();
    let mut hits = job.hits;
    sort_hits(&mut hits);
    match job.failures.into_iter().min_by_key(|(i, _)| *i) {
        Some((_, e)) => Err(e),
        None if job.ordered => Ok((job.nodes, job.outlines, removed, hits)),
        None => {
            let mut nodes = job.nodes;
            let mut outlines = Vec::with_capacity(job.outlines.len());
            for n in &mut nodes {
                renumber(n, &job.outlines, &mut outlines);
            }
            Ok((nodes, outlines, removed, hits))
        }
    }
}

/// Sort a derivation's edit hits by (edit id, node): what
/// `ShapeTree::edit_hits` searches. Ids are few and dense (an edits
/// file's) and an edit's hits come mostly in node order (the order the
/// derivation meets them), so the hits are counted out by id, keeping
/// their order, and only an id's run that is out of node order is sorted
/// (a thousand edits' few thousand hits: a tenth of a general sort's
/// comparisons). The same order `sort_unstable` gives.
fn sort_hits(hits: &mut Vec<(u32, u32)>) {
    let Some(max) = hits.iter().map(|h| h.0).max() else {
        return;
    };
    if hits.len() < 32 || max as usize > 4 * hits.len() + 4096 {
        hits.sort_unstable();
        return;
    }
    let mut at = vec![0u32; max as usize + 2];
    for h in hits.iter() {
        at[h.0 as usize + 1] += 1;
    }
    for i in 1..at.len() {
        at[i] += at[i - 1];
    }
    let mut out = vec![(0u32, 0u32); hits.len()];
    for &h in hits.iter() {
        let slot = &mut at[h.0 as usize];
        out[*slot as usize] = h;
        *slot += 1;
    }
    // `at[id]` is now where id's run ends.
    let mut from = 0usize;
    for &end in &at[..=max as usize] {
        let run = &mut out[from..end as usize];
        if !run.is_sorted() {
            run.sort_unstable();
        }
        from = end as usize;
    }
    *hits = out;
}

/// Give node `n` the geometry `g`. An outline where the node had one
/// replaces its entry (the table stays in node order); otherwise a new
/// outline goes to the end of the table, or the node's entry is left
/// unused, and the result is false: the table must be ordered again.
fn set_geometry(n: &mut Node, outlines: &mut Vec<Arc<Outline>>, g: &Geom) -> bool {
    match (n.geometry.outline_id(), g.table_entry()) {
        (Some(o), Some(a)) if (o.0 as usize) < outlines.len() => {
            let slot = &mut outlines[o.0 as usize];
            if !Arc::ptr_eq(slot, a) {
                *slot = Arc::clone(a);
            }
            n.geometry = match g {
                Geom::Prism(_) => Geometry::Prism(o),
                Geom::Roof(_) => Geometry::Roof(o),
                _ => Geometry::Polygon(o),
            };
            true
        }
        (None, None) => {
            n.geometry = intern(outlines, g);
            true
        }
        _ => {
            n.geometry = intern(outlines, g);
            false
        }
    }
}

#[cfg(test)]
mod tests {
    use super::sort_hits;

    #[test]
    fn sorted_hits_are_what_a_general_sort_gives() {
        // A small generator (no dependency): hits of dense ids, each id's
        // nodes mostly rising, some not; sparse ids take the general sort.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut next = |m: u32| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x % u64::from(m)) as u32
        };
        for (n, ids, spread) in [(0, 1, 1), (5, 3, 10), (3000, 1000, 4), (500, 1 << 30, 50)] {
            let mut hits: Vec<(u32, u32)> =
                (0..n).map(|k| (next(ids), k * 7 + next(spread))).collect();
            let mut want = hits.clone();
            want.sort_unstable();
            sort_hits(&mut hits);
            assert_eq!(hits, want, "{n} hits of {ids} ids");
        }
    }
}
