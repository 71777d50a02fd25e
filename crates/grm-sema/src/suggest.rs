//! "Did you mean ...?" suggestions by edit distance.
//!
//! The rule: the closest candidate by Levenshtein distance over chars,
//! within a cap that grows with the name's length ([`cap_for`]: 1 for short
//! names, up to 3); a case-only (ASCII) difference counts 0; the name
//! itself and the empty name are never suggested; ties go to the first
//! candidate in the list. Short fixed lists (settings, functions, types)
//! are scanned ([`did_you_mean`]); the long ones a file or system offers
//! many look-ups in (global names, symbols) are prepared once
//! ([`Candidates`]), so that thousands of misspellings among thousands of
//! names cost milliseconds, not seconds, with the same answers.

use std::collections::HashMap;

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
    (scratch, cc): (&mut Vec<usize>, &mut Vec<char>),
) -> Option<usize> {
    if c == name || c.is_empty() {
        return None;
    }
    let d = if c.eq_ignore_ascii_case(name) {
        0
    } else {
        cc.clear();
        cc.extend(c.chars());
        distance_chars(name_chars, cc, cap, scratch)
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
    let (mut scratch, mut cc) = (Vec::new(), Vec::new());
    let mut best: Option<(usize, &str)> = None;
    for c in candidates {
        if let Some(d) = score(name, &chars, c, cap, (&mut scratch, &mut cc))
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
/// global names a file sees: one list per file and check; the symbols of a
/// system). A look-up gives exactly what [`best`] gives on the list (the
/// closest name, ties to the first in the list), without measuring every
/// name: the names are kept in a trie, and one search walks it with a row
/// of the edit-distance table per node (shared by every name below it, and
/// only the band within the cap of the diagonal), leaving a branch as soon
/// as no name below it can beat the best one found so far.
#[derive(Debug)]
pub(crate) struct Candidates<'a> {
    names: Vec<&'a str>,
    /// The trie; node 0 is the root (the empty prefix).
    nodes: Vec<Node>,
    /// Names by their ASCII-lowercased form: the indices, ascending (a
    /// case-only difference counts 0, which no edit distance gives).
    folded: HashMap<String, Vec<u32>>,
}

const NONE: u32 = u32::MAX;

#[derive(Debug, Clone)]
struct Node {
    /// The character on the edge into this node.
    ch: char,
    /// Children in ascending character order, as a linked list.
    first_child: u32,
    last_child: u32,
    next_sibling: u32,
    /// The first (lowest) index of a name ending here, or [`NONE`].
    term: u32,
    /// The lowest index of a name in this subtree (for ties).
    min_index: u32,
}

impl Node {
    fn new(ch: char) -> Node {
        Node {
            ch,
            first_child: NONE,
            last_child: NONE,
            next_sibling: NONE,
            term: NONE,
            min_index: NONE,
        }
    }
}

impl<'a> Candidates<'a> {
    pub(crate) fn new(names: Vec<&'a str>) -> Self {
        // Insert in sorted order: each node's children are then created in
        // ascending order, and a name shares its prefix with the previous one.
        let mut order: Vec<u32> = (0..names.len() as u32).collect();
        order.sort_by(|&a, &b| names[a as usize].cmp(names[b as usize]).then(a.cmp(&b)));
        let mut nodes = vec![Node::new('\0')];
        // The path (node per depth) of the previous name, and its chars.
        // It always holds the root: it is cut to `common + 1` nodes at least.
        let mut path: Vec<u32> = vec![0];
        let mut prev: Vec<char> = Vec::new();
        let mut cur: Vec<char> = Vec::new();
        for &i in &order {
            cur.clear();
            cur.extend(names[i as usize].chars());
            let common = prev.iter().zip(&cur).take_while(|(a, b)| a == b).count();
            path.truncate(common + 1);
            for &ch in &cur[common..] {
                let parent = path[path.len() - 1] as usize;
                let id = nodes.len() as u32;
                nodes.push(Node::new(ch));
                // Sorted insertion: the new child is the parent's last.
                match nodes[parent].last_child {
                    NONE => nodes[parent].first_child = id,
                    last => nodes[last as usize].next_sibling = id,
                }
                nodes[parent].last_child = id;
                path.push(id);
            }
            // `path` ends at the node of this name.
            for &n in &path {
                let n = &mut nodes[n as usize];
                n.min_index = n.min_index.min(i);
            }
            let end = &mut nodes[path[path.len() - 1] as usize];
            end.term = end.term.min(i);
            std::mem::swap(&mut prev, &mut cur);
        }
        let mut folded: HashMap<String, Vec<u32>> = HashMap::new();
        for (i, n) in names.iter().enumerate() {
            folded
                .entry(n.to_ascii_lowercase())
                .or_default()
                .push(i as u32);
        }
        Candidates {
            names,
            nodes,
            folded,
        }
    }

    /// `did you mean `x`?` for the closest name, or nothing: the same as
    /// [`did_you_mean`] on the list.
    pub(crate) fn did_you_mean(&self, name: &str) -> Option<String> {
        self.best_scored(name).map(|(_, i)| help(self.names[i]))
    }

    /// The closest name, as [`best`] on the list would give it, with its
    /// distance and index.
    fn best_scored(&self, name: &str) -> Option<(usize, usize)> {
        // A case-only difference: distance 0, the best there is (only the
        // name itself is closer, and it is no suggestion).
        if let Some(ids) = self.folded.get(&name.to_ascii_lowercase())
            && let Some(&i) = ids.iter().find(|&&i| self.names[i as usize] != name)
        {
            return Some((0, i as usize));
        }
        let q: Vec<char> = name.chars().collect();
        let n = q.len();
        let cap = cap_for(n);
        // Every distance fits a byte: cells are clamped to `cap + 1` <= 4.
        let over = (cap + 1) as u8;
        // A row of the table is the band j in i-cap ..= i+cap at depth i
        // (cell k is column j = i - cap + k); cells outside it exceed the cap.
        let w = 2 * cap + 1;
        let mut rows: Vec<u8> = Vec::with_capacity(w * (n + cap + 2));
        rows.extend((0..w).map(|k| {
            // Depth 0: D[0][j] = j.
            match k.checked_sub(cap) {
                Some(j) if j <= n => j.min(cap + 1) as u8,
                _ => over,
            }
        }));
        // (best distance, index), as a pair compared lexicographically.
        let mut best: Option<(u8, u32)> = None;
        // Nodes to visit with their depth; children are pushed last first.
        let mut stack: Vec<(u32, usize)> = Vec::new();
        let push_children = |stack: &mut Vec<(u32, usize)>, node: u32, depth: usize| {
            let start = stack.len();
            let mut c = self.nodes[node as usize].first_child;
            while c != NONE {
                stack.push((c, depth + 1));
                c = self.nodes[c as usize].next_sibling;
            }
            stack[start..].reverse();
        };
        push_children(&mut stack, 0, 0);
        while let Some((id, depth)) = stack.pop() {
            let node = &self.nodes[id as usize];
            // The largest distance a name below may have to win: the cap; a
            // tie with the best so far when a name below comes before it in
            // the list; else less than the best.
            let bound = match best {
                None => cap as u8,
                Some((d, i)) if node.min_index < i => d,
                Some((d, _)) => d.saturating_sub(1),
            };
            // Row `depth` from row `depth - 1` (the parent's: rows of other
            // branches at this depth were written after it was, and are done).
            rows.truncate(depth * w);
            let (parent, _) = rows.split_at(depth * w);
            let parent = &parent[(depth - 1) * w..];
            // `cap_for` is at most 3: a band is at most 7 cells.
            let mut row = [over; 7];
            let mut row_min = over;
            for k in 0..w {
                let Some(j) = (depth + k).checked_sub(cap) else {
                    continue;
                };
                if j > n {
                    break;
                }
                let v = if j == 0 {
                    depth.min(cap + 1) as u8
                } else {
                    let sub = parent[k] + u8::from(q[j - 1] != node.ch);
                    let up = if k + 1 < w { parent[k + 1] + 1 } else { over };
                    let left = if k > 0 { row[k - 1] + 1 } else { over };
                    sub.min(up).min(left).min(over)
                };
                row[k] = v;
                row_min = row_min.min(v);
            }
            rows.extend_from_slice(&row[..w]);
            if row_min > bound {
                continue; // nothing below can win
            }
            if node.term != NONE
                && let Some(k) = (n + cap).checked_sub(depth)
                && k < w
            {
                let d = row[k];
                // 0 is the name itself (no suggestion).
                if d > 0 && d <= cap as u8 && best.is_none_or(|b| (d, node.term) < b) {
                    best = Some((d, node.term));
                }
            }
            push_children(&mut stack, id, depth);
        }
        best.map(|(d, i)| (usize::from(d), i as usize))
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

    /// `next(n)` is below `n`: the suites' generator as a closure.
    fn draws(seed: u64) -> impl FnMut(u64) -> u64 {
        let mut rng = grm_testkit::Rng::seeded(seed);
        move |n| rng.below(n)
    }

    #[test]
    fn prepared_candidates_suggest_exactly_what_the_plain_list_does() {
        // Many short names over a small alphabet: lots of ties, case-only
        // differences, names of every length near the cap.
        let mut next = draws(0x9E37_79B9_7F4A_7C15);
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
    fn prepared_candidates_in_any_order_break_ties_by_position() {
        // Unsorted lists with duplicates and the empty name: the trie walks
        // names in sorted order, but a tie still goes to the first in the
        // list, as with the plain rule.
        let mut next = draws(0x2545_F491_4F6C_DD1D);
        let word = |next: &mut dyn FnMut(u64) -> u64| {
            let len = next(9) as usize;
            (0..len)
                .map(|_| ['x', 'y', 'X', 'ä', '1'][next(5) as usize])
                .collect::<String>()
        };
        let mut suggested = 0;
        for round in 0..40 {
            let list: Vec<String> = (0..5 + round * 10).map(|_| word(&mut next)).collect();
            let prepared = Candidates::new(list.iter().map(String::as_str).collect());
            for _ in 0..200 {
                let name = word(&mut next);
                let plain = best(&name, list.iter().map(String::as_str));
                let fast = prepared.best_scored(&name).map(|(_, i)| list[i].as_str());
                assert_eq!(plain, fast, "{name} in {list:?}");
                suggested += usize::from(plain.is_some());
            }
        }
        assert!(
            suggested > 2000,
            "the case exercises suggestions: {suggested}"
        );
    }

    #[test]
    fn prepared_candidates_rank_ties_and_cases_as_the_plain_rule() {
        let names = ["widht", "wdith", "Width", "width", "wid"];
        let c = Candidates::new(names.to_vec());
        let suggest = |n: &str| c.did_you_mean(n);
        // A case-only difference beats any edit; the first such one wins.
        assert_eq!(suggest("WIDTH").as_deref(), Some("did you mean `Width`?"));
        assert_eq!(suggest("width").as_deref(), Some("did you mean `Width`?"));
        // The name itself is no suggestion; distance ties go to the first.
        assert_eq!(suggest("widh").as_deref(), Some("did you mean `widht`?"));
        assert_eq!(suggest("wi").as_deref(), Some("did you mean `wid`?"));
        assert_eq!(suggest("qqqqqq"), None);
        assert_eq!(Candidates::new(Vec::new()).did_you_mean("a"), None);
        assert_eq!(Candidates::new(vec![""]).did_you_mean(""), None);
    }

    #[test]
    fn prepared_long_similar_names_are_fast() {
        let a = format!("{}b", "a".repeat(200_000));
        let b = format!("{}c", "a".repeat(200_000));
        let c = "a".repeat(199_999);
        let prepared = Candidates::new(vec![c.as_str(), b.as_str()]);
        assert_eq!(prepared.best_scored(&a), Some((1, 1)));
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
