//! A body's points and motion through its particles: which particles are its own, the
//! affine weights that carry a body-frame point, the point in the world, an impulse
//! spread over the particles as a rigid change of velocity, and which pairs may collide.

use glam::{Mat3, Vec3};

use super::ParticleBackend;

impl ParticleBackend {
    /// The particle indices of body `b`.
    pub(super) fn body_parts(&self, b: usize) -> std::ops::Range<usize> {
        let body = &self.bodies[b];
        body.first as usize..(body.first + body.count) as usize
    }

    /// Affine weights of the body-frame point `q` of body `b`, into `out` (one per particle).
    pub(super) fn weights(&self, b: usize, q: Vec3, out: &mut [f32]) {
        let body = &self.bodies[b];
        let d = (q - body.rbar).extend(1.0);
        for (o, row) in out.iter_mut().zip(&self.affine[self.body_parts(b)]) {
            *o = row.dot(d);
        }
    }

    /// Whether bodies `a` and `b` (global) may collide.
    pub(super) fn may_collide(&self, a: usize, b: usize) -> bool {
        let (ra, rb) = (self.bodies[a].ragdoll, self.bodies[b].ragdoll);
        if ra == rb {
            let f = &self.filters[ra as usize];
            let (i, j) = (a - f.first_body as usize, b - f.first_body as usize);
            let bit = i * f.bodies as usize + j;
            self.filter_bits[f.offset + bit / 64] & (1u64 << (bit % 64)) == 0
        } else {
            let key = (a.min(b) as u32, a.max(b) as u32);
            self.cross_disabled.is_empty() || self.cross_disabled.binary_search(&key).is_err()
        }
    }

    /// Body-frame point of body `b` in world space through its particles, from its affine
    /// weights `beta` and its offset `resid` from their reconstruction.
    pub(super) fn point_world(&self, b: usize, beta: &[f32], resid: Vec3) -> Vec3 {
        // Points a body's particles span (every capsule end) have no offset.
        let mut p = if resid == Vec3::ZERO {
            Vec3::ZERO
        } else {
            self.bodies[b].rot * resid
        };
        for (k, &i) in self.parts[self.body_parts(b)].iter().enumerate() {
            p += self.x[i as usize] * beta[k];
        }
        p
    }

    /// Whether none of body `b`'s particles is held.
    pub(super) fn body_free(&self, b: usize) -> bool {
        self.parts[self.body_parts(b)]
            .iter()
            .all(|&i| self.w[i as usize] > 0.0)
    }

    /// Rigid velocity change of body `b` for a linear impulse `j` (at `point`, or at its
    /// centre) and an angular impulse `l`, spread over its free particles so that their
    /// momentum changes by exactly those impulses.
    pub(super) fn apply_impulse(&mut self, b: usize, j: Vec3, point: Option<Vec3>, l: Vec3) {
        let range = self.body_parts(b);
        let mut mass = 0.0f32;
        let mut c = Vec3::ZERO;
        for &i in &self.parts[range.clone()] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                mass += self.m[i];
                c += self.x[i] * self.m[i];
            }
        }
        if mass <= 0.0 {
            return;
        }
        c /= mass;
        let l = l + point.map_or(Vec3::ZERO, |p| (p - c).cross(j));
        let mut inertia = Mat3::ZERO;
        for &i in &self.parts[range.clone()] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                let r = self.x[i] - c;
                inertia += (Mat3::IDENTITY * r.length_squared()
                    - Mat3::from_cols(r * r.x, r * r.y, r * r.z))
                    * self.m[i];
            }
        }
        let trace = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        inertia += Mat3::IDENTITY * (1.0e-6 * trace + 1.0e-12);
        let dw = inertia.inverse() * l;
        let dv = j / mass;
        for &i in &self.parts[range] {
            let i = i as usize;
            if self.w[i] > 0.0 {
                self.v[i] += dv + dw.cross(self.x[i] - c);
            }
        }
        // Faster bodies need a wider margin than the candidate pairs were found with.
        self.pairs_left = 0;
    }

    /// Marks particle `p` as held by one more (or one fewer) kinematic body.
    pub(super) fn set_particle_kinematic(&mut self, p: usize, on: bool) {
        if on {
            self.kin[p] += 1;
        } else {
            self.kin[p] = self.kin[p].saturating_sub(1);
        }
        self.w[p] = if self.kin[p] > 0 || self.m[p] <= 0.0 {
            0.0
        } else {
            1.0 / self.m[p]
        };
        if self.kin[p] > 0 {
            self.kin_from[p] = self.x[p];
            self.kin_to[p] = self.x[p];
        }
    }
}
