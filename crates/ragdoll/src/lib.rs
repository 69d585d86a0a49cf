//! Turns any character into a physically simulated ragdoll and bakes what happens to it
//! into animation files.
//!
//! The pipeline, one module per stage:
//!
//! ```text
//! import ──► skeleton::Character ──► spec::RagdollSpec ──► world::World ──► track::Track ──► export
//! (BVH, glTF,  joints, rest pose,     bodies, shapes,        steps the        per-frame joint   glTF, BVH,
//!  OBJ,        skin, clips            masses, joints         backend          world transforms  report
//!  built-in)
//! ```
//!
//! A mesh that comes without a skeleton (an OBJ, a glTF without a skin) is given one on
//! import by [`rig`]: a spine along its centre line, optional mirrored limbs, automatic
//! skin weights.
//!
//! # Conventions
//!
//! Right-handed, Y up, metres, kilograms, seconds, radians. Degrees appear only in
//! user-facing fields whose names end in `_deg`. Importers convert units and up axes at
//! the edge; nothing past them sees centimetres or Z up.
//!
//! # Example
//!
//! ```
//! use ragdoll::{skeleton, spec, world::{World, WorldSettings}};
//!
//! let character = skeleton::humanoid();
//! let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
//! let (mut world, _id) = World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
//! world.run(0.5);
//! assert!(!world.metrics().nan);
//! let track = world.into_track();
//! assert_eq!(track.frames.len(), 16); // 0.5 s at 30 fps, plus the first frame
//! ```
//!
//! # Note
//!
//! Three backends, each configured by one variant of [`backend::BackendConfig`]: rigid
//! (rapier3d, the default and the reference), fast (our own rigid-body solver for
//! ragdolls and crowds) and particle (our XPBD particle ragdoll); see [`backend`]. Preview pictures are drawn by the separate
//! `ragdoll-preview` crate, the interactive viewer is `ragdoll-view`. Powered mode
//! (`world::Motors`) tracks mocap within 5° with the root on the clip.
//!
//! Events ([`events`]): blasts, projectiles, pushes, fields, pins, and animation hand-over
//! ([`world::Activation`]); scene files ([`scene`]) put characters and events together.
#![deny(missing_docs)]

pub mod backend;
pub mod bounds;
pub mod error;
pub mod events;
pub mod export;
pub mod files;
pub(crate) mod geometry;
pub mod import;
pub mod math;
pub mod report;
pub mod rig;
pub mod scene;
pub mod skeleton;
pub mod spec;
pub mod track;
pub mod world;

pub use error::{Error, Result};
