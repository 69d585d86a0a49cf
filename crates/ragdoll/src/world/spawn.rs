//! Adding a ragdoll to a world: its spec resolved at its start pose and lifted onto the
//! ground, where it starts checked against the world and the ragdolls already there, its
//! bodies and joints handed to the backend, and the riders that carry every skeleton joint
//! on a body so the track can be written for the whole skeleton.

use crate::backend::BodyId;
use glam::Vec3;

use super::overlap::Solid;
use super::playback::{self, Activation};
use super::{Instance, RagdollId, Rider, StartPose, World, start};
use crate::backend::{Backend, BodyDesc, BodyState, Command, JointDesc, SkinPointDesc};
use crate::error::Result;
use crate::math::Transform;
use crate::skeleton::Character;
use crate::spec::{RagdollSpec, Resolved, ResolvedJoint, start_pose};
use crate::track::Track;

impl World {
    /// Adds a ragdoll built from `spec`, placed by `placement` (a rigid transform applied
    /// to the whole character), lifted so that no body starts below the ground.
    ///
    /// May be called between any two steps: a ragdoll added once the world has stepped
    /// starts at rest where it is placed, physics drives it from the next step, and its
    /// track holds that start pose for the frames recorded before it came (so every track
    /// of a world has one frame per output frame). Fails when one of its bodies would start
    /// inside a body of a ragdoll already there (one body's axis inside the other, where
    /// the others are now; see `overlap.rs`), or inside more than 32 bodies of its own;
    /// pairs of its own bodies that start so are kept from colliding.
    pub fn add_ragdoll(
        &mut self,
        character: &Character,
        spec: &RagdollSpec,
        placement: Transform,
    ) -> Result<RagdollId> {
        spec.validate()?;
        let late = self.frames_recorded > 0;
        if late {
            self.index_present_bodies();
        }
        let skeleton = &character.skeleton;
        // 1. Bodies and joint frames from the rest pose; the start pose from the clip.
        let mut resolved = Resolved::new(spec, character)?;
        let mut start = start_pose(character, self.settings.start == StartPose::FirstFrame);
        for t in &mut start {
            *t = placement.mul(t);
        }
        resolved.anchor_at_pose(&start);
        let mut body_start = resolved.body_poses(&start);
        let bone_of_body = &resolved.bone_of_body;
        // 2. Lift onto the ground where any body would start below it.
        let lift = self.lift_onto_ground(spec, &body_start);
        for t in body_start.iter_mut().chain(&mut start) {
            t.translation += lift;
        }
        let joint_descs: Vec<JointDesc> = resolved.joints.iter().map(joint_desc).collect();
        let mut disabled: Vec<(usize, usize)> = spec
            .collision
            .disabled_pairs
            .iter()
            .filter_map(|[a, b]| Some((spec.body_index(a)?, spec.body_index(b)?)))
            .collect();
        // 2b. Where it starts: within the world, on the ground, not inside another
        //     ragdoll; its own parts that start inside each other stop colliding.
        let solids = self.check_start(character, spec, &body_start)?;
        disabled.extend(start::overlapping_parts(spec, &solids)?);
        // 3. Skeleton joints ride on their own or their nearest ancestor's body, with the
        //    offset they have at the start (so the hand-over pose is kept exactly).
        let riders = riders(character, bone_of_body, &start, &body_start);
        let body_of_joint: Vec<usize> = riders.iter().map(|r| r.body).collect();
        let skin: Vec<SkinPointDesc> =
            crate::spec::skin_points(character, spec, &resolved, &body_of_joint)
                .into_iter()
                .map(|parts| SkinPointDesc { parts })
                .collect();
        let bodies: Vec<BodyDesc> = spec
            .bodies
            .iter()
            .zip(&body_start)
            .map(|(b, p)| BodyDesc {
                pose: *p,
                shape: b.shape,
                extra_shapes: b.extra_offsets(),
                mass: b.mass_kg,
                linvel: Vec3::ZERO,
                angvel: Vec3::ZERO,
            })
            .collect();
        let first_body = self.backend.add_ragdoll(&bodies, &joint_descs, &disabled).0;
        self.backend.add_skin_points(BodyId(first_body), &skin);
        if self.settings.joint_damping > 0.0 {
            self.backend.apply(&[Command::JointDamping {
                first_body: BodyId(first_body),
                rate_per_s: self.settings.joint_damping,
            }]);
        }
        let mut exempt_pairs: Vec<(usize, usize)> = disabled
            .iter()
            .map(|&(a, b)| (a.min(b), a.max(b)))
            .collect();
        exempt_pairs.sort_unstable();
        exempt_pairs.dedup();
        if late {
            // Built for this one check: the others will have moved by the next.
            self.start_index = super::overlap::StartIndex::default();
            // Energy came in with it; the drift is measured from the next frame on.
            self.start_energy = None;
            self.last_frame_energy = None;
        } else {
            self.start_index.insert(&solids);
        }
        let playback = playback_of(character, &resolved, placement, lift);
        let joints = resolved.joints;
        let links: Vec<(usize, usize)> = joints.iter().map(|j| (j.parent, j.child)).collect();
        let first_joint = self.instances.iter().map(|i| i.joints.len()).sum();
        self.instances.push(Instance {
            joint_labels: (0..skeleton.len())
                .map(|i| skeleton.joint_label(i))
                .collect(),
            first_joint,
            held_bones: held_bones(character, &riders, &links),
            bone_lengths: Vec::new(),
            playback,
            activation: Activation::Immediately,
            active: true,
            activated_at: Some(self.time),
            removed: false,
            motors: None,
            name: character.name.clone(),
            body_names: spec.bodies.iter().map(|b| b.name.clone()).collect(),
            first_body,
            shapes: spec.bodies.iter().map(|b| b.shape).collect(),
            extras: bodies.iter().map(|b| b.extra_shapes.clone()).collect(),
            exempt_pairs,
            masses: spec.bodies.iter().map(|b| b.mass_kg).collect(),
            joints,
            riders,
            track: Track {
                fps: self.settings.fps,
                frames: vec![start; self.frames_recorded],
            },
        });
        // The bodies' states are readable (body_poses, joint_errors) before the first step.
        self.read_states_of(self.instances.len() - 1);
        Ok(RagdollId(self.instances.len() - 1))
    }

    /// Reads the states of ragdoll `index`'s bodies from the engine, the only ones adding
    /// or setting up that ragdoll changed.
    pub(super) fn read_states_of(&mut self, index: usize) {
        let inst = &self.instances[index];
        let range = inst.first_body..inst.first_body + inst.masses.len();
        if self.states.len() < range.end {
            let still = BodyState {
                pose: Transform::IDENTITY,
                linvel: Vec3::ZERO,
                angvel: Vec3::ZERO,
            };
            self.states.resize(range.end, still);
        }
        self.backend
            .body_states_of(BodyId(range.start), &mut self.states[range]);
    }

    /// Files every ragdoll's bodies where they are now, for the start check of a ragdoll
    /// added after the world has stepped (a removed one's as none: its place is free).
    pub(super) fn index_present_bodies(&mut self) {
        let mut index = super::overlap::StartIndex::default();
        for inst in &self.instances {
            if inst.removed {
                index.insert(&[]);
                continue;
            }
            let poses: Vec<Transform> = self.states
                [inst.first_body..inst.first_body + inst.masses.len()]
                .iter()
                .map(|s| s.pose)
                .collect();
            index.insert(&Solid::of_bodies(&inst.shapes, &inst.extras, &poses));
        }
        self.start_index = index;
    }

    /// How far up a ragdoll whose bodies start at `body_start` must move so that none
    /// starts below the ground.
    fn lift_onto_ground(&self, spec: &RagdollSpec, body_start: &[Transform]) -> Vec3 {
        let Some(ground) = self.settings.ground else {
            return Vec3::ZERO;
        };
        // Every shape of every body, the extra ones too.
        let lowest = body_start
            .iter()
            .zip(&spec.bodies)
            .flat_map(|(p, b)| {
                let extras = b
                    .extra_offsets()
                    .into_iter()
                    .map(|(s, at)| s.lowest_y(&p.mul(&at)));
                std::iter::once(b.shape.lowest_y(p)).chain(extras)
            })
            .fold(f32::INFINITY, f32::min);
        Vec3::Y * (ground - lowest).max(0.0)
    }
}

/// The backend's description of a resolved joint.
fn joint_desc(j: &ResolvedJoint) -> JointDesc {
    JointDesc {
        parent: j.parent,
        child: j.child,
        frame_parent: j.frame_parent,
        frame_child: j.frame_child,
        kind: j.kind,
    }
}

/// The character's first clip, ready to play until the hand-over, when it has frames for
/// every joint.
fn playback_of(
    character: &Character,
    resolved: &Resolved,
    placement: Transform,
    lift: Vec3,
) -> Option<playback::Playback> {
    let skeleton = &character.skeleton;
    character
        .clips
        .first()
        .filter(|c| !c.frames.is_empty() && c.frames.iter().all(|f| f.len() == skeleton.len()))
        .map(|clip| playback::Playback {
            skeleton: skeleton.clone(),
            clip: clip.clone(),
            placement,
            lift,
            offset_s: 0.0,
            bone_of_body: resolved.bone_of_body.clone(),
            body_local: resolved.body_local.clone(),
        })
}

/// Each skeleton joint on the body of its own bone or of its nearest ancestor's (the root
/// body for joints above every body), with the offset it has from that body at the start.
/// Parents come before their children in a skeleton, so one pass finds every joint's body.
fn riders(
    character: &Character,
    bone_of_body: &[usize],
    start: &[Transform],
    body_start: &[Transform],
) -> Vec<Rider> {
    let skeleton = &character.skeleton;
    let root_body = (0..bone_of_body.len())
        .min_by_key(|&i| bone_of_body[i])
        .expect("a spec has bodies");
    let mut body_of_joint: Vec<Option<usize>> = vec![None; skeleton.len()];
    for (b, &j) in bone_of_body.iter().enumerate() {
        if body_of_joint[j].is_none() {
            body_of_joint[j] = Some(b);
        }
    }
    let mut body = vec![root_body; skeleton.len()];
    for j in 0..skeleton.len() {
        body[j] = body_of_joint[j]
            .or_else(|| skeleton.parent(j).map(|p| body[p]))
            .unwrap_or(root_body);
    }
    start
        .iter()
        .zip(&body)
        .map(|(joint_start, &body)| Rider {
            body,
            offset: body_start[body].inverse().mul(joint_start),
        })
        .collect()
}

/// Each skeleton joint's parent where the two ride on one body or on two jointed bodies
/// (`links`: parent and child body of each ragdoll joint); see `Instance::held_bones`.
fn held_bones(
    character: &Character,
    riders: &[Rider],
    links: &[(usize, usize)],
) -> Vec<Option<usize>> {
    let skeleton = &character.skeleton;
    let linked = |a: usize, b: usize| a == b || links.contains(&(a, b)) || links.contains(&(b, a));
    (0..skeleton.len())
        .map(|j| {
            skeleton
                .parent(j)
                .filter(|&p| linked(riders[p].body, riders[j].body))
        })
        .collect()
}
