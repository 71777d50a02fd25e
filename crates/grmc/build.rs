//! Link `grmc` as a position-dependent executable on x86-64 Linux.
//!
//! A one-shot `grmc derive` spends a tenth of its life in the dynamic
//! loader applying the ~22,000 relative relocations of a position-
//! independent image and in the copy-on-write faults of the pages they
//! write (docs/benchmarks.md, "A position-dependent `grmc`"). Linked
//! without `-pie`, the image is laid out at its link address: those
//! relocations and faults are gone (the libraries, the stack, the heap
//! and `mmap` stay randomised; Go links its binaries this way by
//! default). The crates are still compiled as position-independent code,
//! which links into either kind. Only the binary is affected: tests and
//! libraries keep the platform's default.

fn main() {
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let env = std::env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    // `GRM_PIE=1` keeps the default (a position-independent executable).
    println!("cargo:rerun-if-env-changed=GRM_PIE");
    let keep_pie = std::env::var("GRM_PIE").is_ok_and(|v| v == "1");
    if os == "linux" && arch == "x86_64" && env == "gnu" && !keep_pie {
        println!("cargo:rustc-link-arg-bins=-no-pie");
    }
}
