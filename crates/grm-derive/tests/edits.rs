//! Persistent edits replayed in derive mode (docs/edits.md; grm_derive::
//! edits): remove, set, offset, force and pin by identity key, checked
//! against the plain derivation: the edited part shows the edit, every
//! other module is the same, bit for bit, key included; the same output
//! for 1, 2 and 4 threads.

#![allow(clippy::needless_range_loop)]

mod common;

use common::*;
use grm_compile::CompiledSystem;
use grm_derive::{
    DeriveLimits, DeriveOptions, EditAction, EditPlan, Engine, ModuleString, SlotTarget,
    StepRecord, ValueOp,
};
use grm_testkit::Rng;

/// A derivation's strings (0 ..= n) and, per string, whether each module
/// descends from (or is) a module made with one of `keys`.
struct Tracked {
    strings: Vec<ModuleString>,
    inside: Vec<Vec<bool>>,
    /// Per step (1 ..= n), what it decided.
    records: Vec<StepRecord>,
}

impl Tracked {
    fn last(&self) -> &ModuleString {
        self.strings.last().expect("strings")
    }
    fn last_inside(&self) -> &[bool] {
        self.inside.last().expect("flags")
    }
}

/// Derive `n` steps with `engine` (its edits, if any, replayed) on the
/// edited road, tracking the subtrees of `keys`.
fn track(engine: &Engine<'_>, n: u32, seed: u32, keys: &[u32]) -> Tracked {
    let (axiom, mut state) = engine.edited_axiom(seed).expect("axiom");
    let first: Vec<bool> = axiom.keys().iter().map(|k| keys.contains(k)).collect();
    let mut t = Tracked {
        strings: vec![axiom],
        inside: vec![first],
        records: Vec::new(),
    };
    for it in 1..=n {
        let mut rec = StepRecord::default();
        let next = engine
            .edited_step(
                &mut state,
                t.last(),
                it,
                seed,
                &DeriveLimits::default(),
                Some(&mut rec),
            )
            .expect("step");
        assert!(next.is_well_formed());
        let flags = t.last_inside();
        let mut out = Vec::with_capacity(next.len());
        let mut o = 0usize;
        for (i, d) in rec.decided.iter().enumerate() {
            let kept = rec.kept[i] as usize;
            for j in o..o + kept {
                // A copy keeps its key and its flag.
                let born = d.is_some() && keys.contains(&next.keys()[j]);
                out.push(flags[i] || born);
            }
            o += kept;
        }
        assert_eq!(o, next.len());
        t.strings.push(next);
        t.inside.push(out);
        t.records.push(rec);
    }
    t
}

/// The modules of `s` as (symbol, parameter bits, key), where `keep`.
fn modules(s: &ModuleString, keep: impl Fn(usize) -> bool) -> Vec<(u32, Vec<u32>, u32)> {
    (0..s.len())
        .filter(|&i| keep(i))
        .map(|i| {
            let (sym, p) = s.get(i);
            (sym, p.iter().map(|x| x.to_bits()).collect(), s.keys()[i])
        })
        .collect()
}

fn plain(c: &CompiledSystem) -> Engine<'_> {
    Engine::new(c, 1).expect("engine").with_keys(true)
}

fn edited<'c>(c: &'c CompiledSystem, threads: usize, plan: EditPlan) -> Engine<'c> {
    Engine::new(c, threads)
        .expect("engine")
        .with_min_chunk(3)
        .with_edits(plan)
}

/// The final string of an edited derivation on 1, 2 and 4 threads (small
/// chunks, so pieces with and without tags side by side) and on one
/// thread with the default chunks, checked equal; through `derive` and
/// `derive_edited`.
fn final_string(c: &CompiledSystem, n: u32, seed: u32, plan: &EditPlan) -> ModuleString {
    let opts = DeriveOptions {
        iterations: n,
        seed,
        limits: DeriveLimits::default(),
    };
    let mut out: Option<ModuleString> = None;
    // Threads 0: one thread, the default chunks (one piece of the edited
    // rewrite per 4,096 modules); the others pieces of 3 modules.
    for threads in [0, 1, 2, 4] {
        let e = match threads {
            0 => Engine::new(c, 1).expect("engine").with_edits(plan.clone()),
            t => edited(c, t, plan.clone()),
        };
        let (d, _) = e.derive_edited(&opts, &mut |_| {}).expect("derive");
        let again = e.derive(&opts, &mut |_| {}).expect("derive");
        assert_eq!(d.string, again.string);
        match &out {
            None => out = Some(d.string),
            Some(o) => assert_eq!(*o, d.string, "{threads} threads"),
        }
    }
    out.expect("derived")
}

const TREE: &str = "system T {
    iterations = 4;
    module A(len: float, w: float);
    axiom A(1, 0.5);
    A(l, w) -> F(l) [ + A(l * 0.8, w * 0.7) ] [ - A(l * 0.6, w * 0.7) ] A(l * 0.9, w);
    F(l) -> F(l * 1.1);
}";

/// The key of the `k`-th module of symbol `name` in string `it` of `t`.
fn key_of(c: &CompiledSystem, t: &Tracked, it: usize, name: &str, k: usize) -> u32 {
    let sym = c
        .symbol_names
        .iter()
        .position(|n| n == name)
        .expect("symbol") as u32;
    let s = &t.strings[it];
    let i = (0..s.len())
        .filter(|&i| s.sym(i) == sym)
        .nth(k)
        .expect("module");
    s.keys()[i]
}

#[test]
fn no_edits_is_the_plain_derivation() {
    let c = inline(TREE);
    let opts = DeriveOptions::from_system(&c);
    let want = plain(&c).derive(&opts, &mut |_| {}).expect("derive");
    let e = Engine::new(&c, 1)
        .expect("engine")
        .with_keys(true)
        .with_edits(EditPlan::new());
    assert!(e.edit_plan().is_none());
    let (got, outcome) = e.derive_edited(&opts, &mut |_| {}).expect("derive");
    assert_eq!(got.string, want.string);
    assert_eq!(outcome, Default::default());
    // A plan whose key no module has: the same string too.
    let mut p = EditPlan::new();
    p.add(0x1234_5678, 1, EditAction::Remove);
    assert_eq!(final_string(&c, 4, opts.seed, &p), want.string);
}

#[test]
fn removing_a_branch_removes_its_subtree_and_nothing_else() {
    let c = inline(TREE);
    let base = track(&plain(&c), 4, 0, &[]);
    for (it, k) in [(1, 1), (2, 0), (2, 3), (3, 5), (0, 0)] {
        let key = key_of(&c, &base, it, "A", k);
        let ref_run = track(&plain(&c), 4, 0, &[key]);
        let mut p = EditPlan::new();
        p.add(key, 1, EditAction::Remove);
        let got = final_string(&c, 4, 0, &p);
        let inside = ref_run.last_inside();
        assert!(inside.iter().any(|&x| x), "the branch has modules");
        let want = modules(ref_run.last(), |i| !inside[i]);
        assert_eq!(modules(&got, |_| true), want, "A {k} of string {it}");
        let (_, outcome) = edited(&c, 1, p)
            .derive_edited(&DeriveOptions::from_system(&c), &mut |_| {})
            .expect("derive");
        let hits = outcome.hits(key).expect("found");
        assert_eq!(hits.modules, 1);
        assert_eq!(c.symbol_names[hits.symbol as usize], "A");
    }
}

/// Per symbol, where parameter `index` (from 0) of `words` words is.
fn slot(c: &CompiledSystem, name_of: impl Fn(&str) -> Option<u32>) -> Vec<SlotTarget> {
    c.symbol_names
        .iter()
        .map(|n| match name_of(n) {
            Some(word) => SlotTarget {
                word,
                words: 1,
                boolean: false,
            },
            None => SlotTarget::default(),
        })
        .collect()
}

#[test]
fn set_reaches_the_subtree_and_offset_the_generated_value() {
    let c = inline(TREE);
    let base = track(&plain(&c), 4, 0, &[]);
    // `w` is A's second word; F has no `w`.
    let w_slot = |c: &CompiledSystem| slot(c, |n| (n == "A").then_some(1));
    let key = key_of(&c, &base, 2, "A", 1);
    let ref_run = track(&plain(&c), 4, 0, &[key]);
    let inside = ref_run.last_inside();
    let mut p = EditPlan::new();
    let s = p.add_slot(w_slot(&c));
    p.add(
        key,
        3,
        EditAction::Value {
            slot: s,
            op: ValueOp::Set(2.5),
        },
    );
    let got = final_string(&c, 4, 0, &p);
    let want = ref_run.last();
    // Same structure and keys; outside the subtree the same bits; inside,
    // every A's `w` is 2.5 (its `len` untouched: `w` does not feed it).
    assert_eq!(got.parts().syms, want.parts().syms);
    assert_eq!(got.keys(), want.keys());
    let a = c.symbol_names.iter().position(|n| n == "A").expect("A") as u32;
    let mut seen = 0;
    for i in 0..got.len() {
        let (sym, gp) = got.get(i);
        let (_, wp) = want.get(i);
        if inside[i] && sym == a {
            assert_eq!(gp[0].to_bits(), wp[0].to_bits());
            assert_eq!(gp[1], 2.5);
            seen += 1;
        } else {
            assert_eq!(gp, wp, "module {i}");
        }
    }
    assert!(seen > 1, "the subtree's A modules");

    // A deeper edit wins in its own subtree: an offset on one A below.
    let deeper = (0..want.len())
        .find(|&i| inside[i] && want.sym(i) == a && want.keys()[i] != key)
        .map(|i| want.keys()[i])
        .expect("an A below");
    let s2 = p.add_slot(w_slot(&c));
    assert_eq!(s2, 1);
    p.add(
        deeper,
        2,
        EditAction::Value {
            slot: s,
            op: ValueOp::Offset(1.0),
        },
    );
    let got = final_string(&c, 4, 0, &p);
    let i = (0..got.len())
        .find(|&i| got.keys()[i] == deeper)
        .expect("kept");
    // The A was made in the subtree, from a parent whose w is 2.5: its
    // generated w (2.5 * 0.7, or 2.5 along the stem) plus 1, its own
    // offset replacing the set it inherits.
    let w = got.get(i).1[1];
    assert!(w == 2.5f32 * 0.7 + 1.0 || w == 3.5, "{w}");

    // Offset of a module of the final string: its generated value plus the
    // offset, everything else the same.
    let f = c.symbol_names.iter().position(|n| n == "F").expect("F") as u32;
    let j = (0..want.len())
        .rev()
        .find(|&i| want.sym(i) == f)
        .expect("F");
    let mut p = EditPlan::new();
    let s = p.add_slot(slot(&c, |n| (n == "F").then_some(0)));
    p.add(
        want.keys()[j],
        1,
        EditAction::Value {
            slot: s,
            op: ValueOp::Offset(-0.25),
        },
    );
    let got = final_string(&c, 4, 0, &p);
    for i in 0..got.len() {
        if i == j {
            assert_eq!(got.get(i).1[0], want.get(i).1[0] - 0.25);
        } else {
            assert_eq!(got.get(i), want.get(i));
        }
    }
}

const STOCHASTIC: &str = "system S {
    iterations = 5;
    seed = 3;
    axiom A(1);
    A(x) -> (1) F(x) [ + A(x * 0.9) ] [ - A(x * 0.9) ];
    A(x) -> (1) F(x) A(x * 0.8);
    A(x) -> (1) F(x) [ + B ] A(x * 0.7);
    B -> F(uniform(0, 1)) B;
}";

#[test]
fn force_picks_the_alternative_and_leaves_the_rest() {
    let c = inline(STOCHASTIC);
    let base = track(&plain(&c), 5, 3, &[]);
    let a = c.symbol_names.iter().position(|n| n == "A").expect("A") as u32;
    let group = c.groups_of(a)[0];
    let mut forced = 0;
    for it in 1..4usize {
        let s = &base.strings[it];
        for i in (0..s.len()).filter(|&i| s.sym(i) == a).take(3) {
            let key = s.keys()[i];
            let was = base.records[it].decided[i].expect("rewritten");
            let k = (was - group.first_alt + 1) % group.alt_count + 1;
            let mut p = EditPlan::new();
            p.add(key, 1, EditAction::Force(k));
            let e = edited(&c, 1, p.clone());
            let run = track(&e, 5, 3, &[key]);
            // The module with this key is rewritten by alternative k.
            let j = (0..run.strings[it].len())
                .find(|&j| run.strings[it].keys()[j] == key)
                .expect("made");
            assert_eq!(
                run.records[it].decided[j],
                Some(group.first_alt + k - 1),
                "iteration {it}"
            );
            // Outside its subtree, the same modules.
            let ref_run = track(&plain(&c), 5, 3, &[key]);
            let want = modules(ref_run.last(), |i| !ref_run.last_inside()[i]);
            let got = modules(run.last(), |i| !run.last_inside()[i]);
            assert_eq!(got, want);
            assert_ne!(
                modules(run.last(), |i| run.last_inside()[i]),
                modules(ref_run.last(), |i| ref_run.last_inside()[i])
            );
            assert_eq!(final_string(&c, 5, 3, &p), *run.last());
            forced += 1;
        }
    }
    assert!(forced >= 6);
    // An alternative past the group's: it races as written.
    let key = key_of(&c, &base, 2, "A", 0);
    let mut p = EditPlan::new();
    p.add(key, 1, EditAction::Force(9));
    assert_eq!(final_string(&c, 5, 3, &p), *base.last());
}

#[test]
fn pin_replays_another_keys_draws() {
    // Two A's made by one rewrite with the same parameter: the second,
    // pinned to the first's key, grows the first's subtree, module for
    // module.
    let src = "system P {
        iterations = 5;
        axiom A(1);
        A(x) -> (1) F(x) [ + A(x) ] [ - A(x) ];
        A(x) -> (2) F(x * uniform(0.5, 1.5)) A(x);
    }";
    let c = inline(src);
    let base = track(&plain(&c), 5, 0, &[]);
    let a = c.symbol_names.iter().position(|n| n == "A").expect("A") as u32;
    let plus = c.symbol_names.iter().position(|n| n == "+").expect("+") as u32;
    // The first string with two A's, each behind its own bracket.
    let (it, k1, k2) = (1..4)
        .find_map(|it| {
            let s = &base.strings[it];
            let firsts: Vec<usize> = (1..s.len())
                .filter(|&i| s.sym(i) == a && s.sym(i - 1) == plus)
                .collect();
            firsts.first().map(|&i| (it, s.keys()[i], s.keys()[i + 4]))
        })
        .expect("a branching");
    let s = &base.strings[it];
    let i2 = (0..s.len()).find(|&i| s.keys()[i] == k2).expect("second");
    assert_eq!(s.sym(i2), a);
    let mut p = EditPlan::new();
    p.add(k2, 1, EditAction::Pin(k1));
    let run = track(&edited(&c, 1, p.clone()), 5, 0, &[k1]);
    // In the final string, the modules below the pinned one are those
    // below k1, twice over.
    let below: Vec<_> = modules(run.last(), |i| run.last_inside()[i]);
    let once = modules(base.last(), |i| {
        track(&plain(&c), 5, 0, &[k1]).last_inside()[i]
    });
    assert_eq!(below.len(), 2 * once.len());
    assert_eq!(&below[..once.len()], &once[..]);
    assert_eq!(&below[once.len()..], &once[..]);
    assert_eq!(final_string(&c, 5, 0, &p), *run.last());
    // Pinned to its own key: nothing changes.
    let mut p = EditPlan::new();
    p.add(k2, 1, EditAction::Pin(k2));
    assert_eq!(final_string(&c, 5, 0, &p), *base.last());
}

#[test]
fn the_larger_id_wins_on_one_key_and_a_bracket_takes_its_branch() {
    let c = inline(TREE);
    let base = track(&plain(&c), 4, 0, &[]);
    let key = key_of(&c, &base, 2, "A", 2);
    let s = slot(&c, |n| (n == "A").then_some(1));
    let (mut a, mut b) = (EditPlan::new(), EditPlan::new());
    let (sa, sb) = (a.add_slot(s.clone()), b.add_slot(s));
    a.add(
        key,
        5,
        EditAction::Value {
            slot: sa,
            op: ValueOp::Set(9.0),
        },
    );
    a.add(
        key,
        2,
        EditAction::Value {
            slot: sa,
            op: ValueOp::Set(1.0),
        },
    );
    b.add(
        key,
        2,
        EditAction::Value {
            slot: sb,
            op: ValueOp::Set(1.0),
        },
    );
    b.add(
        key,
        5,
        EditAction::Value {
            slot: sb,
            op: ValueOp::Set(9.0),
        },
    );
    assert_eq!(final_string(&c, 4, 0, &a), final_string(&c, 4, 0, &b));
    // Removing a `[` removes its whole branch.
    let push = c.symbol_names.iter().position(|n| n == "[").expect("[") as u32;
    let s1 = &base.strings[1];
    let i = (0..s1.len()).find(|&i| s1.sym(i) == push).expect("[");
    let mut p = EditPlan::new();
    p.add(s1.keys()[i], 1, EditAction::Remove);
    let got = final_string(&c, 1, 0, &p);
    let text = got.to_text(&c.symbol_names);
    assert!(!text.contains('+'), "{text}");
    assert_eq!(text.matches('[').count(), text.matches(']').count());
}

#[test]
fn an_edit_that_makes_a_value_infinite_is_an_error() {
    let c = inline(TREE);
    let base = track(&plain(&c), 4, 0, &[]);
    let key = key_of(&c, &base, 1, "A", 0);
    let mut p = EditPlan::new();
    let s = p.add_slot(slot(&c, |n| (n == "A").then_some(0)));
    p.add(
        key,
        1,
        EditAction::Value {
            slot: s,
            op: ValueOp::Offset(f32::MAX),
        },
    );
    // The A's own len is f32::MAX; its child's, 0.8 of that plus the
    // offset again, overflows: R0204.
    let e = edited(&c, 1, p);
    let err = e
        .derive(&DeriveOptions::from_system(&c), &mut |_| {})
        .expect_err("overflows");
    assert_eq!(err.code(), grm_diag::Code::NonFiniteParameter);
}

/// A random bracketed, stochastic grammar over `A(x)`, `B(x)`, `F(x)`,
/// `+`, `-`, `[`, `]`, whose structure does not depend on parameter
/// values (no conditions, constant weights).
fn grammar(rng: &mut Rng) -> String {
    let module = |rng: &mut Rng| -> String {
        match rng.below(8) {
            0 => "F(x * 1.5)".into(),
            1 => "F(x + 1)".into(),
            2 => format!("A(x * {})", ["0.5", "0.8", "1.1"][rng.below(3usize)]),
            3 => "B(x - 0.5)".into(),
            4 => format!("[ {} A(x * 0.7) ]", rng.pick(&["+", "-"])),
            5 => "[ B(uniform(0, x + 1)) ]".into(),
            _ => rng.pick(&["+", "-"]).to_string(),
        }
    };
    let succ = |rng: &mut Rng| -> String {
        let n = 1 + rng.below(5usize);
        (0..n).map(|_| module(rng)).collect::<Vec<_>>().join(" ")
    };
    let mut s = String::from("system R {\n    axiom A(1) [ B(2) ] F(1);\n");
    for _ in 0..1 + rng.below(3usize) {
        s += &format!("    A(x) -> ({}) {};\n", 1 + rng.below(3u32), succ(rng));
    }
    if rng.below(3) != 0 {
        s += &format!("    B(x) -> {};\n", succ(rng));
    }
    if rng.below(2) == 0 {
        s += "    F(x) -> F(x * 1.01);\n";
    }
    s.push_str("}\n");
    s
}

/// Random grammars, random keys from the grown strings, random edits: the
/// modules outside the edited subtree are the plain derivation's, bit for
/// bit; the edited ones show the edit; any thread count gives the same.
#[test]
fn random_edits_change_their_subtree_only() {
    let mut rng = Rng::seeded(0xED17_0001);
    let n = 5;
    let mut checked = [0usize; 4];
    for case in 0..60 {
        let src = grammar(&mut rng);
        let c = inline(&src);
        let seed = case;
        let base = track(&plain(&c), n, seed, &[]);
        if base.last().len() > 5000 || base.last().is_empty() {
            continue;
        }
        let push = c
            .symbol_names
            .iter()
            .position(|s| s == "[")
            .map(|s| s as u32);
        let pop = c
            .symbol_names
            .iter()
            .position(|s| s == "]")
            .map(|s| s as u32);
        let x_slot = |c: &CompiledSystem| slot(c, |s| matches!(s, "A" | "B" | "F").then_some(0));
        for _ in 0..4 {
            let it = rng.below(n as usize + 1);
            let s = &base.strings[it];
            let i = rng.below(s.len());
            if Some(s.sym(i)) == push || Some(s.sym(i)) == pop {
                continue;
            }
            let key = s.keys()[i];
            let ref_run = track(&plain(&c), n, seed, &[key]);
            let inside = ref_run.last_inside();
            let want = ref_run.last();
            let outside = |st: &ModuleString, ins: &[bool]| modules(st, |i| !ins[i]);
            let mut p = EditPlan::new();
            let what = rng.below(4usize);
            let ctx = format!("case {case} edit {what} on module {i} of string {it}\n{src}");
            match what {
                0 => {
                    p.add(key, 1, EditAction::Remove);
                    let got = final_string(&c, n, seed, &p);
                    assert_eq!(modules(&got, |_| true), outside(want, inside), "{ctx}");
                }
                1 => {
                    let s = p.add_slot(x_slot(&c));
                    let v = rng.range_f32(-3.0, 3.0);
                    p.add(
                        key,
                        1,
                        EditAction::Value {
                            slot: s,
                            op: ValueOp::Set(v),
                        },
                    );
                    let got = final_string(&c, n, seed, &p);
                    assert_eq!(got.parts().syms, want.parts().syms, "{ctx}");
                    assert_eq!(got.keys(), want.keys(), "{ctx}");
                    for j in 0..got.len() {
                        let (sym, gp) = got.get(j);
                        let name = &c.symbol_names[sym as usize];
                        if inside[j] && matches!(name.as_str(), "A" | "B" | "F") {
                            assert_eq!(gp[0], v, "{ctx}");
                        } else if !inside[j] {
                            assert_eq!(gp, want.get(j).1, "{ctx}");
                        }
                    }
                }
                2 => {
                    // Offset a module of the final string.
                    let j = rng.below(want.len());
                    let name = &c.symbol_names[want.sym(j) as usize];
                    if !matches!(name.as_str(), "A" | "B" | "F") {
                        continue;
                    }
                    let by = rng.range_f32(-2.0, 2.0);
                    let s = p.add_slot(x_slot(&c));
                    p.add(
                        want.keys()[j],
                        1,
                        EditAction::Value {
                            slot: s,
                            op: ValueOp::Offset(by),
                        },
                    );
                    let got = final_string(&c, n, seed, &p);
                    let dup = want.keys().iter().filter(|&&k| k == want.keys()[j]).count();
                    for m in 0..got.len() {
                        if want.keys()[m] == want.keys()[j] {
                            assert_eq!(got.get(m).1[0], want.get(m).1[0] + by, "{ctx}");
                        } else if dup == 1 {
                            assert_eq!(got.get(m), want.get(m), "{ctx}");
                        }
                    }
                }
                _ => {
                    let a = c.symbol_names.iter().position(|s| s == "A").expect("A") as u32;
                    let alts = c.groups_of(a)[0].alt_count;
                    let k = 1 + rng.below(alts);
                    p.add(key, 1, EditAction::Force(k));
                    let run = track(&edited(&c, 1, p.clone()), n, seed, &[key]);
                    assert_eq!(
                        outside(run.last(), run.last_inside()),
                        outside(want, inside),
                        "{ctx}"
                    );
                    assert_eq!(final_string(&c, n, seed, &p), *run.last(), "{ctx}");
                }
            }
            checked[what] += 1;
        }
    }
    assert!(checked.iter().all(|&k| k >= 5), "{checked:?}");
}

/// The plant of the replay bench (benches/edits_replay.rs), smaller.
const PLANT: &str = "system Plant {
    seed = 7;
    module A(len: float, w: float);
    axiom A(1, 0.1);
    A(l, w) -> (2) !(w) F(l) [ +(30) A(l * 0.8, w * 0.7) ] [ -(25) A(l * 0.7, w * 0.7) ] /(137) A(l * 0.9, w * 0.9);
    A(l, w) -> (1) !(w) F(l) /(90) A(l * 0.95, w * 0.9);
    F(l) -> F(l * 1.05);
}";

/// Many edits of every kind at once: `derive_edited` (the engine's own
/// rewrite loop with the replay's hooks) writes the string that the
/// replay's recording loop (`edited_step` with a record) writes, step by
/// step, bit for bit, on 1, 2 and 4 threads.
#[test]
fn the_engine_loop_with_hooks_and_the_recording_loop_agree() {
    let c = inline(PLANT);
    let n = 9;
    let seed = 7;
    let base = track(&plain(&c), n, seed, &[]);
    let mut keys: Vec<u32> = base
        .strings
        .iter()
        .flat_map(|s| s.keys().to_vec())
        .collect();
    keys.sort_unstable();
    keys.dedup();
    let mut rng = Rng::seeded(0xED17_0027);
    rng.shuffle(&mut keys);
    assert!(keys.len() > 600, "{}", keys.len());
    let mut p = EditPlan::new();
    let len = p.add_slot(slot(&c, |s| matches!(s, "A" | "F").then_some(0)));
    let w = p.add_slot(slot(&c, |s| (s == "A").then_some(1)));
    for (i, &k) in keys[..300].iter().enumerate() {
        let action = match i % 5 {
            0 => EditAction::Remove,
            1 => EditAction::Value {
                slot: w,
                op: ValueOp::Set(0.05),
            },
            2 => EditAction::Value {
                slot: len,
                op: ValueOp::Offset(0.25),
            },
            3 => EditAction::Force(1 + (i as u32 / 5) % 2),
            _ => EditAction::Pin(keys[300 + i]),
        };
        p.add(k, i as u32 + 1, action);
    }
    let want = track(&edited(&c, 1, p.clone()), n, seed, &[]);
    let got = final_string(&c, n, seed, &p);
    assert_eq!(got, *want.last());
    assert_ne!(got, *base.last(), "the edits change the plant");
    // Step by step: the hooked loop's strings are the recording loop's.
    let e = edited(&c, 2, p.clone());
    for it in 1..=n {
        let opts = DeriveOptions {
            iterations: it,
            seed,
            limits: DeriveLimits::default(),
        };
        let (d, _) = e.derive_edited(&opts, &mut |_| {}).expect("derive");
        assert_eq!(d.string, want.strings[it as usize], "iteration {it}");
    }
}
