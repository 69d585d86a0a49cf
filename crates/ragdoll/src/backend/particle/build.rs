//! Adding a ragdoll: how its bodies become particles (shared at the joint anchors),
//! distances and affine constraints, and how its joints become the limits, subtrees and
//! collision filter the solver reads. Kept apart from the backend's state and its
//! `Backend` methods, which only need the flat arrays this fills.

use glam::{Mat3, Vec3};

use super::{Filter, ParticleBackend, solve};
use crate::backend::tree::JointTree;
use crate::backend::{BodyDesc, BodyId, JointDesc, OneAtATime};
use crate::spec::ResolvedJoint;

/// Joint anchors of one parent closer than this share a particle, metres.
const MERGE_M: f32 = 1.0e-3;

/// Each body's first joint as a child (`None` for the root): that joint's anchor leads the
/// body's particles, whatever order its other joints come in.
fn parent_joints(n: usize, joint_descs: &[JointDesc]) -> Vec<Option<usize>> {
    let mut parent_joint: Vec<Option<usize>> = vec![None; n];
    for (k, j) in joint_descs.iter().enumerate() {
        if parent_joint[j.child].is_none() {
            parent_joint[j.child] = Some(k);
        }
    }
    parent_joint
}

impl ParticleBackend {
    /// Adds one ragdoll; returns the global index of its first body.
    pub(crate) fn add_ragdoll_impl(
        &mut self,
        descs: &[BodyDesc],
        joint_descs: &[JointDesc],
        disabled: &[(usize, usize)],
    ) -> usize {
        let fb = self.bodies.len();
        let fp = self.x.len();
        let ragdoll = self.filters.len() as u32;
        let n = descs.len();
        // 1. A particle per joint anchor (anchors of one parent that coincide share one).
        let jp = self.anchor_particles(descs, joint_descs);
        // 2. Each body's particles, masses and rigidity; a light hub's distances relaxed.
        self.build_bodies(fb, ragdoll, descs, joint_descs, &jp);
        self.set_inverse_masses(fp);
        // 3. What a limit turn needs: each body's particles' centre and inertia.
        for b in fb..fb + n {
            self.set_turn_inertia(b);
        }
        // 4. Joints, with global body indices; their subtrees and order.
        self.add_joints(fb, n, joint_descs);
        // 5. Collision filter: jointed pairs, the spec's pairs, bodies sharing a particle.
        self.add_filter(fb, n, joint_descs, disabled);
        self.disable_shared_particles(fb, n, fp);
        self.start_ragdoll(fb, n);
        fb
    }

    /// A particle at `p`, at rest, massless until its bodies add their shares; every
    /// per-particle array grows with it so they stay the same length. Returns its index.
    pub(super) fn new_particle(&mut self, p: Vec3) -> u32 {
        self.x.push(p);
        self.x_prev.push(p);
        self.x_pred.push(p);
        self.v.push(Vec3::ZERO);
        self.m.push(0.0);
        self.w.push(0.0);
        self.kin.push(0);
        self.kin_from.push(p);
        self.kin_to.push(p);
        (self.x.len() - 1) as u32
    }

    /// A particle per joint anchor (anchors of one parent that coincide share one), so a
    /// joint's two bodies hold the same point and the distances keep it closed. Returns
    /// each joint's particle.
    fn anchor_particles(&mut self, descs: &[BodyDesc], joint_descs: &[JointDesc]) -> Vec<u32> {
        let mut jp: Vec<u32> = Vec::with_capacity(joint_descs.len());
        for (k, j) in joint_descs.iter().enumerate() {
            let p = descs[j.child]
                .pose
                .transform_point(j.frame_child.translation);
            let shared = (0..k).find(|&k2| {
                joint_descs[k2].parent == j.parent
                    && (self.x[jp[k2] as usize] - p).length() < MERGE_M
            });
            let id = match shared {
                Some(k2) => jp[k2],
                None => self.new_particle(p),
            };
            jp.push(id);
        }
        jp
    }

    /// Each body's particles, masses and rigidity; a light hub's distances relaxed (its
    /// heavy neighbours would otherwise pull it apart). `jp` is each joint's particle.
    fn build_bodies(
        &mut self,
        fb: usize,
        ragdoll: u32,
        descs: &[BodyDesc],
        joint_descs: &[JointDesc],
        jp: &[u32],
    ) {
        let parent_joint = parent_joints(descs.len(), joint_descs);
        let masses: Vec<f32> = descs.iter().map(|d| d.mass).collect();
        let links: Vec<(usize, usize)> = joint_descs.iter().map(|j| (j.parent, j.child)).collect();
        let hub = crate::backend::hub::hub_relaxation(&masses, &links);
        for (b, desc) in descs.iter().enumerate() {
            let first_distance = self.distances.len();
            self.build_body(
                fb + b,
                ragdoll,
                desc,
                parent_joint[b].map(|k| jp[k]),
                joint_descs
                    .iter()
                    .enumerate()
                    .filter(|(_, j)| j.parent == b || j.child == b)
                    .map(|(k, _)| jp[k]),
            );
            for d in &mut self.distances[first_distance..] {
                d.relax = hub[b];
            }
        }
    }

    /// Inverse masses of the particles from `fp` on, once every body has added its share
    /// to the ones it shares (held or massless particles do not move).
    fn set_inverse_masses(&mut self, fp: usize) {
        for i in fp..self.x.len() {
            self.w[i] = if self.kin[i] > 0 || self.m[i] <= 0.0 {
                0.0
            } else {
                1.0 / self.m[i]
            };
        }
    }

    /// What a limit turn needs: body `b`'s particles' centre and inertia, with the full
    /// masses of the particles it shares (only now summed over its neighbours).
    fn set_turn_inertia(&mut self, b: usize) {
        let range = self.body_parts(b);
        let (mut c, mut msum) = (Vec3::ZERO, 0.0f32);
        for k in range.clone() {
            let m = self.m[self.parts[k] as usize];
            c += self.rest[k] * m;
            msum += m;
        }
        c /= msum.max(1e-12);
        let mut inertia = Mat3::ZERO;
        for k in range {
            let (r, m) = (self.rest[k] - c, self.m[self.parts[k] as usize]);
            inertia += (Mat3::IDENTITY * r.length_squared()
                - Mat3::from_cols(r * r.x, r * r.y, r * r.z))
                * m;
        }
        let trace = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        inertia += Mat3::IDENTITY * (1.0e-6 * trace + 1.0e-12);
        let body = &mut self.bodies[b];
        body.com = c;
        body.inv_inertia = inertia.inverse();
        body.inv_mass = 1.0 / msum.max(1e-12);
    }

    /// Joints, with global body indices (the ragdoll's `n` bodies start at `fb`); their
    /// subtrees and a parents-first order of the joints, for the final projection.
    fn add_joints(&mut self, fb: usize, n: usize, joint_descs: &[JointDesc]) {
        self.joints
            .extend(joint_descs.iter().map(|j| ResolvedJoint {
                parent: fb + j.parent,
                child: fb + j.child,
                frame_parent: j.frame_parent,
                frame_child: j.frame_child,
                kind: j.kind,
            }));
        self.bounds
            .extend(joint_descs.iter().map(|j| solve::Bounds::of(&j.kind)));
        let first_joint = self.joints.len() - joint_descs.len();
        let links: Vec<(usize, usize)> = joint_descs.iter().map(|j| (j.parent, j.child)).collect();
        let tree = JointTree::new(n, &links);
        self.joint_order
            .extend(tree.order.iter().map(|&k| (first_joint + k) as u32));
        self.trees.push((first_joint as u32, tree));
        self.stamp.resize(self.x.len(), 0);
        self.body_stamp.resize(self.bodies.len(), 0);
    }

    /// Collision filter: jointed pairs and the spec's pairs (a joint's bodies overlap at
    /// it by design).
    fn add_filter(
        &mut self,
        fb: usize,
        n: usize,
        joint_descs: &[JointDesc],
        disabled: &[(usize, usize)],
    ) {
        let offset = self.filter_bits.len();
        self.filter_bits.resize(offset + (n * n).div_ceil(64), 0);
        self.filters.push(Filter {
            first_body: fb as u32,
            bodies: n as u32,
            offset,
        });
        for j in joint_descs {
            self.disable_pair(BodyId(fb + j.parent), BodyId(fb + j.child));
        }
        for &(a, b) in disabled {
            self.disable_pair(BodyId(fb + a), BodyId(fb + b));
        }
    }

    /// Bodies that share a particle would fight over it: no contacts between them. The
    /// ragdoll's particles start at `fp`.
    fn disable_shared_particles(&mut self, fb: usize, n: usize, fp: usize) {
        let mut owners: Vec<Vec<usize>> = vec![Vec::new(); self.x.len() - fp];
        for b in fb..fb + n {
            for &p in &self.parts[self.body_parts(b)] {
                if let Some(list) = (p as usize).checked_sub(fp).and_then(|i| owners.get_mut(i)) {
                    list.push(b);
                }
            }
        }
        for list in &owners {
            for (i, &a) in list.iter().enumerate() {
                for &b in &list[i + 1..] {
                    self.disable_pair(BodyId(a), BodyId(b));
                }
            }
        }
    }

    /// Sizes the per-body scratch for the new bodies and reads their frames off the
    /// particles, the last step's equal to them so the first step sees no spin; the
    /// candidate pairs are found again to take the new bodies in.
    fn start_ragdoll(&mut self, fb: usize, n: usize) {
        self.touched.resize(self.bodies.len(), false);
        self.supported.resize(self.bodies.len(), false);
        self.update_frames();
        for b in fb..fb + n {
            self.bodies[b].rot_prev = self.bodies[b].rot;
        }
        self.pairs_left = 0;
    }
}
