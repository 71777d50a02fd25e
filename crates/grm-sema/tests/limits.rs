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

/// Whole-number settings have upper bounds (what a derivation or a search
/// sized by them can hold): at the bound a setting is accepted, past it
/// refused with E0208 naming the bound. Before the bounds,
/// `particles_start = 4000000000` made the sampler (and the preview in
/// the language server's process) abort on a failed 32 GB allocation.
#[test]
fn whole_number_settings_are_bounded() {
    for (key, max, sample) in [
        ("iterations", MAX_ITERATIONS, false),
        ("generations", MAX_GENERATIONS, true),
        ("particles_start", MAX_PARTICLES, true),
        ("particles_end", MAX_PARTICLES, true),
    ] {
        let src = |v: u64| {
            let mode = if sample { "mode = sample; " } else { "" };
            format!("system S {{ {mode}{key} = {v}; axiom F; }}")
        };
        assert!(codes(&src(u64::from(max))).is_empty(), "{key} = {max}");
        let (_, c) = check_with("main.grm", &src(u64::from(max) + 1), &MemLoader::new());
        let d: Vec<_> = c.diagnostics.iter().filter(|d| d.is_error()).collect();
        assert_eq!(d.len(), 1, "{key}: {d:?}");
        assert_eq!(d[0].code.as_str(), "E0208", "{key}");
        assert!(
            d[0].message.contains(&format!("at most {max}")),
            "{key}: {}",
            d[0].message
        );
    }
    // `seed` takes every 32-bit value.
    assert!(codes("system S { seed = 4294967295; axiom F; }").is_empty());
}

/// A setting of the largest 32-bit float, written as f32 prints it
/// (`3.4028235e38`, a little over f32::MAX as an f64), is finite: it was
/// refused with E0208 while `3.4028234e38` was accepted. A value that
/// rounds past it is still refused.
#[test]
fn a_setting_of_f32_max_is_finite() {
    for key in ["angle", "step", "width", "elasticity"] {
        for v in ["3.4028235e38", "3.4028234e38", "-3.4028235e38"] {
            if key == "width" && v.starts_with('-') {
                continue;
            }
            let src = format!("system S {{ {key} = {v}; axiom F; }}");
            assert!(codes(&src).is_empty(), "{key} = {v}: {:?}", codes(&src));
        }
        let src = format!("system S {{ {key} = 3.4028235e38 * 2; axiom F; }}");
        assert!(codes(&src).contains(&"E0208"), "{key}: {:?}", codes(&src));
    }
    let src = "system S { tropism = vec3(3.4028235e38, -3.4028235e38, 0); axiom F; }";
    assert!(codes(src).is_empty(), "{:?}", codes(src));
}
