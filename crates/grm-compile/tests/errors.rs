//! Lowering errors: each has its code and points at the offending span.

use grm_compile::{CompileErrorKind, compile};
use grm_diag::Code;

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
    // Folded in f32 by the checker: infinite.
    let (e, text) = compile_err("system S { axiom A; A -> F(1e30 * 1e30); }");
    assert!(
        matches!(e.kind, CompileErrorKind::NonFiniteConstant { .. }),
        "{e:?}"
    );
    assert_eq!(e.code(), Code::NonFiniteConstant);
    assert_eq!(text, "1e30 * 1e30");
}

#[test]
fn infinite_constant_weight() {
    // Positive as written, 0 in f32 (a constant that is 0, negative or
    // infinite in f32 is the checker's E0207).
    let (e, text) = compile_err("system S { axiom A; A -> (1e-50) B; A -> (1) C; }");
    assert!(
        matches!(e.kind, CompileErrorKind::BadWeight { .. }),
        "{e:?}"
    );
    assert_eq!(e.code(), Code::InvalidConstantWeight);
    assert_eq!(text, "1e-50");
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
    assert_eq!(err.code(), Code::ExprNeedsTooMuchStack);
    assert!(text.starts_with("x + (x + "), "{text}");
}

#[test]
fn meta_parameter_values_must_fit() {
    let p = program("param s = 1 in 0 .. 2; system S { axiom A(s); }");
    let sys = p.default_system().expect("a system");
    let e = compile(&p, sys, &[]).expect_err("missing value");
    assert_eq!(e.code(), Code::ParamValues);
    let e = compile(&p, sys, &[grm_sema::Value::Bool(true)]).expect_err("wrong type");
    assert_eq!(e.code(), Code::ParamValues);
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
    assert_eq!(e.code(), Code::SettingForParams);
}

/// Internal R0101: a program with checker errors is refused, not lowered
/// (an `Error` expression stands where the checker found a problem).
#[test]
fn a_program_with_errors_is_refused() {
    let mut p = program("system S { axiom A(1); A(x) -> A(x + 1); }");
    let sys = &mut p.systems[0];
    let arg = &mut sys.groups[0].alternatives[0].successor[0].args[0];
    arg.kind = grm_sema::TExprKind::Error;
    let span = arg.span;
    let e = compile(&p, &p.systems[0], &p.default_params()).expect_err("has errors");
    assert_eq!(e.code(), Code::CompiledWithErrors);
    assert_eq!(e.span, span);
    let d = e.to_diagnostic();
    assert_eq!(d.code, Code::CompiledWithErrors);
    assert!(
        d.help.as_deref().is_some_and(|h| h.contains("internal")),
        "{d:?}"
    );
}

/// Internal R0108: the parser never puts a bracket in a left context; the
/// compiler still refuses one.
#[test]
fn a_bracket_in_a_left_context_is_refused() {
    let mut p = program("system S { axiom B A; B < A -> C; }");
    let span = grm_diag::Span::new(11, 12);
    p.systems[0].groups[0]
        .left
        .insert(0, grm_sema::TContextItem::Push(span));
    let e = compile(&p, &p.systems[0], &p.default_params()).expect_err("bracket");
    assert!(
        matches!(e.kind, CompileErrorKind::LeftContextBracket),
        "{e:?}"
    );
    assert_eq!(e.code(), Code::LeftContextBracket);
    assert_eq!(e.to_diagnostic().primary().span, span);
}

/// Internal R0109: the checker resolves no module parameter in an axiom;
/// the compiler still refuses one.
#[test]
fn an_axiom_binding_is_refused() {
    let mut p = program("system S { axiom A(1); A(x) -> A(x); }");
    let arg = &mut p.systems[0].axiom[0].args[0];
    arg.kind = grm_sema::TExprKind::ModuleParam(0);
    let span = arg.span;
    let e = compile(&p, &p.systems[0], &p.default_params()).expect_err("binding");
    assert_eq!(e.code(), Code::AxiomBinding);
    assert_eq!(e.span, span);
}

/// R0107: a spline with more controls than its 16-bit operand field holds.
#[test]
fn too_many_spline_controls() {
    let controls = vec!["0"; 65_536].join(", ");
    let src = format!("system S {{ axiom A(1); A(x) -> A(spline(x, {controls})); }}");
    let (e, text) = compile_err(&src);
    assert!(
        matches!(
            e.kind,
            CompileErrorKind::TooLarge {
                what: "spline controls"
            }
        ),
        "{e:?}"
    );
    assert_eq!(e.code(), Code::TablesTooLarge);
    assert!(text.starts_with("spline(x, 0, 0"), "{}", &text[..40]);
}

/// Every lowering error renders as a diagnostic with its code, the primary
/// label on its span and a help line.
#[test]
fn errors_become_diagnostics() {
    let src = "system S { axiom A; A -> F(1e30 * 1e30); }";
    let (e, text) = compile_err(src);
    let d = e.to_diagnostic();
    assert_eq!(d.code, Code::NonFiniteConstant);
    assert_eq!(d.message, e.to_string());
    assert_eq!(&src[d.primary().span.range()], text);
    assert!(d.help.is_some());
}
