//! Specs: absurd values refused with their body, key and line; every bound's edge; the
//! edges simulate.

use std::path::Path;

use ragdoll::Error;
use ragdoll::skeleton::Character;
use ragdoll::spec::{self, JointKind, RagdollSpec, Shape};

use super::{BACKENDS, humanoid_spec, pair, past, run_finite, world_with};

// --- Specs: absurd values, with the body and key named ------------------------------------

/// Each absurd value of the humanoid's spec, refused by `validate` with the body or joint
/// and the key named, and by `from_toml` at the line of that key.
#[test]
fn absurd_spec_values_are_refused_with_their_place_and_line() {
    type Edit = Box<dyn Fn(&mut RagdollSpec)>;
    let thigh = |s: &RagdollSpec| s.body_index("thigh_l").unwrap();
    let cases: Vec<(Edit, &str, &str, &str)> = vec![
        (
            Box::new(move |s| {
                let i = thigh(s);
                s.bodies[i].shape = Shape::Capsule {
                    radius_m: 0.05,
                    length_m: 1e30,
                };
            }),
            "body \"thigh_l\".shape.length_m",
            "length_m",
            "100 m",
        ),
        (
            Box::new(move |s| {
                let i = thigh(s);
                s.bodies[i].shape = Shape::Capsule {
                    radius_m: 0.05,
                    length_m: 1e20,
                };
            }),
            "body \"thigh_l\".shape.length_m",
            "length_m",
            "1e20",
        ),
        (
            Box::new(move |s| {
                let i = thigh(s);
                s.bodies[i].shape = Shape::Box {
                    size_m: [1e30, 1.0, 1.0],
                };
            }),
            "body \"thigh_l\".shape.size_m",
            "size_m",
            "100 m",
        ),
        (
            Box::new(move |s| {
                let i = thigh(s);
                s.bodies[i].shape = Shape::Capsule {
                    radius_m: 1e-5,
                    length_m: 0.3,
                };
            }),
            "body \"thigh_l\".shape.radius_m",
            "radius_m",
            "0.001",
        ),
        (
            Box::new(move |s| {
                let i = thigh(s);
                s.bodies[i].mass_kg = 1e30;
            }),
            "body \"thigh_l\".mass_kg",
            "mass_kg",
            "1e8",
        ),
        (
            Box::new(move |s| {
                let i = thigh(s);
                s.bodies[i].center_m = [0.0, 4_294_967_296.0, 0.0];
            }),
            "body \"thigh_l\".center_m",
            "center_m",
            "1000 m",
        ),
        (
            Box::new(move |s| {
                let i = thigh(s);
                s.bodies[i].rotation = [0.0, 0.0, 0.0, 2.0];
            }),
            "body \"thigh_l\".rotation",
            "rotation",
            "unit quaternion",
        ),
        (
            Box::new(|s| {
                let j = s.joints.iter().position(|j| j.name == "shin_l").unwrap();
                s.joints[j].kind = JointKind::Hinge {
                    min_deg: 0.0,
                    max_deg: 1e9,
                };
            }),
            "joint \"shin_l\".max_deg",
            "max_deg",
            "190",
        ),
        (
            Box::new(|s| {
                let j = s.joints.iter().position(|j| j.name == "shin_l").unwrap();
                s.joints[j].kind = JointKind::Hinge {
                    min_deg: 90.0,
                    max_deg: 10.0,
                };
            }),
            "joint \"shin_l\".min_deg",
            "min_deg",
            "from min to max",
        ),
        (
            Box::new(|s| {
                let j = s.joints.iter().position(|j| j.name == "thigh_l").unwrap();
                s.joints[j].anchor_m = [1e6, 0.0, 0.0];
            }),
            "joint \"thigh_l\".anchor_m",
            "anchor_m",
            "1000 m",
        ),
        (
            Box::new(|s| {
                let j = s.joints.iter().position(|j| j.name == "thigh_l").unwrap();
                s.joints[j].frame = [0.0; 4];
            }),
            "joint \"thigh_l\".frame",
            "frame",
            "unit quaternion",
        ),
        (
            Box::new(|s| {
                let j = s.joints.iter().position(|j| j.name == "thigh_l").unwrap();
                if let JointKind::SwingTwist { swing_deg, .. } = &mut s.joints[j].kind {
                    *swing_deg = 500.0;
                }
            }),
            "joint \"thigh_l\".swing_deg",
            "swing_deg",
            "180",
        ),
        (
            Box::new(|s| {
                let j = s.joints.iter().position(|j| j.name == "thigh_l").unwrap();
                s.joints[j].parent = "nobody".into();
            }),
            "joint \"thigh_l\".parent",
            "parent",
            "nobody",
        ),
    ];
    for (edit, place, key, bound) in cases {
        let mut s = humanoid_spec();
        edit(&mut s);
        let err = s.validate().unwrap_err().to_string();
        assert!(err.contains(place), "{err} lacks {place}");
        assert!(err.contains(bound), "{err} lacks the bound {bound}");
        // The same through a file, at the line of the key.
        let text = s.to_toml();
        let (line, message) = spec_failure(&text);
        assert!(message.contains(place), "{message}");
        let want = key_line(&text, place, key);
        assert_eq!(line, want, "{message}");
    }
}

/// The line of `key` in the table of the body or joint `place` names.
fn key_line(text: &str, place: &str, key: &str) -> usize {
    let name = place.split('"').nth(1).unwrap();
    let header = if place.starts_with("body") {
        "[[bodies]]"
    } else {
        "[[joints]]"
    };
    let lines: Vec<&str> = text.lines().collect();
    let table = lines
        .iter()
        .enumerate()
        .position(|(i, l)| {
            *l == header
                && lines[i + 1..]
                    .iter()
                    .find(|l| l.starts_with("name = "))
                    .copied()
                    == Some(format!("name = \"{name}\"").as_str())
        })
        .unwrap();
    table
        + 1
        + lines[table..]
            .iter()
            .position(|l| l.starts_with(&format!("{key} =")))
            .unwrap()
}

/// A spec text's error as (line, message).
fn spec_failure(text: &str) -> (usize, String) {
    match RagdollSpec::from_toml(text, Path::new("s.toml")) {
        Err(Error::Parse { line, message, .. }) => (line, message),
        other => panic!("expected an error with a line, got {other:?}"),
    }
}

/// Keys at several places of a file: one line counter, the right line each time.
#[test]
fn spec_errors_give_the_line_of_the_key_wherever_it_is() {
    let text = humanoid_spec().to_toml();
    let insert_after = |text: &str, marker: &str, extra: &str| -> (String, usize) {
        let at = text.find(marker).unwrap() + marker.len();
        let line = text[..at].matches('\n').count() + 2;
        (format!("{}\n{extra}{}", &text[..at], &text[at..]), line)
    };
    let cases = [
        ("format_version = 1", "bogus = 3", "bogus"),
        ("[[bodies]]\nname = \"thigh_l\"", "colour = 3", "colour"),
        ("kind = \"capsule\"", "height_m = 2", "height_m"),
        ("[[joints]]\nname = \"shin_r\"", "max_degs = 3", "max_degs"),
        ("[collision]", "enabled = true", "enabled"),
    ];
    for (marker, extra, key) in cases {
        let (bad, line) = insert_after(&text, marker, extra);
        let (got, message) = spec_failure(&bad);
        assert!(message.contains(key), "{message}");
        assert_eq!(got, line, "{key}: {message}");
        assert_eq!(bad.lines().nth(line - 1), Some(extra));
    }
    // A syntax error on line 2, and a disabled pair naming no body at its own line.
    assert_eq!(spec_failure("format_version = 1\nname = \n").0, 2);
    let mut s = humanoid_spec();
    s.collision
        .disabled_pairs
        .push(["pelvis".into(), "tail".into()]);
    let text = s.to_toml();
    let (line, message) = spec_failure(&text);
    assert!(message.contains("collision.disabled_pairs") && message.contains("tail"));
    let tail = text.lines().position(|l| l.contains("\"tail\"")).unwrap() + 1;
    assert!(
        line < tail && tail - line <= 3,
        "line {line}, the pair's name on {tail}"
    );
}

/// Counts: bodies, joints and pairs past their bound, and the format version.
#[test]
fn spec_counts_and_version_are_bounded() {
    let mut s = humanoid_spec();
    let body = s.bodies[1].clone();
    for k in s.bodies.len()..=spec::MAX_BODIES {
        let mut b = body.clone();
        b.name = format!("extra{k}");
        s.bodies.push(b);
    }
    let err = s.validate().unwrap_err().to_string();
    assert!(err.contains("bodies") && err.contains("512"), "{err}");
    s.bodies.truncate(spec::MAX_BODIES);
    s.validate().unwrap();

    let mut s = humanoid_spec();
    s.format_version = 99;
    assert!(
        s.validate()
            .unwrap_err()
            .to_string()
            .contains("format_version")
    );

    let mut s = humanoid_spec();
    s.name = "x".repeat(spec::MAX_NAME_BYTES);
    s.validate().unwrap();
    s.name.push('x');
    assert!(s.validate().unwrap_err().to_string().contains("256"));
}

// --- Specs: every bound's edge ------------------------------------------------------------

/// Each shape, mass, offset and angle bound: accepted at its edge, refused just past it.
#[test]
fn every_spec_bound_accepts_its_edge_and_refuses_past_it() {
    type Set = fn(&mut RagdollSpec, f32);
    fn capsule(s: &mut RagdollSpec, r: f32, l: f32) {
        for b in &mut s.bodies {
            b.shape = Shape::Capsule {
                radius_m: r,
                length_m: l,
            };
        }
    }
    fn hinge(s: &mut RagdollSpec, lo: f32, hi: f32) {
        s.joints[0].kind = JointKind::Hinge {
            min_deg: lo,
            max_deg: hi,
        };
    }
    fn twist(s: &mut RagdollSpec, swing: f32, tilt: f32) {
        s.joints[0].kind = JointKind::SwingTwist {
            swing_deg: swing,
            twist_deg: [-30.0, 30.0],
            cone_tilt_deg: [tilt, 0.0],
        };
    }
    let edges: Vec<(&str, Set, f32)> = vec![
        ("radius max", |s, v| capsule(s, v, 0.1), spec::MAX_SHAPE_M),
        ("radius min", |s, v| capsule(s, v, 0.1), spec::MIN_SHAPE_M),
        ("length max", |s, v| capsule(s, 0.1, v), spec::MAX_SHAPE_M),
        ("length min", |s, v| capsule(s, 0.1, v), 0.0),
        (
            "box max",
            |s, v| {
                s.bodies[0].shape = Shape::Box {
                    size_m: [v, 1.0, 1.0],
                }
            },
            spec::MAX_SHAPE_M,
        ),
        (
            "box min",
            |s, v| {
                s.bodies[0].shape = Shape::Box {
                    size_m: [1.0, v, 1.0],
                }
            },
            spec::MIN_SHAPE_M,
        ),
        (
            "mass max",
            |s, v| s.bodies.iter_mut().for_each(|b| b.mass_kg = v),
            spec::MAX_BODY_KG,
        ),
        (
            "mass min",
            |s, v| s.bodies.iter_mut().for_each(|b| b.mass_kg = v),
            spec::MIN_BODY_KG,
        ),
        (
            "centre",
            |s, v| s.bodies[0].center_m = [0.0, 0.0, v],
            spec::MAX_OFFSET_M,
        ),
        (
            "centre negative",
            |s, v| s.bodies[0].center_m = [v, 0.0, 0.0],
            -spec::MAX_OFFSET_M,
        ),
        (
            "anchor",
            |s, v| s.joints[0].anchor_m = [0.0, v, 0.0],
            spec::MAX_OFFSET_M,
        ),
        (
            "jointed mass ratio",
            |s, v| s.bodies[1].mass_kg = s.bodies[0].mass_kg * v,
            spec::MAX_JOINT_MASS_RATIO,
        ),
        (
            "hinge max",
            |s, v| hinge(s, 0.0, v),
            spec::MAX_LIMIT_END_DEG,
        ),
        (
            "hinge min",
            |s, v| hinge(s, v, 0.0),
            -spec::MAX_LIMIT_END_DEG,
        ),
        ("swing", |s, v| twist(s, v, 0.0), spec::MAX_SWING_DEG),
        (
            "cone tilt",
            |s, v| twist(s, 30.0, v),
            spec::MAX_CONE_TILT_DEG,
        ),
        (
            "cone tilt negative",
            |s, v| twist(s, 30.0, v),
            -spec::MAX_CONE_TILT_DEG,
        ),
    ];
    for (what, set, edge) in edges {
        let (_, mut s) = pair(
            Shape::Capsule {
                radius_m: 0.1,
                length_m: 0.3,
            },
            1.0,
        );
        set(&mut s, edge);
        s.validate()
            .unwrap_or_else(|e| panic!("{what}: the edge {edge} is refused: {e}"));
        let outside = if edge == 0.0 || edge == spec::MIN_SHAPE_M || edge == spec::MIN_BODY_KG {
            edge.next_down()
        } else {
            past(edge)
        };
        let (_, mut s) = pair(
            Shape::Capsule {
                radius_m: 0.1,
                length_m: 0.3,
            },
            1.0,
        );
        set(&mut s, outside);
        assert!(
            s.validate().is_err(),
            "{what}: {outside}, just past {edge}, is accepted"
        );
    }
}

// --- Specs: the edges simulate --------------------------------------------------------------

/// Specs at the largest and smallest accepted sizes and masses, the longest offsets and
/// the largest jointed mass ratio run a few frames on both backends, finite.
#[test]
fn specs_at_the_bounds_simulate_on_both_backends() {
    let big = spec::MAX_SHAPE_M;
    let mut cases: Vec<(&str, Character, RagdollSpec)> = Vec::new();
    let (c, s) = pair(
        Shape::Capsule {
            radius_m: big,
            length_m: big,
        },
        spec::MAX_BODY_KG,
    );
    cases.push(("largest capsules", c, s));
    let (c, s) = pair(
        Shape::Box {
            size_m: [big, big, big],
        },
        spec::MAX_BODY_KG,
    );
    cases.push(("largest boxes", c, s));
    let (c, s) = pair(
        Shape::Capsule {
            radius_m: spec::MIN_SHAPE_M,
            length_m: 0.0,
        },
        spec::MIN_BODY_KG,
    );
    cases.push(("smallest spheres", c, s));
    let (c, mut s) = pair(
        Shape::Box {
            size_m: [spec::MIN_SHAPE_M, big, spec::MIN_SHAPE_M],
        },
        1.0,
    );
    s.bodies[1].mass_kg = spec::MAX_JOINT_MASS_RATIO;
    s.bodies[0].center_m = [0.0, spec::MAX_OFFSET_M, 0.0];
    s.joints[0].anchor_m = [spec::MAX_OFFSET_M, 0.0, 0.0];
    cases.push(("thin boxes, far offsets, the largest mass ratio", c, s));
    for (what, character, spec) in &cases {
        spec.validate().unwrap();
        for backend in BACKENDS {
            let (world, _) = world_with(character, spec, backend);
            run_finite(world, 0.1, &format!("{what} on {backend:?}"));
        }
    }
}
