//! The engine against a reference rewriter written from the table format
//! alone: every module looks up its groups in order, binds its words where
//! the group says, runs the condition and every computed parameter on the
//! bytecode VM (the semantics the GPU shares), and appends its successor.
//! No fast path, no template, no padding: what the engine's rewrite loop
//! (copies, one-word units, short arithmetic successors written in
//! fixed-size blocks, the general writer) must reproduce bit for bit, on
//! random deterministic grammars whose successors are empty, short, and
//! longer than the engine's blocks, with one, two or three threads. The
//! reference also mints every module's identity key from the rule of
//! docs/engine.md ("Identity"), from symbol names and occurrence indices,
//! not from the compiled salts, and draws by it.

mod common;

use common::*;
use grm_compile::CompiledSystem;
use grm_compile::rng::{self, DrawCtx};
use grm_compile::table::{NONE, PARAM_CODE, PARAM_CONST, PARAM_COPY};
use grm_compile::vm::Vm;
use grm_derive::{DeriveError, DeriveLimits, Engine, ModuleString};
use grm_testkit::Rng;

/// How a reference step fails: the input position of the first module
/// that fails, or the length of an output over the module limit.
#[derive(Debug, PartialEq)]
enum Fail {
    At(u64),
    Limit(u64),
}

/// What the reference makes of a step, in the engine's documented order
/// (docs/engine.md): every module's production decided (conditions run),
/// the output counted and held to `max_modules` before anything is
/// written, then the successors written (computed parameters run).
fn reference_step(
    c: &CompiledSystem,
    input: &ModuleString,
    iteration: u32,
    seed: u32,
    max_modules: u64,
) -> Result<ModuleString, Fail> {
    let mut vm = Vm::new();
    let mut buf = vec![0.0f32; c.max_bind_words as usize];
    let draws = |i: usize| DrawCtx {
        seed,
        iteration,
        position: input.keys()[i],
    };
    // Decide: per module, the alternative and its bound words.
    let mut decided = Vec::with_capacity(input.len());
    let mut len = 0u64;
    for i in 0..input.len() {
        let (sym, params) = input.get(i);
        let mut applied = None;
        for g in c.groups_of(sym) {
            assert_eq!(g.alt_count, 1, "the generator writes one alternative");
            assert_eq!(g.left_len + g.right_len, 0, "and no contexts");
            let o = g.pred_bind_offset as usize;
            buf[..g.bind_words as usize].fill(0.0);
            buf[o..o + g.pred_bind_words as usize]
                .copy_from_slice(&params[..g.pred_bind_words as usize]);
            let bind = &buf[..g.bind_words as usize];
            if g.cond_code != NONE {
                let v = vm
                    .run1(&c.code, &c.consts, g.cond_code, bind, &draws(i))
                    .map_err(|_| Fail::At(i as u64))?;
                if v == 0.0 {
                    continue;
                }
            }
            applied = Some((g.first_alt, g.first_alt, bind.to_vec()));
            break;
        }
        len += applied.as_ref().map_or(1, |(alt, _, _)| {
            c.successor(&c.alts[*alt as usize]).len() as u64
        });
        decided.push(applied);
    }
    if len > max_modules {
        return Err(Fail::Limit(len));
    }
    // Write.
    let mut out = ModuleString::new();
    for (i, applied) in decided.into_iter().enumerate() {
        let (sym, params) = input.get(i);
        let key = input.keys()[i];
        let Some((alt, first_alt, bind)) = applied else {
            out.push_keyed(sym, params, key);
            continue;
        };
        let succ = c.successor(&c.alts[alt as usize]);
        for (j, m) in succ.iter().enumerate() {
            let mut words = Vec::new();
            for p in c.module_params(m) {
                let w = p.words as usize;
                match p.kind {
                    PARAM_CONST => words.extend_from_slice(&c.consts[p.a as usize..][..w]),
                    PARAM_COPY => words.extend_from_slice(&bind[p.a as usize..][..w]),
                    PARAM_CODE => {
                        let v = vm
                            .run(&c.code, &c.consts, p.a, &bind, &draws(i))
                            .map_err(|_| Fail::At(i as u64))?;
                        if v.iter().any(|x| !x.is_finite()) {
                            return Err(Fail::At(i as u64));
                        }
                        words.extend_from_slice(&v[..w]);
                    }
                    k => panic!("parameter kind {k}"),
                }
            }
            out.push_keyed(m.symbol, &words, key_of(c, succ, j, alt - first_alt, key));
        }
    }
    Ok(out)
}

/// The key of successor module `j` of the `alternative`-th production of
/// its group, rewriting a module keyed `parent`: from the symbol's name and
/// its occurrence among the successor's modules of that symbol.
fn key_of(
    c: &CompiledSystem,
    succ: &[grm_compile::table::SuccModule],
    j: usize,
    alternative: u32,
    parent: u32,
) -> u32 {
    let sym = succ[j].symbol;
    let occurrence = succ[..j].iter().filter(|m| m.symbol == sym).count() as u32;
    let name = rng::name_hash(&c.symbol_names[sym as usize]);
    rng::child_key(parent, rng::salt(name, occurrence, alternative))
}

/// The reference's axiom keys: children of the root key of (seed, system
/// name), alternative 0.
fn axiom_keys(c: &CompiledSystem, seed: u32) -> Vec<u32> {
    let root = rng::root_key(seed, rng::name_hash(&c.name));
    let succ = c.successor(&c.alts[c.axiom_alt as usize]);
    (0..succ.len())
        .map(|j| key_of(c, succ, j, 0, root))
        .collect()
}

/// A random deterministic grammar over `F(x)`, `P(x, y)`, `V(v)` (a
/// `vec3`), `A`, `+`, `-`, `[`, `]`: one-word arithmetic patches in every
/// form the engine recognizes (and some it does not), copies, constants,
/// vec3 copies, conditions, and successors from empty to about 30 modules.
fn grammar(rng: &mut Rng) -> String {
    // 1e30 overflows within a few steps: the error paths.
    let k = |rng: &mut Rng| {
        ["0.5", "1.25", "2", "3", "0.75", "1e-3", "-1.5", "1e30"][rng.below(8) as usize]
    };
    let one = |rng: &mut Rng, x: &str| -> String {
        let k = k(rng);
        match rng.below(11) {
            0 => format!("{x} * {k}"),
            1 => format!("{k} * {x}"),
            2 => format!("{x} + {k}"),
            3 => format!("{k} + {x}"),
            4 => format!("{x} - {k}"),
            5 => format!("{k} - {x}"),
            6 => x.to_string(),
            7 => k.to_string(),
            8 => format!("{x} / 2"),
            9 => format!("{x} * {x} * 0.001"),
            _ => format!("sqrt(abs({x}))"),
        }
    };
    let module = |rng: &mut Rng, a: &str, b: &str| -> String {
        match rng.below(9) {
            0 | 1 => format!("F({})", one(rng, a)),
            2 => format!("P({}, {})", one(rng, b), one(rng, a)),
            3 => "A".to_string(),
            4 => "V(vec3(1, 2, 3))".to_string(),
            5 => format!("[ F({}) ]", one(rng, a)),
            _ => rng.pick(&["+", "-"]).to_string(),
        }
    };
    let succ = |rng: &mut Rng, a: &str, b: &str| -> String {
        let len = match rng.below(4) {
            0 => rng.below(3),
            1 => 3 + rng.below(6),
            2 => 8 + rng.below(10),
            _ => 17 + rng.below(14),
        };
        (0..len)
            .map(|_| module(rng, a, b))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let mut s = String::from("system R {\n    axiom F(1) P(2, 3) A V(vec3(0.5, 1, 2)) + F(4);\n");
    // F: sometimes a one-word unit, sometimes a successor; sometimes with a
    // condition (the group search) and a second group.
    match rng.below(4) {
        0 => s += &format!("    F(x) -> F({});\n", one(rng, "x")),
        1 => s += &format!("    F(x) : x < 20 -> {};\n", succ(rng, "x", "x")),
        _ => s += &format!("    F(x) -> {};\n", succ(rng, "x", "x")),
    }
    if rng.below(2) == 0 {
        s += &format!("    P(x, y) -> {};\n", succ(rng, "x", "y"));
    }
    if rng.below(3) != 0 {
        s += &format!("    A -> {};\n", succ(rng, "1", "2"));
    }
    if rng.below(2) == 0 {
        s += "    V(v) -> V(v) F(1);\n";
    }
    s.push_str("}\n");
    s
}

#[test]
fn the_engine_rewrites_as_the_reference_does() {
    let mut rng = Rng::seeded(0x5EED_0002);
    let limits = DeriveLimits {
        max_modules: 200_000,
        ..DeriveLimits::default()
    };
    let (mut compared, mut failed, mut over) = (0, 0, 0);
    for case in 0..150 {
        let src = grammar(&mut rng);
        let c = inline(&src);
        // One thread (one chunk), and several small chunks in parallel.
        // Keyed (the generator's grammars draw nothing, so keys are asked
        // for), and one engine without keys, whose strings must be the same
        // but for the keys.
        let engines = [
            Engine::new(&c, 1).expect("engine").with_keys(true),
            Engine::new(&c, 2)
                .expect("engine")
                .with_min_chunk(7)
                .with_keys(true),
            Engine::new(&c, 3)
                .expect("engine")
                .with_min_chunk(1)
                .with_keys(true),
            Engine::new(&c, 2).expect("engine").with_min_chunk(5),
        ];
        assert!(!engines[3].keyed());
        let mut want = engines[0].axiom(case).expect("axiom");
        assert_eq!(
            want.keys(),
            axiom_keys(&c, case),
            "case {case} axiom\n{src}"
        );
        let mut got: Vec<ModuleString> = engines.iter().map(|_| want.clone()).collect();
        got[3].clear_keys();
        for it in 1..=6 {
            let next = reference_step(&c, &want, it, case, limits.max_modules);
            for (e, g) in engines.iter().zip(&mut got) {
                match (&next, e.step(g, it, case, &limits)) {
                    (Ok(w), Ok(s)) => {
                        same_bits(&format!("case {case} iteration {it}\n{src}"), w, &s);
                        *g = s;
                    }
                    (Err(Fail::At(pos)), Err(DeriveError::Runtime(r))) => {
                        assert_eq!(r.position, *pos, "case {case} iteration {it}\n{src}");
                        assert_eq!(r.iteration, it);
                    }
                    // Over the limit: reported from the counts, before a
                    // parameter that would fail is computed.
                    (Err(Fail::Limit(n)), Err(DeriveError::ModuleLimit { modules, .. })) => {
                        assert_eq!(*n, modules, "case {case} iteration {it}\n{src}");
                        over += 1;
                    }
                    (w, s) => panic!(
                        "case {case} iteration {it}\n{src}\nreference {:?}\nengine {:?}",
                        w.as_ref().map(|s| s.len()),
                        s.map(|s| s.len())
                    ),
                }
            }
            match next {
                Ok(w) => {
                    compared += 1;
                    want = w;
                }
                Err(Fail::Limit(_)) => break,
                Err(Fail::At(_)) => {
                    failed += 1;
                    break;
                }
            }
        }
    }
    // The generator reaches both outcomes.
    assert!(compared > 300, "only {compared} steps compared");
    assert!(failed > 10, "only {failed} cases failed");
    assert!(over > 0, "no case went over the module limit");
    eprintln!("{compared} steps compared, {failed} cases failed, {over} over the limit");
}

/// Bit-for-bit equality, parameters compared as bits.
fn same_bits(what: &str, a: &ModuleString, b: &ModuleString) {
    assert_eq!(a.parts().syms, b.parts().syms, "{what}: symbols");
    assert_eq!(a.parts().starts, b.parts().starts, "{what}: starts");
    let bits = |s: &ModuleString| {
        s.parts()
            .params
            .iter()
            .map(|x| x.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(a), bits(b), "{what}: parameters");
    if !b.keys().is_empty() {
        assert_eq!(a.keys(), b.keys(), "{what}: keys");
    }
}
