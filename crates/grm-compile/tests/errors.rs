//! Lowering errors: each has its code and points at the offending span.

use grm_compile::{CompileErrorKind, compile};

fn program(src: &str) -> grm_sema::Program {
    let (_, checked) = grm_sema::check_with("t.grm", src, &grm_sema::MemLoader::new());
    let errors: Vec<_> = checked
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .collect();
    assert!(errors.is_empty(), "{src}\n{errors:?}");
    checked.program
}

fn compile_err(src: &str) -> (grm_compile::CompileError, String) {
    let p = program(src);
    let sys = p.default_system().expect("a system");
    let e = compile(&p, sys, &p.default_params()).expect_err("should not compile");
    let text = src[e.span.range()].to_string();
    (e, text)
}

#[test]
fn non_finite_constant_parameter() {
    // Folded in f64 by the checker: 1e60, infinite in f32.
    let (e, text) = compile_err("system S { axiom A; A -> F(1e30 * 1e30); }");
    assert!(
        matches!(e.kind, CompileErrorKind::NonFiniteConstant { .. }),
        "{e:?}"
    );
    assert_eq!(e.code(), "R0104");
    assert_eq!(text, "1e30 * 1e30");
}

#[test]
fn infinite_constant_weight() {
    let (e, text) = compile_err("system S { axiom A; A -> (1e30 * 1e30) B; A -> (1) C; }");
    assert!(
        matches!(e.kind, CompileErrorKind::BadWeight { .. }),
        "{e:?}"
    );
    assert_eq!(e.code(), "R0105");
    assert_eq!(text, "1e30 * 1e30");
}

#[test]
fn expression_too_deep_for_the_stack() {
    // x + (x + (x + ...)): every level keeps one value on the stack.
    let mut e = "x".to_string();
    for _ in 0..70 {
        e = format!("x + ({e})");
    }
    let src = format!("system S {{ axiom A(1); A(x) -> A({e}); }}");
    let (err, text) = compile_err(&src);
    assert!(
        matches!(err.kind, CompileErrorKind::TooDeep { depth } if depth > 64),
        "{err:?}"
    );
    assert_eq!(err.code(), "R0106");
    assert!(text.starts_with("x + (x + "), "{text}");
}

#[test]
fn meta_parameter_values_must_fit() {
    let p = program("param s = 1 in 0 .. 2; system S { axiom A(s); }");
    let sys = p.default_system().expect("a system");
    let e = compile(&p, sys, &[]).expect_err("missing value");
    assert_eq!(e.code(), "R0102");
    let e = compile(&p, sys, &[grm_sema::Value::Bool(true)]).expect_err("wrong type");
    assert_eq!(e.code(), "R0102");
    // A value folds into the constant pool.
    let c = compile(&p, sys, &[grm_sema::Value::Float(1.5)]).expect("compiles");
    assert!(c.consts.contains(&1.5));
}

#[test]
fn settings_follow_meta_parameters() {
    let p = program("param n = 3 in 1 .. 9; system S { iterations = n * 2; axiom A; }");
    let sys = p.default_system().expect("a system");
    let c = compile(&p, sys, &[grm_sema::Value::Float(4.0)]).expect("compiles");
    assert_eq!(c.settings.iterations, 8);
    // 2.25 * 2 = 4.5 iterations: not a whole number.
    let e = compile(&p, sys, &[grm_sema::Value::Float(2.25)]).expect_err("4.5 iterations");
    assert_eq!(e.code(), "R0103");
}
