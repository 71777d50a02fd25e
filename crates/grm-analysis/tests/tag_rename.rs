//! Renaming a shape system's semantic tag (docs/edits.md, "In the
//! editor"): a tag has no declaration; F2 on any place its system writes
//! it (a command's tag, `tagged`, `index`, `count`) renames every one of
//! them and no other system's, and says so to the edits files
//! (`RenamedKind::Tag`).

use grm_analysis::{Analysis, RenamedKind};
use grm_sema::MemLoader;
use std::path::Path;
use std::sync::Arc;

const TWO: &str = "system A {
    mode = shape;
    lot = rect(10, 10);
    axiom Lot;
    Lot -> extrude(9) Mass;
    Mass -> comp(faces, facade) { front: Facade | side: Wall };
    Facade -> repeat(y, floor) { 3: Floor };
    Floor : index(floor) < count(floor) && tagged(floor) -> repeat(x) { 2: Wall };
}
system B {
    mode = shape;
    lot = rect(10, 10);
    axiom Lot;
    Lot -> extrude(9) Mass;
    Mass -> comp(faces) { front: Facade | side: Wall };
    Facade -> repeat(y, floor) { 3: Wall };
}
";

fn at(text: &str, needle: &str, n: usize) -> u32 {
    text.match_indices(needle).nth(n).expect(needle).0 as u32
}

#[test]
fn a_tag_renames_in_its_system_only() {
    let mut a = Analysis::new(Arc::new(MemLoader::new()));
    let p = Path::new("two.grm");
    a.set_document(p, 1, TWO);
    let fa = a.analyze(p).expect("analysis");
    let use_at = at(TWO, "floor) &&", 0) + 1;
    let (span, text) = fa.prepare_rename(use_at).expect("a tag renames");
    assert_eq!(text, "floor");
    assert_eq!(&TWO[span.range()], "floor");
    assert_eq!(fa.references(use_at, true).len(), 4);

    let edits = a.rename(p, use_at, "storey").expect("renames");
    assert_eq!(edits.len(), 1);
    let mut out = TWO.to_owned();
    let mut spans: Vec<_> = edits[0].edits.iter().map(|(l, t)| (l.span, t)).collect();
    spans.sort_by_key(|(s, _)| std::cmp::Reverse(s.start));
    for (s, t) in spans {
        out.replace_range(s.range(), t);
    }
    assert_eq!(out.matches("storey").count(), 4, "{out}");
    assert!(
        out.contains("Facade -> repeat(y, floor) { 3: Wall }"),
        "system B's tag: {out}"
    );
    let renamed = a.renamed_name(p, use_at).expect("for the edits");
    assert_eq!(renamed.kind, RenamedKind::Tag);
    assert_eq!(renamed.old, "floor");
    assert_eq!(renamed.systems.len(), 1);
    assert_eq!(renamed.systems[0].name, "A");
    assert!(renamed.systems[0].shape);

    // Onto a tag the system has: refused; B has no `facade`.
    let cmd = at(TWO, "floor) {", 0) + 2;
    let e = a.rename(p, cmd, "facade").unwrap_err();
    assert!(e.0.contains("already has a tag `facade`"), "{e}");
    let in_b = at(TWO, "floor) {", 1) + 2;
    assert_eq!(
        a.rename(p, in_b, "facade").expect("free in B")[0]
            .edits
            .len(),
        1
    );
    assert!(a.rename(p, in_b, "system").is_err(), "a reserved word");
}
