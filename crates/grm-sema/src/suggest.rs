//! "Did you mean ...?" suggestions by edit distance.

/// Levenshtein distance (with a cap: returns `cap + 1` when it exceeds `cap`).
/// Only the cells within `cap` of the diagonal are computed (the others
/// exceed the cap anyway), so the work is linear in the names' length even
/// for two long, similar names.
pub(crate) fn distance(a: &str, b: &str, cap: usize) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    if a.len().abs_diff(b.len()) > cap {
        return cap + 1;
    }
    let over = cap + 1;
    let mut prev: Vec<usize> = (0..=b.len()).map(|j| j.min(over)).collect();
    let mut cur = vec![over; b.len() + 1];
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

/// The closest candidate within a distance that grows with the name's
/// length (1 for short names, up to 3), if any. Ties go to the first.
pub(crate) fn best<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<&'a str> {
    let len = name.chars().count();
    let cap = match len {
        0..=2 => 1,
        3..=5 => 2,
        _ => 3,
    };
    let mut best: Option<(&str, usize)> = None;
    for c in candidates {
        if c == name || c.is_empty() {
            continue;
        }
        // A case-only difference is the most likely typo.
        let d = if c.eq_ignore_ascii_case(name) {
            0
        } else {
            distance(name, c, cap)
        };
        if d <= cap && best.is_none_or(|(_, bd)| d < bd) {
            best = Some((c, d));
        }
    }
    best.map(|(c, _)| c)
}

/// `did you mean `x`?` or nothing.
pub(crate) fn did_you_mean<'a>(
    name: &str,
    candidates: impl IntoIterator<Item = &'a str>,
) -> Option<String> {
    best(name, candidates).map(|c| format!("did you mean `{c}`?"))
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
    fn suggests_close_names_only() {
        assert_eq!(best("branc", ["leaf", "branch", "trunk"]), Some("branch"));
        assert_eq!(best("xyz", ["branch"]), None);
        assert_eq!(
            best("Iterations", ["iterations", "angle"]),
            Some("iterations")
        );
    }
}
