//! Pushes, fields and pins: what they do to the bodies over one substep.

use crate::backend::BodyImpulse;
use crate::backend::{BodyId, Command, PinId};
use glam::Vec3;

use crate::events::{Field, Pin, Push};

use super::{RagdollId, setting_error};
use crate::backend::Backend;
use crate::error::{Error, Result};

/// Air density at sea level, kg/m³ (ISA).
pub(crate) const AIR_DENSITY: f32 = 1.225;

/// A push resolved onto a body: global body index and the point in the body's frame.
#[derive(Clone, Debug)]
pub(crate) struct ActivePush {
    pub push: Push,
    pub body: usize,
    pub local: Vec3,
    pub done: bool,
}

/// Handle of a drag started with [`super::World::drag_start`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct DragId(usize);

/// A pin resolved onto a body.
#[derive(Clone, Debug)]
pub(crate) struct ActivePin {
    pub pin: Pin,
    pub body: usize,
    pub local: Vec3,
    /// The pinned body's mass, kg (a soft pin is a spring per unit of it).
    pub mass: f32,
    /// The backend's pin index once created (pins start with the world).
    pub handle: Option<PinId>,
    pub released: bool,
}

/// Linear interpolation of `(time, value)` keys, held before the first and after the last.
pub(crate) fn sample_keys(keys: &[(f32, Vec3)], t: f32) -> Vec3 {
    match keys {
        [] => Vec3::ZERO,
        [(_, v)] => *v,
        _ => {
            if t <= keys[0].0 {
                return keys[0].1;
            }
            for w in keys.windows(2) {
                let ((t0, a), (t1, b)) = (w[0], w[1]);
                if t <= t1 {
                    let f = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
                    return a.lerp(b, f);
                }
            }
            keys[keys.len() - 1].1
        }
    }
}

/// Overlap of `[a0, a1]` with `[b0, b1]`, seconds.
pub(crate) fn overlap(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    (a1.min(b1) - a0.max(b0)).max(0.0)
}

/// The impulse a field gives one body over `[t0, t1]` (constant over the substep).
///
/// `area_along` gives the body's silhouette area seen along a direction (for wind).
pub(crate) fn field_impulse(
    field: &Field,
    t0: f64,
    t1: f64,
    mass: f32,
    position: Vec3,
    velocity: Vec3,
    area_along: impl Fn(Vec3) -> f32,
) -> Vec3 {
    match field {
        // Gravity fields change the world's gravity instead.
        Field::Gravity { .. } => Vec3::ZERO,
        Field::Radial {
            center,
            strength_mps2,
            radius_m,
            start_s,
            end_s,
        } => {
            let dt = overlap(t0, t1, *start_s as f64, *end_s as f64) as f32;
            let offset = position - *center;
            let d = offset.length();
            if dt <= 0.0 || d >= *radius_m {
                return Vec3::ZERO;
            }
            let dir = if d > 1e-6 { offset / d } else { Vec3::Y };
            dir * (strength_mps2 * (1.0 - d / radius_m) * mass * dt)
        }
        Field::Drag {
            rate_per_s,
            start_s,
            end_s,
        } => {
            let dt = overlap(t0, t1, *start_s as f64, *end_s as f64) as f32;
            // Never more than stops the body within the substep.
            -velocity * mass * (rate_per_s * dt).min(1.0)
        }
        Field::Wind {
            velocity_mps,
            start_s,
            end_s,
        } => {
            let dt = overlap(t0, t1, *start_s as f64, *end_s as f64) as f32;
            let rel = *velocity_mps - velocity;
            let speed = rel.length();
            if dt <= 0.0 || speed < 1e-6 {
                return Vec3::ZERO;
            }
            let area = area_along(rel / speed);
            let drag = 0.5 * AIR_DENSITY * super::blast::DRAG_COEFFICIENT as f32 * area * speed;
            // Never more than brings the body to the wind's speed within the substep.
            rel * (drag * dt).min(mass)
        }
    }
}

impl super::World {
    /// Adds a push (impulse or force) on a body part of ragdoll `id`.
    pub fn add_push(&mut self, id: RagdollId, push: crate::events::Push) -> Result<()> {
        push.validate()?;
        self.push_unchecked(id, push)
    }

    /// [`Self::add_push`] without the bounds: tests reach past what f32 survives with it.
    fn push_unchecked(&mut self, id: RagdollId, push: crate::events::Push) -> Result<()> {
        use crate::events::Push;
        let (Push::Impulse { target, .. } | Push::Force { target, .. }) = &push;
        let (body, local) = self.resolve_target(id, target)?;
        self.pushes.push(ActivePush {
            push,
            body,
            local,
            done: false,
        });
        Ok(())
    }

    /// Adds a force field acting on every ragdoll.
    pub fn add_field(&mut self, field: crate::events::Field) -> Result<()> {
        field.validate()?;
        self.fields.push(field);
        Ok(())
    }

    /// Pins a body part of ragdoll `id` (see [`crate::events::Pin`]). Pins act from the
    /// start until released.
    pub fn add_pin(&mut self, id: RagdollId, pin: crate::events::Pin) -> Result<()> {
        pin.validate()?;
        let (body, local) = self.resolve_target(id, &pin.target)?;
        self.pins.push(ActivePin {
            pin,
            body,
            local,
            mass: self.body_mass(body),
            handle: None,
            released: false,
        });
        Ok(())
    }

    /// Starts dragging body `body` (spec order) of ragdoll `id` by the point `local` (in
    /// the body's frame) toward `target` (world space): a soft pin, a damped spring of
    /// natural frequency `stiffness_hz` and damping ratio `damping_ratio`, whose target
    /// [`Self::drag_move`] moves at run time (a viewer's mouse). Unlike [`Self::add_pin`]'s
    /// keyed path, the target is whatever was set last, so it can follow input that is not
    /// known in advance. The rest of the ragdoll follows through its joints.
    ///
    /// ```
    /// use glam::Vec3;
    /// use ragdoll::{skeleton, spec, world::{World, WorldSettings}};
    ///
    /// let character = skeleton::humanoid();
    /// let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
    /// let (mut world, id) = World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    /// world.run(0.0); // records the first frame, so poses can be read
    /// let head = spec.body_index("head").unwrap();
    /// let start = world.body_poses(id)[head].translation;
    /// let drag = world.drag_start(id, head, Vec3::ZERO, start, 4.0, 1.0).unwrap();
    /// world.drag_move(drag, start + Vec3::new(0.0, 0.5, 0.0)).unwrap(); // lift the head
    /// world.run(1.0);
    /// // The body hangs from its head (which sags below the target under the body's
    /// // weight) instead of slumping onto the ground.
    /// assert!(world.body_poses(id)[head].translation.y > start.y + 0.15);
    /// world.drag_end(drag);
    /// ```
    pub fn drag_start(
        &mut self,
        id: RagdollId,
        body: usize,
        local: Vec3,
        target: Vec3,
        stiffness_hz: f32,
        damping_ratio: f32,
    ) -> Result<DragId> {
        let inst = &self.instances[id.0];
        let Some(name) = inst.body_names.get(body) else {
            return Err(setting_error(
                "drag",
                &format!("{} has no body number {body}", inst.name),
            ));
        };
        if !(super::within_world(local) && super::within_world(target)) {
            return Err(super::beyond_world("drag", "the drag's target", target));
        }
        let spring_ok = stiffness_hz.is_finite()
            && stiffness_hz > 0.0
            && damping_ratio.is_finite()
            && damping_ratio >= 0.0;
        if !spring_ok {
            return Err(setting_error(
                "drag",
                "stiffness must be positive Hz, damping zero or positive",
            ));
        }
        let pin = crate::events::Pin {
            target: name.clone(),
            keys: vec![(0.0, target)],
            stiffness_hz: Some(stiffness_hz),
            damping_ratio,
            release_s: None,
        };
        pin.validate()?;
        let mass = inst.masses[body];
        self.pins.push(ActivePin {
            pin,
            body: inst.first_body + body,
            local,
            mass,
            handle: None,
            released: false,
        });
        Ok(DragId(self.pins.len() - 1))
    }

    /// Moves a drag's target (world space, metres); takes effect from the next step.
    /// Errors when the drag has ended or the target is not finite.
    pub fn drag_move(&mut self, drag: DragId, target: Vec3) -> Result<()> {
        if !super::within_world(target) {
            return Err(super::beyond_world("drag", "the drag's target", target));
        }
        match self.pins.get_mut(drag.0) {
            Some(p) if !p.released => {
                p.pin.keys = vec![(0.0, target)];
                Ok(())
            }
            _ => Err(setting_error("drag", "this drag has ended")),
        }
    }

    /// Lets go of a drag: from the next step the body moves freely. Ending a drag twice
    /// does nothing.
    pub fn drag_end(&mut self, drag: DragId) {
        if let Some(p) = self.pins.get_mut(drag.0) {
            p.released = true;
        }
    }

    /// The body a name refers to (a skeleton joint, on the body it rides on; or a body of
    /// the spec, at its centre) and the point it names in that body's frame.
    pub(super) fn resolve_target(&self, id: RagdollId, target: &str) -> Result<(usize, Vec3)> {
        let inst = &self.instances[id.0];
        // A joint first (its position is what "pin the wrist" means), then a body (its
        // centre): the built-in humanoid's bodies and joints share their names.
        if let Some(j) = inst.joint_labels.iter().position(|n| n == target) {
            let r = &inst.riders[j];
            return Ok((inst.first_body + r.body, r.offset.translation));
        }
        if let Some(b) = inst.body_names.iter().position(|n| n == target) {
            return Ok((inst.first_body + b, Vec3::ZERO));
        }
        Err(Error::Setting {
            setting: "target".into(),
            message: format!("{} has no body or joint named \"{target}\"", inst.name),
        })
    }

    /// Applies pushes, fields and pins over `[t0, t1]`.
    pub(super) fn apply_forces(&mut self, t0: f64, t1: f64) {
        use crate::events::Field;
        // Gravity fields replace the world's gravity while there are any.
        if let Some(g) = self.fields.iter().rev().find_map(|f| match f {
            Field::Gravity { keys } => Some(sample_keys(keys, (0.5 * (t0 + t1)) as f32)),
            _ => None,
        }) {
            self.backend.apply(&[Command::Gravity(g)]);
        }
        self.apply_pushes(t0, t1);
        if self
            .fields
            .iter()
            .any(|f| !matches!(f, Field::Gravity { .. }))
        {
            self.apply_fields(t0, t1);
        }
        self.apply_pins(t0, t1);
    }

    /// Each push's share of `[t0, t1]`: an impulse once its time has come, a force for
    /// the part of its span inside the interval.
    fn apply_pushes(&mut self, t0: f64, t1: f64) {
        use crate::events::Push;
        for p in &mut self.pushes {
            if p.done {
                continue;
            }
            let state = &self.states[p.body];
            let point = state.pose.transform_point(p.local);
            let impulse = match &p.push {
                Push::Impulse {
                    impulse_ns, time_s, ..
                } => {
                    if (*time_s as f64) >= t1 {
                        continue;
                    }
                    p.done = true;
                    *impulse_ns
                }
                Push::Force {
                    force_n,
                    start_s,
                    end_s,
                    ..
                } => {
                    if (*end_s as f64) < t0 {
                        p.done = true;
                        continue;
                    }
                    *force_n * overlap(t0, t1, *start_s as f64, *end_s as f64) as f32
                }
            };
            if impulse != Vec3::ZERO {
                self.impulses.push(BodyImpulse::AtPoint {
                    body: BodyId(p.body),
                    impulse,
                    point,
                });
            }
        }
    }

    /// The force fields other than gravity (radial, drag, wind) on every body of every
    /// active ragdoll, at its centre.
    fn apply_fields(&mut self, t0: f64, t1: f64) {
        for inst in self.instances.iter().filter(|i| i.active && !i.removed) {
            for (k, shape) in inst.shapes.iter().enumerate() {
                let state = self.states[inst.first_body + k];
                let mut impulse = Vec3::ZERO;
                for f in &self.fields {
                    impulse += field_impulse(
                        f,
                        t0,
                        t1,
                        inst.masses[k],
                        state.pose.translation,
                        state.linvel,
                        |dir| super::blast::projected_area(&state, shape, dir),
                    );
                }
                if impulse != Vec3::ZERO {
                    self.impulses.push(BodyImpulse::AtPoint {
                        body: BodyId(inst.first_body + k),
                        impulse,
                        point: state.pose.translation,
                    });
                }
            }
        }
    }

    /// Pins: released when their time comes; a hard pin moves its anchor along its path,
    /// a soft one pulls as a damped spring.
    fn apply_pins(&mut self, t0: f64, t1: f64) {
        for p in &mut self.pins {
            if p.released {
                continue;
            }
            if p.pin.release_s.is_some_and(|r| (r as f64) <= t0) {
                if let Some(handle) = p.handle {
                    self.backend.apply(&[Command::ReleasePin(handle)]);
                }
                p.released = true;
                continue;
            }
            let target = sample_keys(&p.pin.keys, t1 as f32);
            match p.pin.stiffness_hz {
                // Hard: a ball joint to a kinematic anchor moved along the path.
                None => match p.handle {
                    None => {
                        p.handle = Some(self.backend.add_pin(BodyId(p.body), p.local, target, None))
                    }
                    Some(handle) => self.backend.apply(&[Command::MovePin {
                        pin: handle,
                        target,
                    }]),
                },
                // Soft: a damped spring on the pinned point, as an impulse per substep
                // (rapier's soft joints are regularised constraints, not springs of a
                // given frequency).
                Some(hz) => {
                    let state = &self.states[p.body];
                    let point = state.pose.transform_point(p.local);
                    let point_velocity =
                        state.linvel + state.angvel.cross(point - state.pose.translation);
                    let omega = std::f32::consts::TAU * hz;
                    let accel = (target - point) * omega * omega
                        - point_velocity * (2.0 * p.pin.damping_ratio * omega);
                    let impulse = accel * p.mass * (t1 - t0) as f32;
                    self.impulses.push(BodyImpulse::AtPoint {
                        body: BodyId(p.body),
                        impulse,
                        point,
                    });
                }
            }
        }
    }

    /// Mass of body `index` (global), kg.
    pub(super) fn body_mass(&self, index: usize) -> f32 {
        self.instances
            .iter()
            .find(|i| (i.first_body..i.first_body + i.masses.len()).contains(&index))
            .map_or(1.0, |i| i.masses[index - i.first_body])
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::events::Push;
    use crate::world::{BackendKind, World, WorldSettings};

    // Pushes past the bounds (they go through `push_unchecked`): the only way left to make
    // a run go non-finite on purpose, now that every input is bounded.
    #[test]
    fn a_run_that_goes_non_finite_is_flagged_and_holds_its_last_finite_pose() {
        for backend in BackendKind::ALL {
            let character = crate::skeleton::humanoid();
            let spec = crate::spec::build_spec(&character, &Default::default()).unwrap();
            let settings = WorldSettings {
                backend: backend.into(),
                ..Default::default()
            };
            let (mut world, id) = World::with_ragdoll(&character, &spec, &settings).unwrap();
            // Finite, but past what f32 arithmetic survives: the joints between two parts
            // flung apart at 1e37 m/s overflow.
            for (target, x) in [("pelvis", 3.0e38), ("head", -3.0e38)] {
                let push = Push::Impulse {
                    target: target.into(),
                    impulse_ns: Vec3::new(x, 0.0, 0.0),
                    time_s: 0.05,
                };
                world.push_unchecked(id, push).unwrap();
            }
            world.run(0.5);
            assert!(world.metrics().nan, "{backend:?}: {:?}", world.metrics());
            assert!(
                world
                    .body_poses(id)
                    .iter()
                    .all(|p| p.translation.is_finite() && p.rotation.is_finite()),
                "{backend:?}"
            );
            assert!((world.time() - 0.5).abs() < 1e-6, "the clock ran on");
            let track = world.track(id);
            assert_eq!(track.frames.len(), 16);
            assert!(
                track
                    .frames
                    .iter()
                    .flatten()
                    .all(|t| t.translation.is_finite() && t.rotation.is_finite()),
                "{backend:?}: a recorded frame is not finite"
            );
        }
    }
}
