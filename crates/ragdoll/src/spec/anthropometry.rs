//! Body-segment data: how heavy each segment is, how far each joint bends, and how thick
//! a limb is when there is no mesh to measure. Every number here has a source or a reason;
//! `build.rs` only combines them.

/// Mass of each body segment as a percentage of total body mass.
///
/// Limb entries are for ONE side; [`SegmentMassFractions::total_percent`] counts them twice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentMassFractions {
    /// Head and neck together, down to the seventh cervical vertebra.
    pub head_neck: f32,
    /// Upper trunk (thorax): suprasternale to xiphion.
    pub trunk_upper: f32,
    /// Middle trunk (abdomen): xiphion to omphalion.
    pub trunk_middle: f32,
    /// Lower trunk (pelvis): omphalion to the hip joint centres.
    pub trunk_lower: f32,
    /// Upper arm, shoulder to elbow.
    pub upper_arm: f32,
    /// Forearm, elbow to wrist.
    pub forearm: f32,
    /// Hand.
    pub hand: f32,
    /// Thigh, hip to knee.
    pub thigh: f32,
    /// Shank, knee to ankle.
    pub shank: f32,
    /// Foot.
    pub foot: f32,
}

impl SegmentMassFractions {
    /// Sum over the whole body (both sides), percent: 100 up to the table's rounding.
    pub fn total_percent(&self) -> f32 {
        self.head_neck
            + self.trunk_upper
            + self.trunk_middle
            + self.trunk_lower
            + 2.0
                * (self.upper_arm + self.forearm + self.hand + self.thigh + self.shank + self.foot)
    }
}

/// Adult male segment masses, percent of body mass.
///
/// de Leva, P. (1996). Adjustments to Zatsiorsky–Seluyanov's segment inertia parameters.
/// Journal of Biomechanics 29(9), 1223–1230, Table 4.
pub const DE_LEVA_MALE: SegmentMassFractions = SegmentMassFractions {
    head_neck: 6.94,
    trunk_upper: 15.96,
    trunk_middle: 16.33,
    trunk_lower: 11.17,
    upper_arm: 2.71,
    forearm: 1.62,
    hand: 0.61,
    thigh: 14.16,
    shank: 4.33,
    foot: 1.37,
};

/// Adult female segment masses, percent of body mass; same source as [`DE_LEVA_MALE`].
/// The published values add up to 99.99 %, so callers normalise by
/// [`SegmentMassFractions::total_percent`].
pub const DE_LEVA_FEMALE: SegmentMassFractions = SegmentMassFractions {
    head_neck: 6.68,
    trunk_upper: 15.45,
    trunk_middle: 14.65,
    trunk_lower: 12.47,
    upper_arm: 2.55,
    forearm: 1.38,
    hand: 0.56,
    thigh: 14.78,
    shank: 4.81,
    foot: 1.29,
};

/// Share of de Leva's head+neck mass given to a separate neck body. de Leva does not split
/// the segment; a fifth (about 1 kg of a 75 kg body) is our estimate for the cervical
/// segment's soft tissue and vertebrae, and it keeps the neck from being so light that
/// the head–neck–chest chain strains the solver.
pub const NECK_SHARE_OF_HEAD_NECK: f32 = 0.2;

/// Default body mass of a humanoid [`REFERENCE_HUMANOID_HEIGHT_M`] tall, kg: an adult
/// man's, as in crash-test and biomechanics references.
pub const DEFAULT_HUMANOID_MASS_KG: f32 = 75.0;

/// Standing height at which a humanoid weighs [`DEFAULT_HUMANOID_MASS_KG`], metres.
pub const REFERENCE_HUMANOID_HEIGHT_M: f32 = 1.75;

/// A humanoid's default mass at a standing height of `height_m`: 75 kg at 1.75 m, scaled
/// as its volume (the cube of its height). A character scaled in its file keeps its
/// proportions, so its volume goes as the cube: a 0.9 m child-sized figure weighs 10 kg
/// and a 5.6 m giant 2,460 kg, which a blast throws as fast as physics says rather than at
/// a 75 kg figure's speed. Heights are taken within [`HUMANOID_MASS_HEIGHTS_M`], so the
/// lightest segment (a hand, 0.6 %) stays above the lightest body a spec may have; a
/// height that is not a number gives 75 kg.
///
/// ```
/// use ragdoll::spec::humanoid_mass_kg;
/// assert_eq!(humanoid_mass_kg(1.75), 75.0);
/// assert!((humanoid_mass_kg(3.5) - 600.0).abs() < 1e-3);
/// ```
pub fn humanoid_mass_kg(height_m: f32) -> f32 {
    if height_m.is_nan() {
        return DEFAULT_HUMANOID_MASS_KG;
    }
    let (lo, hi) = HUMANOID_MASS_HEIGHTS_M.into_inner();
    DEFAULT_HUMANOID_MASS_KG * (height_m.clamp(lo, hi) / REFERENCE_HUMANOID_HEIGHT_M).powi(3)
}

/// The heights [`humanoid_mass_kg`] scales over, metres: from a 5 cm figurine (1.8 g) to
/// a 100 m giant (14,000 t).
pub const HUMANOID_MASS_HEIGHTS_M: std::ops::RangeInclusive<f32> = 0.05..=100.0;

/// Density used to weigh non-humanoid bodies, kg/m³: water, close to soft tissue.
pub const BODY_DENSITY_KG_M3: f32 = 1000.0;

// Joint ranges, degrees, measured from the anatomical neutral pose. The targets
// are in line with the average active ranges of the American Academy of
// Orthopaedic Surgeons (Greene & Heckman, "The Clinical Measurement of Joint Motion",
// AAOS 1994): knee 0–135/140, elbow 0–150, hip flexion 120 / extension 20–30 /
// abduction 45, ankle dorsiflexion 20 / plantarflexion 50, neck rotation 60–80.
// A swing cone is circular, so ball joints get a cone centred between the extremes of the
// anatomical range and as wide as the larger half of it.

/// Knee flexion range `[min, max]`; never negative: a knee does not bend backwards.
pub const KNEE_FLEXION_DEG: [f32; 2] = [0.0, 140.0];
/// Elbow flexion range `[min, max]`.
pub const ELBOW_FLEXION_DEG: [f32; 2] = [0.0, 145.0];

/// Hip flexion (+) / extension (−) range; the hip cone is centred on its middle.
pub const HIP_FLEXION_DEG: [f32; 2] = [-20.0, 120.0];
/// Hip abduction a cone around the flexion centre must still reach (checked in tests).
pub const HIP_ABDUCTION_DEG: f32 = 45.0;
/// Hip internal/external rotation about the thigh, `[min, max]`.
pub const HIP_TWIST_DEG: [f32; 2] = [-35.0, 35.0];

/// Shoulder cone half-angle: the arm can swing ±90° around the cone centre.
pub const SHOULDER_SWING_DEG: f32 = 90.0;
/// Abduction of the shoulder cone's centre: halfway between arm-down and T-pose, so both
/// common rest poses (and an arms-down first frame) lie well inside the cone.
pub const SHOULDER_CONE_ABDUCTION_DEG: f32 = 45.0;
/// Forward flexion of the shoulder cone's centre: the arm flexes forward far more
/// (180°) than it extends backward (≈60°).
pub const SHOULDER_CONE_FLEXION_DEG: f32 = 20.0;
/// Shoulder internal/external rotation about the upper arm, `[min, max]`.
pub const SHOULDER_TWIST_DEG: [f32; 2] = [-60.0, 60.0];

/// Wrist cone half-angle (flexion 80 / extension 70 / deviation 20–30, kept modest).
pub const WRIST_SWING_DEG: f32 = 40.0;
/// Wrist twist, standing in for forearm pronation/supination (which a hinge elbow lacks).
pub const WRIST_TWIST_DEG: [f32; 2] = [-30.0, 30.0];

/// Ankle cone half-angle: dorsiflexion 20 + plantarflexion 50 = 70, halved.
pub const ANKLE_SWING_DEG: f32 = 35.0;
/// Plantarflexion of the ankle cone's centre, so it spans dorsiflexion 20 / plantar 50.
pub const ANKLE_CONE_PLANTAR_DEG: f32 = 15.0;
/// Ankle inversion/eversion as twist about the foot, `[min, max]`.
pub const ANKLE_TWIST_DEG: [f32; 2] = [-15.0, 15.0];

/// Lumbar cone (pelvis → spine) half-angle: a share of trunk flexion/extension.
pub const LUMBAR_SWING_DEG: f32 = 25.0;
/// Lumbar axial rotation, `[min, max]`.
pub const LUMBAR_TWIST_DEG: [f32; 2] = [-15.0, 15.0];
/// Thoracic cone (spine → chest) half-angle.
pub const THORACIC_SWING_DEG: f32 = 20.0;
/// Thoracic axial rotation, `[min, max]` (the thorax rotates more than the lumbar spine).
pub const THORACIC_TWIST_DEG: [f32; 2] = [-25.0, 25.0];

/// Lower neck (chest → neck) cone half-angle.
pub const NECK_SWING_DEG: f32 = 35.0;
/// Lower neck rotation, `[min, max]`.
pub const NECK_TWIST_DEG: [f32; 2] = [-35.0, 35.0];
/// Head on the neck (atlanto-occipital and atlanto-axial joints) cone half-angle.
pub const HEAD_SWING_DEG: f32 = 25.0;
/// Head rotation on the neck (C1–C2 carries about half of neck rotation), `[min, max]`.
pub const HEAD_TWIST_DEG: [f32; 2] = [-35.0, 35.0];

/// Links of non-humanoid chains (tails, quadruped limbs, unknown rigs): modest limits that
/// let a chain curl without folding onto itself.
pub const CHAIN_SWING_DEG: f32 = 45.0;
/// Twist of non-humanoid chain links, `[min, max]`.
pub const CHAIN_TWIST_DEG: [f32; 2] = [-30.0, 30.0];

// Segment thickness without a mesh, as fractions of standing height H. Rounded from the
// 50th-percentile adult circumferences and breadths of the NASA Anthropometric Source
// Book (NASA RP-1024, 1978), radius = circumference / 2π, for H ≈ 1.75 m; a little thinner
// than the flesh so bodies of a standing ragdoll do not start in contact.

/// Head capsule radius (head breadth ≈ 15.5 cm, length ≈ 19.5 cm).
pub const HEAD_RADIUS_H: f32 = 0.05;
/// Head length from the head joint to the vertex when the skeleton does not say.
pub const HEAD_LENGTH_H: f32 = 0.11;
/// Neck radius (neck circumference ≈ 38 cm).
pub const NECK_RADIUS_H: f32 = 0.03;
/// Upper arm radius (biceps circumference ≈ 31 cm).
pub const UPPER_ARM_RADIUS_H: f32 = 0.026;
/// Forearm radius (forearm circumference ≈ 27 cm).
pub const FOREARM_RADIUS_H: f32 = 0.021;
/// Hand radius (hand thickness ≈ 3 cm, breadth ≈ 9 cm).
pub const HAND_RADIUS_H: f32 = 0.017;
/// Hand length, wrist to fingertip, when the skeleton does not say (≈ 19 cm).
pub const HAND_LENGTH_H: f32 = 0.108;
/// Thigh radius (thigh circumference ≈ 55 cm, thinned toward the knee).
pub const THIGH_RADIUS_H: f32 = 0.043;
/// Shin radius (calf circumference ≈ 37 cm, thinned toward the ankle).
pub const SHIN_RADIUS_H: f32 = 0.03;
/// Foot radius (foot height ≈ 7 cm).
pub const FOOT_RADIUS_H: f32 = 0.02;
/// Foot length, ankle joint to toe tip, when the skeleton does not say (≈ 20 cm).
pub const FOOT_LENGTH_H: f32 = 0.115;
/// Pitch of an estimated foot below horizontal: the ankle sits above the toes.
pub const FOOT_PITCH_DEG: f32 = 20.0;

/// Trunk widths (left–right) and depths (front–back) per segment, fractions of H:
/// hip breadth ≈ 35 cm, waist ≈ 29 × 20 cm, chest ≈ 32 × 23 cm.
pub const PELVIS_WIDTH_H: f32 = 0.19;
/// Pelvis depth, see [`PELVIS_WIDTH_H`].
pub const PELVIS_DEPTH_H: f32 = 0.12;
/// Waist (middle trunk) width, see [`PELVIS_WIDTH_H`].
pub const WAIST_WIDTH_H: f32 = 0.16;
/// Waist depth, see [`PELVIS_WIDTH_H`].
pub const WAIST_DEPTH_H: f32 = 0.11;
/// Chest width, see [`PELVIS_WIDTH_H`].
pub const CHEST_WIDTH_H: f32 = 0.18;
/// Chest depth, see [`PELVIS_WIDTH_H`].
pub const CHEST_DEPTH_H: f32 = 0.12;

// Creatures (non-humanoids): joints read from the rest pose's geometry, not from names.

/// Flexion range of a creature's limb hinge (knee, elbow, hock), `[min, max]` from
/// straight. Goniometry of Labrador Retrievers (Jaegger, Marcellin-Little & Levine 2002,
/// Am. J. Vet. Res. 63(7):979) puts the stifle, elbow and hock between about 40° (fully
/// flexed) and 162–165° (extended) joint angle: about 140° of flexion from straight and
/// none past it; the carpus, the one that extends past straight, reaches 196°, so 10° of
/// hyperextension is allowed.
pub const CREATURE_LIMB_FLEXION_DEG: [f32; 2] = [-10.0, 140.0];
/// How much further than its rest pose a creature's limb hinge flexes, degrees, within
/// [`CREATURE_LIMB_FLEXION_DEG`]. A game creature's skin is weighted for the poses its
/// animations use; bent 97° past rest, the Fox's hind legs stretched its mesh's
/// 99th-percentile edge from 2.27× to 3.15× (`mesh_check`), where the 45° cones before
/// them stretched none of it further.
pub const CREATURE_SKIN_FLEXION_DEG: f32 = 45.0;
/// A limb joint is a hinge only when its rest pose bends at least this much: a straight
/// leg does not say which way it bends, and keeps a cone.
pub const CREATURE_MIN_HINGE_BEND_DEG: f32 = 10.0;
/// A limb bone points at least this far below horizontal, degrees: what tells a leg from a
/// spine or tail bone.
pub const CREATURE_LIMB_DOWN_DEG: f32 = 30.0;
/// A leg reaches within this fraction of the standing height of the ground.
pub const CREATURE_GROUND_BAND_H: f32 = 0.1;
/// Joints followed down a limb looking for the ground: legs have a handful.
pub const CREATURE_MAX_LIMB_LINKS: usize = 8;
/// Total swing an unbranched chain (spine, tail, snake, fish) may bend through, degrees,
/// shared among its links: one full loop, the curl of a sleeping fox's tail or a resting
/// snake's coil. A design bound, not a measured range: 45° per link lets a 20-link snake
/// fold 855° and tie itself in knots when it falls.
pub const CREATURE_CHAIN_TOTAL_BEND_DEG: f32 = 360.0;
/// Smallest cone any chain link gets, so very long chains still bend.
pub const CREATURE_MIN_SWING_DEG: f32 = 3.0;
/// Links counted each way along a chain: past `CREATURE_CHAIN_TOTAL_BEND_DEG /
/// CREATURE_MIN_SWING_DEG` every link gets the smallest cone anyway.
pub const CREATURE_MAX_RUN_LINKS: usize = 120;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn de_leva_tables_sum_to_one_hundred_percent() {
        // The male table is exact; the female one is 99.99 % as published (rounding).
        assert!((DE_LEVA_MALE.total_percent() - 100.0).abs() < 1e-3);
        assert!((DE_LEVA_FEMALE.total_percent() - 100.0).abs() < 0.011);
    }

    #[test]
    fn de_leva_trunk_parts_add_up_to_the_published_trunk() {
        let m = DE_LEVA_MALE;
        assert!((m.trunk_upper + m.trunk_middle + m.trunk_lower - 43.46).abs() < 1e-3);
        let f = DE_LEVA_FEMALE;
        assert!((f.trunk_upper + f.trunk_middle + f.trunk_lower - 42.57).abs() < 1e-3);
    }

    #[test]
    fn hip_cone_reaches_flexion_and_abduction_but_not_far_extension() {
        let centre = 0.5 * (HIP_FLEXION_DEG[0] + HIP_FLEXION_DEG[1]);
        let half = 0.5 * (HIP_FLEXION_DEG[1] - HIP_FLEXION_DEG[0]);
        // Straight leg abducted: spherical distance from the centre by the cosine rule.
        let c = centre.to_radians().cos() * HIP_ABDUCTION_DEG.to_radians().cos();
        assert!(c.acos().to_degrees() < half);
        assert!(centre - half >= -20.5);
    }
}
