//! Shader sources: the WGSL files of `shaders/`, composed with a header
//! generated from Rust (constants and struct layouts) so that the two sides
//! have one definition; and validation with naga (no GPU needed).
//!
//! Composition: a kernel's source is the generated header, then its file
//! with every `//!include NAME.wgsl` line replaced by that file (each file
//! at most once; `generated_tables` is the packed-table loader code
//! generated from `grm-compile`'s records), then the kernel's text substitutions (used to
//! instantiate the scan for `u32` and `vec2<u32>`).

use std::collections::HashSet;

use crate::error::GpuError;

macro_rules! shader_files {
    ($($name:literal),* $(,)?) => {
        &[$(($name, include_str!(concat!("../../../shaders/", $name)))),*]
    };
}

/// The WGSL files, by name (relative to `shaders/`), embedded at build time.
pub const FILES: &[(&str, &str)] = shader_files!(
    "scan.wgsl",
    "scan_add.wgsl",
    "grid.wgsl",
    "rng.wgsl",
    "vm.wgsl",
    "vm_run.wgsl",
    "vm_run_none.wgsl",
    "vm_eval.wgsl",
    "derive.wgsl",
    "contexts.wgsl",
    "contexts_none.wgsl",
    "brackets.wgsl",
    "turtle.wgsl",
    "turtle_scan.wgsl",
    "directory.wgsl",
    "batch.wgsl",
    "wg_scan.wgsl",
    "offsets_global.wgsl",
    "offsets_blocks.wgsl",
    "count_scan.wgsl",
    "expand.wgsl",
    "expand_const.wgsl",
    "expand_vm.wgsl",
    "turtle_cmds.wgsl",
    "expand_turtle.wgsl",
);

/// How a kernel binds a buffer (binding index = position in the list).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bind {
    Uniform,
    Read,
    ReadWrite,
}

/// One compute entry point with its bindings (group 0, bindings 0..n).
#[derive(Debug)]
pub struct Kernel {
    /// Unique name (pipeline cache key, labels).
    pub name: &'static str,
    /// The file in `shaders/`.
    pub file: &'static str,
    pub entry: &'static str,
    pub bindings: &'static [Bind],
    /// Text substitutions applied to the composed source.
    pub subst: &'static [(&'static str, &'static str)],
}

impl Kernel {
    /// The full WGSL source of this kernel.
    pub fn source(&self) -> Result<String, GpuError> {
        compose_with(self.file, self.subst)
    }
}

/// A WGSL file of `shaders/` by name.
pub fn file(name: &str) -> Option<&'static str> {
    FILES.iter().find(|(n, _)| *n == name).map(|(_, s)| *s)
}

/// The generated header followed by `name` with its includes expanded.
pub fn compose(name: &str) -> Result<String, GpuError> {
    compose_with(name, &[])
}

/// As [`compose`], with text substitutions applied to the shader files
/// (before their includes are resolved, so an include may be substituted).
pub fn compose_with(name: &str, subst: &[(&str, &str)]) -> Result<String, GpuError> {
    let mut out = crate::layout::wgsl_header();
    let mut seen = HashSet::new();
    include(name, subst, &mut out, &mut seen)?;
    Ok(out)
}

fn include(
    name: &str,
    subst: &[(&str, &str)],
    out: &mut String,
    seen: &mut HashSet<String>,
) -> Result<(), GpuError> {
    if !seen.insert(name.to_string()) {
        return Ok(());
    }
    if name == "generated_tables" {
        out.push_str(&crate::layout::wgsl_tables());
        return Ok(());
    }
    if name == "generated_directory_store" {
        out.push_str(&crate::layout::wgsl_directory_store());
        return Ok(());
    }
    let text = file(name)
        .ok_or_else(|| GpuError::InvalidInput(format!("internal: no shader file {name}")))?;
    let mut text = text.to_string();
    for (from, to) in subst {
        text = text.replace(from, to);
    }
    out.push_str(&format!("// ---- {name}\n"));
    for line in text.lines() {
        if let Some(rest) = line.trim().strip_prefix("//!include ") {
            include(rest.trim(), subst, out, seen)?;
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    Ok(())
}

/// Parse and validate WGSL with naga; the error text names the kernel.
pub fn validate(label: &str, source: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(source)
        .map_err(|e| format!("{label}: {}", e.emit_to_string(source)))?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::empty(),
    )
    .validate(&module)
    .map_err(|e| format!("{label}: {}", e.emit_to_string(source)))?;
    Ok(module)
}

/// Validate a kernel: its source, its entry point, and that the bindings
/// the shader declares for that entry are exactly the Rust-side list.
pub fn validate_kernel(k: &Kernel) -> Result<(), String> {
    let src = k.source().map_err(|e| e.to_string())?;
    let module = validate(k.name, &src)?;
    if !module
        .entry_points
        .iter()
        .any(|e| e.name == k.entry && e.stage == naga::ShaderStage::Compute)
    {
        return Err(format!("{}: no compute entry point {}", k.name, k.entry));
    }
    for (i, want) in k.bindings.iter().enumerate() {
        let var = module.global_variables.iter().find(|(_, v)| {
            v.binding
                .as_ref()
                .is_some_and(|b| b.group == 0 && b.binding == i as u32)
        });
        let Some((_, var)) = var else {
            return Err(format!("{}: binding {i} is not declared", k.name));
        };
        let got = match var.space {
            naga::AddressSpace::Uniform => Bind::Uniform,
            naga::AddressSpace::Storage { access }
                if access.contains(naga::StorageAccess::STORE) =>
            {
                Bind::ReadWrite
            }
            naga::AddressSpace::Storage { .. } => Bind::Read,
            other => return Err(format!("{}: binding {i} is in {other:?}", k.name)),
        };
        if got != *want {
            return Err(format!(
                "{}: binding {i} is {got:?} in WGSL, {want:?} in Rust",
                k.name
            ));
        }
    }
    let extra = module
        .global_variables
        .iter()
        .filter_map(|(_, v)| v.binding.as_ref())
        .find(|b| b.group != 0 || b.binding as usize >= k.bindings.len());
    if let Some(b) = extra {
        return Err(format!(
            "{}: WGSL declares @group({}) @binding({}) that Rust does not bind",
            k.name, b.group, b.binding
        ));
    }
    Ok(())
}
