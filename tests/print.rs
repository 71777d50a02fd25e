//! `grmc derive --print` writes grm source text: a printed string, pasted
//! back as an axiom, reads back as the same modules (every terminal form,
//! user modules of every parameter type, and the example scenes' strings).

use grm_derive::{DeriveOptions, Engine};

/// Check `src` (no errors allowed) and compile its first system.
fn compiled(name: &str, src: &str, loader: &dyn grm_sema::FileLoader) -> Checked {
    let (_, checked) = grm_sema::check_with(name, src, loader);
    let errors: Vec<_> = checked
        .diagnostics
        .iter()
        .filter(|d| d.is_error())
        .collect();
    assert!(errors.is_empty(), "{name}:\n{src}\n{errors:?}");
    checked
}

type Checked = grm_sema::Checked;

/// The string `iterations` steps from the axiom of `system`, as text.
fn printed(checked: &Checked, system: &str, iterations: u32) -> String {
    let p = &checked.program;
    let sys = p
        .systems
        .iter()
        .find(|s| s.name == system)
        .expect("the system");
    let c = grm_compile::compile(p, sys, &p.default_params()).expect("compiles");
    let engine = Engine::new(&c, 1).expect("engine");
    let opts = DeriveOptions {
        iterations,
        ..DeriveOptions::from_system(&c)
    };
    let d = engine.derive(&opts, &mut |_| {}).expect("derives");
    grm_compile::text::string_text(p, sys, d.string.iter())
}

/// A loader that has the mesh files the declarations below name.
fn meshes() -> grm_sema::MemLoader {
    let mut loader = grm_sema::MemLoader::new();
    loader.add_binary("leaf.obj").add_binary("m.obj");
    loader
}

/// `text` pasted as the axiom of a new system beside `decls` prints as
/// itself.
fn reads_back(decls: &str, text: &str) {
    let src = format!("{decls}\nsystem Pasted {{ axiom {text}; }}\n");
    let checked = compiled("pasted.grm", &src, &meshes());
    assert_eq!(printed(&checked, "Pasted", 0), text, "{src}");
}

const DECLS: &str = "mesh leaf = \"leaf.obj\";\nmaterial bark { color = rgb(0.4, 0.3, 0.2); }";

#[test]
fn every_terminal_form_reads_back() {
    let axiom = "F F(2) f f(0.5) G G(1) g g(3) + +(10) - -(20) & &(5) ^ ^(6) \\ \\(7) / /(8) \
                 | $ [ ] ! !(0.2) ' '(3) { . F . } % translate(1, 2, 3) translate(vec3(0, 1, 0)) \
                 rotate(vec3(0, 0, 1), 45) rotx roty(12) rotz scale(2) scale(1, 2, 3) \
                 cylinder(0.1, 1) cone(0.2, 0.5) sphere(0.3) box(1, 2, 3) disc(0.5) \
                 mesh(leaf) material(bark) color(0.1, 0.2, 0.3) color(vec3(1, 0, 0)) \
                 material(bark) { . F . mesh(leaf) F . } mesh(leaf) [ { . } ] \
                 A(1.5, vec3(1, -2, 0.25), true) B(false) A(-3, vec3(0, 0, 0), false)";
    let src = format!("{DECLS}\nsystem S {{ axiom {axiom}; }}\n");
    let checked = compiled("terminals.grm", &src, &meshes());
    let text = printed(&checked, "S", 0);
    // Polygons, meshes and materials keep their place and names.
    assert!(text.contains("mesh(leaf) material(bark) color("), "{text}");
    assert!(text.contains("scale(1, 2, 3)"), "{text}");
    reads_back(DECLS, &text);
}

#[test]
fn example_strings_read_back() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples");
    let loader = grm_sema::FsLoader;
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).expect("examples/") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|e| e != "grm") {
            continue;
        }
        let src = std::fs::read_to_string(&path).expect("readable");
        let checked = compiled(&path.display().to_string(), &src, &loader);
        let decls: String = checked
            .program
            .meshes
            .iter()
            .map(|m| format!("mesh {} = \"m.obj\";\n", m.name))
            .chain(
                checked
                    .program
                    .materials
                    .iter()
                    .map(|m| format!("material {} {{ }}\n", m.name)),
            )
            .collect();
        for sys in &checked.program.systems {
            if sys.mode != grm_sema::Mode::Derive {
                continue;
            }
            let text = printed(&checked, &sys.name, 3);
            reads_back(&decls, &text);
            seen += 1;
        }
    }
    assert!(seen >= 8, "only {seen} derive systems in examples/");
}
