//! Where a ragdoll may start: within the world (f32 keeps millimetres), on the rigid
//! backend's ground, and not inside another ragdoll (see `overlap.rs`).

use glam::Vec3;

use super::overlap::{self, Solid};
use super::setting_error;
use crate::backend::Backend;
use crate::error::{Error, Result};
use crate::math::Transform;
use crate::skeleton::Character;
use crate::spec::RagdollSpec;

pub use crate::bounds::MAX_COORDINATE_M;

/// Whether `p` is finite and within [`MAX_COORDINATE_M`] of the origin along every axis.
pub(crate) fn within_world(p: Vec3) -> bool {
    p.is_finite() && p.abs().max_element() <= MAX_COORDINATE_M
}

/// The error for a position outside the world.
pub(super) fn beyond_world(setting: &str, what: &str, p: Vec3) -> Error {
    // Plain below a million, else in exponent form (3e38 is 39 digits written out).
    let num = |v: f32| {
        if v.abs() < 1.0e6 {
            format!("{v}")
        } else {
            format!("{v:e}")
        }
    };
    setting_error(
        setting,
        &format!(
            "{what} at [{}, {}, {}] is beyond {MAX_COORDINATE_M} m from the origin along an \
             axis, where positions lose millimetres; keep the scene nearer the origin",
            num(p.x),
            num(p.y),
            num(p.z)
        ),
    )
}

impl super::World {
    /// Checks where the ragdoll about to be added (`body_start`: its bodies' start poses,
    /// spec order) would start, and returns its bodies' solids for the next checks.
    pub(super) fn check_start(
        &mut self,
        character: &Character,
        spec: &RagdollSpec,
        body_start: &[Transform],
    ) -> Result<Vec<Solid>> {
        if let Some((b, p)) = body_start
            .iter()
            .enumerate()
            .find(|(_, p)| !within_world(p.translation))
        {
            let what = format!(
                "ragdoll {} \"{}\"'s body \"{}\"",
                self.instances.len(),
                character.name,
                spec.bodies[b].name
            );
            return Err(beyond_world("placement", &what, p.translation));
        }
        if let Some(edge) = self.backend.ground_half_extent() {
            let off = |p: &Transform| p.translation.x.abs().max(p.translation.z.abs()) > edge;
            if let Some(b) = body_start.iter().position(off) {
                return Err(setting_error(
                    "placement",
                    &format!(
                        "ragdoll {} \"{}\"'s body \"{}\" would start beyond the edge of the \
                     backend's ground, a square {edge} m from the origin each way; \
                     place it nearer, or use the particle or fast backend (their ground has \
                     no edge)",
                        self.instances.len(),
                        character.name,
                        spec.bodies[b].name,
                    ),
                ));
            }
        }
        let solids = Solid::of_spec(spec, body_start);
        if let Some(c) = self.start_index.clash(&solids) {
            let other = &self.instances[c.other];
            return Err(Error::Setting {
                setting: "placement".into(),
                message: format!(
                    "ragdoll {} \"{}\" would start inside ragdoll {} \"{}\": its body \"{}\" \
                 and their body \"{}\" are {:.3} m apart at their axes, within {:.3} m; \
                 place the characters apart",
                    self.instances.len(),
                    character.name,
                    c.other,
                    other.name,
                    spec.bodies[c.body].name,
                    other.body_names[c.other_body],
                    c.gap_m,
                    c.radius_m,
                ),
            });
        }
        Ok(solids)
    }
}

/// Pairs of the new ragdoll's own bodies (`solids`, spec order) that start inside each
/// overlapping (they stop colliding), or the error for a body inside too many of them.
pub(super) fn overlapping_parts(
    spec: &RagdollSpec,
    solids: &[Solid],
) -> Result<Vec<(usize, usize)>> {
    overlap::overlapping_pairs(solids).map_err(|(body, count)| Error::Spec {
        place: format!("body \"{}\"", spec.bodies[body].name),
        message: format!(
            "starts inside {count} other bodies of its ragdoll (one's axis inside the other), \
             more than the {} a body may: rapier's cost for a pile grows with the cube of its \
             size; spread the bodies out",
            overlap::MAX_DEEP_OVERLAPS
        ),
    })
}
