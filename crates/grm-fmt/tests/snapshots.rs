//! Before/after snapshots (insta): the input is the snapshot's description,
//! the formatted text its content. Review changes with `cargo insta review`.

mod common;

fn snap(name: &str, src: &str) {
    let out = common::check(src);
    insta::with_settings!({ description => src, omit_expression => true }, {
        insta::assert_snapshot!(name, out);
    });
}

#[test]
fn messy_plant() {
    snap(
        "messy_plant",
        r#"// A plant, typed in a hurry.
param delta=22.5 in 5..45;const LEN=1;
system Plant{iterations=4;angle=delta;axiom X;
X->F[+X]F[-X]+X;  F->F F;
F(l):l>1->F(l*0.5)F(l*0.5);}
"#,
    );
}

#[test]
fn comments_everywhere() {
    snap(
        "comments_everywhere",
        r#"/* File header,
   two lines. */
import "common.grm"; // shared constants
// The tree.
system Tree { // derive mode
    iterations = 5;   // five steps
    /* before the axiom */ axiom A;



    // A grows.
    A -> F /* the stem */ [ + A ] // left
         [ - A ]              // right
         F A;
    /* dangling at the end */
} // after the system
// end of file
"#,
    );
}

#[test]
fn guided_system() {
    snap(
        "guided_system",
        r#"mesh leafMesh="leaf.obj";
material foliage{color=rgb(0.3,0.55,0.2);roughness=0.6;}
system Tree{mode=sample;axiom branch;skeleton branch,branchOrLeaf,maybeBranch;geometry leaf;
branch->scale(uniform(0.9,1.3)) roty(uniform(0,360))
  F(1) branchOrLeaf;
branchOrLeaf->(1)leaf;branchOrLeaf->(4)branch maybeBranch maybeBranch;
maybeBranch->(1)branch;maybeBranch->(1);
wrapup branch->leaf;wrapup branchOrLeaf->leaf;wrapup maybeBranch->leaf;
leaf->material(foliage)mesh(leafMesh);}
"#,
    );
}

#[test]
fn contexts_and_turtle_symbols() {
    snap(
        "contexts_and_turtle_symbols",
        r#"system Hogeweg{iterations=30;angle=22.5;ignore +-F;axiom F b F b F b;
a<a>b->b[+F b F b];b<a>b->b F b;+->-;-->+;
A->B-F+C F C+F-D&F^D-F+&&C F C+F+B/ /;
P->{.f.f.}$|%;
C(x)<D(y)>[E]G:x+y>=2&&!(x==y)->(if x>y then 2 else 1)D(x-y);}
"#,
    );
}
