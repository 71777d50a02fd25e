//! Instance locators (Lipp, 3.2.1): how a part is named so that it can be
//! found again after the model is regrown. These are the data types and
//! their text forms only; finding a locator's node in a shape tree is
//! `grm_shape`'s (`ShapeTree::resolve`, `ShapeTree::select`).
//!
//! - The **exact locator** is the path from the axiom: every node's label
//!   (symbol, command or insert) and the number of the edge taken out of
//!   it, `{Lot, #1, comp.faces, front 1, Facade, #1, repeat.y, #3, Floor, ...}`.
//!   An edge `#k` is the k-th child bearing the next label (a part
//!   inserted before it under another symbol does not shift it); a plain
//!   number `k` is the raw k-th edge (edits files of version 1).
//!   A component split's edges are named by selector and index within it,
//!   never by a raw face index. Labels are names, not ids, so a locator
//!   outlives a renumbering of the program. In derive and sample mode the
//!   same type names a part of the derivation tree: the labels are module
//!   symbols and the edges the child numbers.
//! - The **semantic locator** lists, along the same path, each tagged
//!   command with the number of the child taken (the part of a split,
//!   the tile of a repeat, the component within its case) and how many
//!   there were: `(facade = 1/4, floor = 3/40, column = 5/50) Window`. A
//!   [`SemanticQuery`] matches it counting from the start, the end or the
//!   centre, and ignores the tags it does not name (all windows of column
//!   5 on every floor); its text form is `(floor = 3, column = end 1, bay
//!   = centre -1) Window`.

use grm_sema::shape::Selector;
use std::fmt;
use std::str::FromStr;

/// The edge taken out of a node.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum EdgeRef {
    /// The edge's raw number, from 1 (what version 1 of the edits file
    /// wrote): shifted by a part inserted before it.
    Number(u32),
    /// `#k`: the `k`-th (from 1) of the node's children whose label is the
    /// one that follows the edge in the locator (the path's next label),
    /// in the children's order (version 2, what locators are made with):
    /// a part of another symbol inserted before it does not shift it.
    Ordinal(u32),
    /// A component split's child: its case's selector and its index within
    /// that case, from 1.
    Component { selector: Selector, index: u32 },
}

impl fmt::Display for EdgeRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EdgeRef::Number(n) => write!(f, "{n}"),
            EdgeRef::Ordinal(k) => write!(f, "#{k}"),
            EdgeRef::Component { selector, index } => write!(f, "{} {index}", selector.name()),
        }
    }
}

/// The exact path from the axiom to a node: `labels[i]`, then `edges[i]`
/// out of it, ..., the node's own label last (`labels.len() == edges.len() + 1`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct ExactLocator {
    pub labels: Vec<String>,
    pub edges: Vec<EdgeRef>,
}

impl ExactLocator {
    /// The depth of the node it names (the axiom's is 0): the number of
    /// edges on its path.
    pub fn depth(&self) -> usize {
        self.edges.len()
    }
}

impl fmt::Display for ExactLocator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{{")?;
        for (i, l) in self.labels.iter().enumerate() {
            if i > 0 {
                write!(f, ", {}, ", self.edges[i - 1])?;
            }
            write!(f, "{l}")?;
        }
        write!(f, "}}")
    }
}

impl FromStr for EdgeRef {
    type Err = String;

    /// `3`, `#2` or `front 2` (the [`fmt::Display`] form).
    fn from_str(s: &str) -> Result<EdgeRef, String> {
        let s = s.trim();
        if let Ok(n) = s.parse::<u32>() {
            return Ok(EdgeRef::Number(n));
        }
        let bad = || {
            format!(
                "`{s}` is not an edge (a number, `#` and an ordinal, or a selector and an index)"
            )
        };
        if let Some(k) = s.strip_prefix('#') {
            return match k.parse::<u32>() {
                Ok(n) if n >= 1 && !k.starts_with('+') => Ok(EdgeRef::Ordinal(n)),
                _ => Err(bad()),
            };
        }
        let (name, index) = s.split_once(' ').ok_or_else(bad)?;
        // Every selector, the roof's included (`slope 2`, `eave 1`).
        let selector = Selector::from_name(name).ok_or_else(bad)?;
        let index = index.trim().parse::<u32>().map_err(|_| bad())?;
        Ok(EdgeRef::Component { selector, index })
    }
}

impl FromStr for ExactLocator {
    type Err = String;

    /// The [`fmt::Display`] form, `{Lot, 1, comp.faces, front 1, Facade}`:
    /// labels and edges alternate, separated by commas (the space after
    /// each is optional; a label holding a comma does not read back).
    fn from_str(s: &str) -> Result<ExactLocator, String> {
        let inner = s
            .trim()
            .strip_prefix('{')
            .and_then(|r| r.strip_suffix('}'))
            .ok_or_else(|| format!("`{s}` is not a locator in braces"))?;
        let mut labels = Vec::new();
        let mut edges = Vec::new();
        for (i, word) in inner.split(',').map(str::trim).enumerate() {
            if i % 2 == 0 {
                labels.push(word.to_owned());
            } else {
                edges.push(word.parse()?);
            }
        }
        if labels.len() != edges.len() + 1 {
            return Err(format!("`{s}` does not end with a label"));
        }
        // Braces are labels too: `{` and `}` are turtle symbols.
        if labels
            .iter()
            .any(|l| l.is_empty() || l.chars().any(char::is_whitespace))
        {
            return Err(format!("`{s}` has an empty label, or one with a space"));
        }
        Ok(ExactLocator { labels, edges })
    }
}

/// One tagged command on the path: its tag, the number of the child
/// taken (from 1) and how many there were.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SemanticEntry {
    pub tag: String,
    pub index: u32,
    pub count: u32,
}

/// The tagged commands on the path from the axiom, and the node's label.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SemanticLocator {
    pub entries: Vec<SemanticEntry>,
    pub label: String,
}

impl fmt::Display for SemanticLocator {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "(")?;
        for (i, e) in self.entries.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            write!(f, "{} = {}/{}", e.tag, e.index, e.count)?;
        }
        write!(f, ") {}", self.label)
    }
}

/// Which end a semantic index counts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Anchor {
    /// `1` is the first (left or bottom).
    Start,
    /// `1` is the last (right or top).
    End,
    /// `0` is the middle one (`(count + 1) / 2`, rounded down: the left of
    /// two middles); negative before it, positive after.
    Centre,
}

impl Anchor {
    /// The index of child `index` (from 1) of `count`, counted from this anchor.
    #[inline]
    pub fn index(self, index: u32, count: u32) -> i64 {
        match self {
            Anchor::Start => i64::from(index),
            Anchor::End => i64::from(count) + 1 - i64::from(index),
            Anchor::Centre => i64::from(index) - i64::from(count.div_ceil(2).max(1)),
        }
    }

    /// The word written before the index in a query's text: none for the
    /// start, `end`, `centre`.
    pub fn word(self) -> Option<&'static str> {
        match self {
            Anchor::Start => None,
            Anchor::End => Some("end"),
            Anchor::Centre => Some("centre"),
        }
    }
}

/// A selection by semantic locator: the tags it names must appear on the
/// path in this order, with these indices; tags it does not name are
/// ignored; `label`, when given, must be the node's.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct SemanticQuery {
    pub entries: Vec<(String, Anchor, i64)>,
    pub label: Option<String>,
}

impl SemanticQuery {
    /// Whether `loc` is selected.
    pub fn matches(&self, loc: &SemanticLocator) -> bool {
        if self.label.as_ref().is_some_and(|l| *l != loc.label) {
            return false;
        }
        let named = |t: &str| self.entries.iter().any(|(q, _, _)| q == t);
        let mut kept = loc.entries.iter().filter(|e| named(&e.tag));
        for (tag, anchor, want) in &self.entries {
            match kept.next() {
                Some(e) if e.tag == *tag && anchor.index(e.index, e.count) == *want => {}
                _ => return false,
            }
        }
        kept.next().is_none()
    }
}

impl fmt::Display for SemanticQuery {
    /// `(floor = 3, column = end 1, bay = centre -1) Window`; `()` with
    /// no entries; no label after `)` when any label matches.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "(")?;
        for (i, (tag, anchor, n)) in self.entries.iter().enumerate() {
            if i > 0 {
                write!(f, ", ")?;
            }
            match anchor.word() {
                Some(w) => write!(f, "{tag} = {w} {n}")?,
                None => write!(f, "{tag} = {n}")?,
            }
        }
        write!(f, ")")?;
        if let Some(label) = &self.label {
            write!(f, " {label}")?;
        }
        Ok(())
    }
}

impl FromStr for SemanticQuery {
    type Err = String;

    /// The [`fmt::Display`] form. Each entry is `tag = N` (from the start,
    /// `N >= 1`), `tag = end N` (`N >= 1`, 1 the last) or `tag = centre N`
    /// (any integer, 0 the middle; `center` is read too); spaces around
    /// the words are free. A tag or label is a word: no space, comma,
    /// `=`, parenthesis or brace. Indices that can never match (0 or less
    /// from the start or the end) are refused.
    fn from_str(s: &str) -> Result<SemanticQuery, String> {
        let t = s.trim();
        let rest = t
            .strip_prefix('(')
            .ok_or_else(|| format!("`{t}` is not a semantic query: it starts with `(`"))?;
        let (inner, after) = rest
            .split_once(')')
            .ok_or_else(|| format!("`{t}` is not a semantic query: no closing `)`"))?;
        let mut entries = Vec::new();
        if !inner.trim().is_empty() {
            for entry in inner.split(',') {
                entries.push(parse_entry(entry.trim())?);
            }
        }
        let label = match after.trim() {
            "" => None,
            l if is_word(l) => Some(l.to_owned()),
            l => {
                return Err(format!(
                    "`{l}` after `)` is not a label (one word, or nothing for any label)"
                ));
            }
        };
        Ok(SemanticQuery { entries, label })
    }
}

/// `tag = N`, `tag = end N`, `tag = centre N`.
fn parse_entry(entry: &str) -> Result<(String, Anchor, i64), String> {
    let bad = || format!("`{entry}` is not `tag = N`, `tag = end N` or `tag = centre N`");
    let (tag, value) = entry.split_once('=').ok_or_else(bad)?;
    let tag = tag.trim();
    if !is_word(tag) {
        return Err(bad());
    }
    let mut words = value.split_whitespace();
    let (anchor, n) = match (words.next(), words.next(), words.next()) {
        (Some("end"), Some(n), None) => (Anchor::End, n),
        (Some("centre" | "center"), Some(n), None) => (Anchor::Centre, n),
        (Some(n), None, None) => (Anchor::Start, n),
        _ => return Err(bad()),
    };
    let n: i64 = n.parse().map_err(|_| bad())?;
    if anchor != Anchor::Centre && n < 1 {
        return Err(format!(
            "`{entry}`: an index from the {} is 1 or more",
            if anchor == Anchor::End {
                "end"
            } else {
                "start"
            }
        ));
    }
    Ok((tag.to_owned(), anchor, n))
}

/// A tag or label: not empty, no white space, none of `,=(){}`.
pub fn is_word(s: &str) -> bool {
    !s.is_empty()
        && !s
            .chars()
            .any(|c| c.is_whitespace() || matches!(c, ',' | '=' | '(' | ')' | '{' | '}'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anchors_count_from_their_end() {
        assert_eq!(Anchor::Start.index(1, 5), 1);
        assert_eq!(Anchor::End.index(5, 5), 1);
        assert_eq!(Anchor::Centre.index(3, 5), 0);
        assert_eq!(Anchor::Centre.index(2, 4), 0);
        assert_eq!(Anchor::Centre.index(1, 4), -1);
        assert_eq!(Anchor::Centre.index(1, 0), 0);
    }

    #[test]
    fn query_text_table() {
        let q = |entries: &[(&str, Anchor, i64)], label: Option<&str>| SemanticQuery {
            entries: entries
                .iter()
                .map(|(t, a, n)| (t.to_string(), *a, *n))
                .collect(),
            label: label.map(str::to_owned),
        };
        let cases = [
            (
                "(floor = 3, column = end 1, bay = centre -1) Window",
                q(
                    &[
                        ("floor", Anchor::Start, 3),
                        ("column", Anchor::End, 1),
                        ("bay", Anchor::Centre, -1),
                    ],
                    Some("Window"),
                ),
            ),
            ("()", q(&[], None)),
            ("() Window", q(&[], Some("Window"))),
            ("(floor = 1)", q(&[("floor", Anchor::Start, 1)], None)),
            ("(bay = centre 0)", q(&[("bay", Anchor::Centre, 0)], None)),
        ];
        for (text, want) in cases {
            let got: SemanticQuery = text.parse().unwrap_or_else(|e| panic!("{text}: {e}"));
            assert_eq!(got, want, "{text}");
            assert_eq!(got.to_string(), text);
        }
        // Loose spacing and `center` read, written canonically.
        let loose: SemanticQuery = "  (floor=3 ,column =  end   1,bay = center -1)Window "
            .parse()
            .unwrap();
        assert_eq!(
            loose.to_string(),
            "(floor = 3, column = end 1, bay = centre -1) Window"
        );
    }

    #[test]
    fn bad_queries_are_refused() {
        for bad in [
            "",
            "floor = 3",
            "(floor = 3",
            "(floor = 0)",
            "(floor = end 0)",
            "(floor = end -2)",
            "(floor = start 2)",
            "(floor 3)",
            "(= 3)",
            "(floor = 3,)",
            "(floor = x)",
            "(floor = 3) two words",
            "(floor = 3) (x)",
            "(fl oor = 3)",
            "(floor = 99999999999999999999)",
        ] {
            assert!(bad.parse::<SemanticQuery>().is_err(), "{bad:?} was read");
        }
    }

    #[test]
    fn exact_locators_round_trip() {
        for text in [
            "{Lot}",
            "{Lot, 1, comp.faces, front 1, Facade, 1, repeat.y, 3, Floor}",
            "{Roof, 1, comp.faces, slope 2, Slope, 1, insert:box}",
            "{Lot, #1, repeat.x, #3, Plot, #1, split.y, #2, Upper}",
        ] {
            let l: ExactLocator = text.parse().unwrap_or_else(|e| panic!("{text}: {e}"));
            assert_eq!(l.to_string(), text);
        }
        let braces: ExactLocator = "{{, 2, }}".parse().unwrap();
        assert_eq!(braces.labels, ["{", "}"]);
        assert_eq!(braces.to_string(), "{{, 2, }}");
        let tight: ExactLocator = "{Lot,1,A}".parse().unwrap();
        assert_eq!(tight.to_string(), "{Lot, 1, A}");
        assert_eq!(tight.depth(), 1);
        for bad in [
            "",
            "Lot",
            "{}",
            "{Lot, 1}",
            "{Lot, x, A}",
            "{Lot, 1, }",
            "{Lot, front, A}",
            "{Lot, 1, A B}",
            "{Lot, 1, , 2, A}",
            "{Lot, #0, A}",
            "{Lot, #, A}",
            "{Lot, #+1, A}",
            "{Lot, # 1, A}",
            "{Lot, #-1, A}",
        ] {
            assert!(bad.parse::<ExactLocator>().is_err(), "{bad:?} was read");
        }
    }
}
