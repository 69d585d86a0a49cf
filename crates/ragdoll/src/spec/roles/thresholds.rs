//! The thresholds of role recognition, as fractions of the standing height H unless said
//! otherwise: each a measurement of real bodies or rigs, kept together so that one
//! threshold's reason is read next to the others'.

/// A leg's lowest point is within this of the ground: feet stand on it in a rest pose,
/// with room for a raised foot or a thick sole.
pub(super) const LEG_GROUND_TOLERANCE_H: f32 = 0.15;
/// Legs hang at least this far below the pelvis (about half of H on real people).
pub(super) const LEG_MIN_DROP_H: f32 = 0.3;
/// A limb stood on hangs from a joint at least this fraction of the skeleton's extent
/// above the ground: a dog's hips (a third of its 1.5 m extent), a dachshund's (0.15 m of
/// 0.9); a person lying flat has nothing higher than about a tenth.
pub(super) const LIMB_MIN_DROP_OF_EXTENT: f32 = 0.12;
/// A skeleton standing on this many limbs or more is a creature, not a person lying down.
pub(super) const STANDING_LIMBS_OF_A_CREATURE: usize = 4;
/// Joints walked up from a foot (or a fingertip) looking for where its limb branches off:
/// an arm with its fingers has eight; the bound keeps a 65,536-deep chain linear.
pub(super) const MAX_LIMB_WALK: usize = 16;
/// Legs do not rise more than this above the pelvis joint (CMU's buttock joints sit a
/// little above it).
pub(super) const LEG_MAX_RISE_H: f32 = 0.1;
/// The spine chain rises at least this far above the pelvis (the head is ~0.45 H above).
pub(super) const SPINE_MIN_RISE_H: f32 = 0.25;
/// Largest angle of the pelvis→chest line from vertical for a standing humanoid; a
/// quadruped's back is near horizontal.
pub(super) const SPINE_MAX_TILT_DEG: f32 = 40.0;
/// An arm's joints are on average at least this far from the mid-plane (shoulders are
/// about 0.1 H out).
pub(super) const ARM_MIN_LATERAL_H: f32 = 0.06;
/// Arms stop at least this far above the ground (fingertips hang at ~0.38 H); front legs
/// of a quadruped reach it.
pub(super) const ARM_MIN_CLEARANCE_H: f32 = 0.2;
/// An arm chain (shoulder to fingertip ≈ 0.4 H) is at least this long.
pub(super) const ARM_MIN_LENGTH_H: f32 = 0.2;
/// Mirror limbs differ in length by at most this fraction.
pub(super) const LIMB_LENGTH_TOLERANCE: f32 = 0.25;
/// The legs' centres are at least this far apart sideways, else there is no left/right.
pub(super) const MIN_LEG_SEPARATION_H: f32 = 0.02;
/// A facing cue (feet, knees) must be at least this big to be trusted.
pub(super) const FORWARD_CUE_MIN_H: f32 = 0.01;
/// Feet must point mostly forward (|forward part| / |horizontal part|) to be a cue;
/// a sideways foot says nothing.
pub(super) const FOOT_CUE_MIN_ALIGNMENT: f32 = 0.5;
/// Non-humanoid bones shorter than this fraction of the skeleton's extent AND shorter
/// than [`CHAIN_MIN_MEDIAN_FRACTION`] of the median bone ride on their parent: too short
/// to be stable bodies (end sites, toe nubs, helper offsets).
pub(super) const CHAIN_MIN_EXTENT_FRACTION: f32 = 0.03;
/// See [`CHAIN_MIN_EXTENT_FRACTION`].
pub(super) const CHAIN_MIN_MEDIAN_FRACTION: f32 = 0.25;
/// A leaf without an end site is assumed to continue its parent bone for this fraction
/// of the parent's length (tails and fingers taper).
pub(crate) const LEAF_LENGTH_FRACTION: f32 = 0.5;
/// A joint counts as skinned when its vertex weights add up to at least this (half a
/// vertex): joints nothing is weighted to are helpers (Fox's `_rootJoint`, `b_Root_00`).
pub(super) const MIN_SKIN_WEIGHT: f32 = 0.5;
