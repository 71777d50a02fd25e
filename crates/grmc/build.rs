//! Build script: link `grmc` as a position-dependent executable on
//! x86-64 Linux.
//!
//! A position-independent `grmc` carries about 21,000 relative
//! relocations (500 KiB of `.rela.dyn`) that the dynamic loader applies at
//! every start, writing 350 KiB of `.data.rel.ro` (one copy-on-write fault
//! a page): a measurable share of a one-shot `grmc derive` of a small
//! scene (docs/benchmarks.md, "Process start-up"). Linked at a fixed
//! address, the executable needs none of them. The price is that the
//! executable's own image is not placed at a random address (shared
//! libraries, the heap and the stack still are).

fn main() {
    println!("cargo::rerun-if-changed=build.rs");
    let os = std::env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let env = std::env::var("CARGO_CFG_TARGET_ENV").unwrap_or_default();
    if os == "linux" && arch == "x86_64" && env == "gnu" {
        println!("cargo::rustc-link-arg-bin=grmc=-no-pie");
    }
}
