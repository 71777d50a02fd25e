//! The expression depth limit (E0211) is the parser's, and the checker
//! neither reports it again nor cascades from it.

use grm_sema::*;

fn codes(text: &str) -> Vec<&'static str> {
    let mut files = MemLoader::new();
    files.add("leaf.obj", "v 0 0 0");
    let (_, c) = check_with("main.grm", text, &files);
    c.diagnostics.iter().map(|d| d.code.as_str()).collect()
}

#[test]
fn the_limit_is_one_number() {
    let nested = |levels: usize| {
        format!(
            "const X = {}1{};\nsystem S {{ axiom F(X); }}",
            "(".repeat(levels - 1),
            ")".repeat(levels - 1)
        )
    };
    assert!(codes(&nested(grm_syntax::MAX_EXPR_DEPTH)).is_empty());
    assert_eq!(codes(&nested(grm_syntax::MAX_EXPR_DEPTH + 1)), ["E0211"]);
}

#[test]
fn a_too_deep_expression_costs_one_diagnostic_anywhere() {
    let deep = format!("{}1", "-".repeat(grm_syntax::MAX_EXPR_DEPTH));
    let srcs = [
        format!("const X = {deep};\nsystem S {{ axiom F(X); }}"),
        format!("param p = {deep} in 0 .. 1;\nsystem S {{ axiom F(p); }}"),
        format!("material m {{ roughness = {deep}; }}\nsystem S {{ axiom material(m) F; }}"),
        format!("system S {{ angle = {deep}; axiom F; }}"),
        format!("system S {{ iterations = {deep}; axiom F; }}"),
        format!("system S {{ axiom F(1) F({deep}); }}"),
        format!("system S {{ axiom A(1); A(x) : {deep} > x -> F A(x); }}"),
        format!("system S {{ axiom A(1); A(x) -> ({deep}) F A(x); }}"),
        format!("system S {{ axiom A(1); A(x) -> F(x) [ A({deep}) ]; }}"),
    ];
    for src in &srcs {
        assert_eq!(codes(src), ["E0211"], "{:.70}", src);
    }
}
