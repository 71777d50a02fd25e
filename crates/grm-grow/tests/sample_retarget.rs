//! Retarget candidates on a sampled model's tree (`grm_grow::retarget`;
//! docs/edits.md, "Retargeting"): in sample mode a node is an expansion
//! keyed by the module it expanded, and its place is the centre of what
//! the turtle drew below it. A module's print (symbol, ancestry, place)
//! finds that module first among the keys of the same symbol.

mod common;

use common::*;
use grm_edits::{EditsFile, Op, Target};
use grm_grow::retarget::{Reason, TreeParts, candidates};
use grm_grow::sample::{SampleRequest, sample};
use grm_sample::{SampleOptions, Schedule};

#[test]
fn a_sampled_branch_is_found_again_by_its_print() {
    let checked = checked("calder_tree.grm");
    let compiled = compile(&checked);
    let curves = grm_guide::Curves::load(example_path("calder_tree.curves.json")).expect("curves");
    let opts = SampleOptions {
        seed: 3,
        threads: 1,
        schedule: Schedule {
            generations: 6,
            particles_start: 12,
            particles_end: 6,
            heuristic_scale: 0.013,
            heuristic_until: 3,
        },
        ..SampleOptions::default()
    };
    let request = SampleRequest {
        tree: true,
        ..SampleRequest::new(&curves, opts)
    };
    let mut sampled = sample(system(&checked), &compiled, &request).expect("samples");
    let tree = sampled.tree.take().expect("the tree");
    let model = &sampled.shown().models()[0];
    let parts = TreeParts::new(&tree, &compiled.symbol_names, &model.interpretation);

    // Every `branch` below the first level whose key is its own.
    let names = &compiled.symbol_names;
    let branches: Vec<u32> = (1..tree.nodes.len() as u32)
        .filter(|&i| {
            let n = &tree.nodes[i as usize];
            n.symbol.is_some_and(|s| names[s as usize] == "branch")
                && tree.ancestry(i).len() > 3
                && parts.node_of_key(n.key) == Some(i)
        })
        .collect();
    assert!(branches.len() >= 3, "{}", branches.len());
    let mut file = EditsFile::default();
    file.add("CalderTree", Target::Key(0x0bad_c0de), Op::Remove);
    let edit = &file.edits[0];
    for &b in &branches {
        let print = parts.print(b);
        assert_eq!(print.label.as_deref(), Some("branch"));
        let ancestry = print.ancestry.clone().expect("ancestry");
        assert_eq!(ancestry[0], "START", "{ancestry:?}");
        assert!(print.centre.is_some(), "a branch draws its bone");
        let c = candidates(&parts, edit, &print, 4);
        assert_eq!((c[0].node, c[0].reason), (b, Reason::Ancestry), "{c:?}");
        assert_eq!(c[0].target, Target::Key(tree.nodes[b as usize].key));
        // A chain of symbols no branch has: the nearest is still itself.
        let mut other = print.clone();
        other.ancestry = Some(vec!["leaf".into()]);
        let c = candidates(&parts, edit, &other, 4);
        assert!(c.iter().all(|x| x.reason == Reason::Nearest), "{c:?}");
        assert_eq!(c[0].node, b);
    }
}
