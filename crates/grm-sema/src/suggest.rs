//! "Did you mean ...?" suggestions by edit distance.

/// Levenshtein distance (with a cap: returns `cap + 1` when it exceeds `cap`).
/// Only the cells within `cap` of the diagonal are computed (the others
/// exceed the cap anyway), so the work is linear in the names' length even
/// for two long, similar names.
#[cfg(test)]
pub(crate) fn distance(a: &str, b: &str, cap: usize) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    distance_chars(&a, &b, cap, &mut Vec::new())
}

/// [`distance`] on decoded names, with the two rows of the table in
/// `scratch` (reused between calls: no allocation per candidate).
fn distance_chars(a: &[char], b: &[char], cap: usize, scratch: &mut Vec<usize>) -> usize {
    if a.len().abs_diff(b.len()) > cap {
        return cap + 1;
    }
    let over = cap + 1;
    scratch.clear();
    scratch.resize(2 * (b.len() + 1), over);
    let (mut prev, mut cur) = scratch.split_at_mut(b.len() + 1);
    for (j, p) in prev.iter_mut().enumerate() {
        *p = j.min(over);
    }
    for (i, ca) in a.iter().enumerate() {
        // Row i + 1 covers the columns lo..=hi; the cells just outside the
        // band count as over the cap.
        let lo = (i + 1).saturating_sub(cap).max(1);
        let hi = (i + 1 + cap).min(b.len());
        cur[lo - 1] = if lo == 1 { (i + 1).min(over) } else { over };
        let mut row_min = cur[lo - 1];
        for j in lo..=hi {
            let cb = b[j - 1];
            let sub = prev[j - 1] + usize::from(!ca.eq_ignore_ascii_case(&cb) || *ca != cb);
            cur[j] = sub.min(prev[j] + 1).min(cur[j - 1] + 1).min(over);
            row_min = row_min.min(cur[j]);
        }
        if hi < b.len() {
            cur[hi + 1] = over;
        }
        if row_min > cap {
            return over;
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The largest distance a suggestion for `name` may have: it grows with
/// the name's length (1 for short names, up to 3).
fn cap_for(len: usize) -> usize {
    match len {
        0..=2 => 1,
        3..=5 => 2,
        _ => 3,
    }
}

/// How close `c` is to `name` (`None`: not a suggestion: the name itself,
/// empty, or farther than `cap`). A case-only difference is the most
/// likely typo and counts as 0.
fn score(
    name: &str,
    name_chars: &[char],
    c: &str,
    cap: usize,
    scratch: &mut Vec<usize>,
) -> Option<usize> {
    if c == name || c.is_empty() {
        return None;
    }
    let d = if c.eq_ignore_ascii_case(name) {
        0
    } else {
        let cc: Vec<char> = c.chars().collect();
        distance_chars(name_chars, &cc, cap, scratch)
    };
    (d <= cap).then_some(d)
}

/// The closest candidate within a distance that grows with the name's
/// length (1 for short names, up to 3), if any. Ties go to the first.
pub(crate) fn best<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    best_scored(name, candidates).map(|(_, c)| c)
}

/// [`best`] with the winner's distance.
fn best_scored<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<(usize, &'a str)> {
    let chars: Vec<char> = name.chars().collect();
    let cap = cap_for(chars.len());
    let mut scratch = Vec::new();
    let mut best: Option<(usize, &str)> = None;
    for c in candidates {
        if let Some(d) = score(name, &chars, c, cap, &mut scratch)
            && best.is_none_or(|(bd, _)| d < bd)
        {
            best = Some((d, c));
        }
    }
    best
}

/// `did you mean `x`?` or nothing.
pub(crate) fn did_you_mean<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<String> {
    best(name, candidates).map(help)
}

fn help(c: &str) -> String {
    format!("did you mean `{c}`?")
}

/// A fixed list of candidate names, prepared once for many look-ups (the
/// global names a file sees: one list per file and check). A look-up gives
/// exactly what [`best`] gives on the list, in the same order, but only
/// measures the names whose length is within the cap of the name's: the
/// others are too far anyway.
#[derive(Debug)]
pub(crate) struct Candidates<'a> {
    names: Vec<&'a str>,
    /// Each name decoded, by index.
    chars: Vec<Vec<char>>,
    /// The indices, by (length in chars, index).
    by_len: Vec<u32>,
}

impl<'a> Candidates<'a> {
    pub(crate) fn new(names: Vec<&'a str>) -> Self {
        let chars: Vec<Vec<char>> = names.iter().map(|n| n.chars().collect()).collect();
        let mut by_len: Vec<u32> = (0..names.len() as u32).collect();
        by_len.sort_by_key(|&i| (chars[i as usize].len(), i));
        Candidates {
            names,
            chars,
            by_len,
        }
    }

    /// The closest name, as [`best`] on the list would give it, with its
    /// distance and index.
    fn best_scored(&self, name: &str) -> Option<(usize, usize)> {
        let chars: Vec<char> = name.chars().collect();
        let cap = cap_for(chars.len());
        let lo = chars.len().saturating_sub(cap);
        let hi = chars.len() + cap;
        let start = self
            .by_len
            .partition_point(|&i| self.chars[i as usize].len() < lo);
        let mut scratch = Vec::new();
        let mut best: Option<(usize, usize)> = None;
        for &i in &self.by_len[start..] {
            let i = i as usize;
            let cc = &self.chars[i];
            if cc.len() > hi {
                break;
            }
            let c = self.names[i];
            if c == name || c.is_empty() {
                continue;
            }
            let d = if c.eq_ignore_ascii_case(name) {
                0
            } else {
                distance_chars(&chars, cc, cap, &mut scratch)
            };
            // Indices ascend within one length, not across lengths: compare
            // both, so that ties still go to the first in the list.
            if d <= cap && best.is_none_or(|b| (d, i) < b) {
                best = Some((d, i));
            }
        }
        best
    }
}

/// `did you mean `x`?` for the closest of `first` followed by `then`, or
/// nothing: the same as [`did_you_mean`] on the two lists chained.
pub(crate) fn did_you_mean_in<'a>(
    name: &str,
    first: impl IntoIterator<Item = &'a str>,
    then: &Candidates<'a>,
) -> Option<String> {
    let a = best_scored(name, first);
    let b = then.best_scored(name);
    let c = match (a, b) {
        // Ties go to the earlier list.
        (Some((da, a)), Some((db, _))) if da <= db => a,
        (_, Some((_, i))) => then.names[i],
        (Some((_, a)), None) => a,
        (None, None) => return None,
    };
    Some(help(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances() {
        assert_eq!(distance("branch", "branc", 3), 1);
        assert_eq!(distance("kitten", "sitting", 5), 3);
        assert_eq!(distance("a", "abcdef", 2), 3);
        assert_eq!(distance("", "ab", 3), 2);
        assert_eq!(distance("abc", "", 3), 3);
        assert_eq!(distance("flaw", "lawn", 3), 2);
        assert_eq!(distance("abcdef", "badcfe", 2), 3);
    }

    #[test]
    fn distance_agrees_with_the_full_table() {
        fn full(a: &str, b: &str) -> usize {
            let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
            let mut prev: Vec<usize> = (0..=b.len()).collect();
            for (i, ca) in a.iter().enumerate() {
                let mut cur = vec![i + 1; b.len() + 1];
                for (j, cb) in b.iter().enumerate() {
                    cur[j + 1] = (prev[j] + usize::from(ca != cb))
                        .min(prev[j + 1] + 1)
                        .min(cur[j] + 1);
                }
                prev = cur;
            }
            prev[b.len()]
        }
        let words = [
            "", "a", "ab", "ba", "abc", "acb", "xabc", "abcx", "axbc", "cab", "aabb",
        ];
        for a in words {
            for b in words {
                for cap in 0..4 {
                    assert_eq!(
                        distance(a, b, cap),
                        full(a, b).min(cap + 1),
                        "{a} {b} {cap}"
                    );
                }
            }
        }
    }

    #[test]
    fn long_similar_names_are_fast() {
        // Quadratic in the length before: minutes for these.
        let a = format!("{}b", "a".repeat(200_000));
        let b = format!("{}c", "a".repeat(200_000));
        assert_eq!(distance(&a, &b, 3), 1);
        assert_eq!(best(&a, [b.as_str()]), Some(b.as_str()));
    }

    #[test]
    fn prepared_candidates_suggest_exactly_what_the_plain_list_does() {
        // Many short names over a small alphabet: lots of ties, case-only
        // differences, names of every length near the cap.
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        let word = |next: &mut dyn FnMut(u64) -> u64| {
            let len = 1 + next(8) as usize;
            (0..len)
                .map(|_| ['a', 'b', 'c', 'A', 'é', '_'][next(6) as usize])
                .collect::<String>()
        };
        let mut globals: Vec<String> = (0..400).map(|_| word(&mut next)).collect();
        globals.push(String::new());
        globals.sort_unstable();
        globals.dedup();
        let bindings: Vec<String> = (0..3).map(|_| word(&mut next)).collect();
        let prepared = Candidates::new(globals.iter().map(String::as_str).collect());
        let mut differ = 0;
        for _ in 0..3000 {
            let name = word(&mut next);
            for first in [&bindings[..], &[]] {
                let plain = did_you_mean(&name, first.iter().chain(&globals).map(String::as_str));
                let fast = did_you_mean_in(&name, first.iter().map(String::as_str), &prepared);
                assert_eq!(plain, fast, "{name}");
                differ += usize::from(plain.is_some());
            }
        }
        assert!(differ > 1000, "the case exercises suggestions: {differ}");
    }

    #[test]
    fn suggests_close_names_only() {
        assert_eq!(best("branc", ["leaf", "branch", "trunk"]), Some("branch"));
        assert_eq!(best("xyz", ["branch"]), None);
        assert_eq!(
            best("Iterations", ["iterations", "angle"]),
            Some("iterations")
        );
    }
}
