//! GPU bracket matching against a stack, on random bracket strings: small,
//! one block, several levels of the minimum tree, nested deeply, and
//! unbalanced (stray `]` and unclosed `[`).

mod common;
use common::*;
use grm_derive::ModuleString;
use grm_gpu::brackets::{UNMATCHED, match_brackets};

fn stack_match(kinds: &[u8]) -> Vec<u32> {
    let mut m = vec![UNMATCHED; kinds.len()];
    let mut st = Vec::new();
    for (i, &k) in kinds.iter().enumerate() {
        if k == 1 {
            st.push(i);
        } else if k == 2
            && let Some(p) = st.pop()
        {
            m[p] = i as u32;
            m[i] = p as u32;
        }
    }
    m
}

#[test]
fn matching_equals_a_stack() {
    let g = gpu();
    let sys = inline("system S { axiom A [ B ] C; }").expect("checks");
    let id = |n: &str| {
        sys.symbol_names
            .iter()
            .position(|s| s == n)
            .expect("symbol") as u32
    };
    let (push, pop, a) = (id("["), id("]"), id("A"));
    let mut rng = Rng::seeded(5);
    let mut cases: Vec<Vec<u8>> = vec![
        vec![],
        vec![1],
        vec![2],
        vec![1, 2],
        vec![2, 1],
        vec![1, 1, 2],
        vec![0, 1, 0, 2, 2, 1],
    ];
    for &(n, p_push, p_pop, balanced) in &[
        (100usize, 3u64, 3u64, true),
        (1_000, 2, 2, true),
        (5_000, 4, 4, false),
        (40_000, 3, 3, true),
        (70_000, 10, 1, true),
        (70_000, 1, 1, false),
    ] {
        let mut v = Vec::with_capacity(n);
        let mut depth = 0i64;
        for _ in 0..n {
            let r = rng.below(10);
            if r < p_push {
                v.push(1);
                depth += 1;
            } else if r < p_push + p_pop && (!balanced || depth > 0) {
                v.push(2);
                depth -= 1;
            } else {
                v.push(0);
            }
        }
        if balanced {
            v.extend(std::iter::repeat_n(2, depth.max(0) as usize));
        }
        cases.push(v);
    }
    for kinds in cases {
        let mut s = ModuleString::new();
        for &k in &kinds {
            s.push([a, push, pop][k as usize], &[]);
        }
        let got = match_brackets(g, &sys, &s).expect("matches");
        assert_eq!(got, stack_match(&kinds), "n = {}", kinds.len());
    }
}
