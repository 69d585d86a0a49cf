//! Hostile settings (issue 10): every value a user can give through a spec, a scene or an
//! event is checked when it is read. Each absurd value is refused with its place in the
//! message; each bound accepts its edge and refuses just past it; and the edges are
//! honest: a ragdoll at the largest accepted sizes, or hit by the strongest accepted
//! events, simulates on both backends without a panic or a NaN.

use std::path::{Path, PathBuf};

use glam::Vec3;
use ragdoll::Error;
use ragdoll::events::{self, Blast, Field, Pin, Projectile, Push};
use ragdoll::math::Transform;
use ragdoll::scene::{self, Scene};
use ragdoll::skeleton::{self, Character, Joint, Skeleton, Source};
use ragdoll::spec::{
    self, BodySpec, JointKind, JointSpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape,
};
use ragdoll::world::{self, BackendKind, Motors, World, WorldSettings};

// --- Helpers -----------------------------------------------------------------------------

/// The built-in humanoid's spec.
fn humanoid_spec() -> RagdollSpec {
    spec::build_spec(&skeleton::humanoid(), &Default::default()).unwrap()
}

/// A two-bone character ("a" above "b") with one body per bone of `shape` and `mass_kg`,
/// jointed by a swing-twist joint "b".
fn pair(shape: Shape, mass_kg: f32) -> (Character, RagdollSpec) {
    let joint = |name: &str, parent, y: f32| Joint {
        name: name.into(),
        parent,
        rest: Transform::from_translation(Vec3::new(0.0, y, 0.0)),
        tip: None,
    };
    let character = Character {
        name: "pair".into(),
        skeleton: Skeleton::new(vec![joint("a", None, 2.0), joint("b", Some(0), -1.0)]).unwrap(),
        meshes: vec![],
        clips: vec![],
        source: Source::BuiltIn,
    };
    let body = |name: &str| BodySpec {
        name: name.into(),
        bone: name.into(),
        role: None,
        shape,
        center_m: [0.0; 3],
        rotation: [0.0, 0.0, 0.0, 1.0],
        mass_kg,
    };
    let spec = RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: "pair".into(),
        bodies: vec![body("a"), body("b")],
        joints: vec![JointSpec {
            name: "b".into(),
            parent: "a".into(),
            child: "b".into(),
            anchor_m: [0.0; 3],
            frame: [0.0, 0.0, 0.0, 1.0],
            kind: JointKind::SwingTwist {
                swing_deg: 45.0,
                twist_deg: [-30.0, 30.0],
                cone_tilt_deg: [0.0, 0.0],
            },
        }],
        collision: spec::CollisionSpec {
            disabled_pairs: vec![["a".into(), "b".into()]],
        },
    };
    (character, spec)
}

/// The next `f32` away from zero: just past a bound.
fn past(x: f32) -> f32 {
    if x >= 0.0 { x.next_up() } else { x.next_down() }
}

/// Runs `world` for `seconds` and checks it stayed finite.
fn run_finite(mut world: World, seconds: f32, what: &str) {
    world.run(seconds);
    assert!(!world.metrics().nan, "{what}: NaN in the run");
    for track in world.into_tracks() {
        assert!(
            track.frames.iter().flatten().all(|t| t.is_finite()),
            "{what}: a non-finite joint transform"
        );
    }
}

/// A world with `spec` on `backend`, and the ragdoll's id.
fn world_with(
    character: &Character,
    spec: &RagdollSpec,
    backend: BackendKind,
) -> (World, world::RagdollId) {
    let settings = WorldSettings {
        backend,
        ..Default::default()
    };
    World::with_ragdoll(character, spec, &settings).unwrap_or_else(|e| panic!("{backend:?}: {e}"))
}

const BACKENDS: [BackendKind; 2] = [BackendKind::Rigid, BackendKind::Particle];

/// The setting an error names and its message.
fn setting_of(r: ragdoll::Result<()>) -> (String, String) {
    match r {
        Err(Error::Setting { setting, message }) => (setting, message),
        other => panic!("expected a setting error, got {other:?}"),
    }
}

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

// --- Events ---------------------------------------------------------------------------------

#[test]
fn the_reported_bullet_at_1e30_mps_is_refused_with_its_bound() {
    let shot = Projectile {
        origin: Vec3::new(0.0, 1.2, 5.0),
        direction: Vec3::NEG_Z,
        mass_kg: 0.008,
        speed_mps: 1e30,
        time_s: 0.0,
    };
    let (setting, message) = setting_of(shot.validate());
    assert_eq!(setting, "speed");
    assert!(
        message.contains("3000 m/s") && message.contains("1e30"),
        "{message}"
    );
    let (mut world, _) = world_with(&skeleton::humanoid(), &humanoid_spec(), BackendKind::Rigid);
    assert!(world.add_projectile(shot).is_err());
}

/// Each event bound: accepted at its edge, refused just past it, naming the setting.
#[test]
fn every_event_bound_accepts_its_edge_and_refuses_past_it() {
    let blast = |tnt: f32, at: f32, time: f32, scale: f32| Blast {
        tnt_kg: tnt,
        position: Vec3::new(at, 0.5, 0.0),
        time_s: time,
        scale,
    };
    type Check = Box<dyn Fn(f32) -> ragdoll::Result<()>>;
    let edges: Vec<(&str, Check, f32)> = vec![
        (
            "tnt",
            Box::new(move |v| blast(v, 0.0, 0.0, 1.0).validate()),
            events::MAX_TNT_KG,
        ),
        (
            "at",
            Box::new(move |v| blast(1.0, v, 0.0, 1.0).validate()),
            world::MAX_COORDINATE_M,
        ),
        (
            "at",
            Box::new(move |v| blast(1.0, v, 0.0, 1.0).validate()),
            -world::MAX_COORDINATE_M,
        ),
        (
            "time",
            Box::new(move |v| blast(1.0, 0.0, v, 1.0).validate()),
            world::MAX_SECONDS,
        ),
        (
            "scale",
            Box::new(move |v| blast(1.0, 0.0, 0.0, v).validate()),
            events::MAX_BLAST_SCALE,
        ),
        (
            "mass",
            Box::new(|v| shot(v, 0.0).validate()),
            events::MAX_PROJECTILE_KG,
        ),
        (
            "speed",
            Box::new(|v| shot(0.001, v).validate()),
            events::MAX_PROJECTILE_SPEED_MPS,
        ),
        (
            "speed",
            Box::new(|v| shot(1.0, v).validate()),
            events::MAX_MOMENTUM_NS,
        ),
        (
            "impulse_ns",
            Box::new(|v| {
                Push::Impulse {
                    target: "head".into(),
                    impulse_ns: Vec3::new(0.0, 0.0, v),
                    time_s: 0.0,
                }
                .validate()
            }),
            events::MAX_MOMENTUM_NS,
        ),
        (
            "force_n",
            Box::new(|v| {
                Push::Force {
                    target: "head".into(),
                    force_n: Vec3::new(v, 0.0, 0.0),
                    start_s: 0.0,
                    end_s: 1.0,
                }
                .validate()
            }),
            events::MAX_FORCE_N,
        ),
        (
            "end_s",
            Box::new(|v| {
                Field::Drag {
                    rate_per_s: 1.0,
                    start_s: 0.0,
                    end_s: v,
                }
                .validate()
            }),
            world::MAX_SECONDS,
        ),
        (
            "rate_per_s",
            Box::new(|v| {
                Field::Drag {
                    rate_per_s: v,
                    start_s: 0.0,
                    end_s: 1.0,
                }
                .validate()
            }),
            events::MAX_DRAG_RATE_PER_S,
        ),
        (
            "velocity_mps",
            Box::new(|v| wind(v).validate()),
            events::MAX_WIND_MPS,
        ),
        (
            "keys",
            Box::new(|v| {
                Field::Gravity {
                    keys: vec![(0.0, Vec3::new(0.0, -v, 0.0))],
                }
                .validate()
            }),
            world::MAX_GRAVITY_MPS2,
        ),
        (
            "strength_mps2",
            Box::new(|v| radial(v, 3.0).validate()),
            world::MAX_GRAVITY_MPS2,
        ),
        (
            "strength_mps2",
            Box::new(|v| radial(v, 3.0).validate()),
            -world::MAX_GRAVITY_MPS2,
        ),
        (
            "radius_m",
            Box::new(|v| radial(1.0, v).validate()),
            2.0 * world::MAX_COORDINATE_M,
        ),
        (
            "stiffness_hz",
            Box::new(|v| pin(Some(v), 0.5).validate()),
            events::MAX_PIN_STIFFNESS_HZ,
        ),
        (
            "damping_ratio",
            Box::new(|v| pin(Some(events::MAX_PIN_STIFFNESS_HZ), v).validate()),
            events::MAX_PIN_DAMPING_HZ / events::MAX_PIN_STIFFNESS_HZ,
        ),
        (
            "damping_ratio",
            Box::new(|v| pin(Some(1.0), v).validate()),
            events::MAX_PIN_DAMPING_HZ,
        ),
        (
            "release_s",
            Box::new(|v| {
                Pin {
                    release_s: Some(v),
                    ..pin(None, 1.0)
                }
                .validate()
            }),
            world::MAX_SECONDS,
        ),
        (
            "keys",
            Box::new(|v| {
                Pin {
                    keys: vec![(0.0, Vec3::new(0.0, v, 0.0))],
                    ..pin(None, 1.0)
                }
                .validate()
            }),
            world::MAX_COORDINATE_M,
        ),
    ];
    for (setting, check, edge) in edges {
        check(edge).unwrap_or_else(|e| panic!("{setting}: the edge {edge} is refused: {e}"));
        let (got, message) = setting_of(check(past(edge)));
        assert_eq!(got, setting, "{message}");
    }
    // Tiny charges and shots, zero speeds and scales are fine; zero charges are not.
    blast(1e-9, 0.0, 0.0, 0.0).validate().unwrap();
    assert!(blast(0.0, 0.0, 0.0, 1.0).validate().is_err());
    assert!(blast(1.0, 0.0, -1.0, 1.0).validate().is_err());
    // Keys: at most MAX_KEYS, in order.
    let keys = |n: usize| Field::Gravity {
        keys: (0..n).map(|k| (k as f32 * 0.01, Vec3::NEG_Y)).collect(),
    };
    keys(events::MAX_KEYS).validate().unwrap();
    assert_eq!(setting_of(keys(events::MAX_KEYS + 1).validate()).0, "keys");
}

fn shot(mass_kg: f32, speed_mps: f32) -> Projectile {
    Projectile {
        origin: Vec3::new(0.0, 1.25, 5.0),
        direction: Vec3::NEG_Z,
        mass_kg,
        speed_mps,
        time_s: 0.05,
    }
}

fn wind(speed: f32) -> Field {
    Field::Wind {
        velocity_mps: Vec3::new(speed, 0.0, 0.0),
        start_s: 0.0,
        end_s: events::OPEN_END_S,
    }
}

fn radial(strength: f32, radius: f32) -> Field {
    Field::Radial {
        center: Vec3::new(0.0, 1.0, 0.0),
        strength_mps2: strength,
        radius_m: radius,
        start_s: 0.0,
        end_s: 0.3,
    }
}

fn pin(stiffness_hz: Option<f32>, damping_ratio: f32) -> Pin {
    Pin {
        target: "hand_l".into(),
        keys: vec![
            (0.0, Vec3::new(0.4, 0.9, 0.0)),
            (0.4, Vec3::new(0.4, 2.0, 0.0)),
        ],
        stiffness_hz,
        damping_ratio,
        release_s: None,
    }
}

/// The strongest accepted events, on the humanoid, on both backends: still finite.
#[test]
fn the_strongest_accepted_events_simulate_on_both_backends() {
    let character = skeleton::humanoid();
    let spec = humanoid_spec();
    for backend in BACKENDS {
        let pinned = pin(
            Some(events::MAX_PIN_STIFFNESS_HZ),
            events::MAX_PIN_DAMPING_HZ / events::MAX_PIN_STIFFNESS_HZ,
        );
        type Add = Box<dyn Fn(&mut World, world::RagdollId) -> ragdoll::Result<()>>;
        let adds: Vec<(&str, Add)> = vec![
            (
                "the largest momentum",
                Box::new(|w, _| w.add_projectile(shot(1.0, events::MAX_MOMENTUM_NS))),
            ),
            (
                "the largest impulse on a hand",
                Box::new(|w, id| {
                    w.add_push(
                        id,
                        Push::Impulse {
                            target: "hand_l".into(),
                            impulse_ns: Vec3::new(events::MAX_MOMENTUM_NS, 0.0, 0.0),
                            time_s: 0.05,
                        },
                    )
                }),
            ),
            (
                "the largest force on a hand",
                Box::new(|w, id| {
                    w.add_push(
                        id,
                        Push::Force {
                            target: "hand_l".into(),
                            force_n: Vec3::new(events::MAX_FORCE_N, 0.0, 0.0),
                            start_s: 0.0,
                            end_s: 0.3,
                        },
                    )
                }),
            ),
            (
                "the strongest wind",
                Box::new(|w, _| w.add_field(wind(events::MAX_WIND_MPS))),
            ),
            (
                "the strongest radial field",
                Box::new(|w, _| w.add_field(radial(world::MAX_GRAVITY_MPS2, 3.0))),
            ),
            (
                "the stiffest, most damped pin",
                Box::new(move |w, id| w.add_pin(id, pinned.clone())),
            ),
        ];
        for (what, add) in adds {
            let (mut world, id) = world_with(&character, &spec, backend);
            add(&mut world, id).unwrap_or_else(|e| panic!("{what}: {e}"));
            run_finite(world, 0.4, &format!("{what} on {backend:?}"));
        }
        let settings = WorldSettings {
            backend,
            gravity: Vec3::new(0.0, -world::MAX_GRAVITY_MPS2, 0.0),
            ..Default::default()
        };
        let (world, _) = World::with_ragdoll(&character, &spec, &settings).unwrap();
        run_finite(world, 0.4, &format!("the strongest gravity on {backend:?}"));
    }
    // The largest charge, on the character, on rigid (the particle backend's broad phase
    // is sized by the fastest body: see the report of issue 10).
    let (mut world, _) = world_with(&character, &spec, BackendKind::Rigid);
    world
        .add_blast(Blast::new(
            events::MAX_TNT_KG,
            Vec3::new(0.0, 1.0, 0.0),
            0.05,
        ))
        .unwrap();
    run_finite(world, 0.4, "the largest charge on rigid");
}

// --- World settings and motors ----------------------------------------------------------

#[test]
fn world_settings_and_runs_are_bounded() {
    let ok = WorldSettings::default();
    type Set = fn(&mut WorldSettings, f32);
    let edges: Vec<(&str, Set, f32)> = vec![
        ("dt", |s, v| s.dt = v, world::STEP_RANGE_S[1]),
        ("fps", |s, v| s.fps = v, world::MAX_FPS),
        (
            "gravity",
            |s, v| s.gravity = Vec3::new(0.0, 0.0, v),
            world::MAX_GRAVITY_MPS2,
        ),
        (
            "ground",
            |s, v| s.ground = Some(v),
            -world::MAX_COORDINATE_M,
        ),
    ];
    for (setting, set, edge) in edges {
        let mut s = ok.clone();
        set(&mut s, edge);
        s.validate()
            .unwrap_or_else(|e| panic!("{setting}: the edge {edge} is refused: {e}"));
        set(&mut s, past(edge));
        assert_eq!(setting_of(s.validate()).0, setting);
    }
    let mut s = ok.clone();
    s.dt = world::STEP_RANGE_S[0];
    s.validate().unwrap();
    s.dt = world::STEP_RANGE_S[0].next_down();
    assert_eq!(setting_of(s.validate()).0, "dt");
    let mut s = ok.clone();
    s.substeps = world::MAX_SUBSTEPS + 1;
    assert_eq!(setting_of(s.validate()).0, "substeps");

    // A run records at most MAX_TRACK_SAMPLES joint transforms: 100 s at 1000 fps is
    // 100 001 frames, so 99 joints fit and 100 do not.
    let fast = WorldSettings {
        fps: 1000.0,
        ..ok.clone()
    };
    assert_eq!(world::MAX_TRACK_SAMPLES / 100_001, 99);
    fast.validate_run(100.0, 99).unwrap();
    assert_eq!(setting_of(fast.validate_run(100.0, 100)).0, "seconds");
    ok.validate_run(world::MAX_SECONDS, 1).unwrap();
    assert!(ok.validate_run(past(world::MAX_SECONDS), 1).is_err());
    assert!(ok.validate_run(f32::NAN, 1).is_err());
}

#[test]
fn motor_keys_are_bounded() {
    let keys = |k: Vec<(f32, f32)>| Motors {
        strength_keys: k,
        root_on_clip: false,
    };
    keys(vec![(world::MAX_SECONDS, 1.0)]).validate().unwrap();
    for bad in [
        keys(vec![(past(world::MAX_SECONDS), 1.0)]),
        keys(vec![(-1.0, 1.0)]),
        keys(vec![(0.0, past(1.0))]),
        keys(
            (0..=events::MAX_KEYS)
                .map(|k| (k as f32 * 0.01, 1.0))
                .collect(),
        ),
    ] {
        assert!(bad.validate().is_err(), "{:?}", &bad.strength_keys[..1]);
    }
}

// --- Scenes -----------------------------------------------------------------------------

/// A scene text's error as (line, message).
fn scene_failure(text: &str, path: &Path) -> (usize, String) {
    match Scene::from_toml(text, path) {
        Ok(_) => panic!("this scene should fail:\n{text}"),
        Err(Error::Parse { line, message, .. }) => (line, message),
        Err(e) => panic!("expected an error with a line, got: {e}"),
    }
}

/// Absurd values in a scene, each refused at its line with its key and its bound.
#[test]
fn absurd_scene_values_are_refused_at_their_line_with_the_bound() {
    let one = "[[character]]\n";
    let cases: Vec<(String, usize, &[&str])> = vec![
        (
            format!("{one}position = [4294967296, 0, 0]\n"),
            2,
            &["position", "10000 m"],
        ),
        (
            format!("{one}facing_deg = 1e30\n"),
            2,
            &["facing_deg", "360"],
        ),
        (format!("{one}mass_kg = 1e30\n"), 2, &["mass_kg", "1e9"]),
        (format!("{one}activate = 1e9\n"), 2, &["activate", "3600"]),
        (
            "duration_s = 1e9\n[[character]]\n".into(),
            1,
            &["duration_s", "3600"],
        ),
        ("fps = 1e6\n[[character]]\n".into(), 1, &["fps", "1000"]),
        (
            "gravity = [0, -1e30, 0]\n[[character]]\n".into(),
            1,
            &["gravity", "1000"],
        ),
        (
            "ground = 1e30\n[[character]]\n".into(),
            1,
            &["ground", "10000"],
        ),
        (
            format!("{one}[[blast]]\ntnt_kg = 1e30\nposition = [0, 0, 0]\n"),
            3,
            &["[[blast]] 1", "tnt_kg", "1e7"],
        ),
        (
            format!("{one}[[blast]]\ntnt_kg = 1\nposition = [0, 0, 0]\nscale = 1e9\n"),
            5,
            &["scale", "100"],
        ),
        (
            format!(
                "{one}[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\nspeed_mps = 1e30\n"
            ),
            5,
            &["speed_mps", "3000"],
        ),
        (
            format!(
                "{one}[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\nmass_kg = 10\nspeed_mps = 1000\n"
            ),
            6,
            &["speed_mps", "momentum", "1000 N·s"],
        ),
        (
            format!(
                "{one}[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\ncount = 10000\ninterval_s = 1\n"
            ),
            6,
            &["interval_s", "3600"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\nimpulse_ns = [1e30, 0, 0]\n"),
            4,
            &["impulse_ns", "1000 N·s"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\nforce_n = [0, 1e5, 0]\n"),
            4,
            &["force_n", "10000 N"],
        ),
        (
            format!("{one}[[push]]\ntarget = \"head\"\nforce_n = [0, 1, 0]\nend_s = 1e9\n"),
            5,
            &["end_s", "3600"],
        ),
        (
            format!("{one}[[field]]\nkind = \"wind\"\nvelocity_mps = [1000, 0, 0]\n"),
            4,
            &["velocity_mps", "340"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"radial\"\ncenter = [0, 0, 0]\nstrength_mps2 = 1e30\nradius_m = 2\n"
            ),
            5,
            &["strength_mps2", "1000"],
        ),
        (
            format!("{one}[[field]]\nkind = \"drag\"\nrate_per_s = 1e30\n"),
            4,
            &["rate_per_s", "1000"],
        ),
        (
            format!(
                "{one}[[field]]\nkind = \"gravity\"\nkeys = [{{ time_s = 0, gravity = [0, -1e30, 0] }}]\n"
            ),
            4,
            &["keys", "gravity", "1000"],
        ),
        (
            format!("{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1e30, 0]\n"),
            4,
            &["position", "10000"],
        ),
        (
            format!(
                "{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\nstiffness_hz = 1000\n"
            ),
            5,
            &["stiffness_hz", "30 Hz"],
        ),
        (
            format!(
                "{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\nstiffness_hz = 10\ndamping_ratio = 10\n"
            ),
            6,
            &["damping_ratio", "30 Hz"],
        ),
        (
            format!("{one}[[pin]]\ntarget = \"hand_l\"\nposition = [0, 1, 0]\nrelease_s = 1e9\n"),
            5,
            &["release_s", "3600"],
        ),
        (
            format!("{one}powered = {{ strength = 1e9 }}\n"),
            2,
            &["powered", "strength"],
        ),
        (
            format!("{one}[output]\nglb = \"{}.glb\"\n", "x".repeat(200)),
            3,
            &["glb", "128"],
        ),
    ];
    for (text, line, words) in &cases {
        let (got, message) = scene_failure(text, Path::new("test.toml"));
        assert_eq!(got, *line, "wrong line for:\n{text}\nmessage: {message}");
        for w in *words {
            assert!(message.contains(w), "{message:?} lacks {w:?} for:\n{text}");
        }
    }
}

/// Counts: characters, events (each shot of a burst counted), keys, and the frames a run
/// would record.
#[test]
fn scene_counts_are_bounded() {
    let path = Path::new("test.toml");
    let many = "[[character]]\nposition = [0, 0, 0]\n".repeat(scene::MAX_CHARACTERS + 1);
    let (line, message) = scene_failure(&many, path);
    assert_eq!(line, 2 * scene::MAX_CHARACTERS + 1);
    assert!(message.contains("1000 characters"), "{message}");

    let blasts = "[[blast]]\ntnt_kg = 1\nposition = [5, 0, 0]\n".repeat(scene::MAX_EVENTS + 1);
    let (line, message) = scene_failure(&format!("[[character]]\n{blasts}"), path);
    assert_eq!(line, 2 + 3 * scene::MAX_EVENTS);
    assert!(message.contains("10000 events"), "{message}");

    let burst = format!(
        "[[character]]\n[[projectile]]\norigin = [0, 1, 5]\ntarget = [0, 1, 0]\ncount = {}\ninterval_s = 0\n[[blast]]\ntnt_kg = 1\nposition = [5, 0, 0]\n",
        scene::MAX_BURST
    );
    let (_, message) = scene_failure(&burst, path);
    assert!(
        message.contains("10001") && message.contains("10000"),
        "{message}"
    );

    let keys: Vec<String> = (0..=events::MAX_KEYS)
        .map(|k| format!("{{ time_s = {}, position = [0, 1, 0] }}", k as f32 * 0.01))
        .collect();
    let pin = format!(
        "[[character]]\n[[pin]]\ntarget = \"hand_l\"\nkeys = [{}]\n",
        keys.join(", ")
    );
    let (line, message) = scene_failure(&pin, path);
    assert_eq!(line, 4);
    assert!(message.contains("10000"), "{message}");

    // An hour at 1000 fps of a humanoid records more than a run keeps.
    let long = "duration_s = 3600\nfps = 1000\n[[character]]\n";
    let (line, message) = scene_failure(long, path);
    assert_eq!(line, 1);
    assert!(
        message.contains("duration_s") && message.contains("joint transforms"),
        "{message}"
    );
}

/// A scratch folder for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ragdoll-hostile-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Files a scene names are relative to the scene file; special files are refused before
/// anything reads them; the scene and spec files are read with a size cap.
#[test]
fn scene_files_are_found_beside_the_scene_and_special_files_refused() {
    let dir = scratch("files");
    std::fs::create_dir_all(dir.join("chars")).unwrap();
    let bvh = "HIERARCHY\nROOT hips\n{\n OFFSET 0 90 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n JOINT chest\n {\n  OFFSET 0 40 0\n  CHANNELS 3 Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 30 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.033\n0 90 0 0 0 0 0 0 0\n";
    std::fs::write(dir.join("chars/two.bvh"), bvh).unwrap();
    let spec = humanoid_spec();
    std::fs::write(dir.join("chars/h.spec.toml"), spec.to_toml()).unwrap();
    let scene_path = dir.join("scene.toml");
    let text = "[[character]]\nfile = \"chars/two.bvh\"\n[[character]]\nspec = \"chars/h.spec.toml\"\nposition = [3, 0, 0]\n";
    std::fs::write(&scene_path, text).unwrap();
    let scene = Scene::load(&scene_path).unwrap();
    assert_eq!(scene.characters.len(), 2);
    assert_eq!(scene.characters[1].spec.bodies.len(), spec.bodies.len());

    for (key, special) in [
        ("file", "/dev/zero"),
        ("spec", "/dev/zero"),
        ("file", "chars"),
    ] {
        let text = format!("[[character]]\n{key} = \"{special}\"\n");
        let (line, message) = scene_failure(&text, &scene_path);
        assert_eq!(line, 2);
        assert!(
            message.contains(key) && message.contains("not a regular file"),
            "{message}"
        );
    }
    // A scene file that is not a regular file, or too large, is not read.
    assert!(Scene::load(Path::new("/dev/zero")).is_err());
    let big = dir.join("big.toml");
    let file = std::fs::File::create(&big).unwrap();
    file.set_len(ragdoll::files::MAX_SETTINGS_BYTES + 1)
        .unwrap();
    let err = Scene::load(&big).unwrap_err().to_string();
    assert!(err.contains("larger than"), "{err}");
    let err = RagdollSpec::load(&big).unwrap_err().to_string();
    assert!(err.contains("larger than"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

// --- Rig options ---------------------------------------------------------------------------

/// A long thin box along X (as the rig module's example).
fn bar_mesh() -> Vec<ragdoll::skeleton::SkinnedMesh> {
    let positions: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                (i >> 1 & 1) as f32 * 0.2,
                (i >> 2) as f32 * 0.2,
            )
        })
        .collect();
    let indices = vec![
        0, 1, 3, 0, 3, 2, 4, 7, 5, 4, 6, 7, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4,
        1, 5, 7, 1, 7, 3,
    ];
    vec![ragdoll::skeleton::SkinnedMesh {
        positions,
        indices,
        ..Default::default()
    }]
}

#[test]
fn rig_options_are_bounded() {
    use ragdoll::rig::{self, Branch, Landmark, RigOptions};
    let meshes = bar_mesh();
    let leg = |name: &str, points: usize, joints: usize| Branch {
        name: name.into(),
        points: (0..points)
            .map(|k| Landmark::Point(Vec3::new(0.0, 0.0, 0.3 + k as f32 * 0.01)))
            .collect(),
        joints,
        mirror: true,
    };
    let with = |joints: usize, branches: Vec<Branch>| RigOptions {
        joints,
        branches,
        ..Default::default()
    };
    let setting = |opts: &RigOptions| match rig::build_skeleton(&meshes, opts) {
        Err(Error::Setting { setting, message }) => format!("{setting}: {message}"),
        other => panic!("expected a setting error, got {other:?}"),
    };
    // Spine joints and the whole rig.
    rig::build_skeleton(&meshes, &with(rig::MAX_JOINTS, vec![])).unwrap();
    assert!(setting(&with(rig::MAX_JOINTS + 1, vec![])).contains("rig.joints"));
    let half = (rig::MAX_RIG_JOINTS - rig::MAX_JOINTS) / 2;
    let full = with(rig::MAX_JOINTS, vec![leg("leg", 2, half - 1)]);
    assert_eq!(
        rig::build_skeleton(&meshes, &full).unwrap().len(),
        rig::MAX_RIG_JOINTS
    );
    let over = with(rig::MAX_JOINTS, vec![leg("leg", 2, half)]);
    assert!(setting(&over).contains("512"), "{}", setting(&over));
    // Landmarks per line, branches, names.
    let many = with(4, vec![leg("leg", rig::MAX_LANDMARKS + 1, 2)]);
    assert!(setting(&many).contains("landmarks"));
    let branches = (0..=rig::MAX_BRANCHES)
        .map(|k| leg(&format!("b{k}"), 2, 1))
        .collect();
    assert!(setting(&with(2, branches)).contains("branches"));
    assert!(setting(&with(4, vec![leg("leg", 2, 1), leg("leg", 2, 1)])).contains("two branches"));
    assert!(setting(&with(4, vec![leg("a/b", 2, 1)])).contains("letters"));
    let mut spine = leg("spine", 2, 1);
    spine.mirror = false;
    assert!(setting(&with(4, vec![spine])).contains("spine00"));
    // Landmarks within the world.
    let mut far = leg("leg", 2, 1);
    far.points[1] = Landmark::Point(Vec3::new(0.0, 0.0, past(world::MAX_COORDINATE_M)));
    assert!(setting(&with(4, vec![far])).contains("10000 m"));
}
