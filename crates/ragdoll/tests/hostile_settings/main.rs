//! Hostile settings: every value a user can give through a spec, a scene or an
//! event is checked when it is read. Each absurd value is refused with its place in the
//! message; each bound accepts its edge and refuses just past it; and the edges are
//! honest: a ragdoll at the largest accepted sizes, or hit by the strongest accepted
//! events, simulates on both backends without a panic or a NaN.
//!
//! One test target in several files: `specs.rs`, `events.rs` (with the world's settings
//! and motors), `scenes.rs` and `rig.rs`; the helpers they share are here.

mod events;
mod rig;
mod scenes;
mod specs;

use glam::Vec3;
use ragdoll::Error;
use ragdoll::math::Transform;
use ragdoll::skeleton::{self, Character, Joint, Skeleton, Source};
use ragdoll::spec::{
    self, BodySpec, JointKind, JointSpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape,
};
use ragdoll::world::{self, BackendKind, World, WorldSettings};

// --- Helpers -----------------------------------------------------------------------------

/// The built-in humanoid's spec.
pub(crate) fn humanoid_spec() -> RagdollSpec {
    spec::build_spec(&skeleton::humanoid(), &Default::default()).unwrap()
}

/// A two-bone character ("a" above "b") with one body per bone of `shape` and `mass_kg`,
/// jointed by a swing-twist joint "b".
pub(crate) fn pair(shape: Shape, mass_kg: f32) -> (Character, RagdollSpec) {
    let joint = |name: &str, parent, y: f32| Joint {
        name: name.into(),
        parent,
        rest: Transform::from_translation(Vec3::new(0.0, y, 0.0)),
        tip: None,
    };
    let character = Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
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
        extra_shapes: Vec::new(),
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
pub(crate) fn past(x: f32) -> f32 {
    if x >= 0.0 { x.next_up() } else { x.next_down() }
}

/// Runs `world` for `seconds` and checks it stayed finite.
pub(crate) fn run_finite(mut world: World, seconds: f32, what: &str) {
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
pub(crate) fn world_with(
    character: &Character,
    spec: &RagdollSpec,
    backend: BackendKind,
) -> (World, world::RagdollId) {
    let settings = WorldSettings {
        backend: backend.into(),
        ..Default::default()
    };
    World::with_ragdoll(character, spec, &settings).unwrap_or_else(|e| panic!("{backend:?}: {e}"))
}

pub(crate) const BACKENDS: [BackendKind; 3] = BackendKind::ALL;

/// The setting an error names and its message.
pub(crate) fn setting_of(r: ragdoll::Result<()>) -> (String, String) {
    match r {
        Err(Error::Setting { setting, message }) => (setting, message),
        other => panic!("expected a setting error, got {other:?}"),
    }
}
