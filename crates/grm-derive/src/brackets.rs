//! The bracket structure of a module string: for every `[` the position of
//! its `]` and vice versa, so context matching can step over a whole branch
//! in O(1). Computed per iteration for context-sensitive systems only.
//!
//! Parallel form: each chunk matches its own brackets with a local stack
//! (disjoint writes); the brackets left unmatched in a chunk (first some
//! `]`, then some `[` — a `[` before an unmatched `]` would have matched it)
//! are matched across chunks in one sequential pass over those leftovers.
//! The result is the same for any chunking.

use rayon::prelude::*;

/// No partner (an unbalanced bracket; the checker rejects those, but a
/// string from elsewhere may have one).
pub const UNMATCHED: u32 = u32::MAX;

/// Per module: 1 for `[`, 2 for `]`, 0 otherwise.
pub(crate) fn mates(
    kinds: impl Fn(u32) -> u8 + Sync,
    syms: &[u32],
    chunk: usize,
    parallel: bool,
) -> Vec<u32> {
    let n = syms.len();
    let mut mate = vec![UNMATCHED; n];
    let chunk = chunk.max(1);
    let local = |base: usize, syms: &[u32], mate: &mut [u32]| -> (Vec<u32>, Vec<u32>) {
        let mut stack: Vec<u32> = Vec::new();
        let mut open_pops = Vec::new();
        for (k, &s) in syms.iter().enumerate() {
            match kinds(s) {
                1 => stack.push((base + k) as u32),
                2 => match stack.pop() {
                    Some(p) => {
                        mate[p as usize - base] = (base + k) as u32;
                        mate[k] = p;
                    }
                    None => open_pops.push((base + k) as u32),
                },
                _ => {}
            }
        }
        (open_pops, stack)
    };
    let leftovers: Vec<(Vec<u32>, Vec<u32>)> = if parallel {
        mate.par_chunks_mut(chunk)
            .zip(syms.par_chunks(chunk))
            .enumerate()
            .map(|(c, (m, s))| local(c * chunk, s, m))
            .collect()
    } else {
        mate.chunks_mut(chunk)
            .zip(syms.chunks(chunk))
            .enumerate()
            .map(|(c, (m, s))| local(c * chunk, s, m))
            .collect()
    };
    let mut stack: Vec<u32> = Vec::new();
    for (pops, pushes) in leftovers {
        for p in pops {
            if let Some(q) = stack.pop() {
                mate[q as usize] = p;
                mate[p as usize] = q;
            }
        }
        stack.extend(pushes);
    }
    mate
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(s: u32) -> u8 {
        match s {
            1 => 1,
            2 => 2,
            _ => 0,
        }
    }

    fn naive(syms: &[u32]) -> Vec<u32> {
        let mut m = vec![UNMATCHED; syms.len()];
        let mut st = Vec::new();
        for (i, &s) in syms.iter().enumerate() {
            if s == 1 {
                st.push(i);
            } else if s == 2
                && let Some(p) = st.pop()
            {
                m[p] = i as u32;
                m[i] = p as u32;
            }
        }
        m
    }

    #[test]
    fn any_chunking_matches_naive() {
        // A deterministic pseudo-random bracket string with nesting.
        let mut syms = Vec::new();
        let mut depth = 0;
        for i in 0..5000u32 {
            let h = grm_compile::rng::hash(9, 0, i, 0) % 7;
            if h < 2 {
                syms.push(1);
                depth += 1;
            } else if h < 4 && depth > 0 {
                syms.push(2);
                depth -= 1;
            } else {
                syms.push(0);
            }
        }
        syms.push(2); // one unmatched `]`
        syms.insert(0, 1); // and the `[` it closes
        syms.push(1); // an unmatched `[`
        let want = naive(&syms);
        for chunk in [1, 2, 3, 7, 64, 1000, 100_000] {
            assert_eq!(mates(kinds, &syms, chunk, false), want, "chunk {chunk}");
            assert_eq!(mates(kinds, &syms, chunk, true), want, "chunk {chunk}");
        }
    }
}
