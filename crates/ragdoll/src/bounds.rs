//! The bounds a world and the events acting on it share: how long a run lasts, how strong
//! gravity and fields may be, how far from the origin anything may be placed. They live
//! apart from both so that the events (which check their times and places against them)
//! do not depend on the world that runs them.

/// Farthest any position given to a world may lie from the origin along an axis, metres:
/// bodies at the start, pins and drags, charges, shots. f32 positions keep about a
/// millimetre there (the spacing of f32 at 10 km is 1 mm); a ragdoll placed at 1,000 km
/// came apart on the particle backend (6 cm spacing), and one at 2^32 m made non-finite
/// frames. (On the rigid backend ragdolls must also start on its ground, a 1 km square.)
pub const MAX_COORDINATE_M: f32 = 1.0e4;

/// Longest run, seconds: an hour, as the CLI's `--seconds` and a scene's `duration_s`.
/// Every event time and key lies within it.
pub const MAX_SECONDS: f32 = 3600.0;

/// Strongest gravity (and any field's acceleration), m/s²: about 100 g. Jupiter's is
/// 25 m/s²; at 100 g a humanoid still lands with contacts within 6 cm on both backends.
pub const MAX_GRAVITY_MPS2: f32 = 1000.0;
