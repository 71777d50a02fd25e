//! "Did you mean ...?" suggestions by edit distance.

/// Levenshtein distance (with a cap: returns `cap + 1` when it exceeds `cap`).
pub(crate) fn distance(a: &str, b: &str, cap: usize) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    if a.len().abs_diff(b.len()) > cap {
        return cap + 1;
    }
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0; b.len() + 1];
    for (i, ca) in a.iter().enumerate() {
        cur[0] = i + 1;
        let mut row_min = cur[0];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(!ca.eq_ignore_ascii_case(cb) || ca != cb);
            cur[j + 1] = sub.min(prev[j + 1] + 1).min(cur[j] + 1);
            row_min = row_min.min(cur[j + 1]);
        }
        if row_min > cap {
            return cap + 1;
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
