//! Taking a ragdoll out of a world between two steps (a game's character leaving the
//! level, a script done with one): the backend stops simulating it, nothing meets it, the
//! world's events, motors and metrics pass it by, and its track holds its last pose so
//! that every track keeps one frame per output frame. The others' ids stay valid.

use super::{RagdollId, World};
use crate::backend::BodyId;
use crate::backend::{Backend, BodyImpulse, Command};
use crate::error::{Error, Result};

impl World {
    /// Takes ragdoll `id` out of the world from the next step (see the module's notes).
    /// Its bodies stay where they are and its track holds its last pose; the memory it
    /// holds is kept until the world is dropped.
    ///
    /// Fails when `id` is not a ragdoll of this world, was removed already, or the backend
    /// cannot remove ragdolls (each built-in one can; see [`Backend::remove_ragdoll`]).
    ///
    /// # Example
    ///
    /// ```
    /// use ragdoll::world::{World, WorldSettings};
    ///
    /// let character = ragdoll::skeleton::humanoid();
    /// let spec = ragdoll::spec::build_spec(&character, &Default::default())?;
    /// let mut world = World::new(&WorldSettings::default())?;
    /// let id = world.add_ragdoll(&character, &spec, Default::default())?;
    /// world.run(0.5);
    /// world.remove_ragdoll(id)?;
    /// world.run(0.5);
    /// assert_eq!(world.track(id).frames.len(), 31);
    /// # Ok::<(), ragdoll::error::Error>(())
    /// ```
    pub fn remove_ragdoll(&mut self, id: RagdollId) -> Result<()> {
        let refuse = |message: String| Error::Setting {
            setting: "ragdoll".into(),
            message,
        };
        let Some(inst) = self.instances.get(id.0) else {
            return Err(refuse(format!(
                "there is no ragdoll {} to remove: the world holds {}",
                id.0,
                self.instances.len()
            )));
        };
        if inst.removed {
            return Err(refuse(format!(
                "ragdoll {} \"{}\" was removed already",
                id.0, inst.name
            )));
        }
        let bodies = inst.first_body..inst.first_body + inst.masses.len();
        if !self.backend.remove_ragdoll(BodyId(inst.first_body)) {
            return Err(refuse(
                "this backend cannot remove ragdolls; the built-in ones can".into(),
            ));
        }
        for p in self.pins.iter_mut().filter(|p| bodies.contains(&p.body)) {
            if !p.released {
                if let Some(handle) = p.handle {
                    self.backend.apply(&[Command::ReleasePin(handle)]);
                }
                p.released = true;
            }
        }
        let inst = &mut self.instances[id.0];
        inst.removed = true;
        // Its bodies stay put, so its frames repeat its last pose.
        // No clip to play and no motors to drive: the world's per-step work passes it by.
        inst.active = true;
        inst.motors = None;
        // Energy left with it; the drift is measured from the next frame on.
        self.start_energy = None;
        self.last_frame_energy = None;
        self.backend.body_states(&mut self.states);
        if self.frames_recorded == 0 {
            // Before the first step the start check's index holds it: its place is free.
            self.index_present_bodies();
        }
        Ok(())
    }

    /// Drops the impulses the events gave bodies of removed ragdolls (a blast reaches
    /// every body in its range; the backend must not move a removed one).
    pub(super) fn drop_impulses_on_removed(&mut self) {
        if !self.instances.iter().any(|i| i.removed) {
            return;
        }
        let mut removed = vec![false; self.states.len()];
        for inst in self.instances.iter().filter(|i| i.removed) {
            let bodies = inst.first_body..inst.first_body + inst.masses.len();
            if let Some(r) = removed.get_mut(bodies) {
                r.fill(true);
            }
        }
        let kept: Vec<BodyImpulse> = self
            .impulses
            .iter()
            .filter(|imp| {
                let (BodyImpulse::AtPoint { body, .. } | BodyImpulse::Angular { body, .. }) = **imp;
                !removed.get(body.0).copied().unwrap_or(false)
            })
            .copied()
            .collect();
        self.impulses = kept;
    }
}
