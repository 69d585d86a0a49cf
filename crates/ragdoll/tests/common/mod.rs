//! Shared by the integration tests: where the third-party test data lives, and the
//! simplest test body.

#![allow(dead_code)] // each test binary uses its own subset

use std::path::{Path, PathBuf};

/// The shared test data folder (`$RAGDOLL_DATA`, else `../shared/data` beside the
/// repository), or `None` with a loud message when it is missing. Under CI
/// (`RAGDOLL_REQUIRE_DATA` set) a missing folder fails the test instead.
pub fn shared_data() -> Option<PathBuf> {
    let dir = std::env::var_os("RAGDOLL_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data"));
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("RAGDOLL_REQUIRE_DATA").is_some() {
        panic!("the shared test data folder {} is missing", dir.display());
    }
    eprintln!(
        "SKIPPING: the shared test data folder {} is missing",
        dir.display()
    );
    None
}

/// A one-joint character "bar" 1 m up with a single capsule body "bar" (long axis vertical):
/// the simplest rigid body to check a load or a field against a closed form.
pub fn one_capsule(
    radius_m: f32,
    length_m: f32,
    mass_kg: f32,
) -> (ragdoll::skeleton::Character, ragdoll::spec::RagdollSpec) {
    use ragdoll::math::Transform;
    use ragdoll::skeleton::{Character, Joint, Skeleton, Source};
    use ragdoll::spec::{BodySpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
    let character = Character {
        name: "bar".into(),
        skeleton: Skeleton::new(vec![Joint {
            name: "bar".into(),
            parent: None,
            rest: Transform::from_translation(glam::Vec3::new(0.0, 1.0, 0.0)),
            tip: None,
        }])
        .unwrap(),
        meshes: vec![],
        clips: vec![],
        source: Source::BuiltIn,
    };
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
        }],
        joints: vec![],
        collision: Default::default(),
    };
    (character, spec)
}
