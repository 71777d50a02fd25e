//! The typed program: what the compiler, engines and language server read.

use grm_sema::*;

fn check_ok(text: &str) -> Program {
    let mut files = MemLoader::new();
    files.add("leaf.obj", "v 0 0 0");
    let (sources, c) = check_with("main.grm", text, &files);
    let rendered: Vec<String> = c
        .diagnostics
        .iter()
        .map(|d| grm_diag::render_plain(d, &sources))
        .collect();
    assert!(c.diagnostics.is_empty(), "{}", rendered.join("\n"));
    assert_invariants(&c.program);
    c.program
}

/// The documented invariants of a program checked without errors.
fn assert_invariants(p: &Program) {
    fn no_error(e: &TExpr) {
        e.walk(&mut |x| {
            assert_ne!(x.ty, Ty::Error, "error type in a clean program: {x:?}");
            assert!(!matches!(x.kind, TExprKind::Error));
        });
    }
    fn module(sys: &System, m: &TModule) {
        let s = sys.symbol(m.symbol);
        assert_eq!(m.args.len(), s.arity, "module {} arity", s.name);
        for (a, t) in m.args.iter().zip(&s.params) {
            no_error(a);
            assert_eq!(a.ty, *t, "argument type of {}", s.name);
        }
    }
    for c in &p.consts {
        no_error(&c.value);
    }
    for sys in &p.systems {
        for m in &sys.axiom {
            module(sys, m);
        }
        for s in &sys.symbols {
            assert_eq!(s.params.len(), s.arity);
        }
        for g in &sys.groups {
            assert!(!g.alternatives.is_empty());
            if let Some(c) = &g.condition {
                no_error(c);
                assert_eq!(c.ty, Ty::Bool);
            }
            for a in &g.alternatives {
                assert_eq!(a.weight.ty, Ty::Float);
                assert_eq!(a.bindings.len() as u32, g.slots);
                for m in &a.successor {
                    module(sys, m);
                }
            }
        }
    }
}

#[test]
fn stochastic_alternatives_form_one_group_with_probabilities() {
    let p = check_ok(
        "system S {
            axiom A(1);
            A(k) : k < 60 -> (6) F A(k + 1);
            A(k) : k < 60 -> (2) F [ + A(k + 1) ] A(k + 1);
            A(k) : k < 60 -> (1) F;
            A(k) : k >= 60 -> F;
        }",
    );
    let sys = &p.systems[0];
    let a = sys.symbol_by_name("A").unwrap();
    let groups: Vec<&Group> = sys.groups_of(a).collect();
    assert_eq!(groups.len(), 2);
    assert_eq!(groups[0].alternatives.len(), 3);
    let probs = groups[0].probabilities().unwrap();
    assert!((probs[0] - 6.0 / 9.0).abs() < 1e-12);
    assert!((probs[2] - 1.0 / 9.0).abs() < 1e-12);
    assert_eq!(groups[1].alternatives.len(), 1);
    assert_eq!(groups[1].probabilities().unwrap(), vec![1.0]);
}

#[test]
fn conditions_equal_up_to_parameter_names_group_together() {
    let p = check_ok(
        "system S {
            axiom A(1);
            A(x) : x > 1 -> (1) F(x);
            A(y) : y > 1 -> (3) F(y) F(y);
            A(z) -> A(z + 1);
        }",
    );
    let sys = &p.systems[0];
    assert_eq!(sys.groups.len(), 2);
    assert_eq!(sys.groups[0].alternatives.len(), 2);
}

#[test]
fn binding_slots_follow_text_order() {
    let p = check_ok(
        "system S {
            axiom A(1) B(2) C(3);
            A(x) < B(y) > C(z) -> B(x + y + z);
            A(a) -> A(a);
            C(c) -> C(c);
        }",
    );
    let sys = &p.systems[0];
    let g = &sys.groups[0];
    assert_eq!(g.slots, 3);
    let TContextItem::Pattern(left) = &g.left[0] else {
        panic!()
    };
    assert_eq!((left.first_slot, left.binds), (0, 1));
    assert_eq!((g.pred.first_slot, g.pred.binds), (1, 1));
    let TContextItem::Pattern(right) = &g.right[0] else {
        panic!()
    };
    assert_eq!((right.first_slot, right.binds), (2, 1));
    let names: Vec<&str> = g.alternatives[0]
        .bindings
        .iter()
        .map(|b| b.name.as_str())
        .collect();
    assert_eq!(names, ["x", "y", "z"]);
    // x + y + z refers to slots 0, 1, 2.
    let mut slots = Vec::new();
    g.alternatives[0].successor[0].args[0].walk(&mut |e| {
        if let TExprKind::ModuleParam(s) = e.kind {
            slots.push(s);
        }
    });
    assert_eq!(slots, [0, 1, 2]);
}

#[test]
fn omitted_terminal_arguments_take_the_settings() {
    let p = check_ok(
        "system S {
            angle = 30;
            step = 2;
            axiom F + f(3) translate(1, 2, 3) scale(2);
        }",
    );
    let sys = &p.systems[0];
    let ax = &sys.axiom;
    assert_eq!(sys.symbol(ax[0].symbol).terminal(), Some(Terminal::Forward));
    assert_eq!(ax[0].args[0].constant(), Some(Value::Float(2.0)));
    assert_eq!(
        sys.symbol(ax[1].symbol).terminal(),
        Some(Terminal::TurnLeft)
    );
    assert_eq!(ax[1].args[0].constant(), Some(Value::Float(30.0)));
    assert_eq!(ax[2].args[0].constant(), Some(Value::Float(3.0)));
    assert_eq!(
        sys.symbol(ax[3].symbol).terminal(),
        Some(Terminal::Translate)
    );
    assert_eq!(ax[3].args[0].constant(), Some(Value::Vec3([1.0, 2.0, 3.0])));
    assert_eq!(
        sys.symbol(ax[4].symbol).terminal(),
        Some(Terminal::ScaleUniform)
    );
    assert_eq!(sys.settings.angle, 30.0);
    assert_eq!(sys.settings.step, 2.0);
}

#[test]
fn f_with_and_without_length_is_one_symbol() {
    let p = check_ok(
        "system S {
            axiom F F(2) push pop [ ];
            F(l) -> F(l / 2) F(l / 2);
        }",
    );
    let sys = &p.systems[0];
    assert_eq!(sys.axiom[0].symbol, sys.axiom[1].symbol);
    assert_eq!(sys.axiom[2].symbol, sys.axiom[4].symbol, "push is [");
    assert_eq!(sys.axiom[3].symbol, sys.axiom[5].symbol, "pop is ]");
    let f = sys.axiom[0].symbol;
    assert_eq!(sys.groups_of(f).count(), 1);
}

#[test]
fn parameter_types_are_inferred_across_uses() {
    let p = check_ok(
        "system S {
            axiom A(vec3(0, 1, 0), 1);
            A(d, l) -> translate(d * l) B(d.y) A(d * 0.5, l);
            B(h) -> F(h);
        }",
    );
    let sys = &p.systems[0];
    let a = sys.symbol(sys.symbol_by_name("A").unwrap());
    assert_eq!(a.params, vec![Ty::Vec3, Ty::Float]);
    let b = sys.symbol(sys.symbol_by_name("B").unwrap());
    assert_eq!(b.params, vec![Ty::Float]);
}

#[test]
fn inference_needs_no_particular_order() {
    // B's parameter is only known to be a vector through A's production,
    // which comes after B's.
    let p = check_ok(
        "system S {
            axiom A(vec3(1, 0, 0));
            B(v) -> translate(v * 2);
            A(u) -> B(u);
        }",
    );
    let sys = &p.systems[0];
    let b = sys.symbol(sys.symbol_by_name("B").unwrap());
    assert_eq!(b.params, vec![Ty::Vec3]);
}

#[test]
fn constants_fold_and_parameter_dependent_ones_stay_global() {
    let p = check_ok(
        "param p = 0.3 in 0 .. 1;
        const c = 1;
        const q = c - p;
        const k = 2 * 3 + c;
        system S {
            axiom F(k) F(q) F(p);
        }",
    );
    let k = p.consts.iter().find(|c| c.name == "k").unwrap();
    assert_eq!(k.value.constant(), Some(Value::Float(7.0)));
    let q = p.consts.iter().position(|c| c.name == "q").unwrap();
    let c = p.consts.iter().position(|c| c.name == "c").unwrap();
    assert!(c < q, "constants are in dependency order");
    let sys = &p.systems[0];
    assert_eq!(sys.axiom[0].args[0].constant(), Some(Value::Float(7.0)));
    assert!(matches!(sys.axiom[1].args[0].kind, TExprKind::Global(id) if id.index() == q));
    assert!(matches!(sys.axiom[2].args[0].kind, TExprKind::Param(_)));
    let globals = p.global_values(&[Value::Float(0.25)]).unwrap();
    assert_eq!(globals[q], Value::Float(0.75));
}

#[test]
fn settings_follow_meta_parameters() {
    let p = check_ok(
        "param depth = 4 in 1 .. 8;
        system S {
            iterations = depth;
            axiom F;
        }",
    );
    let sys = &p.systems[0];
    assert_eq!(sys.settings.iterations, 4);
    let params = [Value::Float(6.0)];
    let globals = p.global_values(&params).unwrap();
    assert_eq!(sys.settings_with(&params, &globals).unwrap().iterations, 6);
    let bad = [Value::Float(6.5)];
    assert!(sys.settings_with(&bad, &globals).is_err());
}

#[test]
fn meta_parameters_meshes_and_materials() {
    let p = check_ok(
        "param spread = 30 in 10 .. 60;
        mesh leaf = \"leaf.obj\";
        material bark { color = rgb(0.4, 0.3, 0.2); roughness = 0.5 + 0.4; }
        system S {
            mode = sample;
            axiom branch;
            skeleton branch;
            geometry deco;
            branch -> rotz(spread) deco F(1) branch;
            wrapup branch -> deco;
            deco -> material(bark) mesh(leaf);
        }",
    );
    assert_eq!(p.params[0].range, Some((10.0, 60.0)));
    assert_eq!(p.params[0].default, Value::Float(30.0));
    assert_eq!(p.meshes[0].path, std::path::PathBuf::from("leaf.obj"));
    let bark = &p.materials[0];
    assert_eq!(
        bark.get(MaterialProp::Roughness).and_then(TExpr::constant),
        // Folded in 32-bit floats, as the engines compute.
        Some(Value::Float(f64::from(0.9f32)))
    );
    let sys = &p.systems[0];
    assert_eq!(sys.mode, Mode::Sample);
    let deco = sys.symbol_by_name("deco").unwrap();
    let g = sys.groups_of(deco).next().unwrap();
    assert_eq!(
        g.alternatives[0].successor[1].args[0].constant(),
        Some(Value::Mesh(MeshId(0)))
    );
    let branch = sys.symbol_by_name("branch").unwrap();
    assert_eq!(sys.symbol(branch).phase, Phase::Skeleton);
    assert_eq!(sys.wrapups_of(branch).count(), 1);
}

#[test]
fn ignore_list_covers_every_form_of_a_terminal() {
    let p = check_ok(
        "system S {
            ignore ! F;
            axiom A ! !(2) F;
            A < F -> A;
        }",
    );
    let sys = &p.systems[0];
    let names: Vec<&str> = sys
        .ignore
        .iter()
        .map(|&i| sys.symbol(i).name.as_str())
        .collect();
    assert_eq!(names, ["!", "!", "F"]);
}

#[test]
fn references_index_finds_definitions_and_uses() {
    let text = "const ratio = 0.9;
system S {
    axiom A(1);
    A(l) -> F(l) A(l * ratio);
}";
    let p = check_ok(text);
    let use_at = text.rfind("ratio").unwrap() as u32;
    let r = p.index.at(FileId(0), use_at + 2).expect("a reference");
    let def = p.index.definition(r.def).expect("its definition");
    assert_eq!(def.span.start as usize, text.find("ratio").unwrap());
    assert_eq!(p.index.occurrences(r.def).count(), 2);
    // A module parameter: the use of `l` points at the binding.
    let l_use = text.find("F(l)").unwrap() as u32 + 2;
    let r = p.index.at(FileId(0), l_use).expect("binding use");
    let Def::Binding { binding } = r.def else {
        panic!("{r:?}")
    };
    assert_eq!(binding.span.start as usize, text.find("A(l)").unwrap() + 2);
    // Symbols: every occurrence of `A`, the first use being its definition.
    let a = p
        .index
        .at(FileId(0), text.find("A(1)").unwrap() as u32)
        .unwrap();
    assert!(a.is_def);
    assert_eq!(p.index.occurrences(a.def).count(), 3);
}

#[test]
fn imports_bring_definitions_into_scope() {
    let mut files = MemLoader::new();
    files.add("lib/common.grm", "const GOLDEN = 137.5;");
    files.add(
        "lib/more.grm",
        "import \"common.grm\";\nconst TWICE = GOLDEN * 2;",
    );
    let (sources, c) = check_with(
        "main.grm",
        "import \"lib/more.grm\";\nsystem S { angle = TWICE - GOLDEN; axiom F; }",
        &files,
    );
    assert!(c.diagnostics.is_empty(), "{:?}", c.diagnostics);
    assert_eq!(c.program.systems[0].settings.angle, 137.5);
    assert!(sources.find("lib/common.grm").is_some());
    assert_eq!(sources.iter().count(), 3);
}

#[test]
fn every_clean_case_satisfies_the_invariants() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.extension().is_some_and(|e| e == "grm") {
            let text = std::fs::read_to_string(&path).unwrap();
            let (_, c) = check_text(&path.to_string_lossy(), &text);
            assert!(!c.has_errors());
            assert_invariants(&c.program);
        }
    }
}
