//! What a simulation leaves behind: every skeleton joint's world transform for every output
//! frame, ready for the exporters, which know nothing of backends.

use crate::math::Transform;

/// Baked motion: world transforms of every skeleton joint, per frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Track {
    /// Output frames per second.
    pub fps: f32,
    /// `frames[f][j]`: world transform of skeleton joint `j` at frame `f` (scale kept from
    /// the rest pose).
    pub frames: Vec<Vec<Transform>>,
}

impl Track {
    /// Seconds between frames.
    pub fn frame_time(&self) -> f32 {
        1.0 / self.fps
    }
}
