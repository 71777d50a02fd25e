//! Turtle tests against hand-computed positions. Strings are built with
//! `ModuleString::push` over a fixed symbol table (no checker needed).

use glam::Vec3;
use grm_derive::ModuleString;
use grm_sema::{MaterialId, MeshId, Terminal};
use grm_turtle::{
    InstanceKind, Interpretation, Interpreter, Paint, Turtle, TurtleConfig, TurtleError,
};

/// Symbol table of the tests: terminals in this order, then users `A`, `B`.
const TABLE: &[(&str, Option<Terminal>)] = &[
    ("F", Some(Terminal::Forward)),
    ("f", Some(Terminal::Move)),
    ("G", Some(Terminal::ForwardNoVertex)),
    ("g", Some(Terminal::MoveNoVertex)),
    ("+", Some(Terminal::TurnLeft)),
    ("-", Some(Terminal::TurnRight)),
    ("&", Some(Terminal::PitchDown)),
    ("^", Some(Terminal::PitchUp)),
    ("\\", Some(Terminal::RollLeft)),
    ("/", Some(Terminal::RollRight)),
    ("|", Some(Terminal::TurnAround)),
    ("$", Some(Terminal::RollHorizontal)),
    ("[", Some(Terminal::Push)),
    ("]", Some(Terminal::Pop)),
    ("!", Some(Terminal::SetWidth)),
    ("!!", Some(Terminal::ShrinkWidth)),
    ("'", Some(Terminal::SetColor)),
    ("''", Some(Terminal::NextColor)),
    ("{", Some(Terminal::PolygonStart)),
    (".", Some(Terminal::PolygonVertex)),
    ("}", Some(Terminal::PolygonEnd)),
    ("%", Some(Terminal::Cut)),
    ("translate", Some(Terminal::Translate)),
    ("rotate", Some(Terminal::Rotate)),
    ("rotx", Some(Terminal::RotX)),
    ("roty", Some(Terminal::RotY)),
    ("rotz", Some(Terminal::RotZ)),
    ("scale", Some(Terminal::ScaleUniform)),
    ("scale3", Some(Terminal::Scale)),
    ("cylinder", Some(Terminal::Cylinder)),
    ("cone", Some(Terminal::Cone)),
    ("sphere", Some(Terminal::Sphere)),
    ("box", Some(Terminal::Box)),
    ("disc", Some(Terminal::Disc)),
    ("mesh", Some(Terminal::Mesh)),
    ("material", Some(Terminal::Material)),
    ("color", Some(Terminal::Color)),
    ("A", None),
    ("B", None),
];

fn sym(name: &str) -> u32 {
    TABLE
        .iter()
        .position(|(n, _)| *n == name)
        .unwrap_or_else(|| panic!("no test symbol {name}")) as u32
}

/// Parse `F(2) + F [ - F ]`: space-separated modules, optional
/// comma-separated float arguments. Arguments are passed as written (no
/// defaults filled in), which exercises the turtle's own defaults.
fn string(text: &str) -> ModuleString {
    let mut s = ModuleString::new();
    for tok in text.split_whitespace() {
        let (name, args) = match tok.find('(') {
            Some(i) if i > 0 => {
                let inner = tok[i + 1..].trim_end_matches(')');
                let args: Vec<f32> = inner
                    .split(',')
                    .map(|a| a.parse().expect("number"))
                    .collect();
                (&tok[..i], args)
            }
            _ => (tok, Vec::new()),
        };
        s.push(sym(name), &args);
    }
    s
}

fn cfg() -> TurtleConfig {
    TurtleConfig {
        angle: 90.0,
        step: 1.0,
        width: 0.1,
        tropism: None,
        elasticity: 0.0,
    }
}

fn interpreter(cfg: TurtleConfig) -> Interpreter {
    Interpreter::from_parts(TABLE.iter().map(|(_, t)| *t).collect(), cfg)
}

fn run_with(cfg: TurtleConfig, text: &str) -> (Interpretation, Turtle) {
    let mut it = interpreter(cfg);
    let end = it.run(&string(text)).expect("interprets");
    (it.finish(), end)
}

fn run(text: &str) -> Interpretation {
    run_with(cfg(), text).0
}

#[track_caller]
fn close(a: Vec3, b: Vec3) {
    assert!(a.distance(b) < 1e-5, "{a} != {b}");
}

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

#[test]
fn initial_frame() {
    let t = Turtle::new(&cfg());
    close(t.position(), Vec3::ZERO);
    close(t.heading(), Vec3::Y);
    close(t.left(), Vec3::X);
    close(t.up(), -Vec3::Z);
    // H x L = U.
    close(t.heading().cross(t.left()), t.up());
}

#[test]
fn forward_turn_forward() {
    let out = run("F + F");
    assert_eq!(out.bones.len(), 2);
    close(out.bones[0].base, v(0.0, 0.0, 0.0));
    close(out.bones[0].tip, v(0.0, 1.0, 0.0));
    close(out.bones[1].base, v(0.0, 1.0, 0.0));
    close(out.bones[1].tip, v(1.0, 1.0, 0.0));
    assert_eq!(out.bones[0].parent, None);
    assert_eq!(out.bones[1].parent, Some(0));
    assert_eq!(out.bones[1].module, 2);
    close(out.bounds.min, v(0.0, 0.0, 0.0));
    close(out.bounds.max, v(1.0, 1.0, 0.0));

    let out = run("F - F");
    close(out.bones[1].tip, v(-1.0, 1.0, 0.0));
    // Explicit angle and length.
    let out = run("F(2) +(45) F(1)");
    let s = 0.5f32.sqrt();
    close(out.bones[1].tip, v(s, 2.0 + s, 0.0));
}

#[test]
fn pitch_roll_turnaround() {
    close(run("F & F").bones[1].tip, v(0.0, 1.0, 1.0));
    close(run("F ^ F").bones[1].tip, v(0.0, 1.0, -1.0));
    // Roll 90 about H moves L from +X to -Z; a left turn then heads along -Z.
    close(run("\\ + F").bones[0].tip, v(0.0, 0.0, -1.0));
    close(run("/ + F").bones[0].tip, v(0.0, 0.0, 1.0));
    let out = run("F | F");
    close(out.bones[1].tip, Vec3::ZERO);
    // Koch square: four sides and back to the start.
    let out = run("F - F - F - F");
    close(out.bones[3].tip, Vec3::ZERO);
    close(out.bounds.min, v(-1.0, 0.0, 0.0));
}

#[test]
fn roll_horizontal() {
    let (_, t) = run_with(cfg(), "+(30) &(40) /(25) $");
    let before = run_with(cfg(), "+(30) &(40) /(25)").1;
    close(t.heading(), before.heading());
    assert!(t.left().y.abs() < 1e-6, "L not horizontal: {}", t.left());
    close(t.heading().cross(t.left()), t.up());
}

#[test]
fn push_pop_parents() {
    let out = run("F [ + F ] F");
    assert_eq!(out.bones.len(), 3);
    close(out.bones[1].tip, v(1.0, 1.0, 0.0));
    assert_eq!(out.bones[1].parent, Some(0));
    close(out.bones[2].base, v(0.0, 1.0, 0.0));
    close(out.bones[2].tip, v(0.0, 2.0, 0.0));
    assert_eq!(out.bones[2].parent, Some(0));
    // Width and colour are restored too.
    let out = run("[ !(0.5) '(2) F ] F");
    assert_eq!(out.bones[0].width_base, 0.5);
    assert_eq!(out.bones[0].paint, Paint::Palette(2));
    assert!((out.bones[1].width_base - 0.1).abs() < 1e-7);
    assert_eq!(out.bones[1].paint, Paint::Palette(0));
}

#[test]
fn cut_skips_to_branch_end() {
    let out = run("F [ + F % F [ F ] F ] F");
    assert_eq!(out.bones.len(), 3);
    close(out.bones[1].tip, v(1.0, 1.0, 0.0));
    close(out.bones[2].tip, v(0.0, 2.0, 0.0));
    // At top level a cut erases the rest of the string.
    assert_eq!(run("F % F F").bones.len(), 1);
}

#[test]
fn tropism_bends_towards_t() {
    let mut c = cfg();
    c.tropism = Some(Vec3::X);
    c.elasticity = 0.5;
    let out = run_with(c, "F F").0;
    // After the first F, H = +Y is rotated towards +X by 0.5 * |Y x X| = 0.5 rad.
    close(out.bones[0].tip, v(0.0, 1.0, 0.0));
    close(
        out.bones[1].tip,
        v(0.0, 1.0, 0.0) + v(0.5f32.sin(), 0.5f32.cos(), 0.0),
    );
    // Parallel to T: no bending.
    c.tropism = Some(Vec3::Y);
    let out = run_with(c, "F F").0;
    close(out.bones[1].tip, v(0.0, 2.0, 0.0));
    // From settings: no tropism without elasticity.
    let s = grm_sema::Settings {
        tropism: Some([1.0, 0.0, 0.0]),
        ..Default::default()
    };
    assert_eq!(TurtleConfig::from_settings(&s).tropism, None);
}

#[test]
fn scale_and_transforms() {
    let out = run("scale(2) F");
    close(out.bones[0].tip, v(0.0, 2.0, 0.0));
    assert!((out.bones[0].width_base - 0.2).abs() < 1e-6);
    // Non-uniform: length scales by y, width by the mean of x and z.
    let out = run("scale3(1,3,2) F");
    close(out.bones[0].tip, v(0.0, 3.0, 0.0));
    assert!((out.bones[0].width_base - 0.15).abs() < 1e-6);
    // Right multiplication: rotate after scale keeps the scaled length.
    let out = run("scale(2) + F");
    close(out.bones[0].tip, v(2.0, 0.0, 0.0));
    // Translate is in turtle space.
    let out = run("+ translate(0,1,0) scale(0.5) translate(0,1,0) F");
    close(out.bones[0].base, v(1.5, 0.0, 0.0));
    close(out.bones[0].tip, v(2.0, 0.0, 0.0));
    // rotate(axis, a) is right-handed about a turtle-space axis.
    close(run("rotate(0,0,1,90) F").bones[0].tip, v(-1.0, 0.0, 0.0));
    close(run("rotz(-90) F").bones[0].tip, v(1.0, 0.0, 0.0));
    close(run("rotx(90) F").bones[0].tip, v(0.0, 0.0, 1.0));
    close(run("rotz(90) roty(90) F").bones[0].tip, v(-1.0, 0.0, 0.0));
    // Moves without drawing.
    let out = run("f F g G");
    assert_eq!(out.bones.len(), 2);
    close(out.bones[0].base, v(0.0, 1.0, 0.0));
    close(out.bones[1].tip, v(0.0, 4.0, 0.0));
    assert_eq!(out.bones[1].parent, Some(0));
}

#[test]
fn widths_and_paint() {
    let out = run("F !(0.5) F !! F");
    assert!((out.bones[0].width_base - 0.1).abs() < 1e-7);
    assert_eq!(out.bones[1].width_tip, 0.5);
    assert!((out.bones[2].width_tip - 0.35).abs() < 1e-6);
    let out = run("F '' F '(5) F color(1,0.5,2) F material(3) F '' F");
    let paints: Vec<Paint> = out.bones.iter().map(|b| b.paint).collect();
    assert_eq!(
        paints,
        vec![
            Paint::Palette(0),
            Paint::Palette(1),
            Paint::Palette(5),
            Paint::Rgb([1.0, 0.5, 1.0]),
            Paint::Material(MaterialId(3)),
            Paint::Palette(6),
        ]
    );
    // Negative width is clamped.
    assert_eq!(run("!(-1) F").bones[0].width_base, 0.0);
}

#[test]
fn polygons() {
    let out = run("{ . F . + F . + F . }");
    assert_eq!(out.polygons.len(), 1);
    let vs = out.vertices(&out.polygons[0]);
    assert_eq!(vs.len(), 4);
    close(vs[0], v(0.0, 0.0, 0.0));
    close(vs[1], v(0.0, 1.0, 0.0));
    close(vs[2], v(1.0, 1.0, 0.0));
    close(vs[3], v(1.0, 0.0, 0.0));
    // G records no vertex, and brackets share the open polygon (ABoP leaves).
    let out = run("{ . [ + G . ] [ G . ] [ - G . ] }");
    assert_eq!(out.polygons.len(), 1);
    assert_eq!(out.polygons[0].len, 4);
    assert_eq!(out.bones.len(), 3);
    // Nested polygons; degenerate and unclosed ones are dropped and counted.
    let out = run("{ . F { . + F . } . + F } { . F . } {");
    assert_eq!(out.polygons.len(), 1);
    assert_eq!(out.warnings.degenerate_polygons, 2);
    assert_eq!(out.warnings.unclosed_polygons, 1);
    assert_eq!(run("} F").warnings.unbalanced_polygon_ends, 1);
}

#[test]
fn instances() {
    let out = run("F cylinder(0.5,2) material(1) mesh(2) sphere(3) box(1,2,3) disc(2) cone(1,1)");
    assert_eq!(out.instances.len(), 6);
    let cyl = &out.instances[0];
    assert_eq!(cyl.kind, InstanceKind::Cylinder);
    assert_eq!(cyl.bone, Some(0));
    close(
        cyl.transform.transform_point3(v(0.0, 1.0, 0.0)),
        v(0.0, 3.0, 0.0),
    );
    close(
        cyl.transform.transform_point3(v(1.0, 0.0, 0.0)),
        v(0.5, 1.0, 0.0),
    );
    assert_eq!(out.instances[1].kind, InstanceKind::Mesh(MeshId(2)));
    assert_eq!(out.instances[1].paint, Paint::Material(MaterialId(1)));
    assert_eq!(out.instances[2].kind, InstanceKind::Sphere);
    // Bounds include the sphere of radius 3 at (0, 1, 0).
    close(out.bounds.min, v(-3.0, -2.0, -3.0));
    close(out.bounds.max, v(3.0, 4.0, 3.0));
    // Bad ids are ignored and counted.
    let out = run("mesh(-1) mesh(0.5) material(1e30)");
    assert!(out.instances.is_empty());
    assert_eq!(out.warnings.bad_ids, 3);
}

#[test]
fn robustness() {
    // Unbalanced pops are ignored.
    let out = run("F ] ] F");
    assert_eq!(out.bones.len(), 2);
    assert_eq!(out.warnings.unbalanced_pops, 2);
    // Non-finite moves drop bones, never panic.
    let out = run("F(1e38) scale(1e38) F(1e38) F");
    assert_eq!(out.bones.len(), 1);
    assert!(out.warnings.non_finite >= 1);
    // Unknown symbols and malformed strings are errors.
    let mut it = interpreter(cfg());
    let mut s = ModuleString::new();
    s.push(999, &[]);
    assert_eq!(
        it.run(&s),
        Err(TurtleError::UnknownSymbol {
            module: 0,
            symbol: 999
        })
    );
    let (syms, mut starts, params, keys) = string("F F").into_parts();
    starts[1] = 7;
    let bad = ModuleString::from_parts(syms, starts, params, keys);
    assert_eq!(it.run(&bad), Err(TurtleError::MalformedString));
    assert!(matches!(
        it.run_range(it.initial(), &string("F"), 0..2, &mut |_, _| {}),
        Err(TurtleError::BadRange { .. })
    ));
}

#[test]
fn run_range_and_user_modules() {
    // The sampler's use: interpret an expansion from a saved state and get
    // the state where each non-terminal in it sits. User modules do not
    // move the turtle.
    let mut it = interpreter(cfg());
    let s = string("F A + F [ B ] ]");
    let mut seen = Vec::new();
    let end = it
        .run_range(it.initial(), &s, 0..s.len(), &mut |i, t| {
            seen.push((i, t.position(), t.bone))
        })
        .expect("runs");
    assert_eq!(seen.len(), 2);
    assert_eq!(seen[0].0, 1);
    close(seen[0].1, v(0.0, 1.0, 0.0));
    assert_eq!(seen[0].2, Some(0));
    close(seen[1].1, v(1.0, 1.0, 0.0));
    assert_eq!(seen[1].2, Some(1));
    close(end.position(), v(1.0, 1.0, 0.0));
    // The stray `]` does not pop a state the caller pushed.
    assert_eq!(it.output().warnings.unbalanced_pops, 1);
    // Continue from a saved state: B's expansion `F` starts at B.
    let saved = {
        let mut st = it.initial();
        st.frame = glam::Affine3A::from_translation(seen[1].1);
        st.bone = seen[1].2;
        st
    };
    let exp = string("+ F");
    it.run_range(saved, &exp, 0..exp.len(), &mut |_, _| {})
        .expect("runs");
    let out = it.finish();
    let last = out.bones.last().expect("bone");
    close(last.base, v(1.0, 1.0, 0.0));
    close(last.tip, v(2.0, 1.0, 0.0));
    assert_eq!(last.parent, Some(1));
}

#[test]
fn fill_origins() {
    let mut out = run("F cylinder(1,1) { . F . F . }");
    out.fill_origins(&[10, 11, 12]);
    assert_eq!(out.bones[0].origin, 10);
    assert_eq!(out.instances[0].origin, 11);
    assert_eq!(out.bones[1].origin, grm_turtle::NO_ORIGIN);
}

/// A million modules: run with `--release -- --ignored` for the timing.
#[test]
#[ignore]
fn million_modules_timing() {
    let mut s = ModuleString::with_capacity(1_000_000, 1_000_000);
    let (f, plus, push, pop) = (sym("F"), sym("+"), sym("["), sym("]"));
    while s.len() < 1_000_000 {
        s.push(push, &[]);
        s.push(plus, &[25.0]);
        s.push(f, &[1.0]);
        s.push(pop, &[]);
        s.push(f, &[0.5]);
    }
    let mut c = cfg();
    c.tropism = Some(v(0.0, -1.0, 0.0));
    c.elasticity = 0.1;
    let t0 = std::time::Instant::now();
    let mut it = interpreter(c);
    it.run(&s).expect("runs");
    let out = it.finish();
    let dt = t0.elapsed();
    println!("{} modules, {} bones in {:?}", s.len(), out.bones.len(), dt);
    assert_eq!(out.bones.len(), 400_000);
}

#[test]
fn frame_locality_for_sample_expansions() {
    // Sample systems: `F A F` where A later expands to `+ F F`. A's
    // expansion starts from A's saved state and does not move the F after
    // A, whichever order the sampler expands things in.
    let mut it = interpreter(cfg());
    let top = string("F A F");
    let mut at_a = None;
    it.run_range(it.initial(), &top, 0..top.len(), &mut |_, t| {
        at_a = Some(*t)
    })
    .expect("runs");
    let at_a = at_a.expect("A seen");
    let expansion = string("+ F F");
    let end = it
        .run_range(at_a, &expansion, 0..expansion.len(), &mut |_, _| {})
        .expect("runs");
    close(end.position(), v(2.0, 1.0, 0.0));
    let out = it.finish();
    assert_eq!(out.bones.len(), 4);
    close(out.bones[1].base, v(0.0, 1.0, 0.0));
    close(out.bones[1].tip, v(0.0, 2.0, 0.0));
    close(out.bones[2].base, v(0.0, 1.0, 0.0));
    close(out.bones[3].tip, v(2.0, 1.0, 0.0));
    // The expansion hangs off the bone that was current at A.
    assert_eq!(out.bones[2].parent, Some(0));
}

/// A random run of turtle commands without brackets, cuts or polygons:
/// moves, turns, rolls, widths, colours and transforms with random
/// arguments (or their defaults).
fn random_commands(rng: &mut grm_testkit::Rng, n: usize) -> String {
    const PLAIN: &[&str] = &[
        "F", "f", "G", "g", "+", "-", "&", "^", "\\", "/", "|", "$", "!!", "''",
    ];
    let mut out = Vec::new();
    for _ in 0..n {
        let a = rng.range(-3.0, 3.0) as f32;
        let tok = match rng.below(10) {
            0 => format!("F({})", rng.range(0.1, 2.0) as f32),
            1 => format!("+({})", a * 30.0),
            2 => format!("&({})", a * 30.0),
            3 => format!("/({})", a * 30.0),
            4 => format!("!({})", rng.range(0.01, 0.5) as f32),
            5 => format!("'({})", rng.below(8)),
            6 => match rng.below(4) {
                0 => format!("translate({a},{},{})", a * 0.5, -a),
                1 => format!("rotx({})", a * 20.0),
                2 => format!("scale({})", rng.range(0.5, 1.5) as f32),
                _ => format!("rotate({},{},{},{})", 0.3, a, 1.0, a * 10.0),
            },
            _ => rng.pick(PLAIN).to_string(),
        };
        out.push(tok);
    }
    out.join(" ")
}

/// What a bone looks like, bit for bit, without its module index; its
/// parent mapped through `parent`.
fn bone_key(b: &grm_turtle::Bone, parent: impl Fn(u32) -> u32) -> String {
    format!(
        "{:?} {:?} {:?} {:?} {:?} {:?} {:?}",
        b.base.to_array().map(f32::to_bits),
        b.tip.to_array().map(f32::to_bits),
        b.left.to_array().map(f32::to_bits),
        b.width_base.to_bits(),
        b.width_tip.to_bits(),
        b.paint,
        b.parent.map(parent),
    )
}

/// A branch leaves the turtle as it found it: `S [ T ] U` draws the bones
/// of `S U`, bit for bit, with the branch's bones in between (parents
/// renumbered past them), on random command strings with and without
/// tropism; a cut `%` inside the branch changes only the branch.
#[test]
fn a_branch_leaves_the_turtle_as_it_found_it() {
    let mut rng = grm_testkit::Rng::seeded(0x7u64 << 40 | 0x0e71e);
    for case in 0..300 {
        let mut c = cfg();
        if case % 3 == 0 {
            c.tropism = Some(v(0.0, -1.0, 0.2));
            c.elasticity = 0.3;
        }
        let n = |rng: &mut grm_testkit::Rng| 1 + rng.below(12usize);
        let (ls, lt, lu) = (n(&mut rng), n(&mut rng), n(&mut rng));
        let s = random_commands(&mut rng, ls);
        let mut t = random_commands(&mut rng, lt);
        if rng.below(4) == 0 {
            // A nested branch, or a cut, inside the branch.
            let inner = random_commands(&mut rng, 3);
            t = if rng.below(2) == 0 {
                format!("{t} [ {inner} ] F")
            } else {
                format!("{t} % {inner}")
            };
        }
        let u = random_commands(&mut rng, lu);
        let plain = run_with(c, &format!("{s} {u}")).0;
        let branched = run_with(c, &format!("{s} [ {t} ] {u}")).0;
        let before = run_with(c, &s).0.bones.len();
        let inside = run_with(c, &format!("{s} [ {t} ]")).0.bones.len() - before;
        let what = format!("case {case}: {s} [ {t} ] {u}");
        assert_eq!(
            branched.bones.len(),
            plain.bones.len() + inside,
            "{what}: bone count"
        );
        let shift = |p: u32| {
            if (p as usize) < before {
                p
            } else {
                p + inside as u32
            }
        };
        for (k, b) in plain.bones.iter().enumerate() {
            let j = if k < before { k } else { k + inside };
            assert_eq!(
                bone_key(&branched.bones[j], |p| p),
                bone_key(b, shift),
                "{what}: bone {k}"
            );
        }
        assert_eq!(branched.warnings, plain.warnings, "{what}: warnings");
    }
}

/// A forest's interpretation: a second tree appended beside the first
/// keeps the first as it was and is the second moved, with its bone,
/// vertex and module indices shifted past what came before.
#[test]
fn append_translated_places_a_second_interpretation() {
    let first_text = "F [ + F ] sphere(1) { . F . + F . }";
    let second_text = "F + F [ - F ] cone(1,2) { . f . + f . + f . }";
    let a = run(first_text);
    let b = run(second_text);
    let modules_a = string(first_text).len() as u32;
    let offset = v(10.0, 0.0, -3.0);
    let mut m = a.clone();
    m.append_translated(&b, offset, modules_a).expect("fits");

    let (na, ni, np) = (a.bones.len(), a.instances.len(), a.polygons.len());
    assert!(na > 0 && ni > 0 && np > 0, "{a:?}");
    assert!(!b.bones.is_empty() && !b.instances.is_empty() && !b.polygons.is_empty());
    assert_eq!(m.bones.len(), na + b.bones.len());
    assert_eq!(m.instances.len(), ni + b.instances.len());
    assert_eq!(m.polygons.len(), np + b.polygons.len());
    assert_eq!(m.bones[..na], a.bones[..]);
    assert_eq!(m.instances[..ni], a.instances[..]);
    assert_eq!(m.polygons[..np], a.polygons[..]);
    for (got, want) in m.bones[na..].iter().zip(&b.bones) {
        close(got.base, want.base + offset);
        close(got.tip, want.tip + offset);
        close(got.left, want.left);
        assert_eq!(got.parent, want.parent.map(|p| p + na as u32));
        assert_eq!(got.module, want.module + modules_a);
        assert_eq!(got.width_base, want.width_base);
    }
    for (got, want) in m.instances[ni..].iter().zip(&b.instances) {
        close(
            Vec3::from(got.transform.translation),
            Vec3::from(want.transform.translation) + offset,
        );
        assert_eq!(got.transform.matrix3, want.transform.matrix3);
        assert_eq!(got.bone, want.bone.map(|p| p + na as u32));
        assert_eq!(got.module, want.module + modules_a);
    }
    for (got, want) in m.polygons[np..].iter().zip(&b.polygons) {
        let (gv, wv) = (m.vertices(got), b.vertices(want));
        assert_eq!(gv.len(), wv.len());
        assert!(gv.len() >= 3);
        for (g, w) in gv.iter().zip(wv) {
            close(*g, *w + offset);
        }
        assert_eq!(got.module, want.module + modules_a);
    }
    close(m.bounds.min, a.bounds.min.min(b.bounds.min + offset));
    close(m.bounds.max, a.bounds.max.max(b.bounds.max + offset));

    // A module index past 32 bits refuses and leaves the forest as it was.
    let before = m.clone();
    assert_eq!(m.append_translated(&b, offset, u32::MAX), None);
    assert_eq!(m, before);
}
