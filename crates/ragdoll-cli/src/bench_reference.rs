//! `ragdoll bench --reference`: the pile workload on plain rapier3d, a yardstick anyone can
//! rebuild. Our rigid backend is rapier too, but with our bodies, limits, contact filter
//! and solver settings, so the ratio to it says how our settings compare, not how our
//! solvers compare with a general engine as people use one.
//!
//! The reference ragdoll is the common 11-capsule one (pelvis, chest, head, upper and lower
//! arms, upper and lower legs; [`parts`] says where its sizes and masses come from) with
//! rapier's own joints: spherical joints with per-axis limits, revolute ones for elbows
//! and knees, and jointed capsules kept from colliding by the joints' own
//! `contacts_enabled(false)`, the usual setup. Everything else is rapier's default:
//! `IntegrationParameters::default()` (its 4 solver iterations set explicitly, since the
//! ratio is quoted for them), sleeping on, CCD off, friction 0.5, no restitution, and the
//! workspace's rapier features (`enhanced-determinism`, as the rigid backend is built).
//! The piles are the bench's: the same placements, the same lift onto the ground, the same
//! ground box, stepped at 1/60 s.
//!
//! Our humanoid has 17 bodies where this one has 11, and our world keeps its readings
//! (limits, penetration, energy) inside its step: a ratio to this workload is of whole
//! products, each as it is used. Only readings taken after the timed stepping are reported
//! here (overlap, speed, joint gaps and the lowest body at the end), so that rapier's CPU
//! time holds rapier alone.

use anyhow::Result;
use glam::{Quat, Vec3};
use ragdoll::math::Transform;
use ragdoll::world::BackendKind;
use rapier3d::parry::query;
use rapier3d::prelude::*;
use serde_json::json;

use crate::bench::{self, Timing};
use crate::progress::Progress;

/// Solver iterations of the reference: rapier's default, written out because the ratio is
/// quoted for it.
pub const SOLVER_ITERATIONS: usize = 4;

/// The bench's step, seconds.
const DT_S: f32 = 1.0 / 60.0;

/// Half the side of the ground box, metres: the rigid backend's ground (a box, not a
/// half-space, as there), so both rapier workloads meet the same floor.
const GROUND_HALF_EXTENT_M: f32 = 500.0;
/// The ground box's thickness below Y = 0, metres, as the rigid backend's.
const GROUND_THICKNESS_M: f32 = 2.0;

/// How a part hangs from its parent. Angles are of the child's rotation relative to the
/// parent's, about axes of the standing pose (X to the left, Y up, Z forward), degrees.
#[derive(Clone, Copy, Debug)]
enum Link {
    /// A ball joint at `at` with limits about X, Y and Z.
    Ball { at: Vec3, limits_deg: [[f32; 2]; 3] },
    /// A hinge at `at` about `axis` (the flexion is positive).
    Hinge {
        at: Vec3,
        axis: Vec3,
        limits_deg: [f32; 2],
    },
}

/// One capsule of the reference ragdoll, standing on Y = 0 as the built-in humanoid stands.
/// [`parts`] lists pelvis, chest, head, then upper arm, forearm, thigh and shin of the
/// left side, then of the right.
#[derive(Clone, Copy, Debug)]
pub struct Part {
    /// The capsule's two tips (caps included), metres.
    pub tips: [Vec3; 2],
    pub radius_m: f32,
    pub mass_kg: f32,
    /// The part it hangs from (an index into [`parts`]) and the joint; `None` for the pelvis.
    parent: Option<(usize, Link)>,
}

impl Part {
    fn centre(&self) -> Vec3 {
        0.5 * (self.tips[0] + self.tips[1])
    }

    /// Half the length between the two sphere centres, as rapier's capsules take it.
    fn half_height(&self) -> f32 {
        0.5 * (self.tips[1] - self.tips[0]).length() - self.radius_m
    }

    /// From rapier's capsule (along Y) to this one's axis.
    fn turn(&self) -> Quat {
        Quat::from_rotation_arc(Vec3::Y, (self.tips[1] - self.tips[0]).normalize())
    }

    /// Lowest point of the capsule once `placement` has moved it, metres.
    fn lowest_y(&self, placement: &Transform) -> f32 {
        let axis = (self.tips[1] - self.tips[0]).normalize() * self.radius_m;
        let a = placement.transform_point(self.tips[0] + axis);
        let b = placement.transform_point(self.tips[1] - axis);
        a.y.min(b.y) - self.radius_m
    }
}

/// The built-in humanoid's joints the capsules run between (its left side), metres.
const SPINE: Vec3 = Vec3::new(0.0, 1.07, 0.0);
const NECK: Vec3 = Vec3::new(0.0, 1.47, 0.0);
const SHOULDER: Vec3 = Vec3::new(0.18, 1.43, 0.0);
const HIP: Vec3 = Vec3::new(0.09, 0.91, 0.0);
const KNEE: Vec3 = Vec3::new(0.09, 0.50, 0.0);
/// The humanoid's arms hang along this unit vector, 65° below horizontal; the upper arm
/// is 0.29 m long, the forearm, hand and fingers 0.26 + 0.18 m.
const ARM: Vec3 = Vec3::new(0.423, -0.906, 0.0);

/// The reference ragdoll: 75 kg and 1.75 m, the size and mass of the built-in humanoid, so
/// the two piles hold the same people. Capsule tips are the humanoid's joints
/// (`ragdoll::skeleton::humanoid()`), the forearm reaching to the fingertips and the lower
/// leg to the sole; masses are its spec's (`ragdoll::spec::build_spec`, de Leva), the
/// spine's shared between pelvis and chest and hands and feet added to forearms and lower
/// legs; limb radii are the spec's, the trunk's round numbers near its boxes' size. A test
/// holds the table to the humanoid and its spec.
pub fn parts() -> [Part; 11] {
    let trunk = trunk();
    let (left, right) = (limbs(0), limbs(1));
    std::array::from_fn(|i| match i {
        0..3 => trunk[i],
        3..7 => left[i - 3],
        _ => right[i - 7],
    })
}

fn trunk() -> [Part; 3] {
    let ball = |parent: usize, at: Vec3, deg: f32| {
        Some((
            parent,
            Link::Ball {
                at,
                limits_deg: [[-deg, deg]; 3],
            },
        ))
    };
    [
        Part {
            tips: [Vec3::new(-0.17, 0.99, 0.0), Vec3::new(0.17, 0.99, 0.0)],
            radius_m: 0.09,
            mass_kg: 14.363,
            parent: None,
        },
        Part {
            tips: [SPINE, NECK],
            radius_m: 0.12,
            mass_kg: 17.921,
            parent: ball(0, SPINE, 30.0),
        },
        Part {
            tips: [NECK, Vec3::new(0.0, 1.75, 0.0)],
            radius_m: 0.09,
            mass_kg: 5.155,
            parent: ball(1, NECK, 45.0),
        },
    ]
}

/// Upper arm, forearm, thigh and shin of the left side (`k` 0) or the right (`k` 1),
/// indices 3 to 6 or 7 to 10 of [`parts`].
fn limbs(k: usize) -> [Part; 4] {
    let m = Vec3::new(if k == 0 { 1.0 } else { -1.0 }, 1.0, 1.0);
    let first = 3 + 4 * k;
    let elbow = SHOULDER + ARM * 0.29;
    [
        Part {
            tips: [SHOULDER * m, elbow * m],
            radius_m: 0.041,
            mass_kg: 2.371,
            parent: Some((
                1,
                Link::Ball {
                    at: SHOULDER * m,
                    limits_deg: [[-80.0, 80.0]; 3],
                },
            )),
        },
        Part {
            tips: [elbow * m, (elbow + ARM * 0.44) * m],
            radius_m: 0.033,
            mass_kg: 1.657,
            parent: Some((
                first,
                Link::Hinge {
                    at: elbow * m,
                    // Flexion brings the hand forward (+Z): the turn of the arm toward Z.
                    axis: (ARM * m).cross(Vec3::Z).normalize(),
                    limits_deg: [0.0, 145.0],
                },
            )),
        },
        Part {
            tips: [HIP * m, KNEE * m],
            radius_m: 0.074,
            mass_kg: 10.519,
            parent: Some((
                0,
                Link::Ball {
                    at: HIP * m,
                    // Flexion swings the thigh forward, a turn about -X.
                    limits_deg: [[-100.0, 20.0], [-35.0, 35.0], [-40.0, 40.0]],
                },
            )),
        },
        Part {
            tips: [KNEE * m, Vec3::new(KNEE.x, 0.0, 0.0) * m],
            radius_m: 0.048,
            mass_kg: 4.234,
            parent: Some((
                first + 2,
                Link::Hinge {
                    at: KNEE * m,
                    // Flexion takes the heel back (-Z): a turn about +X.
                    axis: Vec3::X,
                    limits_deg: [0.0, 140.0],
                },
            )),
        },
    ]
}

/// A world of plain rapier piles, and whether rapier has had to freeze a body whose state
/// went non-finite (it says so only in the step that does it).
struct PlainWorld {
    world: PhysicsWorld,
    non_finite: bool,
}

impl PlainWorld {
    fn new() -> Self {
        let mut world = PhysicsWorld::new();
        world.integration_parameters.dt = DT_S;
        world.integration_parameters.num_solver_iterations = SOLVER_ITERATIONS;
        let ground = ColliderBuilder::cuboid(
            GROUND_HALF_EXTENT_M,
            0.5 * GROUND_THICKNESS_M,
            GROUND_HALF_EXTENT_M,
        )
        .translation(Vec3::new(0.0, -0.5 * GROUND_THICKNESS_M, 0.0))
        .build();
        world.colliders.insert(ground);
        PlainWorld {
            world,
            non_finite: false,
        }
    }

    fn step(&mut self) {
        self.world.step();
        self.non_finite |= !self.world.quarantine().is_empty();
    }

    /// Adds one ragdoll placed as the bench places its humanoids, lifted as the world
    /// lifts them: just enough that no capsule starts below the ground.
    fn add_ragdoll(&mut self, parts: &[Part], placement: &Transform) -> Vec<RigidBodyHandle> {
        let lowest = parts
            .iter()
            .map(|p| p.lowest_y(placement))
            .fold(f32::INFINITY, f32::min);
        let lift = Vec3::Y * (-lowest).max(0.0);
        let w = &mut self.world;
        let mut handles: Vec<RigidBodyHandle> = Vec::with_capacity(parts.len());
        for p in parts {
            // Bodies keep the standing pose's axes (turned by the placement), so every
            // joint's frame is the same axes on both sides and all its angles are 0 at rest.
            let at = placement.transform_point(p.centre()) + lift;
            let body = RigidBodyBuilder::dynamic().pose(Pose::from_parts(at, placement.rotation));
            let capsule = ColliderBuilder::capsule_y(p.half_height(), p.radius_m)
                .position(Pose::from_parts(Vec3::ZERO, p.turn()))
                .mass(p.mass_kg);
            handles.push(w.insert(body, capsule).0);
            if let Some((parent, link)) = p.parent {
                let anchors = |at: Vec3| (at - parts[parent].centre(), at - p.centre());
                let joint: GenericJoint = match link {
                    Link::Ball { at, limits_deg } => {
                        let (a1, a2) = anchors(at);
                        let mut j = SphericalJointBuilder::new()
                            .local_anchor1(a1)
                            .local_anchor2(a2)
                            .contacts_enabled(false);
                        let axes = [JointAxis::AngX, JointAxis::AngY, JointAxis::AngZ];
                        for (axis, [lo, hi]) in axes.into_iter().zip(limits_deg) {
                            j = j.limits(axis, [lo.to_radians(), hi.to_radians()]);
                        }
                        j.build().into()
                    }
                    Link::Hinge {
                        at,
                        axis,
                        limits_deg: [lo, hi],
                    } => {
                        let (a1, a2) = anchors(at);
                        RevoluteJointBuilder::new(axis)
                            .local_anchor1(a1)
                            .local_anchor2(a2)
                            .limits([lo.to_radians(), hi.to_radians()])
                            .contacts_enabled(false)
                            .build()
                            .into()
                    }
                };
                let child = handles[handles.len() - 1];
                w.impulse_joints.insert(handles[parent], child, joint, true);
            }
        }
        handles
    }

    /// What the piles look like now (see [`Readings`]).
    fn readings(&self) -> Readings {
        let w = &self.world;
        let mut r = Readings {
            non_finite: self.non_finite,
            lowest_body_m: f32::INFINITY,
            ..Readings::default()
        };
        for (_, b) in w.bodies.iter() {
            r.end_fastest_mps = r.end_fastest_mps.max(b.linvel().length());
            r.non_finite |= !b.position().translation.is_finite();
        }
        for (_, c) in w.colliders.iter().filter(|(_, c)| c.parent().is_some()) {
            r.lowest_body_m = r.lowest_body_m.min(c.compute_aabb().mins.y);
        }
        for (_, j) in w.impulse_joints.iter() {
            let a = w.bodies[j.body1()]
                .position()
                .transform_point(j.data.local_frame1.translation);
            let b = w.bodies[j.body2()]
                .position()
                .transform_point(j.data.local_frame2.translation);
            r.end_joint_gap_m = r.end_joint_gap_m.max(a.distance(b));
        }
        // Every pair near enough to touch is one of the narrow phase's pairs; the depth is
        // measured from the shapes, not taken from the solver's contacts.
        for pair in w.narrow_phase.contact_pairs() {
            let (c1, c2) = (&w.colliders[pair.collider1], &w.colliders[pair.collider2]);
            if let (Some(b1), Some(b2)) = (c1.parent(), c2.parent())
                && w.impulse_joints.joints_between(b1, b2).next().is_some()
            {
                continue;
            }
            if let Ok(Some(c)) =
                query::contact(c1.position(), c1.shape(), c2.position(), c2.shape(), 0.0)
            {
                r.end_overlap_m = r.end_overlap_m.max(-c.dist);
            }
        }
        r
    }
}

/// The reference workload's readings after its last step, all worlds together.
#[derive(Clone, Copy, Debug, Default)]
pub struct Readings {
    /// Whether any body's state went non-finite (rapier then freezes it).
    pub non_finite: bool,
    /// Deepest overlap between two capsules that are not jointed, or a capsule and the
    /// ground, metres.
    pub end_overlap_m: f32,
    /// Fastest body, m/s: how much at rest the piles are.
    pub end_fastest_mps: f32,
    /// Widest gap between the two sides of a joint, metres: whether the ragdolls hold
    /// together.
    pub end_joint_gap_m: f32,
    /// Lowest point of any capsule, metres (the ground is at 0): whether one fell through.
    pub lowest_body_m: f32,
}

impl Readings {
    fn merge(&mut self, o: &Readings) {
        self.non_finite |= o.non_finite;
        self.end_overlap_m = self.end_overlap_m.max(o.end_overlap_m);
        self.end_fastest_mps = self.end_fastest_mps.max(o.end_fastest_mps);
        self.end_joint_gap_m = self.end_joint_gap_m.max(o.end_joint_gap_m);
        self.lowest_body_m = self.lowest_body_m.min(o.lowest_body_m);
    }

    /// The bench's bounds for a stable run (joints within 5 cm, overlap within 10 cm),
    /// here at the end only.
    fn stable(&self) -> bool {
        !self.non_finite && self.end_joint_gap_m < 0.05 && self.end_overlap_m < 0.1
    }
}

/// One run of the reference workload.
pub struct PlainRow {
    pub timing: Timing,
    pub readings: Readings,
}

impl PlainRow {
    /// The run as the JSON output lists it, under `plain_rapier`.
    pub fn json(&self, steps: usize) -> serde_json::Value {
        let r = &self.readings;
        let mut run = json!({
            "workload": "pile",
            "engine": "rapier3d 0.36, plain",
            "bodies_per_ragdoll": 11,
            "solver_iterations": SOLVER_ITERATIONS,
            "stable": r.stable(),
            "non_finite": r.non_finite,
            "end_overlap_m": r.end_overlap_m,
            "end_fastest_body_mps": r.end_fastest_mps,
            "end_joint_gap_m": r.end_joint_gap_m,
            "lowest_body_m": r.lowest_body_m,
        });
        bench::merge(&mut run, self.timing.json(steps));
        run
    }
}

/// Builds and steps `n` reference ragdolls in the bench's piles, on `threads` threads.
pub fn run_plain_pile(
    piles: crate::bench_piles::Piles,
    n: usize,
    threads: usize,
    steps: usize,
    progress: &Progress,
) -> Result<PlainRow> {
    progress.stage(
        n as u64,
        &format!("N={n} threads={threads}: building plain rapier"),
    );
    let parts = parts();
    let mut worlds = Vec::new();
    for share in piles.world_shares(n, threads) {
        let mut w = PlainWorld::new();
        for k in share {
            w.add_ragdoll(&parts, &piles.placement(k, n));
            progress.inc(1);
        }
        worlds.push(w);
    }
    let timing = bench::step_timed(&mut worlds, n, threads, steps, progress, PlainWorld::step)?;
    let mut readings = Readings {
        lowest_body_m: f32::INFINITY,
        ..Readings::default()
    };
    for w in &worlds {
        readings.merge(&w.readings());
    }
    Ok(PlainRow { timing, readings })
}

/// Prints the reference run under ours, and how many times as many ragdoll-steps per
/// CPU-second ours did.
pub fn print_beside(p: &PlainRow, ours: &Timing, backend: BackendKind, steps: usize) {
    let r = &p.readings;
    outln!(
        "{}  stable={}  at the end: overlap {:.1} mm, fastest body {:.2} m/s, joint gap {:.1} mm, lowest body {:.1} mm",
        p.timing.text("plain-rapier", steps),
        r.stable(),
        r.end_overlap_m * 1000.0,
        r.end_fastest_mps,
        r.end_joint_gap_m * 1000.0,
        r.lowest_body_m * 1000.0,
    );
    match ours.cpu_ratio(&p.timing) {
        Some(x) => outln!(
            "      {} / plain rapier: {x:.2}× the ragdoll-steps per CPU-second",
            backend.as_str()
        ),
        None => outln!(
            "      {} / plain rapier: CPU time unknown",
            backend.as_str()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ragdoll::skeleton;
    use ragdoll::spec::{self, BuildOptions};

    /// The capsules of [`parts`], in its order.
    const NAMES: [&str; 11] = [
        "pelvis",
        "chest",
        "head",
        "upper_arm_l",
        "forearm_l",
        "thigh_l",
        "shin_l",
        "upper_arm_r",
        "forearm_r",
        "thigh_r",
        "shin_r",
    ];

    /// The table is the built-in humanoid: its joints at the capsules' tips, its spec's
    /// masses merged as the doc of [`parts`] says, 75 kg and 1.75 m in all.
    #[test]
    fn the_reference_ragdoll_is_the_built_in_humanoid() {
        let character = skeleton::humanoid();
        let s = &character.skeleton;
        let rest = s.rest_world();
        let joint = |name: &str| rest[s.find(name).unwrap()].translation;
        let parts = parts();
        let part = |name: &str| parts[NAMES.iter().position(|n| *n == name).unwrap()];
        let close = |a: Vec3, b: Vec3| a.distance(b) < 2e-3;
        for (name, tip, bone) in [
            ("chest", 0, "spine"),
            ("chest", 1, "neck"),
            ("head", 0, "neck"),
            ("upper_arm_l", 0, "upper_arm_l"),
            ("upper_arm_r", 1, "forearm_r"),
            ("forearm_l", 0, "forearm_l"),
            ("thigh_r", 0, "thigh_r"),
            ("thigh_l", 1, "shin_l"),
            ("shin_l", 0, "shin_l"),
        ] {
            assert!(
                close(part(name).tips[tip], joint(bone)),
                "{name} {tip} {bone}"
            );
        }
        let ends = s.rest_bone_ends();
        let hand = s.find("hand_r").unwrap();
        assert!(close(part("forearm_r").tips[1], ends[hand].unwrap()));
        let top = parts.iter().flat_map(|p| p.tips).map(|t| t.y);
        assert!((top.clone().fold(f32::MIN, f32::max) - 1.75).abs() < 1e-4);
        assert!(top.fold(f32::MAX, f32::min).abs() < 1e-4, "stands on Y = 0");

        let spec = spec::build_spec(&character, &BuildOptions::default()).unwrap();
        let kg = |name: &str| spec.bodies[spec.body_index(name).unwrap()].mass_kg;
        for (name, merged) in [
            ("pelvis", kg("pelvis") + 0.5 * kg("spine")),
            ("chest", kg("chest") + 0.5 * kg("spine")),
            ("head", kg("head")),
            ("upper_arm_l", kg("upper_arm_l")),
            ("forearm_r", kg("forearm_r") + kg("hand_r")),
            ("thigh_l", kg("thigh_l")),
            ("shin_r", kg("shin_r") + kg("foot_r")),
        ] {
            assert!((part(name).mass_kg - merged).abs() < 2e-3, "{name}");
        }
        let total: f32 = parts.iter().map(|p| p.mass_kg).sum();
        assert!((total - spec.total_mass_kg()).abs() < 0.01, "{total}");
    }

    /// The hinges' sign: a knee and an elbow flex (forward for the forearm, back for the
    /// shin) and do not bend the other way, with no gravity to help either.
    #[test]
    fn knees_and_elbows_bend_only_in_flexion() {
        for (child, parent, flex) in [(6, 5, Vec3::X), (4, 3, (ARM.cross(Vec3::Z)).normalize())] {
            let mut bent = [0.0f32; 2];
            for (k, sign) in [1.0f32, -1.0].into_iter().enumerate() {
                let mut w = PlainWorld::new();
                w.world.gravity = Vec3::ZERO;
                let h = w.add_ragdoll(&parts(), &Transform::IDENTITY);
                w.world.bodies[h[child]].set_angvel(flex * 4.0 * sign, true);
                for _ in 0..15 {
                    w.step();
                }
                let q = w.world.bodies[h[parent]].rotation().inverse()
                    * w.world.bodies[h[child]].rotation();
                // The turn about the hinge's axis, of the child relative to its parent.
                bent[k] = 2.0 * Vec3::new(q.x, q.y, q.z).dot(flex).atan2(q.w).to_degrees();
            }
            assert!(bent[0] > 15.0, "{child} does not flex: {bent:?}");
            assert!(bent[1] > -3.0, "{child} bends backward: {bent:?}");
        }
    }

    /// A full pile starts with nothing inside anything: the placements and the lift keep
    /// the capsules apart before the first step, as the world keeps the humanoids.
    #[test]
    fn a_pile_starts_apart() {
        let mut w = PlainWorld::new();
        let n = 8;
        for k in 0..n {
            w.add_ragdoll(
                &parts(),
                &crate::bench_piles::Piles::default().placement(k, n),
            );
        }
        w.world.detect_collisions(&(), &());
        let r = w.readings();
        assert!(r.end_overlap_m < 1e-3, "{r:?}");
        assert!(
            r.lowest_body_m.abs() < 1e-4,
            "lifted onto the ground: {r:?}"
        );
        assert_eq!(w.world.impulse_joints.len(), 10 * n);
    }
}
