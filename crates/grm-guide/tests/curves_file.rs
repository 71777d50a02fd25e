//! The curves JSON format: the shipped examples load, defaults apply, and
//! every kind of error names the file, the curve and the field.

use std::path::PathBuf;

use glam::DVec3;
use grm_guide::{CurveParams, Curves, CurvesErrorKind, Location};

fn example(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../../examples")
        .join(name)
}

fn err(text: &str) -> String {
    match Curves::from_json_str("calder_tree.curves.json", text) {
        Ok(c) => panic!("expected an error, got {c:?}"),
        Err(e) => e.to_string(),
    }
}

/// A valid three-curve file with `curve1` spliced in as the second curve.
fn with_second_curve(curve1: &str) -> String {
    format!(
        r#"{{
  "version": 1,
  "curves": [
    {{ "name": "trunk", "points": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]] }},
    {curve1},
    {{ "name": "right", "points": [[0,2,0],[1,2.5,0],[2,3,0],[3,3,0]] }}
  ]
}}"#
    )
}

#[test]
fn calder_tree_example_loads_with_defaults_applied() {
    let c = Curves::load(example("calder_tree.curves.json")).expect("example loads");
    let names: Vec<_> = c.curves().iter().map(|c| c.name.as_deref()).collect();
    assert_eq!(names, [Some("trunk"), Some("left_arm"), Some("right_arm")]);
    // The trunk rises from the origin; the arms leave it near its top, one
    // to each side.
    let trunk = c.curves()[0].bezier;
    assert_eq!(trunk.eval(0.0), DVec3::ZERO);
    assert_eq!(trunk.eval(1.0), DVec3::new(0.0, 4.0, 0.0));
    let left = c.curves()[1].bezier.eval(1.0);
    let right = c.curves()[2].bezier.eval(1.0);
    assert!(left.x < -2.0 && right.x > 2.0);
    for g in c.curves() {
        assert_eq!(
            g.params,
            CurveParams {
                distance: [0.0, 0.0, 100.0],
                alignment_scale: 400.0,
                alignment_offset: 0.6,
                utilization_scale: 100.0,
                segment_length: 0.2,
                thickness: 0.0,
            }
        );
    }
    assert_eq!(c.density(), None);
}

#[test]
fn vine_wall_example_loads() {
    let c = Curves::load(example("vine_wall.curves.json")).expect("example loads");
    assert_eq!(c.curves().len(), 3);
    assert_eq!(c.curves()[0].params.thickness, 0.15);
    assert_eq!(c.curves()[2].params.alignment_offset, 0.3);
}

#[test]
fn minimal_file_gets_calder_defaults_and_overrides_win() {
    let c = Curves::from_json_str(
        "t.json",
        r#"{ "version": 1,
             "defaults": { "alignment_scale": 300 },
             "density": { "radius": 0.25, "scale": 5 },
             "curves": [
               { "points": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]] },
               { "points": [[0,0,0],[1,1,0],[2,2,0],[3,3,1]], "alignment_scale": 10, "thickness": 0.5 }
             ] }"#,
    )
    .expect("valid");
    let p0 = c.curves()[0].params;
    assert_eq!(
        p0,
        CurveParams {
            alignment_scale: 300.0,
            ..CurveParams::default()
        }
    );
    // Calder's defaults.
    assert_eq!(p0.distance, [0.0, 0.0, 100.0]);
    assert_eq!(p0.alignment_offset, 0.6);
    assert_eq!(p0.segment_length, 0.2);
    assert_eq!(p0.utilization_scale, 0.0);
    assert_eq!(p0.thickness, 0.0);
    let p1 = c.curves()[1].params;
    assert_eq!(p1.alignment_scale, 10.0);
    assert_eq!(p1.thickness, 0.5);
    assert_eq!(c.curves()[0].name, None);
    let d = c.density().expect("density given");
    assert_eq!((d.radius, d.scale), (0.25, 5.0));
}

#[test]
fn canonical_json_round_trips() {
    let c = Curves::load(example("calder_tree.curves.json")).expect("example loads");
    let text = c.to_json_string();
    let back = Curves::from_json_str(c.source(), &text).expect("canonical text loads");
    assert_eq!(back, c);
    let d = Curves::from_json_str(
        "d.json",
        r#"{"version":1,"density":{"radius":0.3,"scale":2},"curves":[{"points":[[0,0,0],[0.1,1,0],[0,2,0.5],[0,3,0]]}]}"#,
    )
    .expect("valid");
    assert_eq!(
        Curves::from_json_str("d.json", &d.to_json_string()).expect("reloads"),
        d
    );
}

#[test]
fn field_errors_name_file_curve_and_field() {
    let cases: &[(&str, &str)] = &[
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "alignment_offset": 1.5 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): alignment_offset 1.5 is outside [-1, 1]"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0]] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): points has 3 points; a cubic Bezier needs exactly 4 control points"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5],[-2,3,0],[-3,3,0]] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): points[1] has 2 coordinates; expected 3 [x, y, z]"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,"3",0],[-3,3,0]] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): points[2][1] is a string; expected a number"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "alignmnet_scale": 3 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): alignmnet_scale is not a known curve key (expected name, points, or a parameter)"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "segment_length": 0 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): segment_length 0 must be a finite number > 0"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "alignment_scale": -1 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): alignment_scale -1 must be a finite number >= 0"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "thickness": -0.1 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): thickness -0.1 must be a finite number >= 0"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "utilization_scale": -5 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): utilization_scale -5 must be a finite number >= 0"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "distance": [0, 100] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): distance has 2 coefficients; expected 3 [m0, m1, m2]"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "distance": [0, 0, -100] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): distance[2] -100 is negative (it would reward bones for leaving the curve)"#,
        ),
        (
            r#"{ "name": "left", "points": [[1,1,1],[1,1,1],[1,1,1],[1,1,1]] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): points make a curve of zero length (all control points coincide)"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "segment_length": 0.0001 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): segment_length 0.0001 splits the curve (length 3.191) into 31914 segments; at most 2048 are allowed"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,1e9,0],[-3,3,0]] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): points[2] [-2, 1e9, 0] has a coordinate beyond ±1e6 (models are built in single precision)"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,1e300,0],[-3,3,0]] }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): points[2] [-2, 1e300, 0] has a coordinate beyond ±1e6 (models are built in single precision)"#,
        ),
        (
            r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "segment_length": 1e-300 }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): segment_length 1e-300 splits the curve (length 3.191) into more than a billion segments; at most 2048 are allowed"#,
        ),
        (
            r#"{ "name": "trunk", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]] }"#,
            r#"calder_tree.curves.json: curve 1 ("trunk"): name "trunk" is already used by curve 0"#,
        ),
        (
            r#"{ "name": 7, "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]] }"#,
            r#"calder_tree.curves.json: curve 1: name is a number; expected a string"#,
        ),
        (
            r#"{ "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "alignment_offset": -2 }"#,
            r#"calder_tree.curves.json: curve 1: alignment_offset -2 is outside [-1, 1]"#,
        ),
        (
            r#"{ "name": "left" }"#,
            r#"calder_tree.curves.json: curve 1 ("left"): points is missing (four control points [x, y, z])"#,
        ),
        (
            r#"[0, 1]"#,
            r#"calder_tree.curves.json: curve 1: (curve) is an array; expected an object"#,
        ),
    ];
    for (curve, want) in cases {
        assert_eq!(err(&with_second_curve(curve)), *want, "for curve {curve}");
    }
}

#[test]
fn file_level_errors() {
    let cases: &[(&str, &str)] = &[
        (
            r#"{ "curves": [] }"#,
            "calder_tree.curves.json: version is missing (expected 1)",
        ),
        (
            r#"{ "version": 2, "curves": [] }"#,
            "calder_tree.curves.json: version 2 is not supported (this grm reads version 1)",
        ),
        (
            r#"{ "version": "1", "curves": [] }"#,
            r#"calder_tree.curves.json: version is a string; expected the integer 1"#,
        ),
        (
            r#"{ "version": 1.0, "curves": [] }"#,
            "calder_tree.curves.json: version 1.0 must be written as the integer 1",
        ),
        (
            r#"{ "version": 1, "curves": [] }"#,
            "calder_tree.curves.json: curves is empty (at least one curve is needed)",
        ),
        (
            r#"{ "version": 1 }"#,
            "calder_tree.curves.json: curves is missing",
        ),
        (
            r#"{ "version": 1, "curves": {} }"#,
            "calder_tree.curves.json: curves is an object; expected an array of curves",
        ),
        (
            r#"{ "version": 1, "curve": [] }"#,
            "calder_tree.curves.json: curve is not a known key (expected version, defaults, density, curves)",
        ),
        (
            r#"[1, 2]"#,
            r#"calder_tree.curves.json: (document) is an array; expected an object with "version" and "curves""#,
        ),
        (
            r#"{ "version": 1, "defaults": { "alignment_offset": 3 }, "curves": [] }"#,
            "calder_tree.curves.json: defaults: alignment_offset 3 is outside [-1, 1]",
        ),
        (
            r#"{ "version": 1, "defaults": { "offset": 3 }, "curves": [] }"#,
            "calder_tree.curves.json: defaults: offset is not a known parameter (expected one of distance, alignment_scale, alignment_offset, utilization_scale, segment_length, thickness)",
        ),
        (
            r#"{ "version": 1, "density": { "radius": 0, "scale": 1 }, "curves": [{ "points": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]] }] }"#,
            "calder_tree.curves.json: density: radius 0 must be a finite number > 0",
        ),
        (
            r#"{ "version": 1, "density": { "radius": 0.2 }, "curves": [] }"#,
            "calder_tree.curves.json: density: scale is missing",
        ),
    ];
    for (text, want) in cases {
        assert_eq!(err(text), *want, "for {text}");
    }
}

#[test]
fn defaults_apply_to_errors_of_curves_that_inherit_them() {
    // The default is in range but this curve overrides it out of range.
    let text = r#"{ "version": 1, "defaults": { "alignment_offset": 0.5 },
        "curves": [ { "name": "a", "points": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]], "alignment_offset": 1.01 } ] }"#;
    assert_eq!(
        err(text),
        r#"calder_tree.curves.json: curve 0 ("a"): alignment_offset 1.01 is outside [-1, 1]"#
    );
}

#[test]
fn syntax_errors_have_line_and_column() {
    let text = "{\n  \"version\": 1,\n  \"curves\": [\n    { \"points\": [[0,0,0],, }\n  ]\n}\n";
    let e = Curves::from_json_str("calder_tree.curves.json", text).unwrap_err();
    match &e.kind {
        CurvesErrorKind::Syntax { line, column, .. } => {
            assert_eq!((*line, *column), (4, 26));
        }
        other => panic!("expected a syntax error, got {other:?}"),
    }
    assert_eq!(
        e.to_string(),
        "calder_tree.curves.json:4:26: invalid JSON: expected value"
    );
    // Trailing garbage, and a number too large for f64.
    assert!(err("{ \"version\": 1 } x").starts_with("calder_tree.curves.json:1:18: invalid JSON:"));
    let big = err("{ \"version\": 1e999 }");
    assert!(big.starts_with("calder_tree.curves.json:1:"), "{big}");
    assert!(big.contains("invalid JSON: number out of range"), "{big}");
    // A file cut short after a line break: serde_json says column 0; the
    // column is 1-based like every other.
    let cut = err("{\n  \"version\": 1,\n");
    assert!(
        cut.starts_with("calder_tree.curves.json:3:1: invalid JSON: EOF"),
        "{cut}"
    );
}

#[test]
fn structured_error_location() {
    let e = Curves::from_json_str(
        "f.json",
        &with_second_curve(r#"{ "name": "left", "points": [[0,2,0],[-1,2.5,0],[-2,3,0],[-3,3,0]], "alignment_offset": 1.5 }"#),
    )
    .unwrap_err();
    assert_eq!(e.file, "f.json");
    match e.kind {
        CurvesErrorKind::Field { at, field, .. } => {
            assert_eq!(
                at,
                Location::Curve {
                    index: 1,
                    name: Some("left".into())
                }
            );
            assert_eq!(field, "alignment_offset");
        }
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn missing_file_is_an_io_error_naming_the_path() {
    let e = Curves::load("no/such/dir/x.curves.json").unwrap_err();
    assert!(matches!(e.kind, CurvesErrorKind::Io(_)));
    assert!(
        e.to_string()
            .starts_with("no/such/dir/x.curves.json: cannot read: ")
    );
}

/// Each kind of curves error has its code (R0501 to R0504), and its
/// diagnostic keeps the message and points where it is told to.
#[test]
fn curves_errors_have_codes() {
    use grm_diag::{Code, FileId, Span};
    let io = Curves::load("no/such/dir/x.curves.json").unwrap_err();
    let syntax = Curves::from_json_str("f.json", "{ \"version\": 1 } x").unwrap_err();
    let version =
        Curves::from_json_str("f.json", "{ \"version\": 2, \"curves\": [] }").unwrap_err();
    let field = Curves::from_json_str("f.json", "{ \"version\": 1 }").unwrap_err();
    for (e, code) in [
        (io, Code::CurvesIo),
        (syntax, Code::CurvesSyntax),
        (version, Code::CurvesVersion),
        (field, Code::CurvesField),
    ] {
        assert_eq!(e.code(), code, "{e}");
        let d = e.to_diagnostic(FileId(1), Span::new(2, 3));
        assert_eq!(d.code, code);
        assert_eq!(d.message, e.to_string());
        assert_eq!(
            (d.primary().file, d.primary().span),
            (FileId(1), Span::new(2, 3))
        );
        assert!(d.help.is_some());
    }
}

#[test]
fn a_key_given_twice_is_an_error_with_its_position() {
    let text = "{ \"version\": 1, \"curves\": [ { \"points\": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]],\n  \"alignment_scale\": 1, \"alignment_scale\": 400 } ] }";
    let e = Curves::from_json_str("v.json", text).unwrap_err();
    assert!(
        matches!(e.kind, CurvesErrorKind::Syntax { line: 2, .. }),
        "{e:?}"
    );
    assert!(
        e.to_string()
            .contains("the key \"alignment_scale\" is given twice"),
        "{e}"
    );
}

#[test]
fn a_byte_order_mark_is_accepted() {
    let text = "\u{feff}{ \"version\": 1, \"curves\": [ { \"points\": [[0,0,0],[0,1,0],[0,2,0],[0,3,0]] } ] }";
    let c = Curves::from_json_str("bom.json", text).expect("a BOM is not an error");
    assert_eq!(c.curves().len(), 1);
}
