//! Identity keys (grm_compile::rng, "Identity keys"; docs/engine.md,
//! "Identity"): a module's key, and so its draws, depend on its ancestry
//! alone. Inserting a module that draws nothing re-rolls nothing else;
//! editing one production re-rolls only what descends from its
//! applications; keys are the same for any thread count.

mod common;

use common::*;
use grm_compile::CompiledSystem;
use grm_derive::{DeriveLimits, Engine, ModuleString};
use grm_testkit::Rng;

/// The modules of `s` as (symbol name, parameter bits, key), keys as the
/// engine carries them.
fn modules(c: &CompiledSystem, s: &ModuleString) -> Vec<(String, Vec<u32>, u32)> {
    (0..s.len())
        .map(|i| {
            let (sym, params) = s.get(i);
            (
                c.symbol_names[sym as usize].clone(),
                params.iter().map(|x| x.to_bits()).collect(),
                s.keys()[i],
            )
        })
        .collect()
}

/// Strings 0 ..= n with keys (asked for where the system draws nothing).
fn keyed_strings(c: &CompiledSystem, n: u32, seed: u32) -> Vec<ModuleString> {
    strings_with(c, n, seed, 1, true)
}

fn compile_text(path: &str, text: &str) -> CompiledSystem {
    let (_, checked) = grm_sema::check_text(path, text);
    let errors: Vec<_> = checked
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .collect();
    assert!(errors.is_empty(), "{text}\n{errors:?}");
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    grm_compile::compile(p, sys, &p.default_params()).expect("compiles")
}

/// The repro of issue 25: `f(0)` (a move of length 0 that draws nothing)
/// inserted before the stochastic plant's axiom leaves every other module,
/// its parameters and its key, as it was, for many seeds.
#[test]
fn a_module_inserted_in_the_axiom_re_rolls_nothing() {
    let path = repo().join("examples/stochastic_plant.grm");
    let text = std::fs::read_to_string(&path).expect("example");
    assert!(text.contains("axiom F;"));
    let edited = text.replace("axiom F;", "axiom f(0) F;");
    let p = path.display().to_string();
    let (a, b) = (compile_text(&p, &text), compile_text(&p, &edited));
    assert!(
        a.draws_randomly(),
        "the plant draws: its strings carry keys"
    );
    for seed in 0..12 {
        let sa = strings(&a, 5, seed, 1);
        let sb = strings(&b, 5, seed, 2);
        let (la, lb) = (sa.last().expect("final"), sb.last().expect("final"));
        let want = modules(&a, la);
        let got: Vec<_> = modules(&b, lb)
            .into_iter()
            .filter(|(name, _, _)| name != "f")
            .collect();
        assert_eq!(lb.len(), la.len() + 1, "seed {seed}: one more module");
        assert!(want == got, "seed {seed}: the plant changed");
    }
}

/// Random stochastic, parametric, context-free grammars that draw (weights,
/// `uniform`, `normal`, `randint`, `chance`, `choose`): a module of a new
/// symbol `Z` (no production, draws nothing) inserted anywhere in the axiom
/// or in successors changes no other module's key, parameters or symbol.
#[test]
fn modules_that_draw_nothing_inserted_anywhere_re_roll_nothing() {
    let mut rng = Rng::seeded(0x1D_0001);
    let mut compared = 0u64;
    for case in 0..60 {
        let g = Grammar::random(&mut rng);
        let plain = g.text(&mut Rng::seeded(case), 0.0);
        let with_z = g.text(&mut Rng::seeded(case), 0.35);
        assert!(with_z.contains(" Z"), "{with_z}");
        let (a, b) = (inline(&plain), inline(&with_z));
        for seed in [case as u32, 7] {
            let sa = keyed_strings(&a, 6, seed);
            let sb = keyed_strings(&b, 6, seed);
            for (it, (x, y)) in sa.iter().zip(&sb).enumerate() {
                let want = modules(&a, x);
                let got: Vec<_> = modules(&b, y)
                    .into_iter()
                    .filter(|(name, _, _)| name != "Z")
                    .collect();
                assert!(
                    want == got,
                    "case {case} seed {seed} iteration {it}\n{plain}\n{with_z}"
                );
                compared += want.len() as u64;
            }
        }
    }
    assert!(compared > 15_000, "only {compared} modules compared");
}

/// A random grammar: per symbol a list of productions (weight, successor
/// modules); successors are kept as token lists so that `Z` can be
/// inserted between them.
struct Grammar {
    axiom: Vec<String>,
    rules: Vec<String>,
    succs: Vec<Vec<String>>,
}

impl Grammar {
    fn random(rng: &mut Rng) -> Grammar {
        let module = |rng: &mut Rng, x: &str| -> String {
            match rng.below(10) {
                0 => format!("A({x} * {})", 0.5 + rng.below(4) as f32 * 0.25),
                1 => format!("A(uniform(0, {x} + 1))"),
                2 => format!("B({x} + normal(0, 1), {})", rng.below(5)),
                3 => format!("B(randint(1, 4), {x})"),
                4 => format!("F({x})"),
                5 => "+(choose(10, 1, 20, 2))".to_string(),
                6 => "-(25)".to_string(),
                7 => format!("C({x} * 0.5 + uniform(0, 1))"),
                8 => "C(2)".to_string(),
                _ => "F(uniform(0.5, 1.5))".to_string(),
            }
        };
        let succ = |rng: &mut Rng, x: &str| -> Vec<String> {
            let n = rng.below(5) as usize;
            let mut v: Vec<String> = (0..n).map(|_| module(rng, x)).collect();
            if rng.below(3) == 0 && !v.is_empty() {
                v.insert(0, "[".into());
                let k = 1 + rng.below(v.len() as u64) as usize;
                v.insert(k.min(v.len()), "]".into());
            }
            v
        };
        let mut rules = Vec::new();
        let mut succs = Vec::new();
        for (pred, x) in [("A(x)", "x"), ("B(x, y)", "y"), ("C(x)", "x")] {
            let alts = 1 + rng.below(3);
            for _ in 0..alts {
                let w = if rng.below(4) == 0 {
                    format!("({x} + 1)")
                } else {
                    format!("({})", 1 + rng.below(3))
                };
                rules.push(format!("    {pred} -> {w}"));
                succs.push(succ(rng, x));
            }
        }
        let axiom = (0..1 + rng.below(4)).map(|_| module(rng, "1")).collect();
        Grammar {
            axiom,
            rules,
            succs,
        }
    }

    /// The grammar's text, a `Z` inserted before each module (and at the
    /// end of each successor) with probability `p`.
    fn text(&self, rng: &mut Rng, p: f64) -> String {
        let mut z = |v: &[String]| -> String {
            let mut out = Vec::new();
            for m in v.iter().chain(std::iter::once(&String::new())) {
                if p > 0.0 && (rng.below(1000) as f64) < p * 1000.0 {
                    out.push("Z".to_string());
                }
                if !m.is_empty() {
                    out.push(m.clone());
                }
            }
            out.join(" ")
        };
        let mut s = String::from("system R {\n    seed = 3;\n");
        s += &format!("    axiom {};\n", z(&self.axiom));
        for (r, succ) in self.rules.iter().zip(&self.succs) {
            let body = z(succ);
            s += &format!("{r} {};\n", if body.is_empty() { "" } else { &body });
        }
        s += "}\n";
        // At least one Z where asked (the test needs an insertion).
        if p > 0.0 && !s.contains(" Z") {
            s = s.replacen("axiom ", "axiom Z ", 1);
        }
        s
    }
}

/// Edit production `alt` of `text`: its first float parameter expression
/// `e` becomes `(e) * 1.25 + 0.5`, or, without one, its first successor
/// module is written twice. `None` if the production is not in the root
/// file or its successor is empty.
fn edit_production(path: &str, text: &str, c: &CompiledSystem, alt: u32) -> Option<String> {
    let (_, checked) = grm_sema::check_text(path, text);
    let p = &checked.program;
    let sys = p.default_system()?;
    let a = &c.alts[alt as usize];
    let g = &c.groups[a.group as usize];
    let sema = &sys.groups[g.sema_group as usize];
    let production = &sema.alternatives[(alt - g.first_alt) as usize];
    if sys.file != p.root || production.successor.is_empty() {
        return None;
    }
    // Written arguments only (an implicit default, such as `F`'s length,
    // has the module's own span).
    let float = production
        .successor
        .iter()
        .flat_map(|m| m.args.iter().map(move |a| (m, a)))
        .find(|(m, e)| e.ty == grm_sema::Ty::Float && e.span.start > m.span.start)
        .map(|(_, e)| e);
    let mut out = text.to_string();
    match float {
        Some(e) => {
            let (s, t) = (e.span.start as usize, e.span.end as usize);
            out.replace_range(s..t, &format!("({}) * 1.25 + 0.5", &text[s..t]));
        }
        None => {
            let m = &production.successor[0];
            let (s, t) = (m.span.start as usize, m.span.end as usize);
            out.insert_str(s, &format!("{} ", &text[s..t]));
        }
    }
    Some(out)
}

/// Compare the derivations of the original system `c` (its strings
/// `orig`, 0 ..= n) and the edited one `e` after an edit of alternative
/// `alt`, from the engines' own decisions. A module is *touched* when it
/// descends from an application of `alt` in either derivation; the
/// untouched modules of both strings are walked in step, iteration by
/// iteration: they must be the same modules (symbol, parameters, key) in
/// the same order, and make the same decision (both copied, or both
/// rewritten by the same production) unless one of the two decisions is
/// `alt` (then both subtrees are touched). Returns (modules untouched, modules
/// in the original final string, whether anything changed).
fn compare_edit(
    c: &CompiledSystem,
    e: &CompiledSystem,
    orig: &[ModuleString],
    n: u32,
    seed: u32,
    alt: u32,
) -> Result<(usize, usize, bool), String> {
    let new = keyed_strings(e, n, seed);
    let (ec, ee) = (
        Engine::new(c, 1).expect("engine").with_keys(true),
        Engine::new(e, 1).expect("engine").with_keys(true),
    );
    let width = |cs: &CompiledSystem, d: Option<u32>| {
        d.map_or(1, |a| cs.alts[a as usize].succ_len as usize)
    };
    // Touched flags of the current strings.
    let (mut ta, mut tb) = (vec![false; orig[0].len()], vec![false; new[0].len()]);
    for it in 0..=n as usize {
        let (ma, mb) = (modules(c, &orig[it]), modules(e, &new[it]));
        let (ua, ub): (Vec<_>, Vec<_>) = (
            (0..ma.len()).filter(|&i| !ta[i]).collect(),
            (0..mb.len()).filter(|&i| !tb[i]).collect(),
        );
        if ua.len() != ub.len() || ua.iter().zip(&ub).any(|(&i, &j)| ma[i] != mb[j]) {
            return Err(format!(
                "editing production {alt} changed modules that do not descend from it (string {it})"
            ));
        }
        if it == n as usize {
            let changed = ma != mb;
            return Ok((ua.len(), ma.len(), changed));
        }
        let step = it as u32 + 1;
        let da = ec.decisions(&orig[it], step, seed).expect("decisions");
        let db = ee.decisions(&new[it], step, seed).expect("decisions");
        // Untouched pairs whose decision involves `alt` become touched.
        let (mut hit_a, mut hit_b) = (ta.clone(), tb.clone());
        for (&i, &j) in ua.iter().zip(&ub) {
            let (x, y) = (da[i], db[j]);
            if x == Some(alt) || y == Some(alt) {
                hit_a[i] = true;
                hit_b[j] = true;
            } else if x != y {
                return Err(format!(
                    "editing production {alt} changed the choice of a module that does not descend from it (string {it}: {x:?} -> {y:?})"
                ));
            }
        }
        ta = da
            .iter()
            .zip(&hit_a)
            .flat_map(|(&d, &t)| std::iter::repeat_n(t, width(c, d)))
            .collect();
        tb = db
            .iter()
            .zip(&hit_b)
            .flat_map(|(&d, &t)| std::iter::repeat_n(t, width(e, d)))
            .collect();
        assert_eq!(ta.len(), orig[it + 1].len(), "decisions match the string");
        assert_eq!(tb.len(), new[it + 1].len(), "decisions match the string");
    }
    unreachable!("the loop returns at the last string")
}

/// Every production of every context-free derive-mode example, edited one
/// at a time (a parameter expression changed, or a successor module
/// added): the modules of the final string that descend from no
/// application of it, in the original derivation and in the edited one,
/// are the same modules in the same order with the same keys and
/// parameters. Context-sensitive systems are left out: there an edit
/// changes what its neighbours' contexts see, which is the grammar's
/// meaning, not a re-roll.
#[test]
fn editing_one_production_re_rolls_only_its_descendants() {
    let mut edits = 0;
    let mut kept_total = (0u64, 0u64);
    for file in [
        "stochastic_plant.grm",
        "ternary_tree.grm",
        "bracketed_plant.grm",
        "row_of_trees.grm",
        "koch_island.grm",
        "hilbert3d.grm",
    ] {
        let path = repo().join("examples").join(file);
        let path = path.display().to_string();
        let text = std::fs::read_to_string(&path).expect("example");
        let c = compile_text(&path, &text);
        if c.has_context() {
            continue;
        }
        let seed = c.settings.seed;
        // Iterations that keep the strings small for a debug build.
        let mut n = c.settings.iterations;
        while n > 1 && keyed_strings(&c, n, seed).last().expect("final").len() > 40_000 {
            n -= 1;
        }
        let orig = keyed_strings(&c, n, seed);
        for alt in 0..c.axiom_alt {
            let Some(edited) = edit_production(&path, &text, &c, alt) else {
                continue;
            };
            let e = compile_text(&path, &edited);
            assert_eq!(e.alts.len(), c.alts.len());
            let (kept, total, changed) =
                compare_edit(&c, &e, &orig, n, seed, alt).unwrap_or_else(|m| panic!("{file}: {m}"));
            // The edit did change something (else the test shows nothing).
            assert!(changed, "{file}: production {alt}'s edit changed nothing");
            kept_total.0 += kept as u64;
            kept_total.1 += total as u64;
            edits += 1;
            eprintln!(
                "{file}: production {alt}: {kept} of {total} modules ({:.1}%) untouched",
                100.0 * kept as f64 / total.max(1) as f64
            );
        }
    }
    assert!(edits >= 12, "only {edits} edits");
    eprintln!(
        "{edits} edits: {:.1}% of the final modules untouched on average",
        100.0 * kept_total.0 as f64 / kept_total.1.max(1) as f64
    );
}

/// The weight of one production of a stochastic group multiplied by 3 or
/// by 0.2, one production at a time, in the stochastic plant and in random
/// grammars with constant and computed weights: the choice between two
/// other productions never changes (the race of grm_compile::rng), so the
/// modules that descend from no application of the edited production, in
/// either derivation, are unchanged, keys and parameters included.
#[test]
fn editing_one_weight_re_rolls_only_its_descendants() {
    let mut cases: Vec<(String, String)> = Vec::new();
    let plant = repo().join("examples").join("stochastic_plant.grm");
    cases.push((
        plant.display().to_string(),
        std::fs::read_to_string(&plant).expect("example"),
    ));
    let mut rng = Rng::seeded(0x1D_0002);
    for case in 0..40 {
        let g = Grammar::random(&mut rng);
        cases.push((
            format!("random{case}.grm"),
            g.text(&mut Rng::seeded(case), 0.0),
        ));
    }
    let (mut edits, mut changed_edits) = (0, 0);
    let mut kept_total = (0u64, 0u64);
    for (path, text) in &cases {
        let c = compile_text(path, text);
        let seed = c.settings.seed;
        let mut n = 5;
        while n > 1 && keyed_strings(&c, n, seed).last().expect("final").len() > 20_000 {
            n -= 1;
        }
        let orig = keyed_strings(&c, n, seed);
        for alt in 0..c.axiom_alt {
            let g = &c.groups[c.alts[alt as usize].group as usize];
            let span = c.weight_spans[alt as usize];
            if g.alt_count < 2 || span == c.alt_spans[alt as usize] {
                continue;
            }
            for factor in ["3", "0.2"] {
                let (s, t) = (span.start as usize, span.end as usize);
                let mut edited = text.clone();
                edited.replace_range(s..t, &format!("({} * {factor})", &text[s..t]));
                let e = compile_text(path, &edited);
                let (kept, total, changed) = compare_edit(&c, &e, &orig, n, seed, alt)
                    .unwrap_or_else(|m| panic!("{path} (weight x {factor}): {m}\n{edited}"));
                if !path.starts_with("random") {
                    eprintln!(
                        "{path}: weight of production {alt} x {factor}: {kept} of {total} modules ({:.1}%) untouched",
                        100.0 * kept as f64 / total.max(1) as f64
                    );
                }
                edits += 1;
                changed_edits += usize::from(changed);
                kept_total.0 += kept as u64;
                kept_total.1 += total as u64;
            }
        }
    }
    assert!(edits >= 60, "only {edits} weight edits");
    assert!(
        changed_edits * 4 >= edits,
        "only {changed_edits} of {edits} weight edits changed anything"
    );
    eprintln!(
        "{edits} weight edits ({changed_edits} changed the string): {:.1}% of the final modules untouched on average",
        100.0 * kept_total.0 as f64 / kept_total.1.max(1) as f64
    );
}

/// Keys are the same for any thread count and chunking.
#[test]
fn keys_do_not_depend_on_threads() {
    let c = example("stochastic_plant.grm", None);
    let base = strings(&c, 6, 5, 1);
    for threads in [2, 8] {
        let engine = Engine::new(&c, threads).expect("engine").with_min_chunk(3);
        let mut s = engine.axiom(5).expect("axiom");
        for it in 1..=6 {
            s = engine
                .step(&s, it, 5, &DeriveLimits::default())
                .expect("step");
            assert_eq!(
                s.keys(),
                base[it as usize].keys(),
                "{threads} threads, iteration {it}"
            );
        }
    }
}

/// Collisions: keys are 32 bits, so a string of n modules holds about
/// n^2 / 2^33 equal pairs by chance; the largest examples stay near that
/// (a collision only makes two modules draw alike).
#[test]
fn key_collisions_are_as_rare_as_chance() {
    for (file, n) in [("stochastic_plant.grm", 8), ("bracketed_plant.grm", 6)] {
        let c = example(file, None);
        let s = keyed_strings(&c, n, 1);
        let last = s.last().expect("final");
        let mut keys = last.keys().to_vec();
        keys.sort_unstable();
        let dup = keys.windows(2).filter(|w| w[0] == w[1]).count();
        let m = keys.len() as f64;
        let expected = m * m / 2f64.powi(33);
        eprintln!(
            "{file} n={n}: {} modules, {dup} equal keys (chance: {expected:.2})",
            keys.len()
        );
        assert!(
            (dup as f64) <= 4.0 * expected + 4.0,
            "{file}: {dup} collisions among {m} keys, {expected:.2} expected"
        );
    }
}
