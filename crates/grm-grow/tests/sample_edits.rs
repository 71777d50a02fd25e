//! Sample mode's persistent edits (docs/edits.md, "Sample mode"): the
//! Calder tree of examples/ sampled with key-targeted edits replayed
//! inside the sampler (`SampleRequest::edits`): a forced alternative is
//! taken, a removed subtree is gone, a set parameter changes the bone,
//! a pin keeps the draws, the model is the same on any thread count, and
//! each class comes out of the classification.

mod common;
use common::*;

use grm_edits::{EditClass, EditsFile, Op, Target};
use grm_grow::sample::{SampleRequest, Sampled, sample};
use grm_sample::{SampleOptions, SampledModel, Schedule};

const SYSTEM: &str = "CalderTree";

/// A short search: 6 generations, 12 -> 6 particles.
fn short(seed: u32, threads: usize) -> SampleOptions {
    SampleOptions {
        seed,
        threads,
        schedule: Schedule {
            generations: 6,
            particles_start: 12,
            particles_end: 6,
            heuristic_scale: 0.013,
            heuristic_until: 3,
        },
        ..SampleOptions::default()
    }
}

struct Calder {
    checked: grm_sema::Checked,
    compiled: grm_compile::CompiledSystem,
    curves: grm_guide::Curves,
}

impl Calder {
    fn new() -> Calder {
        let checked = checked("calder_tree.grm");
        let compiled = compile(&checked);
        let curves =
            grm_guide::Curves::load(example_path("calder_tree.curves.json")).expect("curves");
        Calder {
            checked,
            compiled,
            curves,
        }
    }

    fn run(&self, opts: SampleOptions, edits: Option<&EditsFile>) -> Sampled {
        let request = SampleRequest {
            edits: edits.map(|f| &f.edits[..]),
            ..SampleRequest::new(&self.curves, opts)
        };
        sample(system(&self.checked), &self.compiled, &request).expect("samples")
    }

    fn symbol(&self, name: &str) -> u32 {
        self.compiled
            .symbol_names
            .iter()
            .position(|n| n == name)
            .expect("symbol") as u32
    }

    /// The alternatives of `symbol`'s (one, normal) group.
    fn alts(&self, name: &str) -> (u32, u32) {
        let g = &self.compiled.groups_of(self.symbol(name))[0];
        (g.first_alt, g.alt_count)
    }
}

fn model(s: &Sampled) -> &SampledModel {
    &s.shown().models()[0]
}

fn file(edits: &[(Target, Op)]) -> EditsFile {
    let mut f = EditsFile::default();
    for (t, op) in edits {
        f.add(SYSTEM, t.clone(), op.clone()).expect("an id");
    }
    f
}

/// The node of `m`'s tree made with `key`.
fn node(m: &SampledModel, key: u32) -> Option<&grm_sample::TreeNode> {
    m.tree.nodes.iter().find(|n| n.key == key)
}

/// The first node of symbol `sym` whose parent is node `parent`, in
/// ordinal order.
fn child_of(m: &SampledModel, parent: u32, sym: u32) -> Vec<&grm_sample::TreeNode> {
    let mut kids: Vec<_> = m
        .tree
        .nodes
        .iter()
        .filter(|n| n.symbol == sym && n.parent.map(|p| p.0) == Some(parent))
        .collect();
    kids.sort_by_key(|n| n.parent.map(|p| p.1));
    kids
}

/// The keys of the root's path every particle shares: START's branch and
/// that branch's branchOrLeaf (one production each above it).
fn first_keys(c: &Calder, m: &SampledModel) -> (u32, u32) {
    let branch = c.symbol("branch");
    let bol = c.symbol("branchOrLeaf");
    let start = m
        .tree
        .nodes
        .iter()
        .position(|n| n.parent.is_some())
        .unwrap() as u32;
    let b = child_of(m, start, branch)[0];
    let bi = m
        .tree
        .nodes
        .iter()
        .position(|n| std::ptr::eq(n, b))
        .unwrap() as u32;
    let l = child_of(m, bi, bol)[0];
    (b.key, l.key)
}

fn reports(s: &Sampled) -> Vec<(u32, EditClass, bool)> {
    s.edits
        .as_ref()
        .expect("classified")
        .iter()
        .map(|r| (r.id, r.class, r.replayed))
        .collect()
}

#[test]
fn no_edits_and_an_empty_file_are_the_plain_sampler() {
    let c = Calder::new();
    let plain = c.run(short(7, 1), None);
    let empty = c.run(short(7, 1), Some(&EditsFile::default()));
    let (m, e) = (model(&plain), model(&empty));
    assert_eq!(m.string, e.string);
    assert_eq!(m.bone_list(), e.bone_list());
    assert!(plain.edits.is_none() && m.edits.is_none());
    assert_eq!(empty.edits.as_deref(), Some(&[][..]));
    // A key no module has changes nothing and is dormant.
    let f = file(&[(Target::Key(0xdead_beef), Op::Remove)]);
    let gone = c.run(short(7, 1), Some(&f));
    assert_eq!(model(&gone).string, m.string);
    assert_eq!(
        reports(&gone),
        vec![(1, EditClass::StructurallyInvalid, false)]
    );
}

#[test]
fn a_forced_alternative_is_taken() {
    let c = Calder::new();
    let plain = c.run(short(7, 1), None);
    let (_, bol) = first_keys(&c, model(&plain));
    let (first, count) = c.alts("branchOrLeaf");
    assert_eq!(count, 2);
    for k in 1..=2u32 {
        let f = file(&[(Target::Key(bol), Op::Force { alternative: k })]);
        let s = c.run(short(7, 1), Some(&f));
        let m = model(&s);
        let n = node(m, bol).expect("the forced module is in the model");
        assert_eq!(n.alt, Some(first + k - 1), "force {k}");
        assert_eq!(reports(&s), vec![(1, EditClass::Valid, true)]);
        if k == 1 {
            // A leaf at the first tip: the trunk's one bone is the whole
            // skeleton.
            assert_eq!(m.skeleton_bones, 1);
        }
    }
}

/// The first branchOrLeaf forced to grow a branch and two maybeBranch:
/// the force, that branchOrLeaf's key, the run with it and the key of its
/// first maybeBranch.
fn forced_first_branch_or_leaf(c: &Calder) -> (Op, u32, Sampled, u32) {
    let force = Op::Force { alternative: 2 };
    let plain = c.run(short(7, 1), None);
    let (_, bol) = first_keys(c, model(&plain));
    let s = c.run(
        short(7, 1),
        Some(&file(&[(Target::Key(bol), force.clone())])),
    );
    let m = model(&s);
    let bi = m.tree.nodes.iter().position(|n| n.key == bol).unwrap() as u32;
    let kids = child_of(m, bi, c.symbol("maybeBranch"));
    assert_eq!(kids.len(), 2);
    let target = kids[0].key;
    (force, bol, s, target)
}

#[test]
fn a_removed_subtree_is_gone() {
    let c = Calder::new();
    let maybe = c.symbol("maybeBranch");
    let (force, bol, _, target) = forced_first_branch_or_leaf(&c);
    let f = file(&[
        (Target::Key(bol), force.clone()),
        (Target::Key(target), Op::Remove),
    ]);
    let s = c.run(short(7, 1), Some(&f));
    let m = model(&s);
    assert!(
        node(m, target).is_none(),
        "the removed module is not expanded"
    );
    assert!(!m.string.keys().contains(&target), "nor written");
    let bi = m.tree.nodes.iter().position(|n| n.key == bol).unwrap() as u32;
    assert_eq!(child_of(m, bi, maybe).len(), 1, "one maybeBranch is left");
    // Nothing below it: no node's ancestry passes through its key.
    for n in &m.tree.nodes {
        let mut p = n.parent.map(|p| p.0);
        while let Some(i) = p {
            assert_ne!(m.tree.nodes[i as usize].key, target);
            p = m.tree.nodes[i as usize].parent.map(|p| p.0);
        }
    }
    assert_eq!(
        reports(&s),
        vec![(1, EditClass::Valid, true), (2, EditClass::Valid, true)]
    );
}

/// A module an edit removed leaves a print in the sampled model's tree
/// (`DerivationTree::removed`, then `grm_grow::Tree::removed`): its
/// parent, symbol, key and place among the parent's children. From it,
/// when the key is lost, the retarget candidates start under the same
/// parent (the remaining `maybeBranch` there takes its place).
#[test]
fn a_removed_module_leaves_a_print_for_its_retarget() {
    use grm_grow::retarget::{Reason, TreeParts, candidates};
    let c = Calder::new();
    let maybe = c.symbol("maybeBranch");
    let (force, bol, forced, target) = forced_first_branch_or_leaf(&c);
    let fm = model(&forced);
    // The print the edit's part had while it was there.
    let ft = forced.tree_of(fm);
    let fparts = TreeParts::new(&ft, &c.compiled.symbol_names, &fm.interpretation);
    let before = fparts.print_of_key(target).expect("a print of the module");

    let f = file(&[
        (Target::Key(bol), force.clone()),
        (Target::Key(target), Op::Remove),
    ]);
    let s = c.run(short(7, 1), Some(&f));
    let m = model(&s);
    let bi = m.tree.nodes.iter().position(|n| n.key == bol).unwrap() as u32;
    // branch, maybeBranch (removed), maybeBranch: one expanded before it.
    assert_eq!(
        m.tree.removed,
        vec![grm_sample::RemovedModule {
            parent: bi,
            key: target,
            symbol: maybe,
            sibling: 1,
        }]
    );
    let t = s.tree_of(m);
    assert_eq!(t.removed.len(), 1);
    let parts = TreeParts::new(&t, &c.compiled.symbol_names, &m.interpretation);
    let print = parts
        .print_of_key(target)
        .expect("a print of the removed module");
    assert_eq!(print.label.as_deref(), Some("maybeBranch"));
    assert_eq!(print.ancestry, before.ancestry);
    assert!(print.centre_of_parent && print.centre.is_some());
    assert_eq!(print.sibling, Some(1));
    // As if its key were lost: the first candidate is the maybeBranch
    // left under the same parent, by ancestry.
    let lost = file(&[(Target::Key(0x0bad_c0de), Op::Remove)]);
    let cands = candidates(&parts, &lost.edits[0], &print, 4);
    let left = child_of(m, bi, maybe)[0].key;
    assert_eq!(cands[0].reason, Reason::Ancestry, "{cands:?}");
    assert_eq!(cands[0].target, Target::Key(left), "{cands:?}");
    assert_eq!(t.nodes[cands[0].node as usize].parent, Some(bi));
}

#[test]
fn a_set_parameter_changes_the_bone() {
    let c = Calder::new();
    let f_sym = c.symbol("F");
    let plain = c.run(short(7, 1), None);
    let pm = model(&plain);
    let (branch, _) = first_keys(&c, pm);
    let bn = node(pm, branch).unwrap();
    // The first bone's `F(1)`: a module of the first branch's successor.
    let fk = (bn.modules.start..bn.modules.end)
        .find(|&i| pm.string.sym(i as usize) == f_sym)
        .map(|i| pm.string.keys()[i as usize])
        .unwrap();
    let len = |m: &SampledModel| {
        let n = node(m, branch).unwrap();
        let b = &m.interpretation.bones[n.bones.start as usize];
        (b.tip - b.base).length()
    };
    let f_of = |m: &SampledModel| {
        let i = m.string.keys().iter().position(|&k| k == fk).unwrap();
        m.string.get(i).1[0]
    };
    // branch -> scale(0.9..1.3) ... scale(0.7) trunk F(1): 0.63 to 0.91.
    let before = len(pm);
    assert!((0.6..0.95).contains(&before), "{before}");
    let f = file(&[(
        Target::Key(fk),
        Op::Set {
            name: "1".into(),
            value: 5.0,
        },
    )]);
    let s = c.run(short(7, 1), Some(&f));
    let m = model(&s);
    assert_eq!(f_of(m), 5.0);
    let after = len(m);
    assert!((3.1..4.6).contains(&after), "{after}");
    assert_eq!(reports(&s), vec![(1, EditClass::Valid, true)]);
    // An offset adds to what the production computed.
    let f = file(&[(
        Target::Key(fk),
        Op::Offset {
            name: "1".into(),
            by: 0.5,
        },
    )]);
    let s = c.run(short(7, 1), Some(&f));
    assert_eq!(f_of(model(&s)), 1.5);
    // On the first branch, `1` names every symbol's first parameter in
    // its subtree (the F, and scale, rotx, roty's too): every F is 2
    // (the search stops early with such bones: one may be all).
    let f = file(&[(
        Target::Key(branch),
        Op::Set {
            name: "1".into(),
            value: 2.0,
        },
    )]);
    let s = c.run(short(7, 1), Some(&f));
    let m = model(&s);
    let fs: Vec<f32> = (0..m.string.len())
        .filter(|&i| m.string.sym(i) == f_sym)
        .map(|i| m.string.get(i).1[0])
        .collect();
    assert!(!fs.is_empty() && fs.iter().all(|&x| x == 2.0), "{fs:?}");
}

#[test]
fn a_pin_keeps_the_draws() {
    let c = Calder::new();
    let plain = c.run(short(7, 1), None);
    let (branch, _) = first_keys(&c, model(&plain));
    // Other searches with the same seed (so the same keys).
    let others: Vec<SampleOptions> = vec![
        SampleOptions {
            candidates: 1,
            ..short(7, 1)
        },
        SampleOptions {
            candidates: 5,
            ..short(7, 1)
        },
        SampleOptions {
            schedule: Schedule {
                generations: 5,
                particles_start: 9,
                particles_end: 5,
                heuristic_scale: 0.013,
                heuristic_until: 2,
            },
            ..short(7, 1)
        },
    ];
    let first_bone = |m: &SampledModel| {
        let n = node(m, branch).unwrap();
        m.bone_list()[n.bones.start as usize]
    };
    // Unpinned, the first bone is drawn by the particle that grew it.
    let a = first_bone(model(&plain));
    let differ = others
        .iter()
        .filter(|o| first_bone(model(&c.run((*o).clone(), None))) != a)
        .count();
    assert!(differ > 0, "another search draws another first bone");
    // Pinned to its key, it is the same in every search, and so is every
    // module of its subtree that both searches grew (it draws from its
    // key): the same production and parameters (how far each search
    // grew the subtree, and what it left to wrap-up, is the search's).
    let f = file(&[(Target::Key(branch), Op::Pin { key: branch })]);
    let sa = c.run(short(7, 1), Some(&f));
    assert_eq!(reports(&sa), vec![(1, EditClass::Valid, true)]);
    for o in others {
        let sb = c.run(o, Some(&f));
        let (ma, mb) = (model(&sa), model(&sb));
        assert_eq!(first_bone(ma), first_bone(mb));
        let mut shared = 0;
        for n in &ma.tree.nodes {
            // (One search may have left it to wrap-up.)
            if let Some(o) = node(mb, n.key).filter(|o| o.kind == n.kind) {
                assert_eq!((n.alt, &n.params), (o.alt, &o.params));
                shared += 1;
            }
        }
        assert!(shared > 2, "{shared}");
    }
}

#[test]
fn edits_replay_the_same_on_any_thread_count() {
    let c = Calder::new();
    let plain = c.run(short(11, 1), None);
    let pm = model(&plain);
    let (branch, bol) = first_keys(&c, pm);
    // Keys drawn from the plain model's tree (some are gone once the
    // first edits change it: dormant, the same on every thread count).
    let keys: Vec<u32> = pm
        .tree
        .nodes
        .iter()
        .skip(3)
        .step_by(5)
        .map(|n| n.key)
        .collect();
    let mut edits = vec![
        (Target::Key(bol), Op::Force { alternative: 2 }),
        (
            Target::Key(branch),
            Op::Offset {
                name: "1".into(),
                by: 0.25,
            },
        ),
    ];
    for (j, &k) in keys.iter().enumerate() {
        edits.push((
            Target::Key(k),
            match j % 3 {
                0 => Op::Remove,
                1 => Op::Pin { key: k ^ 1 },
                _ => Op::Force { alternative: 1 },
            },
        ));
    }
    let f = file(&edits);
    let one = c.run(short(11, 1), Some(&f));
    for threads in [2, 4] {
        let many = c.run(short(11, threads), Some(&f));
        let (a, b) = (model(&one), model(&many));
        assert_eq!(a.string, b.string, "{threads} threads");
        assert_eq!(a.string.keys(), b.string.keys());
        assert_eq!(a.bone_list(), b.bone_list());
        assert_eq!(one.edits, many.edits);
    }
    assert_ne!(model(&one).string, pm.string, "the edits change the model");
}

#[test]
fn each_class() {
    let c = Calder::new();
    let plain = c.run(short(7, 1), None);
    let (branch, bol) = first_keys(&c, plain.shown().models().first().unwrap());
    let maybe = c.symbol("maybeBranch");
    // Both maybeBranch of the first branchOrLeaf grow a branch; the
    // second pinned to the first's key grows the first's subtree, so the
    // first's branch key is made twice: an edit on it is ambiguous.
    let forced = file(&[(Target::Key(bol), Op::Force { alternative: 2 })]);
    let s = c.run(short(7, 1), Some(&forced));
    let m = model(&s);
    let bi = m.tree.nodes.iter().position(|n| n.key == bol).unwrap() as u32;
    let kids = child_of(m, bi, maybe);
    let (mb1, mb2) = (kids[0].key, kids[1].key);
    // mb2 pinned to mb1's key: both grow the same production (forced,
    // or wrap-up's one) and so write modules with the same keys.
    let pinned = file(&[
        (Target::Key(bol), Op::Force { alternative: 2 }),
        (Target::Key(mb1), Op::Force { alternative: 1 }),
        (Target::Key(mb2), Op::Force { alternative: 1 }),
        (Target::Key(mb2), Op::Pin { key: mb1 }),
    ]);
    let s = c.run(short(7, 1), Some(&pinned));
    let m = model(&s);
    let n1 = node(m, mb1).expect("mb1");
    let n2 = m
        .tree
        .nodes
        .iter()
        .filter(|n| n.key == mb1)
        .nth(1)
        .expect("mb2 carries mb1's key");
    assert_eq!(n1.alt, n2.alt);
    let twice = m.string.keys()[n1.modules.start as usize];
    assert_eq!(twice, m.string.keys()[n2.modules.start as usize]);
    let f = file(&[
        (Target::Key(bol), Op::Force { alternative: 2 }),
        (Target::Key(mb1), Op::Force { alternative: 1 }),
        (Target::Key(mb2), Op::Force { alternative: 1 }),
        (Target::Key(mb2), Op::Pin { key: mb1 }),
        (
            Target::Key(twice),
            Op::Material {
                name: "bark".into(),
            },
        ),
        (Target::Key(0x0bad_f00d), Op::Remove),
        (Target::Key(branch), Op::Force { alternative: 3 }),
        (
            Target::Key(branch),
            Op::Set {
                name: "girth".into(),
                value: 1.0,
            },
        ),
        (
            Target::Key(branch),
            Op::Material {
                name: "bark".into(),
            },
        ),
        (
            Target::Exact("{START, 1, branch}".parse().unwrap()),
            Op::Remove,
        ),
    ]);
    let s = c.run(short(7, 1), Some(&f));
    let r = s.edits.as_ref().unwrap();
    let class = |id: u32| {
        let x = r.iter().find(|x| x.id == id).unwrap();
        (x.class, x.replayed)
    };
    assert_eq!(class(1), (EditClass::Valid, true));
    assert_eq!(class(2), (EditClass::Valid, true));
    assert_eq!(class(3), (EditClass::Valid, true));
    assert_eq!(class(4), (EditClass::Valid, true));
    // Found twice (pinned lineages share keys): reported, not replayed.
    assert_eq!(class(5), (EditClass::Ambiguous, false));
    assert_eq!(r[4].modules, 2);
    assert_eq!(class(6), (EditClass::StructurallyInvalid, false));
    // `branch` has one alternative; no symbol has a `girth`.
    assert_eq!(class(7), (EditClass::Stale, false));
    assert_eq!(class(8), (EditClass::Stale, false));
    // Found, but not replayed in sample mode (reported, never silent).
    assert_eq!(class(9), (EditClass::Valid, false));
    assert!(r[8].detail.contains("sample mode"), "{}", r[8].detail);
    assert_eq!(class(10), (EditClass::SemanticallyInvalid, false));
}

/// A key edit's recorded symbol (`Edit::symbol`, version 3) in sample
/// mode: with the module's own symbol it replays as without one; with
/// another the module made with the key is left as it is (the plain
/// model) and the edit is reported.
#[test]
fn a_key_edit_with_another_symbol_names_nothing() {
    let c = Calder::new();
    let plain = c.run(short(7, 1), None);
    let (b, _) = first_keys(&c, model(&plain));
    let with = |symbol: Option<&str>| {
        let mut f = file(&[(Target::Key(b), Op::Remove)]);
        f.edits[0].symbol = symbol.map(str::to_owned);
        f
    };
    let removed = c.run(short(7, 1), Some(&with(None)));
    assert!(node(model(&removed), b).is_none());
    let own = c.run(short(7, 1), Some(&with(Some("branch"))));
    assert_eq!(model(&own).string, model(&removed).string);
    assert_eq!(reports(&own), vec![(1, EditClass::Valid, true)]);
    for symbol in ["branchOrLeaf", "Nope"] {
        let other = c.run(short(7, 1), Some(&with(Some(symbol))));
        assert_eq!(model(&other).string, model(&plain).string, "{symbol}");
        assert_eq!(
            reports(&other),
            vec![(1, EditClass::StructurallyInvalid, false)],
            "{symbol}"
        );
    }
}
