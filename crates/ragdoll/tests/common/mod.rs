//! Shared by the integration tests: where the third-party test data lives, which example
//! scenes need it, and the simplest test body.

#![allow(dead_code)] // each test binary uses its own subset

use std::path::{Path, PathBuf};

/// The shared test data folder (`$RAGDOLL_DATA`, else `../shared/data` beside the
/// repository). Every test that calls this is `#[ignore = "needs ../shared/data"]`, so a
/// clone without the folder lists it as ignored instead of passing having run nothing; run
/// with `--ignored`, a missing folder is a failure that names where it looked.
pub fn shared_data() -> PathBuf {
    let dir = std::env::var_os("RAGDOLL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    assert!(
        dir.is_dir(),
        "the shared test data folder {} is missing (set RAGDOLL_DATA to where it is)",
        dir.display()
    );
    dir
}

/// The repository's `examples/` folder.
pub const EXAMPLES_DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");

/// How an example scene that needs the shared test data starts: a reader sees it on the
/// first line, and the tests run such a scene only when the data is asked for.
pub const NEEDS_DATA: &str = "# Needs ../shared/data";

/// The example scenes in `examples/`, sorted, as (those that run on a bare clone, those
/// that need the shared data). A scene that points into `shared/data/` without saying so
/// on its first line fails here, so the first line cannot drift from the truth.
pub fn examples() -> (Vec<PathBuf>, Vec<PathBuf>) {
    let mut files: Vec<PathBuf> = std::fs::read_dir(EXAMPLES_DIR)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    let (data, bare): (Vec<PathBuf>, Vec<PathBuf>) = files.into_iter().partition(|p| {
        let text = std::fs::read_to_string(p).unwrap();
        let marked = text.starts_with(NEEDS_DATA);
        assert!(
            marked || !text.contains("shared/data/"),
            "{} points into shared/data/ but does not start with {NEEDS_DATA:?}",
            p.display()
        );
        marked
    });
    (bare, data)
}

/// A character that is only a skeleton (no mesh, no clip), named `name`.
pub fn skeleton_character(
    name: &str,
    joints: Vec<ragdoll::skeleton::Joint>,
) -> ragdoll::skeleton::Character {
    use ragdoll::skeleton::{Character, Skeleton, Source};
    Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: name.into(),
        skeleton: Skeleton::new(joints).unwrap(),
        meshes: vec![],
        clips: vec![],
        source: Source::BuiltIn,
    }
}

/// A skeleton-only character from rows of (joint name, parent row, world position at rest).
pub fn character_from_rows<S: AsRef<str>>(
    name: &str,
    rows: &[(S, Option<usize>, glam::Vec3)],
) -> ragdoll::skeleton::Character {
    let joints = rows
        .iter()
        .map(|(joint, parent, p)| ragdoll::skeleton::Joint {
            name: joint.as_ref().into(),
            parent: *parent,
            rest: ragdoll::math::Transform::from_translation(
                *p - parent.map_or(glam::Vec3::ZERO, |q| rows[q].2),
            ),
            tip: None,
        })
        .collect();
    skeleton_character(name, joints)
}

/// A one-joint character "bar" 1 m up with a single capsule body "bar" (long axis vertical):
/// the simplest rigid body to check a load or a field against a closed form.
pub fn one_capsule(
    radius_m: f32,
    length_m: f32,
    mass_kg: f32,
) -> (ragdoll::skeleton::Character, ragdoll::spec::RagdollSpec) {
    use ragdoll::math::Transform;
    use ragdoll::skeleton::Joint;
    use ragdoll::spec::{BodySpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
    let character = skeleton_character(
        "bar",
        vec![Joint {
            name: "bar".into(),
            parent: None,
            rest: Transform::from_translation(glam::Vec3::new(0.0, 1.0, 0.0)),
            tip: None,
        }],
    );
    let spec = RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: "bar".into(),
        bodies: vec![BodySpec {
            name: "bar".into(),
            bone: "bar".into(),
            role: None,
            shape: Shape::Capsule { radius_m, length_m },
            center_m: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
            mass_kg,
            extra_shapes: Vec::new(),
        }],
        joints: vec![],
        collision: Default::default(),
    };
    (character, spec)
}

/// A hard pin holding `target` (a joint or body name) at `point` from the start on.
pub fn pin_at(target: &str, point: glam::Vec3) -> ragdoll::events::Pin {
    ragdoll::events::Pin {
        target: target.into(),
        keys: vec![(0.0, point)],
        stiffness_hz: None,
        damping_ratio: 0.0,
        release_s: None,
    }
}

/// A chain of `links` capsules hanging from "j0" along `dir` (unit), each `len` metres,
/// joined by swing-twist joints with a `swing_deg` cone.
pub fn chain(
    links: usize,
    len: f32,
    dir: glam::Vec3,
    swing_deg: f32,
) -> (ragdoll::skeleton::Character, ragdoll::spec::RagdollSpec) {
    use glam::{Quat, Vec3};
    use ragdoll::math::Transform;
    use ragdoll::skeleton::Joint;
    use ragdoll::spec::{BodySpec, JointKind, JointSpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
    let mut joints = Vec::new();
    for i in 0..=links {
        joints.push(Joint {
            name: format!("j{i}"),
            parent: (i > 0).then(|| i - 1),
            rest: Transform::from_translation(if i == 0 {
                Vec3::new(0.0, 2.0, 0.0)
            } else {
                dir * len
            }),
            tip: None,
        });
    }
    let character = skeleton_character("chain", joints);
    // Each capsule lies along its bone: its local Y turned onto `dir`.
    let rotation = Quat::from_rotation_arc(Vec3::Y, dir).to_array();
    let bodies = (0..links)
        .map(|i| BodySpec {
            name: format!("link{i}"),
            bone: format!("j{i}"),
            role: None,
            shape: Shape::Capsule {
                radius_m: 0.02,
                length_m: len,
            },
            center_m: (dir * (0.5 * len)).to_array(),
            rotation,
            mass_kg: 1.0,
            extra_shapes: Vec::new(),
        })
        .collect();
    let frame = Quat::from_rotation_arc(Vec3::X, dir).to_array();
    let joints = (1..links)
        .map(|i| JointSpec {
            name: format!("link{i}"),
            parent: format!("link{}", i - 1),
            child: format!("link{i}"),
            anchor_m: [0.0; 3],
            frame,
            kind: JointKind::SwingTwist {
                swing_deg,
                twist_deg: [-30.0, 30.0],
                cone_tilt_deg: [0.0, 0.0],
            },
        })
        .collect();
    let spec = RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: "chain".into(),
        bodies,
        joints,
        collision: Default::default(),
    };
    spec.validate().unwrap();
    (character, spec)
}

/// The period of body 0 of ragdoll `id` swinging about x = 0, seconds: the mean spacing of
/// its centre's crossings from +x to −x over 8 s of `world` stepping at `dt`.
pub fn measured_swing_period(
    world: &mut ragdoll::world::World,
    id: ragdoll::world::RagdollId,
    dt: f64,
) -> f64 {
    world.run(0.0);
    let mut last_x = world.body_poses(id)[0].translation.x;
    let mut crossings = Vec::new();
    for step in 1..=(8.0 / dt) as usize {
        world.step();
        let x = world.body_poses(id)[0].translation.x;
        if last_x > 0.0 && x <= 0.0 {
            crossings.push((step as f64 - 1.0 + (last_x / (last_x - x)) as f64) * dt);
        }
        last_x = x;
    }
    assert!(crossings.len() >= 4, "{crossings:?}");
    (crossings[crossings.len() - 1] - crossings[0]) / (crossings.len() - 1) as f64
}

/// The period in theory of a solid capsule (cylinder plus two hemispheres) hanging from
/// one end as a compound pendulum, small swings: 2π √(I_pivot / (m g d)).
pub fn capsule_pendulum_period(radius: f32, length: f32, mass: f32) -> f64 {
    let (r, l, m) = (radius as f64, length as f64, mass as f64);
    let (v_cyl, v_sph) = (
        std::f64::consts::PI * r * r * l,
        4.0 / 3.0 * std::f64::consts::PI * r.powi(3),
    );
    let (mc, ms) = (m * v_cyl / (v_cyl + v_sph), m * v_sph / (v_cyl + v_sph));
    let i_centre =
        mc * (l * l / 12.0 + r * r / 4.0) + ms * (0.4 * r * r + l * l / 4.0 + 0.375 * l * r);
    let d = l / 2.0;
    let g = ragdoll::world::STANDARD_GRAVITY as f64;
    std::f64::consts::TAU * ((i_centre + m * d * d) / (m * g * d)).sqrt()
}

/// The built-in humanoid with `foot_l` re-hung from the pelvis (as IK rigs hang feet from
/// the root), at the same place.
pub fn humanoid_with_detached_foot() -> ragdoll::skeleton::Character {
    let mut c = ragdoll::skeleton::humanoid();
    let world = c.skeleton.rest_world();
    let pelvis = c.skeleton.find("pelvis").unwrap();
    let foot = c.skeleton.find("foot_l").unwrap();
    let mut joints = c.skeleton.joints().to_vec();
    joints[foot].parent = Some(pelvis);
    joints[foot].rest = world[pelvis].inverse().mul(&world[foot]);
    c.skeleton = ragdoll::skeleton::Skeleton::new(joints).unwrap();
    c
}
