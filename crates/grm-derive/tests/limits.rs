//! Runaway grammars stop with a typed error before allocating; run-time
//! failures (NaN, infinite values, bad weights) name the iteration, the
//! module and the source span.

mod common;

use common::*;
use grm_derive::{DeriveError, DeriveLimits, DeriveOptions, RuntimeErrorKind, derive};
use grm_diag::{Code, FileId, Span};

fn run(
    src: &str,
    iterations: u32,
    limits: DeriveLimits,
    threads: usize,
) -> Result<grm_derive::Derivation, DeriveError> {
    let c = inline(src);
    let opts = DeriveOptions {
        iterations,
        seed: 0,
        limits,
    };
    derive(&c, &opts, threads, &mut |_| {})
}

fn span_text(src: &str, e: &DeriveError) -> String {
    let (_, span) = e.location().expect("a location");
    src[span.range()].to_string()
}

#[test]
fn module_limit_stops_before_allocating() {
    let src = "system Runaway { axiom A; A -> A A; }";
    let limits = DeriveLimits {
        max_modules: 1_000_000,
        ..DeriveLimits::default()
    };
    for threads in [1, 2] {
        let e = run(src, 100, limits, threads).unwrap_err();
        match &e {
            DeriveError::ModuleLimit {
                iteration,
                modules,
                limit,
                ..
            } => {
                assert_eq!(*iteration, 20);
                assert_eq!(*modules, 1 << 20);
                assert_eq!(*limit, 1_000_000);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(e.code(), Code::ModuleLimit);
        assert_eq!(span_text(src, &e), "Runaway");
        assert!(
            e.to_string()
                .contains("iteration 20 would produce 1048576 modules")
        );
    }
}

/// With the default limits (50 million modules) a thousandfold fan-out
/// stops at iteration 3 (10^9 modules) having built only 10^6.
#[test]
fn default_limits_catch_a_fast_runaway() {
    let succ = vec!["A"; 1000].join(" ");
    let src = format!("system Runaway {{ axiom A; A -> {succ}; }}");
    let e = run(&src, 10, DeriveLimits::default(), 1).unwrap_err();
    assert!(
        matches!(
            e,
            DeriveError::ModuleLimit {
                iteration: 3,
                modules: 1_000_000_000,
                ..
            }
        ),
        "{e:?}"
    );
}

#[test]
fn memory_limit() {
    let src = "system Runaway { axiom A(1); A(x) -> A(x) A(x + 1); }";
    let limits = DeriveLimits {
        max_modules: u64::MAX,
        max_bytes: 1 << 20,
    };
    let e = run(src, 100, limits, 1).unwrap_err();
    let DeriveError::MemoryLimit {
        iteration,
        bytes,
        limit,
        modules,
        words,
        ..
    } = e
    else {
        panic!("{e:?}")
    };
    // 12 bytes per module (symbol, start, one parameter) in and out: the
    // input of 2^k modules plus the output of 2^(k+1) passes 1 MiB at k = 15.
    assert_eq!(iteration, 16);
    assert_eq!(modules, 1 << 16);
    assert_eq!(words, 1 << 16);
    assert!(bytes > limit);
    assert_eq!(limit, 1 << 20);
}

#[test]
fn nan_parameter_points_at_the_expression() {
    let src = "system S { axiom A(2); A(x) -> A(x - 1) B(sqrt(x)); }";
    for threads in [1, 2] {
        let e = run(src, 10, DeriveLimits::default(), threads).unwrap_err();
        let DeriveError::Runtime(r) = &e else {
            panic!("{e:?}")
        };
        assert_eq!(r.iteration, 4);
        assert_eq!(r.position, 0);
        assert_eq!(r.symbol, "A");
        assert!(matches!(r.kind, RuntimeErrorKind::NonFinite { value } if value.is_nan()));
        assert_eq!(e.code(), Code::NonFiniteParameter);
        assert_eq!(span_text(src, &e), "sqrt(x)");
    }
}

#[test]
fn infinite_parameter() {
    let src = "system S { axiom A(1); A(x) -> A(x * 1e30); }";
    let e = run(src, 5, DeriveLimits::default(), 1).unwrap_err();
    let DeriveError::Runtime(r) = &e else {
        panic!("{e:?}")
    };
    assert_eq!(r.iteration, 2);
    assert!(matches!(r.kind, RuntimeErrorKind::NonFinite { value } if value == f32::INFINITY));
    assert_eq!(span_text(src, &e), "x * 1e30");
}

/// In a successor of several arithmetic words (written by the engine's
/// short-successor path, one test for the whole successor, and by the
/// general writer when the successor is longer), the word reported is
/// the first one that failed, in the successor's order.
#[test]
fn first_infinite_word_of_a_successor_is_reported() {
    let short = "system S { axiom A(1e10); A(x) -> B(x * 2) B(x - 1e9) B(x * 1e30) B(1e30 * x); }";
    let long = "system S { axiom A(1e10); A(x) -> + + + + + + + + B(x * 2) B(x - 1e9) B(x * 1e30) B(1e30 * x); }";
    for src in [short, long] {
        for threads in [1, 2] {
            let e = run(src, 1, DeriveLimits::default(), threads).unwrap_err();
            let DeriveError::Runtime(r) = &e else {
                panic!("{e:?}")
            };
            assert_eq!((r.iteration, r.position), (1, 0));
            assert!(
                matches!(r.kind, RuntimeErrorKind::NonFinite { value } if value == f32::INFINITY),
                "{:?}",
                r.kind
            );
            assert_eq!(span_text(src, &e), "x * 1e30", "{src}");
        }
    }
}

/// The first failing module in string order is reported, whatever the
/// chunking.
#[test]
fn lowest_position_error_wins() {
    // Modules A(3) .. A(-3): the first negative argument is at position 4.
    let src = "system S { axiom A(3) A(2) A(1) A(0) A(-1) A(-2) A(-3); A(x) -> B(sqrt(x)); }";
    let c = inline(src);
    for (threads, chunk) in [(1, 8192), (2, 1), (8, 2)] {
        let engine = grm_derive::Engine::new(&c, threads)
            .expect("engine")
            .with_min_chunk(chunk);
        let e = engine
            .derive(
                &DeriveOptions {
                    iterations: 1,
                    seed: 0,
                    limits: DeriveLimits::default(),
                },
                &mut |_| {},
            )
            .unwrap_err();
        let DeriveError::Runtime(r) = e else {
            panic!("{e:?}")
        };
        assert_eq!(r.position, 4, "threads {threads}");
    }
}

#[test]
fn zero_weight_at_run_time() {
    let src = "system S { axiom A(1); A(x) -> (x) A(x - 1) A(x - 1); A(x) -> (x) A(x - 1); }";
    let e = run(src, 5, DeriveLimits::default(), 1).unwrap_err();
    let DeriveError::Runtime(r) = &e else {
        panic!("{e:?}")
    };
    assert_eq!(r.iteration, 2);
    assert_eq!(r.position, 0);
    assert!(matches!(r.kind, RuntimeErrorKind::BadWeight { value } if value == 0.0));
    assert_eq!(e.code(), Code::InvalidWeight);
    assert_eq!(span_text(src, &e), "x");
}

#[test]
fn stats_count_lipp_modules() {
    let src = "system S { axiom A; A -> A B; B -> A; }";
    let mut seen = Vec::new();
    let c = inline(src);
    let d = derive(
        &c,
        &DeriveOptions {
            iterations: 5,
            seed: 0,
            limits: DeriveLimits::default(),
        },
        1,
        &mut |s| seen.push(s.iteration),
    )
    .expect("derives");
    // Fibonacci lengths: 1 2 3 5 8 13.
    let lens: Vec<u64> = d.stats.iter().map(|s| s.modules).collect();
    assert_eq!(lens, [1, 2, 3, 5, 8, 13]);
    assert_eq!(seen, [0, 1, 2, 3, 4, 5]);
    assert_eq!(d.stats[5].cumulative_modules, 2 + 3 + 5 + 8 + 13);
    assert_eq!(d.stats[5].processed_modules, 1 + 2 + 3 + 5 + 8);
    assert_eq!(
        d.string.to_text(&c.symbol_names),
        "A B A A B A B A A B A A B"
    );
}

/// Parameters are computed in f32 exactly as the bytecode says: one IEEE
/// operation per operator (the engine's shortcuts for `x * k`, `k * x`,
/// `x + k`, `k + x`, `x - k` included), whatever the thread count.
#[test]
fn f32_arithmetic_is_exact() {
    let src = "system S { axiom A(1.1); A(x) -> B(x * 3.7) B(2.5 * x) B(x + 1.3) B(0.7 + x) B(x - 0.1) B(0.1 - x) B(x / 3) B(x * x + 1); }";
    let c = inline(src);
    let x = 1.1f32;
    let want = [
        x * 3.7f32,
        2.5f32 * x,
        x + 1.3f32,
        0.7f32 + x,
        x - 0.1f32,
        0.1f32 - x,
        x / 3.0f32,
        x * x + 1.0f32,
    ];
    for threads in [1, 2] {
        let s = strings(&c, 1, 0, threads);
        let got: Vec<u32> = s[1].parts().params.iter().map(|v| v.to_bits()).collect();
        let want: Vec<u32> = want.iter().map(|v| v.to_bits()).collect();
        assert_eq!(got, want);
    }
}

/// A diagnostic points at the span the error names, or at the given
/// system span when it names none; the help line comes along.
#[test]
fn errors_become_diagnostics() {
    let src = "system S { axiom A(2); A(x) -> A(x - 1) B(sqrt(x)); }";
    let e = run(src, 10, DeriveLimits::default(), 1).unwrap_err();
    let d = e.to_diagnostic(FileId(7), Span::new(0, 1));
    assert_eq!(d.code, Code::NonFiniteParameter);
    assert_eq!(&src[d.primary().span.range()], "sqrt(x)");
    assert_eq!(d.primary().file, e.location().expect("a location").0);
    assert_eq!(d.help, e.help());
    assert!(d.help.is_some());
    let e = DeriveError::ThreadPool("no threads".into());
    let d = e.to_diagnostic(FileId(7), Span::new(3, 4));
    assert_eq!(d.code, Code::ThreadPool);
    assert_eq!(
        (d.primary().file, d.primary().span),
        (FileId(7), Span::new(3, 4))
    );
}

/// Internal R0207: tables that break their invariants are refused before
/// anything runs.
#[test]
fn broken_tables_are_refused() {
    let mut c = inline("system S { axiom A; A -> F A; }");
    c.symbols[0].group_count = 1000;
    let Err(e) = grm_derive::Engine::new(&c, 1) else {
        panic!("expected invalid tables")
    };
    assert!(matches!(e, DeriveError::InvalidTables(_)), "{e:?}");
    assert_eq!(e.code(), Code::InvalidTables);
    let d = e.to_diagnostic(c.file, c.span);
    assert!(
        d.help.as_deref().is_some_and(|h| h.contains("internal")),
        "{d:?}"
    );
}

/// Internal R0208: a module string that does not fit the system.
#[test]
fn foreign_strings_are_refused() {
    let c = inline("system S { axiom A(1); A(x) -> A(x + 1); }");
    let engine = grm_derive::Engine::new(&c, 1).expect("engine");
    let (mut syms, starts, params, keys) = engine.axiom(0).expect("axiom").into_parts();
    syms[0] = 99;
    let s = grm_derive::ModuleString::from_parts(syms, starts, params, keys);
    let e = engine
        .step(&s, 1, 0, &DeriveLimits::default())
        .expect_err("unknown symbol");
    assert!(matches!(e, DeriveError::InvalidInput(_)), "{e:?}");
    assert_eq!(e.code(), Code::InvalidModuleString);
}

/// R0203: a string past 32-bit indices, caught before it is allocated.
#[test]
fn strings_past_32_bit_indices_are_refused() {
    let succ = vec!["A"; 1700].join(" ");
    let src = format!("system Big {{ axiom A; A -> {succ}; }}");
    let limits = DeriveLimits {
        max_modules: u64::MAX,
        max_bytes: u64::MAX,
    };
    let e = run(&src, 3, limits, 1).unwrap_err();
    assert!(
        matches!(e, DeriveError::TooLarge { iteration: 3, modules, .. } if modules == 1700u64.pow(3)),
        "{e:?}"
    );
    assert_eq!(e.code(), Code::StringTooLarge);
    assert_eq!(span_text(&src, &e), "Big");
}

/// R0209: more threads than [`grm_derive::MAX_THREADS`] is a typed error
/// before any thread starts (tens of thousands of threads would exhaust
/// memory and fail inside the new threads, a panic no caller could catch).
/// Cheap: nothing is started, so this test starts no thread at all.
#[test]
fn too_many_threads_is_a_typed_error() {
    let c = inline("system S { axiom A; A -> F A; }");
    for threads in [grm_derive::MAX_THREADS + 1, 100_000, usize::MAX] {
        let Err(e) = grm_derive::Engine::new(&c, threads) else {
            panic!("{threads} threads accepted");
        };
        assert_eq!(
            e,
            DeriveError::TooManyThreads {
                threads,
                max: grm_derive::MAX_THREADS
            }
        );
        assert_eq!(e.code(), Code::ThreadPool);
        assert_eq!(e.code().as_str(), "R0209");
        assert!(e.to_string().contains("more than the 1024"), "{e}");
        let d = e.to_diagnostic(FileId(7), Span::new(3, 4));
        assert_eq!(d.code, Code::ThreadPool);
        assert_eq!(
            (d.primary().file, d.primary().span),
            (FileId(7), Span::new(3, 4))
        );
        assert!(
            d.help
                .as_deref()
                .is_some_and(|h| h.contains("at most 1024"))
        );
        // The one-call entry point refuses it the same way.
        let opts = DeriveOptions {
            iterations: 3,
            seed: 0,
            limits: DeriveLimits::default(),
        };
        assert_eq!(derive(&c, &opts, threads, &mut |_| {}).err(), Some(e));
    }
    assert_eq!(grm_derive::MAX_THREADS, 1024);
    // 0 (all cores) and a few threads still work.
    for threads in [0, 3] {
        assert_eq!(strings(&c, 2, 0, threads), strings(&c, 2, 0, 1));
    }
}
