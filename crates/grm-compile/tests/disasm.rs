//! Disassembly snapshots of compiled examples, and compile-all checks.

use std::path::{Path, PathBuf};

fn examples_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples")
}

/// Check an example and compile one of its systems with default parameters;
/// returns the compiled system and the file text.
fn compile_example(file: &str, system: Option<&str>) -> (grm_compile::CompiledSystem, String) {
    let path = examples_dir().join(file);
    let text = std::fs::read_to_string(&path).expect("example exists");
    let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
    assert!(!checked.has_errors(), "{file}: {:?}", checked.diagnostics);
    let p = &checked.program;
    let sys = match system {
        Some(n) => p.system(n).expect("system exists"),
        None => p.default_system().expect("a system"),
    };
    let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
    c.validate().expect("valid tables");
    (c, text)
}

fn disasm(file: &str, system: Option<&str>) -> String {
    let (c, text) = compile_example(file, system);
    grm_compile::disassemble(&c, Some(&text))
}

#[test]
fn disasm_row_of_trees() {
    insta::assert_snapshot!(disasm("row_of_trees.grm", None));
}

#[test]
fn disasm_ternary_tree() {
    insta::assert_snapshot!(disasm("ternary_tree.grm", None));
}

#[test]
fn disasm_context_plant_a() {
    insta::assert_snapshot!(disasm("context_plant_a.grm", None));
}

#[test]
fn disasm_stochastic_plant() {
    insta::assert_snapshot!(disasm("stochastic_plant.grm", None));
}

#[test]
fn disasm_vine_wall() {
    insta::assert_snapshot!(disasm("vine_wall.grm", None));
}

/// Every system of every example compiles, validates, packs and the packed
/// header points at the sections.
#[test]
fn every_example_system_compiles() {
    let mut n = 0;
    for entry in std::fs::read_dir(examples_dir())
        .expect("examples/")
        .flatten()
    {
        let path = entry.path();
        if path.extension().is_none_or(|e| e != "grm") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("readable");
        let (_, checked) = grm_sema::check_text(&path.display().to_string(), &text);
        assert!(!checked.has_errors(), "{}", path.display());
        let p = &checked.program;
        // Shape systems have no bytecode (R0806).
        for sys in p
            .systems
            .iter()
            .filter(|s| s.loc.file == p.root && s.mode != grm_sema::Mode::Shape)
        {
            let c = grm_compile::compile(p, sys, &p.default_params())
                .unwrap_or_else(|e| panic!("{}: {}: {e}", path.display(), sys.name));
            c.validate().expect("valid");
            let words = c.pack();
            let header: &grm_compile::table::PackedHeader = bytemuck::from_bytes(
                bytemuck::cast_slice(&words[..size_of::<grm_compile::table::PackedHeader>() / 4]),
            );
            assert_eq!(header.magic, grm_compile::table::PACKED_MAGIC);
            assert_eq!(header.code_count as usize, c.code.len());
            let code = &words[header.code_offset as usize..][..c.code.len()];
            assert_eq!(code, &c.code[..]);
            assert_eq!(
                header.consts_offset as usize + c.consts.len(),
                header.log2_offset as usize
            );
            let table = &words[header.log2_offset as usize..];
            assert_eq!(table, &grm_compile::rng::LOG2_TABLE[..]);
            n += 1;
        }
    }
    assert!(n >= 12, "only {n} systems");
}
