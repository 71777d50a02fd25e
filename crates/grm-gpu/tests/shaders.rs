//! Every shader is parsed and validated with naga, and the structs shared
//! with Rust have the same layout on both sides. No GPU needed.

use grm_gpu::{kernels, layout, shader};

#[test]
fn every_kernel_validates_with_naga() {
    let mut failures = Vec::new();
    for k in kernels::ALL {
        if let Err(e) = shader::validate_kernel(k) {
            failures.push(e);
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn every_shader_file_is_used_by_a_kernel_or_included() {
    for (name, _) in shader::FILES {
        let used = kernels::ALL.iter().any(|k| {
            k.file == *name
                || k.source()
                    .is_ok_and(|s| s.contains(&format!("// ---- {name}\n")))
        });
        assert!(used, "shaders/{name} is not used by any kernel");
    }
}

#[test]
fn shader_folder_matches_the_embedded_list() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../shaders");
    let mut on_disk: Vec<String> = std::fs::read_dir(dir)
        .expect("shaders/ exists")
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl"))
        .collect();
    on_disk.sort();
    let mut embedded: Vec<String> = shader::FILES.iter().map(|(n, _)| n.to_string()).collect();
    embedded.sort();
    assert_eq!(
        on_disk, embedded,
        "every shaders/*.wgsl must be listed in shader::FILES"
    );
}

#[test]
fn shared_struct_layouts_agree_with_rust() {
    let header = layout::wgsl_header();
    let module = shader::validate("header", &header).expect("header validates");
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).expect("layout");
    for st in layout::all_structs() {
        let (name, size, offsets) = (st.name, st.size, st.offsets);
        let (handle, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("struct {name} missing from the WGSL header"));
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("{name} is not a struct in WGSL");
        };
        assert_eq!(
            *span as usize, size,
            "{name}: WGSL size {span} != Rust size {size}"
        );
        assert_eq!(layouter[handle].size as usize, size, "{name}: size");
        assert_eq!(members.len(), offsets.len(), "{name}: member count");
        for (m, (rname, roff)) in members.iter().zip(&offsets) {
            assert_eq!(m.name.as_deref(), Some(*rname), "{name}: member order");
            assert_eq!(
                m.offset as usize, *roff,
                "{name}.{rname}: WGSL offset {} != Rust offset {roff}",
                m.offset
            );
        }
    }
}

#[test]
fn the_vm_handles_every_op() {
    let vm = shader::file("vm_run.wgsl").expect("vm_run.wgsl");
    for op in grm_compile::op::Op::ALL {
        let name = layout::op_const_name(*op);
        let handled = vm.lines().any(|l| {
            let l = l.trim();
            l.starts_with("case ")
                && l.split(|c: char| c == ',' || c == ':' || c.is_whitespace())
                    .any(|w| w == name)
        });
        assert!(
            handled,
            "shaders/vm_run.wgsl has no `case {name}` for {op:?}"
        );
    }
}
