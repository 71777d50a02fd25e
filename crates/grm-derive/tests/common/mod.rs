//! Shared helpers for the engine tests: load and compile examples or inline
//! grammars, derive strings step by step, read tests/derive_expect files.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use grm_compile::CompiledSystem;
use grm_derive::{DeriveLimits, Engine, ModuleString};

pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Check and compile `system` (or the default one) of an example file.
pub fn example(file: &str, system: Option<&str>) -> CompiledSystem {
    let path = repo().join("examples").join(file);
    let text = std::fs::read_to_string(&path).expect("example exists");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{file}: {:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = match system {
        Some(n) => p.system(n).expect("system exists"),
        None => p.default_system().expect("a system"),
    };
    grm_compile::compile(p, sys, &p.default_params()).expect("compiles")
}

/// Check and compile the first system of an inline grammar; returns it and
/// the source text.
pub fn inline(src: &str) -> CompiledSystem {
    let (_, checked) = grm_sema::check_with("inline.grm", src, &grm_sema::MemLoader::new());
    let errors: Vec<_> = checked
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .collect();
    assert!(errors.is_empty(), "{src}\n{errors:?}");
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    grm_compile::compile(p, sys, &p.default_params()).expect("compiles")
}

/// Strings 0 ..= n (the axiom first).
pub fn strings(c: &CompiledSystem, n: u32, seed: u32, threads: usize) -> Vec<ModuleString> {
    strings_with(c, n, seed, threads, false)
}

/// [`strings`], carrying identity keys where `keys` (they are carried
/// anyway when the system draws).
pub fn strings_with(
    c: &CompiledSystem,
    n: u32,
    seed: u32,
    threads: usize,
    keys: bool,
) -> Vec<ModuleString> {
    let engine = Engine::new(c, threads).expect("engine").with_keys(keys);
    let mut out = vec![engine.axiom(seed).expect("axiom")];
    for it in 1..=n {
        let next = engine
            .step(
                out.last().expect("nonempty"),
                it,
                seed,
                &DeriveLimits::default(),
            )
            .expect("step");
        assert!(next.is_well_formed());
        out.push(next);
    }
    out
}

/// One module of an expected string: a name and, if written, parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Tok {
    pub name: String,
    pub params: Option<Vec<f64>>,
}

/// Parse `F(0.3) + [ A ]`-style text.
pub fn parse_modules(text: &str) -> Vec<Tok> {
    let mut out = Vec::new();
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b' ' {
            i += 1;
            continue;
        }
        let start = i;
        while i < b.len() && b[i] != b' ' && b[i] != b'(' {
            i += 1;
        }
        let name = text[start..i].to_string();
        let mut params = None;
        if i < b.len() && b[i] == b'(' {
            let close = text[i..].find(')').expect("closing paren") + i;
            params = Some(
                text[i + 1..close]
                    .split(',')
                    .map(|x| x.trim().parse::<f64>().expect("number"))
                    .collect(),
            );
            i = close + 1;
        }
        out.push(Tok { name, params });
    }
    out
}

/// The expected lengths and strings of a tests/derive_expect file.
pub struct Expect {
    pub lens: Vec<(u32, u64)>,
    pub strs: Vec<(u32, Vec<Tok>)>,
}

pub fn expect(file: &str) -> Expect {
    let text = std::fs::read_to_string(repo().join("tests/derive_expect").join(file))
        .expect("derive_expect file");
    let mut e = Expect {
        lens: Vec::new(),
        strs: Vec::new(),
    };
    for line in text.lines() {
        if let Some(rest) = line.strip_prefix("len ") {
            let mut it = rest.split_whitespace();
            let n = it.next().and_then(|x| x.parse().ok()).expect("iteration");
            let l = it.next().and_then(|x| x.parse().ok()).expect("length");
            e.lens.push((n, l));
        } else if let Some(rest) = line.strip_prefix("str ") {
            let (n, body) = rest.split_once(' ').unwrap_or((rest, ""));
            e.strs
                .push((n.parse().expect("iteration"), parse_modules(body)));
        }
    }
    e
}

/// Compare a derived string with an expected one: names equal; written
/// parameters equal to a relative tolerance of 1e-5 (unwritten ones are
/// the defaults grm fills in and are not compared).
pub fn assert_matches(c: &CompiledSystem, got: &ModuleString, want: &[Tok], what: &str) {
    let text = got.to_text(&c.symbol_names);
    assert_eq!(got.len(), want.len(), "{what}: length\n got: {text}");
    for (i, (t, (sym, params))) in want.iter().zip(got.iter()).enumerate() {
        assert_eq!(
            c.symbol_names[sym as usize], t.name,
            "{what}: module {i}\n got: {text}"
        );
        if let Some(ps) = &t.params {
            assert_eq!(ps.len(), params.len(), "{what}: module {i} arity");
            for (w, g) in ps.iter().zip(params) {
                let tol = 1e-5 * w.abs().max(1e-3);
                assert!(
                    (f64::from(*g) - w).abs() <= tol,
                    "{what}: module {i}: {g} != {w}\n got: {text}"
                );
            }
        }
    }
}
