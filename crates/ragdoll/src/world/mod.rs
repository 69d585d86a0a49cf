//! The runtime half: a [`World`] made from a [`RagdollSpec`](crate::spec::RagdollSpec).
// OWNER: lead; placeholder until the rigid backend lands.

use crate::error::Result;
use crate::skeleton::Character;
use crate::spec::RagdollSpec;
use crate::track::Track;

/// World settings.
#[derive(Clone, Debug, Default)]
pub struct WorldSettings {}

/// A simulated world.
pub struct World {
    track: Track,
}

impl World {
    /// Creates a world.
    pub fn new(character: &Character, spec: &RagdollSpec, settings: &WorldSettings) -> Result<Self> {
        let _ = (character, spec, settings);
        todo!()
    }
    /// Runs for `seconds`.
    pub fn run(&mut self, seconds: f32) {
        let _ = seconds;
    }
    /// The baked track.
    pub fn into_track(self) -> Track {
        self.track
    }
}
