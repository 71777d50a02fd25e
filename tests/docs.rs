//! Documentation stays in step with the code.

use std::path::Path;

fn read(rel: &str) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel);
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("read {}: {e}", p.display()))
}

/// `docs/diagnostics.md` has a `## CODE: title` section for every code, and
/// no section for a code that does not exist.
#[test]
fn diagnostics_doc_lists_every_code() {
    let doc = read("docs/diagnostics.md");
    let mut documented = Vec::new();
    for line in doc.lines() {
        if let Some(rest) = line.strip_prefix("## ")
            && let Some((code, _)) = rest.split_once(':')
        {
            documented.push(code.trim().to_string());
        }
    }
    for code in grm_diag::Code::ALL {
        assert!(
            documented.iter().any(|d| d == code.as_str()),
            "docs/diagnostics.md lacks `## {}: {}`",
            code.as_str(),
            code.title()
        );
    }
    for d in &documented {
        assert!(
            grm_diag::Code::from_str_code(d).is_some(),
            "docs/diagnostics.md documents unknown code {d}"
        );
    }
}

/// The codes the snapshot suites exempt as internal (`grm_tests::runner::
/// EXEMPT`) say in docs/diagnostics.md that they are internal.
#[test]
fn internal_codes_are_documented_as_internal() {
    let doc = read("docs/diagnostics.md");
    for (code, why) in grm_tests::runner::EXEMPT {
        if !why.starts_with("internal") {
            continue;
        }
        let head = format!("{}:", code.as_str());
        let section = doc
            .split("\n## ")
            .find(|s| s.starts_with(&head))
            .unwrap_or_else(|| panic!("docs/diagnostics.md lacks `## {head}`"));
        assert!(
            section.contains("Internal"),
            "docs/diagnostics.md: {code} is exempt from the snapshot suites as internal; its section must say \"Internal\""
        );
    }
}

/// Every example in `examples/` checks without errors.
#[test]
fn examples_check_clean() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).expect("examples/ exists").flatten() {
        let p = entry.path();
        if p.extension().is_some_and(|e| e == "grm") {
            let text = std::fs::read_to_string(&p).expect("readable example");
            let mut sources = grm_diag::SourceMap::new();
            let root = sources.add(p.display().to_string(), text);
            let checked = grm_sema::check(&mut sources, root, &grm_sema::FsLoader);
            let errs: Vec<String> = checked
                .diagnostics
                .iter()
                .map(|d| grm_diag::render_plain(d, &sources))
                .collect();
            assert!(errs.is_empty(), "{}:\n{}", p.display(), errs.join("\n"));
            n += 1;
        }
    }
    assert!(n >= 10, "expected at least 10 examples, found {n}");
}
