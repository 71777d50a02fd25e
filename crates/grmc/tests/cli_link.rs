//! How `grmc` is linked (`crates/grmc/build.rs`): on x86-64 Linux a
//! position-dependent executable, so a one-shot command pays no run-time
//! relocations (docs/benchmarks.md, "A position-dependent `grmc`"), unless
//! the build asked for a position-independent one (`GRM_PIE=1`).

#![cfg(all(target_os = "linux", target_arch = "x86_64", target_env = "gnu"))]

/// The ELF type of the `grmc` binary: 2 (`ET_EXEC`, position-dependent)
/// or 3 (`ET_DYN`, position-independent).
fn elf_type() -> u16 {
    let bytes = std::fs::read(env!("CARGO_BIN_EXE_grmc")).expect("the grmc binary");
    assert_eq!(&bytes[..4], b"\x7fELF", "grmc is an ELF file");
    // e_type: two bytes at offset 16, little-endian on x86-64.
    u16::from_le_bytes([bytes[16], bytes[17]])
}

#[test]
fn grmc_is_position_dependent_unless_asked() {
    let pie = option_env!("GRM_PIE") == Some("1");
    assert_eq!(elf_type(), if pie { 3 } else { 2 });
}
