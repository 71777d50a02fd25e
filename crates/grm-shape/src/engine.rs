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

/// The size past which the top of the tree is not derived deeper for
/// more parallelism (each deepening derives the top again).
const TOP_NODES: usize = 4096;

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
    /// Where the rule run set attributes: (the block position from which
    /// on, the attributes), in order.
    attr_marks: Vec<(usize, AttrId)>,
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

#[inline]
fn node(
    kind: NodeKind,
    scope: Scope,
    geometry: Geometry,
    key: u32,
    edge: u32,
    depth: u32,
    parent_offset: u32,
) -> Node {
    Node {
        kind,
        scope,
        geometry,
        key,
        edge,
        case: 0,
        selector: None,
        attrs: AttrId(0),
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
            None => self.run_with(root, root_outline, cut, budget, stop, prefix, &mut ()),
            Some(plan) => {
                let mut replay = Replay::new(
                    plan,
                    carried.unwrap_or(Carried {
                        state: plan.root_state(&root),
                        forced: Forced::default(),
                    }),
                );
                // Node indices below the stack's flag bit.
                let budget = budget.min(FLAGGED as usize - 1);
                self.run_with(root, root_outline, cut, budget, stop, prefix, &mut replay)
            }
        }
    }

    /// [`Engine::run`] with the replay hook `hook` (`()`: no edits).
    #[allow(clippy::too_many_arguments)]
    fn run_with<'r, H: Hook<'r>>(
        &self,
        mut root: Node,
        root_outline: Option<Arc<Outline>>,
        cut: Option<u32>,
        budget: usize,
        stop: &AtomicBool,
        prefix: &Ancestry,
        hook: &mut H,
    ) -> Result<Job, Overflow> {
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
            // path; the others are off every path).
            let at = entry & !H::FLAG;
            let mut state = replay::NONE;
            if let Some(r) = hook.get() {
                if stack.len() < r.floor {
                    r.leave(stack.len());
                    scratch.keep_material = r.forced.material.is_some();
                }
                if entry & H::FLAG != 0 {
                    state = r.stack.pop().unwrap_or(replay::NONE);
                }
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
            let start = job.nodes.len();
            // The replay's work on this shape (`Some`: its forcing and
            // whether its own edits force its block's, opening a region),
            // only where it is on a target's path, in a forced mesh's
            // region, or may be named by key or query: the other shapes
            // cost the tests alone (their forcing is the region's, already
            // in `scratch`).
            let mut special = false;
            if let Some(r) = hook.get()
                && (state != replay::NONE
                    || r.attend && (r.meshed || r.plan.may_name(symbol, shape.key)))
            {
                if !self.own_edits(r, &mut job, at, state, &mut scratch) {
                    continue;
                }
                special = true;
            }
            let shape = &job.nodes[at as usize];
            let inherited = job.nodes[at as usize].attrs;
            scratch.attrs = inherited;
            scratch.edge = 0;
            scratch.attr_marks.clear();
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
                    &mut scratch,
                ),
            };
            close_block(&mut job.nodes, start, at, inherited, &scratch);
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
            if let Some(r) = hook.get()
                && special
            {
                let (forced, opens) = r.shape;
                replay_block(
                    r,
                    &mut job.nodes,
                    at,
                    start,
                    &mut stack[before..],
                    before,
                    state,
                    forced,
                    opens,
                );
                scratch.force = None;
                scratch.keep_material = r.forced.material.is_some();
            }
        }
        job.ordered = !scratch.unordered;
        Ok(job)
    }

    /// Run the rule of the shape at `at`, appending its block to `out`.
    /// `Err(None)` is the node limit. (Inlined into its one caller, the
    /// derivation loop: as a call it cost the facade benchmark 5 to 10%.)
    #[inline(always)]
    fn expand(
        &self,
        out: &mut Vec<Node>,
        outlines: &mut Vec<Arc<Outline>>,
        at: u32,
        symbol: SymbolId,
        budget: usize,
        s: &mut Scratch,
    ) -> Result<(), Option<ShapeError>> {
        let program = self.program;
        let Some(rule) = program.rule(symbol) else {
            return Ok(());
        };
        let shape = &out[at as usize];
        let key = shape.key;
        let depth = shape.depth;
        let base = shape.scope;
        let inherited = shape.attrs;
        let mut scope = shape.scope;
        let mut geometry = resolve(outlines, shape.geometry);
        // What expressions read of the shape (docs/shapes.md, "Expressions").
        s.tags.clear();
        s.path.clear();
        let uses = &program.exprs.uses;
        if uses.tags || !uses.queried.is_empty() {
            s.path.push(key);
            ancestry(out, at as usize, &mut s.tags, &mut s.path);
            s.tags.extend_from_slice(&s.prefix.tags);
            s.path.extend_from_slice(&s.prefix.keys);
        }
        let cx = Shape {
            seed: self.seed,
            key,
            index: shape.index,
            count: shape.count,
            depth,
            tags: &s.tags,
            path: &s.path,
            queries: self.queries,
        };
        let exprs = &program.exprs;
        let eval = &mut s.eval;
        let mut num = |p: &Param, scope: &Scope, site: &mut Site| -> f32 {
            match *p {
                Param::Const(v) => v,
                Param::Expr(e) => exprs.eval(e, &cx, scope, site, eval),
            }
        };
        let alts = &rule.alternatives;
        let alt = if let Some(k) = s.force.filter(|&k| (k as usize) < alts.len()) {
            // A persistent edit forces the alternative (crate::replay).
            k
        } else if alts.len() == 1 && alts[0].is_plain() {
            0
        } else {
            // The race of `grm_compile::rng` among the alternatives whose
            // condition holds and whose weight is positive: the earliest
            // time over weight wins, the first alternative on a tie.
            let time = |k: usize| race_time(hash(self.seed, 0, key, choice_draw(k as u32)));
            let mut best: Option<(u32, f32, u32)> = None;
            for (k, a) in alts.iter().enumerate() {
                if let Some(c) = a.condition {
                    let mut site = Site::new(k as u32, SITE_CONDITION);
                    let v = num(&Param::Expr(c), &base, &mut site);
                    if v == 0.0 || v.is_nan() {
                        continue;
                    }
                }
                let mut site = Site::new(k as u32, SITE_WEIGHT);
                let w = match num(&a.weight, &base, &mut site) {
                    f32::INFINITY => f32::MAX,
                    w => w,
                };
                if !(w.is_finite() && w > 0.0) {
                    continue;
                }
                let t = time(k);
                if best.is_none_or(|b| race_earlier(t, w, b.0, b.1)) {
                    best = Some((t, w, k as u32));
                }
            }
            match best {
                Some(b) => b.2,
                // No alternative holds: a terminal shape.
                None => return Ok(()),
            }
        };
        out[at as usize].kind = NodeKind::Shape {
            symbol,
            alternative: Some(alt),
        };
        let name = || program.symbols[symbol.0 as usize].name.clone();
        let fail = |e: ShapeError| Err(Some(e));
        let finite = |what: &'static str, v: f32| -> Result<f32, Option<ShapeError>> {
            if v.is_finite() {
                Ok(v)
            } else {
                Err(Some(ShapeError::BadValue {
                    symbol: name(),
                    what,
                    value: v,
                }))
            }
        };
        let max_depth = self.limits.max_depth;
        let too_deep = |d: u32| -> Result<(), Option<ShapeError>> {
            if d > max_depth {
                Err(Some(ShapeError::TooDeep {
                    max: max_depth,
                    symbol: name(),
                }))
            } else {
                Ok(())
            }
        };
        s.stack.clear();
        s.attr_stack.clear();
        let block = out.len();
        // The premixed salts of the children the operations make.
        let salts = &self.salts[symbol.0 as usize][alt as usize];
        {
            for (i, op) in rule.alternatives[alt as usize].ops.iter().enumerate() {
                // Each operation's draws have their own site (the draw
                // index: docs/shapes.md, "Identity").
                let site = &mut Site::new(alt, SITE_OPS + i as u32);
                match op {
                    Op::Extrude(h) => {
                        let h = finite("the extrusion height", num(h, &scope, site))?.max(0.0);
                        geometry = match geometry {
                            Geom::Rect | Geom::Box => Geom::Box,
                            Geom::Polygon(o) | Geom::Prism(o) => Geom::Prism(o),
                            Geom::Edge | Geom::Roof(_) => {
                                return fail(ShapeError::WrongGeometry {
                                    symbol: name(),
                                    op: "extrude",
                                    geometry: geometry.describe(),
                                });
                            }
                        };
                        scope.size.z = h;
                    }
                    Op::Translate(v) => {
                        let v = Vec3::new(
                            finite("a translation", num(&v[0], &scope, site))?,
                            finite("a translation", num(&v[1], &scope, site))?,
                            finite("a translation", num(&v[2], &scope, site))?,
                        );
                        scope = scope.translated(v);
                    }
                    Op::Rotate { axis, degrees } => {
                        let d = finite("a rotation angle", num(degrees, &scope, site))?;
                        scope = scope.rotated(*axis, d);
                    }
                    Op::Size(sz) => {
                        // All three read the scope before the operation.
                        let mut v = [0.0f32; 3];
                        for i in 0..3 {
                            if let Some(p) = &sz[i] {
                                v[i] = finite("a size", num(p, &scope, site))?.max(0.0);
                            }
                        }
                        let mut f = [1.0f64; 3];
                        for i in 0..3 {
                            if sz[i].is_some() {
                                let v = v[i];
                                let old = scope.size[i];
                                f[i] = if old > 0.0 {
                                    f64::from(v) / f64::from(old)
                                } else {
                                    1.0
                                };
                                scope.size[i] = v;
                            }
                        }
                        if let Geom::Roof(o) = &geometry
                            && let Some(r) = o.roof()
                            && f != [1.0; 3]
                        {
                            let roof = r.scaled(f);
                            geometry = Geom::Roof(Arc::new(Outline::with_roof(
                                roof.base_polygons(),
                                roof,
                            )));
                        } else if let Some(o) = geometry.outline()
                            && (f[0] != 1.0 || f[1] != 1.0)
                        {
                            let scaled = o.scaled(f[0], f[1]);
                            geometry = Geom::from_outline(
                                scaled,
                                scope.size.x,
                                scope.size.y,
                                geometry.is_mass(),
                            );
                        }
                    }
                    Op::Center(axes) => {
                        let reference = s.stack.last().map_or(base, |e| e.0);
                        let delta = reference.center() - scope.center();
                        for (i, &on) in axes.iter().enumerate() {
                            if on {
                                let a = scope.axis([Axis::X, Axis::Y, Axis::Z][i]);
                                scope.origin += a * delta.dot(a);
                            }
                        }
                    }
                    Op::Push => {
                        s.stack.push((scope, geometry.clone()));
                        s.attr_stack.push(s.attrs);
                    }
                    Op::Pop => match s.stack.pop() {
                        Some((sc, g)) => {
                            scope = sc;
                            geometry = g;
                            let saved = s.attr_stack.pop().unwrap_or(inherited);
                            if saved != s.attrs {
                                s.attrs = saved;
                                s.attr_marks.push((out.len(), saved));
                            }
                        }
                        None => return fail(ShapeError::PopWithoutPush { symbol: name() }),
                    },
                    Op::Offset(d) => {
                        let d = finite("an offset distance", num(d, &scope, site))?;
                        let Some(outline) = crate::component::outline_of(&scope, &geometry) else {
                            return fail(ShapeError::WrongGeometry {
                                symbol: name(),
                                op: "offset",
                                geometry: geometry.describe(),
                            });
                        };
                        match outline.offset(f64::from(d)) {
                            Some(o) => {
                                geometry = Geom::from_outline(
                                    o,
                                    scope.size.x,
                                    scope.size.y,
                                    geometry.is_mass(),
                                );
                            }
                            // Nothing left: the shape makes nothing more.
                            None => break,
                        }
                    }
                    Op::Insert(asset) => {
                        too_deep(depth + 1)?;
                        s.edge += 1;
                        let here = out.len() as u32;
                        out.push(node(
                            NodeKind::Insert { asset: *asset },
                            scope,
                            intern(outlines, &geometry),
                            child_key_premixed(key, salts[i]),
                            s.edge,
                            depth + 1,
                            here - at,
                        ));
                    }
                    Op::Emit(sym) => {
                        too_deep(depth + 1)?;
                        s.edge += 1;
                        let here = out.len() as u32;
                        out.push(node(
                            NodeKind::Shape {
                                symbol: *sym,
                                alternative: None,
                            },
                            scope,
                            intern(outlines, &geometry),
                            child_key_premixed(key, salts[i]),
                            s.edge,
                            depth + 1,
                            here - at,
                        ));
                    }
                    Op::Split(sp) | Op::Repeat(sp) => {
                        let is_repeat = matches!(op, Op::Repeat(_));
                        too_deep(depth + 2)?;
                        s.sizes.clear();
                        s.sizes.extend(
                            sp.parts
                                .iter()
                                .map(|p| p.size.eval(|p| num(p, &scope, site))),
                        );
                        let extent = scope.size[sp.axis.index()];
                        let size_err = |error| {
                            Err(Some(ShapeError::Size {
                                symbol: name(),
                                error,
                            }))
                        };
                        // The layout depends on the op, the extent and the
                        // sizes only: look it up before laying it out.
                        let op_id = std::ptr::from_ref(sp) as usize;
                        let bits = extent.to_bits();
                        let hit = s
                            .memo
                            .iter()
                            .position(|m| m.op == op_id && m.extent == bits && m.sizes == s.sizes);
                        let slot = match hit {
                            Some(i) => i,
                            None => {
                                if s.memo.len() < MEMO {
                                    s.memo.push(Memo::default());
                                }
                                let i = s.memo_next % MEMO.min(s.memo.len());
                                s.memo_next = s.memo_next.wrapping_add(1);
                                let m = &mut s.memo[i];
                                m.op = usize::MAX;
                                let laid = if is_repeat {
                                    repeat_into(
                                        &s.sizes,
                                        extent,
                                        self.limits.max_nodes as u64,
                                        &mut m.layout,
                                    )
                                } else {
                                    m.layout.tiles = 1;
                                    split_into(&s.sizes, extent, &mut m.layout.spans)
                                };
                                match laid {
                                    Ok(()) => {}
                                    Err(SizeError::TooManyTiles { .. }) => return Err(None),
                                    Err(e) => return size_err(e),
                                }
                                m.op = op_id;
                                m.extent = bits;
                                m.sizes.clear();
                                m.sizes.extend_from_slice(&s.sizes);
                                let parts = sp.parts.len() as u32;
                                let tiles = m.layout.tiles;
                                m.kids.clear();
                                m.kids.extend(m.layout.spans.iter().filter_map(|span| {
                                    let target = sp.parts[span.part as usize].target?;
                                    let number = span.tile * parts + span.part + 1;
                                    let th = program.symbols[target.0 as usize].name_hash;
                                    let (index, count) = if is_repeat {
                                        (span.tile + 1, tiles)
                                    } else {
                                        (span.part + 1, parts)
                                    };
                                    Some(Kid {
                                        start: span.start,
                                        len: span.len,
                                        target,
                                        number,
                                        index,
                                        count,
                                        salt: premix(salt(th, number, 0)),
                                    })
                                }));
                                i
                            }
                        };
                        let kids = &s.memo[slot].kids;
                        let command = if is_repeat {
                            Command::Repeat(sp.axis)
                        } else {
                            Command::Split(sp.axis)
                        };
                        s.edge += 1;
                        let cmd_key = child_key_premixed(key, salts[i]);
                        let cmd_at = out.len();
                        out.push(node(
                            NodeKind::Command {
                                command,
                                tag: sp.tag,
                            },
                            scope,
                            intern(outlines, &geometry),
                            cmd_key,
                            s.edge,
                            depth + 1,
                            cmd_at as u32 - at,
                        ));
                        let dir = scope.axis(sp.axis);
                        // A box, rectangle or edge is cut by arithmetic
                        // alone: each part has the same geometry.
                        let same = plain(&geometry);
                        for kid in kids {
                            let g = match same {
                                Some(g) => g,
                                None => {
                                    let Some(g) =
                                        geometry.slab(&scope, sp.axis, kid.start, kid.len)
                                    else {
                                        continue;
                                    };
                                    intern(outlines, &g)
                                }
                            };
                            let here = out.len();
                            let mut n = node(
                                NodeKind::Shape {
                                    symbol: kid.target,
                                    alternative: None,
                                },
                                scope.slab_along(dir, sp.axis, kid.start, kid.len),
                                g,
                                child_key_premixed(cmd_key, kid.salt),
                                kid.number,
                                depth + 2,
                                (here - cmd_at) as u32,
                            );
                            (n.index, n.count) = (kid.index, kid.count);
                            out.push(n);
                            if out.len() > budget {
                                return Err(None);
                            }
                        }
                        let len = out.len() - cmd_at - 1;
                        out[cmd_at].children_offset = 1;
                        out[cmd_at].children_len = len as u32;
                    }
                    Op::Roof {
                        kind,
                        angle,
                        overhang,
                    } => {
                        let angle = f64::from(finite("a roof angle", num(angle, &scope, site))?);
                        let d = f64::from(finite("a roof overhang", num(overhang, &scope, site))?);
                        let kind = *kind;
                        match crate::roof::on_shape(&scope, &geometry, true, |o| {
                            crate::roof::build(o, kind, angle, d)
                        }) {
                            Ok((sc, g)) => (scope, geometry) = (sc, g),
                            Err(e) => return fail(roof_error(name(), "roof", &geometry, e)),
                        }
                    }
                    Op::Taper(h) => {
                        let h = f64::from(finite("a taper height", num(h, &scope, site))?.max(0.0));
                        match crate::roof::on_shape(&scope, &geometry, false, |o| {
                            crate::roof::taper(o, h)
                        }) {
                            Ok((sc, g)) => (scope, geometry) = (sc, g),
                            Err(e) => return fail(roof_error(name(), "taper", &geometry, e)),
                        }
                    }
                    Op::Comp(c) => {
                        too_deep(depth + 2)?;
                        let comps = match components(&scope, &geometry, c.target) {
                            Ok(v) => v,
                            Err(NotApplicable) => {
                                return fail(ShapeError::WrongGeometry {
                                    symbol: name(),
                                    op: match c.target {
                                        CompTarget::Faces => "a component split into faces",
                                        CompTarget::Edges => "a component split into edges",
                                    },
                                    geometry: geometry.describe(),
                                });
                            }
                        };
                        s.edge += 1;
                        let cmd_key = child_key_premixed(key, salts[i]);
                        let cmd_at = out.len();
                        out.push(node(
                            NodeKind::Command {
                                command: Command::Comp(c.target),
                                tag: c.tag,
                            },
                            scope,
                            intern(outlines, &geometry),
                            cmd_key,
                            s.edge,
                            depth + 1,
                            cmd_at as u32 - at,
                        ));
                        let case_of = |comp: &crate::component::Component| {
                            c.cases
                                .iter()
                                .position(|k| comp.classes.matches(k.selector))
                        };
                        s.counts.clear();
                        s.counts.resize(c.cases.len() * 2, 0);
                        for comp in &comps {
                            if let Some(k) = case_of(comp) {
                                s.counts[k] += 1;
                            }
                        }
                        for comp in comps {
                            let Some(k) = case_of(&comp) else { continue };
                            let seen = &mut s.counts[c.cases.len() + k];
                            *seen += 1;
                            let index = *seen;
                            let Some(target) = c.cases[k].target else {
                                continue;
                            };
                            let th = program.symbols[target.0 as usize].name_hash;
                            let here = out.len();
                            let mut n = node(
                                NodeKind::Shape {
                                    symbol: target,
                                    alternative: None,
                                },
                                comp.scope,
                                intern(outlines, &comp.geometry),
                                child_key(cmd_key, salt(th, index, k as u32)),
                                index,
                                depth + 2,
                                (here - cmd_at) as u32,
                            );
                            n.case = k as u32;
                            n.selector = Some(c.cases[k].selector);
                            n.count = s.counts[k];
                            out.push(n);
                            if out.len() > budget {
                                return Err(None);
                            }
                        }
                        let len = out.len() - cmd_at - 1;
                        out[cmd_at].children_offset = 1;
                        out[cmd_at].children_len = len as u32;
                    }
                    // A material an edit forces wins (crate::replay).
                    Op::Material(_) if s.keep_material => {}
                    Op::Material(_) | Op::Color(_) | Op::Texture(_) => {
                        let mut rgb = None;
                        if let Op::Color(c) = op {
                            let mut v = [0.0f32; 3];
                            for (x, p) in v.iter_mut().zip(c) {
                                *x = finite("a colour channel", num(p, &scope, site))?;
                            }
                            rgb = Some(v);
                        }
                        // The same attribute set on the same attributes
                        // (every window of a facade setting its glass):
                        // remembered, without the shared table's lock.
                        let key = match (op, rgb) {
                            (Op::Material(m), _) => (0, [m.0, 0, 0]),
                            (Op::Texture(t), _) => (1, [t.0, 0, 0]),
                            (_, c) => (2, c.unwrap_or_default().map(f32::to_bits)),
                        };
                        let id = match s.attr_memo.iter().find(|m| m.0 == s.attrs && m.1 == key) {
                            Some(m) => m.2,
                            None => {
                                let id = self.set_attribute(op, rgb, s.attrs).map_err(Some)?;
                                if s.attr_memo.len() < ATTR_MEMO {
                                    s.attr_memo.push((s.attrs, key, id));
                                } else {
                                    s.attr_memo[s.attr_memo_next] = (s.attrs, key, id);
                                    s.attr_memo_next = (s.attr_memo_next + 1) % ATTR_MEMO;
                                }
                                id
                            }
                        };
                        if id != s.attrs {
                            s.attrs = id;
                            s.attr_marks.push((out.len(), id));
                        }
                    }
                }
            }
            // A shape whose rule made nothing (no successor, command or
            // insert) is a leaf drawn as its rule left it: its node takes
            // the final scope and geometry (docs/shapes.md, "The tree").
            if out.len() == block
                && let Some(n) = out.get_mut(at as usize)
                && !finalize(n, outlines, scope, &geometry)
            {
                s.unordered = true;
            }
            Ok(())
        }
    }

    /// Derive with `threads` workers: the top of the tree here, deep
    /// enough to give each worker several subtrees, then the subtrees on
    /// the workers, then the slices spliced in, in the tree's order.
    fn parallel(
        &self,
        root: Node,
        root_outline: Option<Arc<Outline>>,
        threads: usize,
    ) -> Result<Job, ShapeError> {
        let max = self.limits.max_nodes;
        let never = AtomicBool::new(false);
        let mut cut = 1;
        let mut top = loop {
            let top = self
                .run(
                    root,
                    root_outline.clone(),
                    Some(cut),
                    max,
                    &never,
                    &Ancestry::default(),
                    None,
                )
                .map_err(|Overflow| ShapeError::TooManyShapes { max })?;
            // Deep enough for four subtrees per worker; but never derive a
            // big top again and again (a narrow grammar): past `TOP_NODES`
            // the top is what it is.
            if top.cut.is_empty()
                || top.cut.len() >= 4 * threads
                || top.nodes.len() >= TOP_NODES
                || cut >= 32
            {
                break top;
            }
            cut += 1;
        };
        let budget = max.saturating_sub(top.nodes.len());
        let uses = &self.program.exprs.uses;
        // The edits' semantic queries read the tagged commands above a
        // job's root too.
        let needs_ancestry =
            uses.tags || !uses.queried.is_empty() || self.edits.is_some_and(EditPlan::has_semantic);
        let roots: Vec<JobRoot> = top
            .cut
            .iter()
            .enumerate()
            .map(|(c, &(i, _))| {
                let n = top.nodes[i as usize];
                let mut a = Ancestry::default();
                if needs_ancestry {
                    ancestry(&top.nodes, i as usize, &mut a.tags, &mut a.keys);
                }
                (
                    n,
                    n.geometry
                        .outline_id()
                        .and_then(|o| top.outlines.get(o.0 as usize).cloned()),
                    a,
                    top.cut_carried.get(c).copied(),
                )
            })
            .collect();
        let next = AtomicUsize::new(0);
        let stop = AtomicBool::new(false);
        let workers = threads.min(roots.len()).max(1);
        let done: Vec<Vec<(usize, Result<Job, Overflow>)>> = std::thread::scope(|sc| {
            let handles: Vec<_> = (0..workers)
                .map(|_| {
                    sc.spawn(|| {
                        let mut mine = Vec::new();
                        loop {
                            let j = next.fetch_add(1, Ordering::Relaxed);
                            let Some((r, o, a, carried)) = roots.get(j) else {
                                break;
                            };
                            let mut r = *r;
                            r.parent_offset = 0;
                            let result =
                                self.run(r, o.clone(), None, budget + 1, &stop, a, *carried);
                            if result.is_err() {
                                stop.store(true, Ordering::Relaxed);
                            }
                            mine.push((j, result));
                        }
                        mine
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().unwrap_or_default())
                .collect()
        });
        let mut jobs: Vec<Option<Job>> = (0..roots.len()).map(|_| None).collect();
        for (j, r) in done.into_iter().flatten() {
            match r {
                Ok(job) => jobs[j] = Some(job),
                Err(Overflow) => return Err(ShapeError::TooManyShapes { max }),
            }
        }
        let mut jobs: Vec<Job> = match jobs.into_iter().collect::<Option<Vec<Job>>>() {
            Some(j) => j,
            // A worker that died (it cannot: the engine does not panic).
            None => return Err(ShapeError::TooManyShapes { max }),
        };
        let total = top.nodes.len() + jobs.iter().map(|j| j.nodes.len() - 1).sum::<usize>();
        if total > max {
            return Err(ShapeError::TooManyShapes { max });
        }
        // New index of each top node: shifted by the slices spliced before it.
        let mut shift = vec![0u32; top.nodes.len() + 1];
        {
            let mut add = 0u32;
            let mut c = 0;
            for (i, s) in shift.iter_mut().enumerate() {
                while c < top.cut.len() && top.cut[c].1 as usize == i {
                    add += jobs[c].nodes.len() as u32 - 1;
                    c += 1;
                }
                *s = add;
            }
        }
        // A cut shape whose rule made nothing takes its final state from
        // its job's root before the top's outlines are renumbered (so the
        // table stays in node order).
        for (c, &(i, _)) in top.cut.iter().enumerate() {
            let root = &jobs[c].nodes[0];
            if root.children_len == 0
                && let Some(n) = top.nodes.get_mut(i as usize)
            {
                let g = resolve(&jobs[c].outlines, root.geometry);
                n.scope = root.scope;
                set_geometry(n, &mut top.outlines, &g);
            }
        }
        let new = |i: usize| i as u32 + shift[i];
        let mut out: Vec<Node> = Vec::with_capacity(total);
        let mut outlines: Vec<Arc<Outline>> = Vec::new();
        let mut failures: Vec<(u32, ShapeError)> = Vec::new();
        for (i, e) in top.failures {
            failures.push((new(i as usize), e));
        }
        // The replay's removed shapes and hits, renumbered likewise (the
        // jobs' in `splice`).
        let mut removed: Vec<u32> = top.removed.iter().map(|&i| new(i as usize)).collect();
        let mut hits: Vec<(u32, u32)> = top
            .hits
            .iter()
            .map(|&(id, i)| (id, new(i as usize)))
            .collect();
        let mut c = 0;
        let mut starts = vec![0u32; top.cut.len()];
        for (i, mut n) in top.nodes.iter().copied().enumerate() {
            while c < top.cut.len() && top.cut[c].1 as usize == i {
                starts[c] = splice(
                    &mut out,
                    &mut outlines,
                    &mut jobs[c],
                    new(top.cut[c].0 as usize),
                    &mut failures,
                    &mut removed,
                    &mut hits,
                );
                c += 1;
            }
            renumber(&mut n, &top.outlines, &mut outlines);
            let here = new(i);
            if i > 0 {
                n.parent_offset = here - new(i - n.parent_offset as usize);
            }
            if n.children_len > 0 {
                n.children_offset = new(i + n.children_offset as usize) - here;
            }
            out.push(n);
        }
        while c < top.cut.len() {
            starts[c] = splice(
                &mut out,
                &mut outlines,
                &mut jobs[c],
                new(top.cut[c].0 as usize),
                &mut failures,
                &mut removed,
                &mut hits,
            );
            c += 1;
        }
        // The cut shapes take their jobs' roots (the alternative applied,
        // their blocks).
        for (c, &(i, _)) in top.cut.iter().enumerate() {
            let r = new(i as usize) as usize;
            let root = &jobs[c].roots_kind;
            out[r].kind = root.0;
            out[r].attrs = jobs[c].root_attrs;
            out[r].key = jobs[c].root_key;
            out[r].children_len = root.1;
            out[r].children_offset = if root.1 > 0 { starts[c] - r as u32 } else { 0 };
        }
        Ok(Job {
            hits,
            removed,
            cut_carried: Vec::new(),
            nodes: out,
            outlines,
            failures,
            cut: Vec::new(),
            roots_kind: (root.kind, 0),
            root_attrs: root.attrs,
            root_key: root.key,
            ordered: true,
        })
    }
}

/// A parallel job's root: the node, its outline, its ancestors' tags and
/// keys, and with a plan of edits its replay state.
type JobRoot = (Node, Option<Arc<Outline>>, Ancestry, Option<Carried>);

/// The derivation loop's replay hook: `()` replays nothing (every call
/// inlines to nothing, so the plain derivation is the loop without
/// edits), [`Replay`] a plan's edits.
trait Hook<'p> {
    /// The bit of a derivation stack entry that says the shape has an
    /// entry on the replay's stack (0: no replay).
    const FLAG: u32;
    /// The replay state, if any.
    fn get(&mut self) -> Option<&mut Replay<'p>>;
}

/// [`Hook::FLAG`] of a replay.
const FLAGGED: u32 = 1 << 31;

impl<'p> Hook<'p> for () {
    const FLAG: u32 = 0;
    #[inline(always)]
    fn get(&mut self) -> Option<&mut Replay<'p>> {
        None
    }
}

impl<'p> Hook<'p> for Replay<'p> {
    const FLAG: u32 = FLAGGED;
    #[inline(always)]
    fn get(&mut self) -> Option<&mut Replay<'p>> {
        Some(self)
    }
}

/// The derivation loop's replay state (a job's).
struct Replay<'p> {
    /// The edits replayed.
    plan: &'p EditPlan,
    /// The trie states of the shapes on the derivation stack that are on
    /// an exact target's path (flagged there), in step with it; the
    /// shapes off every path have none.
    stack: Vec<u32>,
    /// The forced regions, innermost last: where a shape's own edits
    /// force a material or mesh, its subtree's shapes are those pushed on
    /// the derivation stack at or above the height (`floor`) its block
    /// was pushed at, until a shape below it is popped. The first is the
    /// job root's forcing, at height 0 (never left).
    regions: Vec<(usize, Forced)>,
    /// The innermost region's height and forcing, and whether it forces
    /// a mesh (every block in it then has its inserts replaced).
    floor: usize,
    forced: Forced,
    meshed: bool,
    /// Whether every shape off the exact targets' paths is looked at:
    /// some edit names shapes by key or query, or a mesh is forced.
    attend: bool,
    /// The forcing of the shape at hand and whether its own edits
    /// changed it (`Engine::own_edits`).
    shape: (Forced, bool),
    /// Scratch: the trie states of the block at hand, from its start, and
    /// its ordinals counted (`EditPlan::block_states`).
    block: Vec<u32>,
    counts: Vec<(usize, replay::Label, u32)>,
    /// Scratch: the edits of the shape at hand, the tags on its path, the
    /// indices a query pattern reads there.
    matched: Vec<(u32, replay::Action)>,
    path: replay::PathScratch,
    /// Forced materials remembered: (attributes, material, result).
    memo: Vec<(AttrId, crate::ir::MaterialId, AttrId)>,
}

impl<'p> Replay<'p> {
    /// The state of a job whose root's replay state is `root`.
    fn new(plan: &'p EditPlan, root: Carried) -> Replay<'p> {
        Replay {
            plan,
            stack: vec![root.state],
            regions: vec![(0, root.forced)],
            floor: 0,
            forced: root.forced,
            meshed: root.forced.mesh.is_some(),
            attend: plan.names_any() || root.forced.mesh.is_some(),
            shape: (root.forced, false),
            block: Vec::new(),
            counts: Vec::new(),
            matched: Vec::new(),
            path: replay::PathScratch::default(),
            memo: Vec::new(),
        }
    }

    /// A shape was popped off the derivation stack, which now holds
    /// `height` entries, below the innermost region's floor: leave the
    /// regions it is not in.
    #[cold]
    #[inline(never)]
    fn leave(&mut self, height: usize) {
        while self.regions.len() > 1 && self.regions.last().is_some_and(|r| height < r.0) {
            self.regions.pop();
        }
        (self.floor, self.forced) = self.regions.last().copied().unwrap_or_default();
        self.meshed = self.forced.mesh.is_some();
        self.attend = self.plan.names_any() || self.meshed;
    }

    /// Open a forced region (`forced`) for the shapes the derivation
    /// stack holds from `floor` on.
    fn open(&mut self, floor: usize, forced: Forced) {
        self.regions.push((floor, forced));
        (self.floor, self.forced) = (floor, forced);
        self.meshed = forced.mesh.is_some();
        self.attend = self.plan.names_any() || self.meshed;
    }
}

/// A shape's replay state, carried down from its parent's.
#[derive(Clone, Copy)]
struct Carried {
    /// Its state in the exact targets' trie (`replay::NONE`: off every
    /// target's path, and so is its subtree).
    state: u32,
    /// What its ancestors' edits force on it.
    forced: Forced,
}

/// After the shape at `at` (trie state `state`, forcing `forced`: its own
/// edits over its ancestors') made the block `nodes[start..]`, whose shapes
/// the derivation stack took as `pushed` (last first, from height `floor`
/// on), when the block needs
/// anything of the replay: the forced mesh on the block's inserts; a forced
/// region for its shapes where the shape's own edits force (`opens`); on a
/// target's path, each shape's trie state, and those still on a path
/// flagged. A forced material needs nothing more: the shape's attributes
/// carry it to the block and its rules' materials were skipped. Off every
/// path, a shape is matched only when a key target or a query may name it
/// (`EditPlan::may_name`, asked when it is popped).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn replay_block(
    r: &mut Replay,
    nodes: &mut [Node],
    at: u32,
    start: usize,
    pushed: &mut [u32],
    floor: usize,
    state: u32,
    forced: Forced,
    opens: bool,
) {
    let block = &mut nodes[start..];
    if let Some(a) = forced.mesh {
        for n in block.iter_mut() {
            if let NodeKind::Insert { .. } = n.kind {
                n.kind = NodeKind::Insert { asset: a };
            }
        }
    }
    if opens && !pushed.is_empty() {
        r.open(floor, forced);
    }
    if state == replay::NONE || pushed.is_empty() {
        return;
    }
    // Each node's state from its parent's (the shape or a command of the
    // block before it).
    let plan = r.plan;
    plan.block_states(
        block,
        start,
        at as usize,
        state,
        &mut r.block,
        &mut r.counts,
    );
    for e in pushed.iter_mut() {
        let state = r.block[*e as usize - start];
        if state != replay::NONE {
            *e |= FLAGGED;
            r.stack.push(state);
        }
    }
}

impl Engine<'_> {
    /// The edits whose target is the shape `job.nodes[at]` (trie state
    /// `state`), resolved and applied to the shape: its hits recorded;
    /// `None` when one removes it (recorded in `job.removed`); else a
    /// forced material set on its attributes (its subtree inherits them,
    /// the rules' materials below are skipped: `Scratch::keep_material`),
    /// a pin on its key and a forced alternative in `s.force`, and its
    /// forcing in `r.shape`, with whether its own edits changed it (its
    /// block opens a forced region); false when removed.
    #[inline(never)]
    fn own_edits(
        &self,
        r: &mut Replay,
        job: &mut Job,
        at: u32,
        state: u32,
        s: &mut Scratch,
    ) -> bool {
        let here = at as usize;
        let mut forced = r.forced;
        r.matched.clear();
        r.plan.matches(
            &job.nodes,
            here,
            state,
            &s.prefix.tags,
            &mut r.path,
            &mut r.matched,
        );
        r.shape = (forced, false);
        if r.matched.is_empty() {
            return true;
        }
        job.hits.extend(r.matched.iter().map(|&(id, _)| (id, at)));
        let own = Own::of(&r.matched);
        r.matched.clear();
        if own.remove {
            job.removed.push(at);
            return false;
        }
        if let Some(m) = own.material {
            match self.forced_material(r, job.nodes[here].attrs, m) {
                Ok(a) => job.nodes[here].attrs = a,
                Err(e) => job.failures.push((at, e)),
            }
        }
        if let Some(k) = own.pin {
            job.nodes[here].key = k;
        }
        s.force = own.force;
        let opens = own.material.is_some() || own.mesh.is_some();
        if opens {
            forced.material = own.material.or(forced.material);
            forced.mesh = own.mesh.or(forced.mesh);
            s.keep_material = forced.material.is_some();
        }
        r.shape = (forced, opens);
        true
    }

    /// The attributes `attrs` with material `m` forced by an edit,
    /// remembered (a forced floor's hundreds of parts share a few sets).
    fn forced_material(
        &self,
        r: &mut Replay,
        attrs: AttrId,
        m: crate::ir::MaterialId,
    ) -> Result<AttrId, ShapeError> {
        if let Some(&(_, _, a)) = r.memo.iter().find(|e| e.0 == attrs && e.1 == m) {
            return Ok(a);
        }
        let a = self.set_attribute(&Op::Material(m), None, attrs)?;
        if r.memo.len() >= 16 {
            r.memo.remove(0);
        }
        r.memo.push((attrs, m, a));
        Ok(a)
    }

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
    // Attributes (crate::attributes): each node of the block takes those
    // set before it was made; a shape whose rule made nothing keeps those
    // its rule left.
    if inherited != AttrId(0) || !s.attr_marks.is_empty() {
        apply_attributes(out, block, at, inherited, s.attrs, &s.attr_marks);
    }
    // A shape's direct children count its edges, for counting from the end.
    let mut j = block;
    while j < out.len() {
        out[j].count = s.edge;
        j += 1 + out[j].children_len as usize
            * usize::from(matches!(out[j].kind, NodeKind::Command { .. }));
    }
}

/// Give each node of the block `out[block..]` the attributes set before it
/// was made (`marks`: from which position on, which; before the first,
/// `inherited`); a shape whose rule made nothing (the shape at `at`) keeps
/// those its rule left, `last`.
#[cold]
#[inline(never)]
fn apply_attributes(
    out: &mut [Node],
    block: usize,
    at: u32,
    inherited: AttrId,
    last: AttrId,
    marks: &[(usize, AttrId)],
) {
    // The block in runs, one per mark: a node takes the last mark at or
    // before it (a mark before the run's start only changes what the
    // next run takes).
    let mut current = inherited;
    let mut from = block;
    for &(to, a) in marks {
        let to = to.clamp(from, out.len());
        out[from..to].iter_mut().for_each(|n| n.attrs = current);
        (from, current) = (to, a);
    }
    if let Some(rest) = out.get_mut(from..) {
        rest.iter_mut().for_each(|n| n.attrs = current);
    }
    if out.len() == block
        && let Some(n) = out.get_mut(at as usize)
    {
        n.attrs = last;
    }
}

/// Append a job's slice (its nodes but the root) to `out`; `root` is the
/// cut shape's index in `out`'s numbering.
/// Returns where the slice starts.
fn splice(
    out: &mut Vec<Node>,
    outlines: &mut Vec<Arc<Outline>>,
    job: &mut Job,
    root: u32,
    failures: &mut Vec<(u32, ShapeError)>,
    removed: &mut Vec<u32>,
    hits: &mut Vec<(u32, u32)>,
) -> u32 {
    let base = out.len() as u32; // job index k goes to base + k - 1
    let at = |k: u32| if k == 0 { root } else { base + k - 1 };
    job.roots_kind = (job.nodes[0].kind, job.nodes[0].children_len);
    job.root_attrs = job.nodes[0].attrs;
    job.root_key = job.nodes[0].key;
    for (k, e) in job.failures.drain(..) {
        failures.push((at(k), e));
    }
    removed.extend(job.removed.iter().map(|&k| at(k)));
    hits.extend(job.hits.iter().map(|&(id, k)| (id, at(k))));
    for (k, mut n) in job.nodes.drain(..).enumerate().skip(1) {
        renumber(&mut n, &job.outlines, outlines);
        if k as u32 == n.parent_offset {
            n.parent_offset = base + k as u32 - 1 - root;
        }
        out.push(n);
    }
    base
}

/// Move a node's outline from a job's table to the final one (the next
/// entry: one per node, in node order).
/// The error of a roof or taper that could not be made: the roof's own
/// reason, or the geometry that takes none.
fn roof_error(
    symbol: String,
    op: &'static str,
    geometry: &Geom,
    e: Option<crate::roof::RoofError>,
) -> ShapeError {
    match e {
        Some(error) => ShapeError::Roof { symbol, error },
        None => ShapeError::WrongGeometry {
            symbol,
            op,
            geometry: geometry.describe(),
        },
    }
}

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
    hits.sort_unstable();
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

/// Give the shape `n`, whose rule made nothing, the scope and geometry its
/// rule left. Returns whether the outline table is still one entry per
/// node in node order ([`set_geometry`]).
#[cold]
#[inline(never)]
fn finalize(n: &mut Node, outlines: &mut Vec<Arc<Outline>>, scope: Scope, g: &Geom) -> bool {
    n.scope = scope;
    set_geometry(n, outlines, g)
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
