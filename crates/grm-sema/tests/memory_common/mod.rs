//! Shared by the parsing-memory tests (issue 32 item 4) of grm-sema
//! (`grmc check`), grm-fmt (`grmc fmt`) and grm-analysis (the language
//! server): a counting global allocator and generated grammars, realistic
//! and pathological. Each test binary that includes this module counts
//! its own allocations.
//!
//! The figure is the peak of bytes allocated at once while a step runs,
//! over the source's size: bytes, not time, so a busy machine does not
//! change it.

#![allow(dead_code)]
// A counting global allocator is the one way to see every allocation.
#![allow(unsafe_code)]

// A counting global allocator is the one way to see every allocation.
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

pub struct Counting;

pub static CURRENT: AtomicUsize = AtomicUsize::new(0);
pub static PEAK: AtomicUsize = AtomicUsize::new(0);
/// What the blocks take in glibc's allocator: each rounded up to its chunk
/// ([`chunk`]), at once and at peak.
pub static CURRENT_CHUNKS: AtomicUsize = AtomicUsize::new(0);
pub static PEAK_CHUNKS: AtomicUsize = AtomicUsize::new(0);
/// Blocks live at once.
pub static BLOCKS: AtomicUsize = AtomicUsize::new(0);

/// The size of the chunk glibc's malloc gives a request of `size` bytes
/// on a 64-bit machine: the size plus an 8-byte header, rounded up to 16,
/// at least 32. Blocks of a few bytes take 32.
pub fn chunk(size: usize) -> usize {
    (size + 8).next_multiple_of(16).max(32)
}

pub static ALLOCS: AtomicUsize = AtomicUsize::new(0);
pub static PEAK_AT: AtomicUsize = AtomicUsize::new(0);

fn grow_chunks(by: usize) {
    let now = CURRENT_CHUNKS.fetch_add(by, Ordering::Relaxed) + by;
    let n = ALLOCS.fetch_add(1, Ordering::Relaxed);
    if PEAK_CHUNKS.fetch_max(now, Ordering::Relaxed) < now {
        PEAK_AT.store(n, Ordering::Relaxed);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded to the system allocator with the same layout.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = CURRENT.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
            grow_chunks(chunk(layout.size()));
            BLOCKS.fetch_add(1, Ordering::Relaxed);
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by `alloc` above with `layout`.
        unsafe { System.dealloc(ptr, layout) };
        CURRENT.fetch_sub(layout.size(), Ordering::Relaxed);
        CURRENT_CHUNKS.fetch_sub(chunk(layout.size()), Ordering::Relaxed);
        BLOCKS.fetch_sub(1, Ordering::Relaxed);
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded to the system allocator.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                let grow = new_size - layout.size();
                let now = CURRENT.fetch_add(grow, Ordering::Relaxed) + grow;
                PEAK.fetch_max(now, Ordering::Relaxed);
            } else {
                CURRENT.fetch_sub(layout.size() - new_size, Ordering::Relaxed);
            }
            let (old, new) = (chunk(layout.size()), chunk(new_size));
            if new >= old {
                grow_chunks(new - old);
            } else {
                CURRENT_CHUNKS.fetch_sub(old - new, Ordering::Relaxed);
            }
        }
        p
    }
}

#[global_allocator]
pub static ALLOC: Counting = Counting;

/// The peak number of bytes allocated at once while `f` runs, over what
/// was allocated when it started, and its result. Tests in one binary run
/// in parallel: the tests that measure hold [`LOCK`].
pub fn peak_during<T>(f: impl FnOnce() -> T) -> (usize, T) {
    let (b, _, out) = peaks_during(f);
    (b, out)
}

/// [`peak_during`], and the peak of glibc's chunks ([`chunk`]) over those
/// at the start.
pub fn peaks_during<T>(f: impl FnOnce() -> T) -> (usize, usize, T) {
    let base = CURRENT.load(Ordering::SeqCst);
    PEAK.store(base, Ordering::SeqCst);
    let base_chunks = CURRENT_CHUNKS.load(Ordering::SeqCst);
    PEAK_CHUNKS.store(base_chunks, Ordering::SeqCst);
    let out = f();
    (
        PEAK.load(Ordering::SeqCst) - base,
        PEAK_CHUNKS.load(Ordering::SeqCst) - base_chunks,
        out,
    )
}

pub fn realistic(size: usize) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(size + 4096);
    s.push_str("// generated grammar: many systems\nparam spread = 30 in 10 .. 60;\n");
    s.push_str("const SHRINK = 0.85;\nmaterial bark { color = rgb(0.45, 0.32, 0.2); }\n");
    let mut k = 0;
    while s.len() < size {
        let _ = write!(
            s,
            "\n/* system {k}: a block comment\n   over two lines */\nsystem S{k} {{\n    iterations = 4;\n    angle = spread;\n    ignore + -;\n    module A0(l: float, w: float);\n    axiom A0(1, 0.1);\n"
        );
        let m = 12;
        for i in 0..m {
            let n = (i + 1) % m;
            let _ = writeln!(s, "    // production group {i}");
            let _ = writeln!(
                s,
                "    A{i}(l, w) : l > 0.01 -> (2) F(l) [ + A{n}(l * SHRINK, w * 0.7) ] B{i}(w); // trailing"
            );
            let _ = writeln!(
                s,
                "    A{i}(l, w) : l > 0.01 -> (1) F(l) [ - A{n}(l * SHRINK, w) ] B{i}(w * 0.5);"
            );
            let _ = writeln!(
                s,
                "    A{i}(l, _w) -> F(l + uniform(0, 0.1)) {{ . F(l / 2) }};"
            );
            let _ = writeln!(
                s,
                "    A{n}(_x, _y) < B{i}(w) -> !(w) B{i}(max(w - 0.01, 0));"
            );
        }
        s.push_str("}\n");
        k += 1;
    }
    s
}

/// The productions of [`realistic`] in one system of about `size` bytes
/// (a chain of symbols `A0`, `A1`, ...).
pub fn one_large_system(size: usize) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(size + 4096);
    s.push_str("// one large system\nconst SHRINK = 0.85;\n\nsystem S {\n    iterations = 4;\n");
    s.push_str("    angle = 30;\n    axiom A0(1, 0.1);\n");
    let mut i = 0;
    while s.len() < size {
        let n = i + 1;
        let _ = writeln!(s, "    // production group {i}");
        let _ = writeln!(
            s,
            "    A{i}(l, w) : l > 0.01 -> (2) F(l) [ + A{n}(l * SHRINK, w * 0.7) ] B{i}(w); // trailing"
        );
        let _ = writeln!(
            s,
            "    A{i}(l, w) : l > 0.01 -> (1) F(l) [ - A{n}(l * SHRINK, w) ] B{i}(w * 0.5);"
        );
        let _ = writeln!(
            s,
            "    A{i}(l, _w) -> F(l + uniform(0, 0.1)) {{ . F(l / 2) }};"
        );
        let _ = writeln!(
            s,
            "    A{n}(_x, _y) < B{i}(w) -> !(w) B{i}(max(w - 0.01, 0));"
        );
        i += 1;
    }
    s.push_str("}\n");
    s
}

/// Held by a test while it measures (tests of one binary run in threads,
/// and the allocator counts them all).
pub static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The budget: bytes at once per source byte (issue 32: "under 32"), met
/// by realistic grammars.
pub const BUDGET: f64 = 32.0;

/// The ceiling the pathological inputs are held to for now (a guard
/// against regressions, not the budget): one very long line and deep
/// nesting still take more than [`BUDGET`]
/// (docs/benchmarks.md, "Parsing memory (session 19)").
pub const PATHOLOGICAL_CEILING: f64 = 256.0;

/// The generated grammars the budget is checked on: two realistic ones of
/// 2 MiB (many systems; one large system) and the others of about `size`
/// bytes each: realistic (many systems, productions, expressions and comments)
/// and pathological (one huge expression, one very long line, deep
/// nesting, nesting past the parser's limit, comments only).
pub fn inputs(size: usize) -> Vec<(&'static str, String)> {
    let mut out = vec![
        ("realistic", realistic(2 << 20)),
        ("one large system", one_large_system(2 << 20)),
    ];
    let mut s = String::from("system S {\n    iterations = 1;\n    axiom F;\n    F -> F(");
    let mut i = 0usize;
    while s.len() < size {
        s.push_str(&format!("{i}.5 * 0.25 + "));
        i += 1;
    }
    s.push_str("1);\n}\n");
    out.push(("one huge expression", s));
    let mut s = String::from("system S {\n    iterations = 1;\n    axiom F;\n    F -> ");
    while s.len() < size {
        s.push_str("F(1) [ + F(0.5) ] - G ");
    }
    s.push_str(";\n    G -> G;\n}\n");
    out.push(("one long line", s));
    let mut s = String::from("system S {\n    iterations = 1;\n    axiom F;\n");
    let deep = format!(
        "    F -> F({}1{}) [ [ [ [ + F ] ] ] ];\n",
        "(".repeat(150),
        ")".repeat(150)
    );
    while s.len() < size {
        s.push_str(&deep);
    }
    s.push_str("}\n");
    out.push(("deep nesting", s));
    let d = size / 2;
    let s = format!(
        "system S {{\n    axiom F;\n    F -> F({}1{});\n}}\n",
        "(".repeat(d),
        ")".repeat(d)
    );
    out.push(("nesting past the limit", s));
    let mut s = String::new();
    while s.len() < size {
        s.push_str("// a comment line, long enough to matter\n/* block */\n");
    }
    s.push_str("system S { axiom F; F -> F; }\n");
    out.push(("comments", s));
    out
}

/// What `what` is held to: [`BUDGET`] for the realistic grammar of many
/// systems, the huge expression and the comments; 40 for one large system
/// (35 for check and 32.5 for fmt: not yet under the budget, the checker
/// keeps a system's whole tree while it resolves and infers it);
/// [`PATHOLOGICAL_CEILING`] for the rest.
pub fn limit(what: &str) -> f64 {
    if what == "one large system" {
        40.0
    } else if matches!(what, "realistic" | "one huge expression" | "comments") {
        BUDGET
    } else {
        PATHOLOGICAL_CEILING
    }
}

pub fn report(what: &str, text: &str, bytes: usize) -> f64 {
    let per = bytes as f64 / text.len() as f64;
    eprintln!(
        "{what}: {:.1} MB peak for {:.2} MB of text: {per:.1} bytes per source byte",
        bytes as f64 / 1e6,
        text.len() as f64 / 1e6
    );
    per
}
