//! Folded and run-time values agree: the same expression, once folded by
//! the checker (`grm_sema::eval`, in 32-bit float arithmetic:
//! `grm_sema::scalar`) as a `const`, and once computed by the engine while
//! rewriting (the bytecode VM and the engine's fast paths, in f32), over
//! random expressions. Both compute in f32 with the same definitions, so
//! they must give the same bits (NaN for NaN).
//!
//! Three groups:
//!
//! - **exact**: whole numbers and small binary fractions, the operators and
//!   the piecewise functions (`floor ceil round fract sign abs min max
//!   clamp step mix %`, comparisons, `&& || !`, `if`), magnitudes kept
//!   small.
//! - **continuous**: one transcendental or vector function of exact
//!   arguments.
//! - **general**: both of those nested in each other, with literals that
//!   f32 cannot hold exactly (`0.1`, `16777217`, `1e-7`) and divisions by
//!   3 and 0.3: where a fold in f64 gave other
//!   answers than the engine (`0.1 + 0.2 == 0.3` is true in f32, false in
//!   f64).

use grm_derive::{DeriveLimits, Engine};
use grm_tests::Rng;
use std::fmt::Write as _;

/// Check and compile the first system of `src` (no errors allowed).
fn inline(src: &str) -> grm_compile::CompiledSystem {
    let (_, checked) = grm_sema::check_with("inline.grm", src, &grm_sema::MemLoader::new());
    let errors: Vec<_> = checked
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .collect();
    assert!(errors.is_empty(), "{src}\n{errors:?}");
    let p = &checked.program;
    let sys = p.default_system().expect("a system");
    grm_compile::compile(p, sys, &p.default_params()).unwrap_or_else(|e| panic!("{src}\n{e:?}"))
}

/// The string of one rewriting step of `c`'s axiom.
fn step_once(c: &grm_compile::CompiledSystem) -> grm_derive::ModuleString {
    let engine = Engine::new(c, 1).expect("engine");
    let axiom = engine.axiom(0).expect("axiom");
    engine
        .step(&axiom, 1, 0, &DeriveLimits::default())
        .expect("step")
}

/// A number literal as source text (negative ones in parentheses).
fn lit(v: f64) -> String {
    if v < 0.0 {
        format!("({v})")
    } else {
        format!("{v}")
    }
}

/// A float expression of the exact group over `x` and `y`.
fn exact(r: &mut Rng, depth: u32) -> String {
    if depth == 0 || r.below(5) == 0 {
        return match r.below(4) {
            0 => "x".into(),
            1 => "y".into(),
            2 => lit(r.int(-9, 9) as f64),
            _ => lit(r.int(-19, 19) as f64 / 4.0),
        };
    }
    let d = depth - 1;
    macro_rules! e {
        () => {
            exact(r, d)
        };
    }
    let s = match r.below(22) {
        0 => format!("{} + {}", e!(), e!()),
        1 => format!("{} - {}", e!(), e!()),
        2 => format!("-({})", e!()),
        3 => {
            let k = r.int(-4, 4);
            format!("({}) * {}", e!(), lit(k as f64))
        }
        4 => format!("({}) / {}", e!(), [2, 4, -2][r.below(3)]),
        5 => {
            let k = [1, 2, 3, 5, 7, -3, -4][r.below(7)];
            format!("({}) % {}", e!(), lit(k as f64))
        }
        6 => format!("floor({})", e!()),
        7 => format!("ceil({})", e!()),
        8 => format!("round({})", e!()),
        9 => format!("fract({})", e!()),
        10 => format!("sign({})", e!()),
        11 => format!("abs({})", e!()),
        12 => format!("min({}, {})", e!(), e!()),
        13 => format!("max({}, {})", e!(), e!()),
        14 => format!("clamp({}, {}, {})", e!(), e!(), e!()),
        15 => format!("step({}, {})", e!(), e!()),
        16 => {
            let t = [0.0, 0.5, 1.0, 0.25][r.below(4)];
            format!("mix({}, {}, {t})", e!(), e!())
        }
        17 | 18 => format!(
            "if {} then {} else {}",
            cond(r, d),
            exact(r, d),
            exact(r, d)
        ),
        19 => format!(
            "vec3({}, {}, {}).{}",
            e!(),
            e!(),
            e!(),
            ["x", "y", "z"][r.below(3)]
        ),
        20 => format!("(vec3({}, {}, 1) * {}).y", e!(), e!(), e!()),
        _ => format!("(vec3({}, 0, {}) + vec3({}, 1, 2)).x", e!(), e!(), e!()),
    };
    // Keep magnitudes small: every value stays a short binary fraction.
    format!("clamp({s}, -1000, 1000)")
}

/// A boolean expression of the exact group.
fn cond(r: &mut Rng, depth: u32) -> String {
    let d = depth.saturating_sub(1);
    match r.below(9) {
        0 => format!("{} < {}", exact(r, d), exact(r, d)),
        1 => format!("{} <= {}", exact(r, d), exact(r, d)),
        2 => format!("{} > {}", exact(r, d), exact(r, d)),
        3 => format!("{} >= {}", exact(r, d), exact(r, d)),
        4 => format!("{} == {}", exact(r, d), exact(r, d)),
        5 => format!("{} != {}", exact(r, d), exact(r, d)),
        6 => format!("({}) && ({})", cond(r, d), cond(r, d)),
        7 => format!("({}) || ({})", cond(r, d), cond(r, d)),
        _ => format!("!({})", cond(r, d)),
    }
}

/// One function of the continuous group over `x` and `y`, which hold
/// values of `[-4, 4]` in steps of 1/4.
fn continuous(r: &mut Rng) -> String {
    match r.below(18) {
        0 => "sin(x * 20)".into(),
        1 => "cos(y * 20 + 7)".into(),
        2 => "tan(x * 10)".into(), // within (-45, 45) degrees
        3 => "asin(x / 4.5)".into(),
        4 => "acos(y / 4.5)".into(),
        5 => "atan(x * 3)".into(),
        6 => "atan2(x + 0.5, y - 0.25)".into(),
        7 => "sqrt(abs(x) + 1)".into(),
        8 => "exp(x)".into(),
        9 => "ln(abs(y) + 0.5)".into(),
        10 => "log10(abs(x) * 10 + 1)".into(),
        11 => "pow(abs(x) + 1, y / 2)".into(),
        12 => "length(vec3(x, y, 1))".into(),
        13 => "dot(vec3(x, y, 1), vec3(y, 2, x))".into(),
        14 => "distance(vec3(x, 1, y), vec3(y, x, 3))".into(),
        15 => "normalize(vec3(x, y, 1)).y".into(),
        16 => "cross(vec3(x, 1, 2), vec3(y, 3, x)).z".into(),
        _ => "smoothstep(-3, 5, x + y)".into(),
    }
}

/// `expr` with the bindings replaced by the axiom's values.
fn substitute(expr: &str, x: f64, y: f64) -> String {
    let mut out = String::with_capacity(expr.len() + 16);
    let b = expr.as_bytes();
    for (i, c) in expr.char_indices() {
        let word = |k: usize| k < b.len() && (b[k].is_ascii_alphanumeric() || b[k] == b'_');
        // A lone `x` / `y` (not part of a name, not a field `.x`).
        let lone = !word(i + 1) && (i == 0 || !(word(i - 1) || b[i - 1] == b'.'));
        match c {
            'x' if lone => out.push_str(&lit(x)),
            'y' if lone => out.push_str(&lit(y)),
            _ => out.push(c),
        }
    }
    out
}

/// Run `exprs` both ways at (`x`, `y`); returns (expression, folded, run).
fn both(exprs: &[String], x: f64, y: f64) -> Vec<(String, f32, f32)> {
    let mut src = String::new();
    for (i, e) in exprs.iter().enumerate() {
        writeln!(src, "const C{i} = {};", substitute(e, x, y)).unwrap();
    }
    src.push_str("system S {\n    iterations = 1;\n    axiom A(");
    write!(src, "{}, {})", lit(x), lit(y)).unwrap();
    for i in 0..exprs.len() {
        write!(src, " K(C{i})").unwrap();
    }
    src.push_str(";\n    A(x, y) ->");
    for e in exprs {
        write!(src, " B({e})").unwrap();
    }
    src.push_str(";\n}\n");
    let c = inline(&src);
    let s = step_once(&c);
    // B(v0) ... B(vn) K(c0) ... K(cn)
    assert_eq!(s.len(), 2 * exprs.len(), "{src}");
    let n = exprs.len();
    (0..n)
        .map(|i| (exprs[i].clone(), s.get(n + i).1[0], s.get(i).1[0]))
        .collect()
}

#[test]
fn exact_expressions_fold_and_run_to_the_same_value() {
    let mut r = Rng::seeded(0x9e37_79b9_7f4a_7c15);
    let mut checked = 0;
    for round in 0..40 {
        let x = r.int(-16, 16) as f64 / 4.0;
        let y = r.int(-16, 16) as f64 / 4.0;
        let exprs: Vec<String> = (0..30).map(|_| exact(&mut r, 4)).collect();
        for (e, folded, run) in both(&exprs, x, y) {
            assert!(
                folded == run,
                "round {round}, x = {x}, y = {y}: `{e}` folds to {folded} but runs to {run}"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 1200);
}

/// The same bits, or NaN for NaN.
fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

#[test]
fn continuous_functions_fold_and_run_to_the_same_value() {
    let mut r = Rng::seeded(0x2545_f491_4f6c_dd1d);
    for round in 0..20 {
        let x = r.int(-16, 16) as f64 / 4.0;
        let y = r.int(-16, 16) as f64 / 4.0;
        let exprs: Vec<String> = (0..18).map(|_| continuous(&mut r)).collect();
        for (e, folded, run) in both(&exprs, x, y) {
            assert!(
                same(folded, run),
                "round {round}, x = {x}, y = {y}: `{e}` folds to {folded} but runs to {run}"
            );
        }
    }
}

/// A float expression of the general group over `x` and `y`.
fn general(r: &mut Rng, depth: u32) -> String {
    if depth == 0 || r.below(5) == 0 {
        return match r.below(6) {
            0 => "x".into(),
            1 => "y".into(),
            _ => lit([0.1, 0.2, 0.3, 0.7, 1.1, 16777217.0, 1e-7, 2.5][r.below(8)]),
        };
    }
    let d = depth - 1;
    macro_rules! g {
        () => {
            general(r, d)
        };
    }
    match r.below(14) {
        0 => format!("{} + {}", g!(), g!()),
        1 => format!("{} - {}", g!(), g!()),
        2 => format!(
            "({}) * {}",
            g!(),
            ["0.1", "0.3", "7", "1.1", "y"][r.below(5)]
        ),
        3 => format!("({}) / {}", g!(), ["3", "0.3", "7", "x"][r.below(4)]),
        4 => format!("({}) % {}", g!(), ["0.3", "3", "1.7"][r.below(3)]),
        5 => format!("sin({})", g!()),
        6 => format!(
            "pow(abs({}) % 10 + 0.5, {})",
            g!(),
            ["0.5", "1.5", "y"][r.below(3)]
        ),
        7 => format!("sqrt(abs({}))", g!()),
        8 => format!("atan2({}, {})", g!(), g!()),
        9 => format!("mix({}, {}, 0.3)", g!(), g!()),
        10 => format!("smoothstep(0.1, 0.7, {})", g!()),
        11 => format!("length(vec3({}, {}, 0.1))", g!(), g!()),
        12 => format!("(if {} == {} then 1 else 0)", g!(), g!()),
        _ => format!("spline({}, 0.1, 0.3, 0.7, 1.1, 0.2)", g!()),
    }
}

#[test]
fn any_expression_folds_and_runs_to_the_same_bits() {
    let mut r = Rng::seeded(0x51_7cc1_b727_220a);
    let mut checked = 0;
    for round in 0..30 {
        let x = [0.1, -0.3, 1.1, 7.0, 16777217.0][r.below(5)];
        let y = [0.2, 2.5, -1.7, 0.0][r.below(4)];
        let exprs: Vec<String> = (0..25).map(|_| general(&mut r, 4)).collect();
        for (e, folded, run) in both(&exprs, x, y) {
            assert!(
                same(folded, run),
                "round {round}, x = {x}, y = {y}: `{e}` folds to {folded} but runs to {run}"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 750);
}

/// The cases that showed the f64 fold: a constant condition, a literal
/// beyond f32's whole numbers and an inexact remainder give what the same
/// arithmetic gives at run time.
#[test]
fn f32_arithmetic_in_constants_and_at_run_time() {
    let c = inline(
        "system S {\n    axiom A(0.1) B A(16777217) F(16777217 - 16777216) G(5 % 0.3);\n    \
         A(x) : x + 0.2 == 0.3 -> X(x - 16777216);\n    B : 0.1 + 0.2 == 0.3 -> Y(1);\n    \
         G(x) -> G(x - 5 % 0.3);\n}\n",
    );
    let s = step_once(&c);
    let params: Vec<Vec<f32>> = (0..s.len()).map(|i| s.get(i).1.to_vec()).collect();
    // A(0.1) -> X(0.1 - 16777216): the condition holds in f32. B -> Y(1):
    // so does the constant one. A(16777217) is A(16777216): its condition
    // fails, it stays. 16777217 - 16777216 is 0, as is 5 % 0.3 - 5 % 0.3.
    assert_eq!(
        params,
        [
            vec![-16777216.0],
            vec![1.0],
            vec![16777216.0],
            vec![0.0],
            vec![0.0]
        ]
    );
}

/// The generator's substitution itself: names and fields keep their `x`.
#[test]
fn substitution_replaces_only_the_bindings() {
    assert_eq!(
        substitute("max(x, vec3(y, 1, x).x) + exp(y)", 1.5, -2.0),
        "max(1.5, vec3((-2), 1, 1.5).x) + exp((-2))"
    );
}
