//! `grm-tests`: shared helpers for the workspace-level test suites.
//!
//! Role: run the real pipeline (parse + check, with the real file loader)
//! on files under `tests/ui/` and render what a user would see; for
//! `tests/run/`, also run the engines as grmc does ([`runner`]). Inputs:
//! paths relative to this crate. Outputs: plain-text renderings for insta
//! snapshots and the set of codes produced.
//!
//! Invariant: renderings use paths relative to this crate and no colour, so
//! snapshots are identical on every machine.

pub mod runner;

/// The suites' generator of random inputs (`GRM_TEST_SEED` soaks them).
pub use grm_testkit::Rng;

use grm_diag::SourceMap;
use std::collections::BTreeSet;
use std::path::Path;

/// The codes a ui file declares on its first line: `// expect: E0101 W0001`
/// or `// expect: none`.
pub fn declared_codes(text: &str) -> Option<BTreeSet<String>> {
    let first = text.lines().next()?;
    let rest = first.trim().strip_prefix("// expect:")?;
    Some(
        rest.split_whitespace()
            .filter(|c| *c != "none")
            .map(str::to_string)
            .collect(),
    )
}

/// Check a file the way `grmc check` does, from a path relative to this
/// crate's directory (the working directory of cargo tests).
pub fn check_file(rel: &Path) -> (SourceMap, grm_sema::Checked) {
    let text =
        std::fs::read_to_string(rel).unwrap_or_else(|e| panic!("read {}: {e}", rel.display()));
    let mut sources = SourceMap::new();
    let shown = rel.to_string_lossy().replace('\\', "/");
    let root = sources.add(shown, text);
    let mut checked = grm_sema::check(&mut sources, root, &grm_sema::FsLoader);
    checked.diagnostics.extend(grm_compile::check(&checked));
    (sources, checked)
}

/// Source and rendered diagnostics together, as one snapshot body.
pub fn render_case(rel: &Path) -> (String, BTreeSet<String>) {
    let (sources, checked) = check_file(rel);
    let root = sources.get(grm_diag::FileId(0));
    let mut out = String::new();
    for (i, line) in root.text.lines().enumerate() {
        out.push_str(&format!("{:>3} | {line}\n", i + 1));
    }
    out.push_str("\n----- diagnostics -----\n");
    if checked.diagnostics.is_empty() {
        out.push_str("(none)\n");
    }
    for d in &checked.diagnostics {
        out.push_str(&grm_diag::render_human(d, &sources, false));
    }
    let codes = checked
        .diagnostics
        .iter()
        .map(|d| d.code.as_str().to_string())
        .collect();
    (out, codes)
}

/// A clean grammar of about `lines` lines exercising every construct the
/// checker works hard on: constants, meta-parameters, several systems,
/// parametric, stochastic, conditional and context-sensitive productions.
/// Used by the check benchmark and the language-server latency tests.
pub fn generated_grammar(lines: usize) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "// generated benchmark grammar");
    let _ = writeln!(s, "param spread = 30 in 10 .. 60;");
    let _ = writeln!(s, "const SHRINK = 0.85;");
    let per_system = 50;
    let mut sys = 0;
    while s.lines().count() + per_system + 10 < lines {
        let _ = writeln!(s, "\nsystem S{sys} {{");
        let _ = writeln!(s, "    iterations = 4;");
        let _ = writeln!(s, "    angle = spread;");
        let _ = writeln!(s, "    ignore + -;");
        let _ = writeln!(s, "    axiom A0(1, 0.1);");
        let n = (per_system - 6) / 4;
        for i in 0..n {
            let next = (i + 1) % n;
            let _ = writeln!(
                s,
                "    A{i}(l, w) : l > 0.01 -> (2) F(l) [ + A{next}(l * SHRINK, w * 0.7) ] B{i}(w);"
            );
            let _ = writeln!(
                s,
                "    A{i}(l, w) : l > 0.01 -> (1) F(l) [ - A{next}(l * SHRINK, w) ] B{i}(w * 0.5);"
            );
            let _ = writeln!(s, "    A{i}(l, _w) -> F(l + uniform(0, 0.1));");
            let _ = writeln!(
                s,
                "    A{next}(_x, _y) < B{i}(w) -> !(w) B{i}(max(w - 0.01, 0));"
            );
        }
        let _ = writeln!(s, "}}");
        sys += 1;
    }
    s
}

#[cfg(test)]
mod gen_tests {
    #[test]
    fn generated_grammar_is_clean() {
        let text = super::generated_grammar(1000);
        let (sources, checked) = grm_sema::check_text("gen.grm", &text);
        let diags: Vec<String> = checked
            .diagnostics
            .iter()
            .take(5)
            .map(|d| grm_diag::render_plain(d, &sources))
            .collect();
        assert!(checked.diagnostics.is_empty(), "{}", diags.join("\n"));
        assert!(text.lines().count() >= 950);
    }
}
