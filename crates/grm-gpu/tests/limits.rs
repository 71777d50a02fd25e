//! Derivations that outgrow a limit stop with a typed error before the
//! dispatch that would need it: never a device loss, a crash or a hang.

mod common;
use common::*;
use grm_diag::Code;
use grm_gpu::{GpuDeriveOptions, GpuError, RuntimeKind, derive};

fn unlimited(iterations: u32) -> GpuDeriveOptions {
    GpuDeriveOptions {
        iterations,
        seed: 0,
        max_modules: u64::MAX,
        max_bytes: u64::MAX,
        sync_iterations: false,
        cpu_prefix: 0,
        keys: false,
    }
}

/// Each module carries 8 parameter words and becomes 64 modules: the
/// parameter buffer grows 64x per iteration until it passes the device's
/// `max_storage_buffer_binding_size` (128 MiB on lavapipe).
#[test]
fn a_buffer_over_the_device_limit_is_a_typed_error() {
    let g = gpu();
    let succ = vec!["A(a, b, c, d, e, f, g, h)"; 64].join(" ");
    let src = format!(
        "system S {{ axiom A(1, 2, 3, 4, 5, 6, 7, 8); A(a, b, c, d, e, f, g, h) -> {succ}; }}"
    );
    let sys = inline(&src).expect("checks");
    let limit = g
        .limits()
        .max_storage_buffer_binding_size
        .min(g.limits().max_buffer_size);
    // The first iteration whose parameter buffer (32 bytes a module) is too big.
    let mut k = 0u32;
    while 32 * 64u64.pow(k) <= limit {
        k += 1;
    }
    assert!(
        k <= 5,
        "this test needs a device limit below 32 GiB (got {limit})"
    );
    let r = derive(g, &sys, &unlimited(k + 2));
    if let Err(e @ GpuError::BufferTooLarge { .. }) = &r {
        assert_eq!(e.code(), Code::GpuBufferTooLarge);
    }
    match r {
        Err(GpuError::BufferTooLarge {
            bytes, limit: l, ..
        }) => {
            assert!(bytes > l && l <= limit.max(l), "{bytes} bytes, limit {l}");
        }
        other => panic!(
            "expected BufferTooLarge, got {:?}",
            other.map(|d| d.string.len())
        ),
    }
    // The device still works afterwards.
    let small = derive(g, &sys, &unlimited(1)).expect("derives after the error");
    assert_eq!(small.string.len(), 64);
}

/// A successor of 70,000 modules: the second string would have 4.9e9
/// modules, past the 32-bit indices.
#[test]
fn a_count_past_32_bits_is_a_typed_error() {
    let g = gpu();
    let succ = vec!["A"; 70_000].join(" ");
    let sys = inline(&format!("system S {{ axiom A; A -> {succ}; }}")).expect("checks");
    let r = derive(g, &sys, &unlimited(2));
    if let Err(e @ GpuError::CountOverflow { .. }) = &r {
        assert_eq!(e.code(), Code::GpuCountOverflow);
    }
    match r {
        Err(GpuError::CountOverflow { .. }) => {}
        other => panic!(
            "expected CountOverflow, got {:?}",
            other.map(|d| d.string.len())
        ),
    }
    // Under a module limit below 2^32 the same count is the limit's error
    // (R0201, as the CPU reports it), saying the count is a lower bound.
    let limited = GpuDeriveOptions {
        max_modules: 50_000_000,
        ..unlimited(2)
    };
    match derive(g, &sys, &limited) {
        Err(e @ GpuError::ModuleLimit { .. }) => {
            assert_eq!(e.code(), Code::ModuleLimit);
            assert!(
                e.to_string().contains("more than 4294967294 modules"),
                "{e}"
            );
        }
        other => panic!(
            "expected ModuleLimit, got {:?}",
            other.map(|d| d.string.len())
        ),
    }
    let e = derive(g, &sys, &unlimited(2)).expect_err("overflows");
    assert!(e.to_string().contains("(more than 4294967294)"), "{e}");
}

#[test]
fn module_and_memory_limits_stop_before_allocating() {
    let g = gpu();
    let sys = example("koch_island.grm", None);
    let opts = GpuDeriveOptions {
        iterations: 5,
        seed: 0,
        max_modules: 10_000,
        max_bytes: u64::MAX,
        sync_iterations: false,
        cpu_prefix: 0,
        keys: false,
    };
    let r = derive(g, &sys, &opts);
    if let Err(e @ GpuError::ModuleLimit { .. }) = &r {
        assert_eq!(e.code(), Code::ModuleLimit);
    }
    match r {
        // Lengths 7, 59, 475, 3803, 30427: iteration 4 is the first over 10,000.
        Err(GpuError::ModuleLimit {
            iteration: 4,
            modules: 30427,
            limit: 10_000,
        }) => {}
        other => panic!(
            "expected ModuleLimit, got {:?}",
            other.map(|d| d.string.len())
        ),
    }
    let opts = GpuDeriveOptions {
        iterations: 5,
        seed: 0,
        max_modules: u64::MAX,
        max_bytes: 100_000,
        sync_iterations: false,
        cpu_prefix: 0,
        keys: false,
    };
    let r = derive(g, &sys, &opts);
    if let Err(e @ GpuError::MemoryLimit { .. }) = &r {
        assert_eq!(e.code(), Code::MemoryLimit);
    }
    match r {
        Err(GpuError::MemoryLimit {
            iteration, bytes, ..
        }) => {
            assert!(iteration <= 4 && bytes > 100_000);
        }
        other => panic!(
            "expected MemoryLimit, got {:?}",
            other.map(|d| d.string.len())
        ),
    }
}

/// Runtime errors: the same iteration, position and kind as the CPU.
#[test]
fn runtime_errors_match_the_cpu() {
    let g = gpu();
    let cases = [
        (
            "system S { axiom A(2) A(3); A(x) -> A(x - 1) F(1 / (x - 1)); }",
            RuntimeKind::NonFinite,
        ),
        (
            "system S { axiom B(1) B(0) B(-1); B(x) -> (x) B(x); B(x) -> (1) C; }",
            RuntimeKind::BadWeight,
        ),
    ];
    for (src, want) in cases {
        let sys = inline(src).unwrap_or_else(|| panic!("checks: {src}"));
        let cpu = cpu_derive(&sys, 3, 0);
        let cpu_code = cpu.as_ref().err().map(|e| e.code());
        let Err(grm_derive::DeriveError::Runtime(e)) = cpu else {
            panic!("the CPU derives {src}: {cpu:?}");
        };
        let r = derive(g, &sys, &unlimited(3));
        // Both engines report the same code.
        assert_eq!(r.as_ref().err().map(GpuError::code), cpu_code, "{src}");
        match r {
            Err(GpuError::Runtime {
                iteration,
                position,
                kind,
                ..
            }) => {
                assert_eq!(
                    (iteration, position, kind),
                    (e.iteration, e.position, want),
                    "{src}"
                );
            }
            other => panic!(
                "{src}: expected a runtime error, got {:?}",
                other.map(|d| d.string.len())
            ),
        }
    }
}

/// A production binding more parameter words than the kernels hold is
/// refused before anything runs (R0606); the CPU derives it.
#[test]
fn too_many_bound_words_are_unsupported() {
    let g = gpu();
    let names: Vec<String> = (0..33).map(|i| format!("a{i}")).collect();
    let zeros = vec!["0"; 33].join(", ");
    let src = format!(
        "system S {{ axiom A({zeros}); A({}) -> A({}); }}",
        names.join(", "),
        names.join(", ")
    );
    let sys = inline(&src).expect("checks");
    let e = match derive(g, &sys, &unlimited(1)) {
        Err(e) => e,
        Ok(d) => panic!("expected Unsupported, got {} modules", d.string.len()),
    };
    assert!(matches!(e, GpuError::Unsupported(_)), "{e:?}");
    assert_eq!(e.code(), Code::GpuUnsupported);
    assert!(cpu_derive(&sys, 1, 0).is_ok());
}
