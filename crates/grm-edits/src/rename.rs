//! A name of the grammar renamed in the edits that use it (docs/edits.md,
//! "In the editor": the language server's rename changes the edits file
//! beside the grammar too, so that its edits still name what they named).

use crate::file::{Edit, Op, Target};

/// What kind of name of the grammar is renamed, and so where an edit
/// uses it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NameKind {
    /// A system: the edit's `system`.
    System,
    /// A symbol of the edit's system: the labels of an exact target (a
    /// shape's or a module's), the label of a semantic query, the symbol
    /// a key edit recorded.
    Symbol,
    /// A material: a `material` operation's name.
    Material,
    /// A mesh: a `mesh` operation's name, and an exact target's
    /// `insert:NAME` labels (an insert of that mesh on the path).
    Mesh,
    /// A meta-parameter or constant: a `set` or `offset` operation's name
    /// (in shape mode; in derive mode those name a module's parameter,
    /// which is no global: the caller passes this kind for shape systems
    /// only).
    Parameter,
    /// A semantic tag of a shape system: the tags a semantic query names
    /// (`(floor = 3) Window`).
    Tag,
}

impl Edit {
    /// Rename `old` to `new` wherever this edit uses a name of kind `kind`
    /// (the caller picks the edits of the systems that see the name);
    /// whether anything changed. Only whole names change: a label or
    /// operation name that merely contains `old` stays.
    pub fn rename(&mut self, kind: NameKind, old: &str, new: &str) -> bool {
        let swap = |s: &mut String| {
            let hit = s == old;
            if hit {
                *s = new.to_owned();
            }
            hit
        };
        match kind {
            NameKind::System => swap(&mut self.system),
            NameKind::Symbol => match &mut self.target {
                Target::Exact(l) => l.labels.iter_mut().fold(false, |any, l| swap(l) | any),
                Target::Semantic(q) => q.label.as_mut().is_some_and(swap),
                // The symbol a key edit recorded (`Edit::symbol`).
                Target::Key(_) => self.symbol.as_mut().is_some_and(swap),
            },
            NameKind::Material => match &mut self.op {
                Op::Material { name } => swap(name),
                _ => false,
            },
            NameKind::Mesh => {
                let op = match &mut self.op {
                    Op::Mesh { name } => swap(name),
                    _ => false,
                };
                let label = match &mut self.target {
                    Target::Exact(l) => l.labels.iter_mut().fold(false, |any, l| {
                        let hit = l.strip_prefix("insert:") == Some(old);
                        if hit {
                            *l = format!("insert:{new}");
                        }
                        hit | any
                    }),
                    _ => false,
                };
                op | label
            }
            NameKind::Parameter => match &mut self.op {
                Op::Set { name, .. } | Op::Offset { name, .. } => swap(name),
                _ => false,
            },
            NameKind::Tag => match &mut self.target {
                Target::Semantic(q) => q
                    .entries
                    .iter_mut()
                    .fold(false, |any, (tag, _, _)| swap(tag) | any),
                _ => false,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::file::parse;

    fn edit(json: &str) -> Edit {
        let p = parse(&format!("{{\"version\": 2, \"edits\": [{json}]}}"));
        assert!(p.errors.is_empty(), "{:?}", p.errors);
        p.file.edits.into_iter().next().expect("one edit")
    }

    #[test]
    fn each_kind_renames_only_its_own_whole_names() {
        let mut e = edit(
            r#"{"id": 1, "system": "Tower", "target": {"exact": "{Lot, #1, Window, #2, Windows, #1, insert:Window}"}, "op": "remove"}"#,
        );
        assert!(e.rename(NameKind::Symbol, "Window", "Pane"));
        assert_eq!(
            e.target.text(),
            "{Lot, #1, Pane, #2, Windows, #1, insert:Window}"
        );
        assert!(
            !e.rename(NameKind::Symbol, "Tower", "Block"),
            "not a symbol here"
        );
        assert!(e.rename(NameKind::System, "Tower", "Block"));
        assert_eq!(e.system, "Block");
        assert!(e.rename(NameKind::Mesh, "Window", "Sash"));
        assert_eq!(
            e.target.text(),
            "{Lot, #1, Pane, #2, Windows, #1, insert:Sash}"
        );

        let mut q = edit(
            r#"{"id": 2, "system": "Tower", "target": {"semantic": "(floor = end 1) Window"}, "selected": 4, "op": "material", "name": "glass"}"#,
        );
        assert!(q.rename(NameKind::Symbol, "Window", "Pane"));
        assert_eq!(q.target.text(), "(floor = end 1) Pane");
        assert_eq!(q.selected, Some(4), "the count stays");
        assert!(
            !q.rename(NameKind::Mesh, "glass", "x"),
            "a material is no mesh"
        );
        assert!(q.rename(NameKind::Material, "glass", "clear"));
        assert_eq!(
            q.op,
            Op::Material {
                name: "clear".into()
            }
        );

        let mut s = edit(
            r#"{"id": 3, "system": "Tower", "target": {"key": "0a1b2c3d"}, "op": "offset", "name": "floors", "by": 1}"#,
        );
        assert!(!s.rename(NameKind::Symbol, "floors", "storeys"));
        assert!(
            !s.rename(NameKind::Parameter, "floor", "storey"),
            "whole names"
        );
        assert!(s.rename(NameKind::Parameter, "floors", "storeys"));
        assert_eq!(
            s.op,
            Op::Offset {
                name: "storeys".into(),
                by: 1.0
            }
        );
        // A key edit's recorded symbol (version 3).
        let p = parse(
            r#"{"version": 3, "edits": [{"id": 6, "system": "Tower", "target": {"key": "0a1b2c3d"}, "symbol": "Window", "op": "remove"}]}"#,
        );
        let mut k = p.file.edits.into_iter().next().expect("one edit");
        assert!(!k.rename(NameKind::Symbol, "Win", "Pane"), "whole names");
        assert!(k.rename(NameKind::Symbol, "Window", "Pane"));
        assert_eq!(k.symbol.as_deref(), Some("Pane"));
        assert_eq!(k.target.text(), "0a1b2c3d", "the key stays");
        let mut any = edit(
            r#"{"id": 4, "system": "Tower", "target": {"semantic": "(floor = 2)"}, "op": "mesh", "name": "sash"}"#,
        );
        assert!(!any.rename(NameKind::Symbol, "Window", "Pane"), "no label");
        assert!(any.rename(NameKind::Mesh, "sash", "frame"));
        assert_eq!(
            any.op,
            Op::Mesh {
                name: "frame".into()
            }
        );

        // A tag: the query's entries that name it, anchors and indices kept.
        let mut t = edit(
            r#"{"id": 5, "system": "Tower", "target": {"semantic": "(facade = 1, floor = end 2, floorplate = 3) floor"}, "op": "remove"}"#,
        );
        assert!(t.rename(NameKind::Tag, "floor", "storey"));
        assert_eq!(
            t.target.text(),
            "(facade = 1, storey = end 2, floorplate = 3) floor",
            "whole tags only, the label is no tag"
        );
        assert!(!t.rename(NameKind::Tag, "column", "bay"), "not named");
        assert!(!e.rename(NameKind::Tag, "Window", "Pane"), "exact: no tags");
    }
}
