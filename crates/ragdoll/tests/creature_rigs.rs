//! Creature rigs as their tools lay them out, built here and turned four ways: a spider
//! whose hub bone carries skin and has no length of its own (all eight legs start at its
//! joint), and whose deform feet and pole targets an IK rig parents to the root. The hub
//! gets a body, each foot joins its own shin where it sits, the poles get none, and
//! dropped on every backend it lands whole.
//!
//! Before, the hub had no body, its skin and all eight legs hung from the first leg, and
//! the eight feet were joined to that leg half a metre away: `fast` opened joints 12 cm.

mod rigid_parts_files;

use std::path::PathBuf;

use glam::Vec3;
use ragdoll::backend::BackendKind;
use ragdoll::import::{self, ImportOptions};
use ragdoll::math::Transform;
use ragdoll::skeleton::Character;
use ragdoll::spec::{BuildOptions, RagdollSpec, build_spec};
use ragdoll::world::{World, WorldSettings};
use rigid_parts_files::{bones_glb, spider};

const FACINGS: [f32; 4] = [0.0, 90.0, 180.0, 270.0];

fn load_as(name: &str, bytes: &[u8]) -> Character {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let k = N.fetch_add(1, Ordering::Relaxed);
    let dir: PathBuf =
        std::env::temp_dir().join(format!("ragdoll-creature-{}-{k}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    let c = import::load(&path, &ImportOptions::default()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    c
}

/// The parent body's bone of each joint's body, by bone name.
fn parent_of<'a>(spec: &'a RagdollSpec, bone: &str) -> Option<&'a str> {
    let body = spec.bodies.iter().find(|b| b.bone == bone)?;
    let joint = spec.joints.iter().find(|j| j.child == body.name)?;
    let parent = spec.bodies.iter().find(|b| b.name == joint.parent)?;
    Some(parent.bone.as_str())
}

#[test]
fn a_spiders_hub_has_a_body_and_its_ik_feet_join_their_shins() {
    for facing in FACINGS {
        let label = format!("spider facing {facing}°");
        let c = load_as("spider.glb", &bones_glb(&spider(), facing));
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        let has_body = |bone: &str| spec.bodies.iter().any(|b| b.bone == bone);
        assert!(has_body("Body"), "{label}: the hub has no body");
        assert!(!has_body("Root"), "{label}: the root carries no skin");
        for k in 0..4 {
            for s in ["L", "R"] {
                let (femur, shin, foot) = (
                    format!("Femur{k}.{s}"),
                    format!("Shin{k}.{s}"),
                    format!("Foot{k}.{s}"),
                );
                assert!(
                    !has_body(&format!("Pole{k}.{s}")),
                    "{label}: a pole has a body"
                );
                assert_eq!(parent_of(&spec, &femur), Some("Body"), "{label}: {femur}");
                assert_eq!(
                    parent_of(&spec, &shin),
                    Some(femur.as_str()),
                    "{label}: {shin}"
                );
                assert_eq!(
                    parent_of(&spec, &foot),
                    Some(shin.as_str()),
                    "{label}: {foot}"
                );
            }
        }
    }
}

/// Dropped from 30 cm for 4 s, on every backend: its joints hold (within a centimetre,
/// as the creature drops hold theirs), nothing sinks, and on `rigid` and `fast` it comes to
/// rest.
#[test]
fn a_spider_with_ik_feet_lands_whole_on_every_backend() {
    for facing in FACINGS {
        let c = load_as("spider.glb", &bones_glb(&spider(), facing));
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        for backend in BackendKind::ALL {
            let what = format!("spider facing {facing}° on {backend:?}");
            let settings = WorldSettings {
                backend,
                ..Default::default()
            };
            let mut world = World::new(&settings).unwrap();
            let id = world
                .add_ragdoll(&c, &spec, Transform::from_translation(Vec3::Y * 0.3))
                .unwrap();
            world.run(4.0);
            let m = world.metrics();
            println!("{what}: {m:?}");
            assert!(!m.nan, "{what}");
            // rapier's soft joints open up to 12-13 mm in the README's piles.
            let joint_gap = if backend == BackendKind::Rigid {
                0.015
            } else {
                0.01
            };
            assert!(m.max_joint_separation_m < joint_gap, "{what}: {m:?}");
            assert!(m.max_penetration_m < 0.03, "{what}: {m:?}");
            // A known gap, as for the spider of `creature_drops.rs`: the world's limit clamp
            // turns legs the solver left past their cones back into the floor, which lifts
            // the spider a little: 0.003-6.7 % energy gained over the four facings and three
            // backends. The bound is ten times a passive drop's 1 %, two orders of
            // magnitude under what a torn ragdoll gains (the spider: 1,383×).
            assert!(m.energy_drift < 0.1, "{what}: {m:?}");
            let speed = world
                .body_velocities(id)
                .iter()
                .map(|(v, _)| v.length())
                .fold(0.0f32, f32::max);
            println!("  fastest body at the end: {speed:.3} m/s");
            // The particle backend's spider still rocks on its legs at 4 s (0.21 m/s at
            // most here, 0.4 m/s for `creature_drops.rs`' spider): a known gap.
            if backend != BackendKind::Particle {
                assert!(speed < 0.2, "{what}: still moving at {speed} m/s");
            }
        }
    }
}
