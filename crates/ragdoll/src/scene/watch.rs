//! What a scene watches of each character, step by step, for its entry in the report:
//! what the world measures only for the whole scene.

use super::SceneCharacter;
use crate::report::{AIRBORNE_CLEARANCE_M, CharacterReport};
use crate::spec::Role;
use crate::track::Track;
use crate::world::{RagdollId, World};

/// One g, m/s² (ISO 80000-3).
const STANDARD_GRAVITY_MPS2: f32 = 9.80665;

/// What a scene watches of one character, step by step, while it is physical: what the
/// world measures only for the whole scene.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Watch {
    violation_deg: f32,
    separation_m: f32,
    max_speed_mps: f32,
    airborne_s: f32,
    /// The head body's velocity after the last step watched, and the most acceleration
    /// beyond gravity seen so far, m/s².
    head_velocity: Option<glam::Vec3>,
    head_accel: f32,
}

impl Watch {
    /// Takes in character `c` (ragdoll `id`) after a step of `dt` seconds over `ground`.
    pub(super) fn observe(
        &mut self,
        world: &World,
        id: RagdollId,
        c: &SceneCharacter,
        ground: Option<f32>,
        gravity: glam::Vec3,
        dt: f32,
    ) {
        if world.activated_at(id).is_none() {
            return;
        }
        let velocities = world.body_velocities(id);
        let head = c
            .spec
            .bodies
            .iter()
            .position(|b| b.role == Some(Role::Head));
        if let Some((v, _)) = head.and_then(|h| velocities.get(h)) {
            // What an accelerometer in the head reads: its change of velocity less what
            // gravity alone would have made (a free fall reads nothing).
            if let Some(before) = self.head_velocity {
                let felt = ((*v - before) / dt - gravity).length();
                self.head_accel = self.head_accel.max(felt);
            }
            self.head_velocity = Some(*v);
        }
        for (sep, viol) in world.joint_errors(id) {
            self.violation_deg = self.violation_deg.max(viol);
            self.separation_m = self.separation_m.max(sep);
            if !(sep.is_finite() && viol.is_finite()) {
                (self.violation_deg, self.separation_m) = (f32::INFINITY, f32::INFINITY);
            }
        }
        let (mut momentum, mut mass) = (glam::Vec3::ZERO, 0.0f32);
        for (b, (v, _)) in c.spec.bodies.iter().zip(velocities) {
            momentum += v * b.mass_kg;
            mass += b.mass_kg;
        }
        if mass > 0.0 {
            self.max_speed_mps = self.max_speed_mps.max((momentum / mass).length());
        }
        if let Some(g) = ground {
            let lowest = c
                .spec
                .bodies
                .iter()
                .zip(world.body_poses(id))
                .map(|(b, pose)| b.shape.lowest_y(&pose))
                .fold(f32::INFINITY, f32::min);
            if lowest > g + AIRBORNE_CLEARANCE_M {
                self.airborne_s += dt;
            }
        }
    }
}

/// Assembles character `c`'s entry in the report from its run.
pub(super) fn character_report(
    c: &SceneCharacter,
    track: &Track,
    activated_at_s: Option<f64>,
    watch: &Watch,
    ground: Option<f32>,
    bvh: Option<String>,
) -> CharacterReport {
    let (max_limit_violation_deg, max_joint_separation_m) =
        (watch.violation_deg, watch.separation_m);
    let finite = max_limit_violation_deg.is_finite()
        && max_joint_separation_m.is_finite()
        && track.frames.iter().flatten().all(|t| t.is_finite());
    CharacterReport {
        name: c.name.clone(),
        input: c.input.clone(),
        position: c.position.to_array(),
        facing_deg: c.facing_deg,
        activated_at_s,
        bodies: c.spec.bodies.len(),
        joints: c.spec.joints.len(),
        skeleton_joints: track.frames.first().map_or(0, |f| f.len()),
        total_mass_kg: c.spec.total_mass_kg(),
        height_m: crate::import::standing_height(&c.character),
        // JSON has no infinity or NaN: serde_json writes those as `null`, and `nan` says
        // why.
        max_limit_violation_deg,
        max_joint_separation_m,
        max_speed_mps: watch.max_speed_mps,
        airborne_s: ground.map(|_| watch.airborne_s),
        peak_head_accel_g: watch
            .head_velocity
            .map(|_| watch.head_accel / STANDARD_GRAVITY_MPS2),
        nan: !finite,
        bvh,
    }
}
