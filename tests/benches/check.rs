//! Benchmark: `grmc check` on a generated 1,000-line grammar.
//!
//! Prints the median time of lexing, parsing, the full check (parse +
//! resolve + types + phases + warnings) and the check plus compiling every
//! system (what `grmc check` runs) over many runs, and the ratios
//! between them (the baseline is the lexer, measured in the same run).
//! Target: the full check under 10 ms.
//!
//!     cargo bench -p grm-tests --bench check

use grm_diag::{FileId, SourceMap};
use std::time::{Duration, Instant};

fn median(mut v: Vec<Duration>) -> Duration {
    v.sort();
    v[v.len() / 2]
}

fn time<F: FnMut()>(runs: usize, mut f: F) -> Duration {
    f(); // warm up
    median(
        (0..runs)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed()
            })
            .collect(),
    )
}

fn main() {
    let text = grm_tests::generated_grammar(1000);
    let lines = text.lines().count();
    let runs = 50;
    let lex = time(runs, || {
        std::hint::black_box(grm_syntax::lexer::lex(FileId(0), &text));
    });
    let parse = time(runs, || {
        std::hint::black_box(grm_syntax::parse(FileId(0), &text));
    });
    let mut diags = 0;
    let check = time(runs, || {
        let mut sources = SourceMap::new();
        let root = sources.add("bench.grm", text.clone());
        let c = grm_sema::check(&mut sources, root, &grm_sema::FsLoader);
        diags = c.diagnostics.len();
        std::hint::black_box(c);
    });
    // What `grmc check` and the editor run since they also compile every
    // system (the compile errors, R01xx): the check plus `grm_compile::check`.
    let with_compile = time(runs, || {
        let mut sources = SourceMap::new();
        let root = sources.add("bench.grm", text.clone());
        let c = grm_sema::check(&mut sources, root, &grm_sema::FsLoader);
        std::hint::black_box(grm_compile::check(&c));
        std::hint::black_box(c);
    });
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "grmc check benchmark: generated grammar, {lines} lines, {} bytes, {diags} diagnostics",
        text.len()
    );
    println!("  lex    {:>8.3} ms   (baseline)", ms(lex));
    println!(
        "  parse  {:>8.3} ms   {:>6.2}x lex",
        ms(parse),
        ms(parse) / ms(lex)
    );
    println!(
        "  check  {:>8.3} ms   {:>6.2}x lex   target < 10 ms: {}",
        ms(check),
        ms(check) / ms(lex),
        if ms(check) < 10.0 { "met" } else { "NOT met" }
    );
    println!(
        "  check + compile {:>8.3} ms   {:>6.2}x lex   target < 10 ms: {}",
        ms(with_compile),
        ms(with_compile) / ms(lex),
        if ms(with_compile) < 10.0 {
            "met"
        } else {
            "NOT met"
        }
    );
}
