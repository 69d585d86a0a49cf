//! Laying a body out as particles: a stick or a cluster of anchors with a side and a
//! centre particle (see the module docs), or, for a body whose anchors cannot carry its
//! inertia, an equimomental set.

use glam::{Mat3, Mat4, Vec3, Vec4};

use super::{Affine, Body, Distance, ParticleBackend, triad_frame};
use crate::backend::BodyDesc;
use crate::geometry::capsule_of;
use crate::math::Transform;

/// Shortest stick, metres: a leaf whose capsule barely reaches past its anchor gets a tip
/// this far away, so its direction stays well defined.
const MIN_STICK_M: f32 = 0.02;
/// Smallest share of a body's mass kept on its centre particle, so it never goes to zero
/// (a short, fat body such as a head has more inertia than its ends can carry).
const MIN_CENTRE_SHARE: f32 = 0.05;
/// Bounds of the side particle's share of its body's mass. Its share times its distance
/// squared is the moment about the bone; a very light one would let a twist limit throw it
/// around, a heavy one would swamp the moment across the bone.
const SIDE_SHARE: (f32, f32) = (0.005, 0.15);
/// A cluster's side particle's share of its mass.
const CLUSTER_SIDE_SHARE: f32 = 0.05;
/// Least share of a stick's moment of inertia across its bone that its anchors must carry
/// for the stick layout to be used; below it the body gets the equimomental layout.
///
/// The three-point rule needs more mass on the anchors the nearer the centre of mass sits
/// to one of them; past the room it has, the centre particle balances the rest, metres
/// away and nearly weightless, and the body keeps almost no inertia about one axis. A head
/// or a hand edited into a ball round its joint (0.75 m across, 4 cm of bone) carried
/// 0.2 % of it: a contact or a blast spun it without bound and the run went non-finite
/// within two steps. The built-in humanoid's worst part, its head, carries 20 %; its
/// limbs carry all of it; the rigged Stanford dragon's tail 6 % (the equimomental set
/// left it creeping along the floor at 4 cm/s after 7 s, where the stick rests).
const MIN_CARRIED_SHARE: f32 = 0.02;
/// Share of an equimomental body's mass on its anchors (split evenly): enough for the
/// joints to have some weight of their own, little enough for four particles round the
/// centre of mass to carry the rest of the inertia.
const EQUIMOMENTAL_ANCHOR_SHARE: f32 = 0.1;
/// Least spread of an equimomental body's particles along any axis, as a share of its
/// mean spread: a flat body's set stays a solid tetrahedron, whose distances hold it rigid
/// in 3-D (four points in a plane can fold).
const MIN_SPREAD_SHARE: f32 = 1.0e-3;

/// Least-norm affine weights of `q` over `points` (they sum to one and reproduce `q`
/// exactly when the points span it), through the rows `(AAᵀ)⁻¹ cᵢ` of the centred points.
fn affine_rows(points: &[Vec3]) -> (Vec3, Vec<Vec4>) {
    let rbar = points.iter().copied().sum::<Vec3>() / points.len() as f32;
    let mut aat = Mat4::ZERO;
    for r in points {
        let c = (*r - rbar).extend(1.0);
        aat += Mat4::from_cols(c * c.x, c * c.y, c * c.z, c * c.w);
    }
    let trace = aat.x_axis.x + aat.y_axis.y + aat.z_axis.z;
    let eps = 1.0e-4 * trace + 1.0e-9;
    aat += Mat4::from_diagonal(Vec4::new(eps, eps, eps, 0.0));
    let inv = aat.inverse();
    (
        rbar,
        points
            .iter()
            .map(|r| inv * (*r - rbar).extend(1.0))
            .collect(),
    )
}

/// The tip of a leaf body with one anchor at `lb` (body frame): the capsule end farther
/// from the anchor, or a point past the centre when the capsule barely reaches past it.
fn leaf_tip(lb: Vec3, e: [Vec3; 2], radius: f32) -> Vec3 {
    let far = if (e[0] - lb).length() > (e[1] - lb).length() {
        e[0]
    } else {
        e[1]
    };
    if (far - lb).length() >= MIN_STICK_M {
        far
    } else {
        let dir = (-lb).normalize_or(Vec3::Y);
        lb + dir * radius.max(MIN_STICK_M)
    }
}

/// `m · r rᵀ`.
fn outer(r: Vec3, m: f32) -> Mat3 {
    Mat3::from_cols(r * r.x, r * r.y, r * r.z) * m
}

/// Lower-triangular `L` with `L Lᵀ = m`, or `None` unless `m` (symmetric) is positive
/// definite with every pivot above `floor`.
fn cholesky(m: Mat3, floor: f32) -> Option<Mat3> {
    let a = |i: usize, j: usize| m.col(j)[i];
    let d0 = a(0, 0);
    if d0 <= floor {
        return None;
    }
    let l00 = d0.sqrt();
    let (l10, l20) = (a(1, 0) / l00, a(2, 0) / l00);
    let d1 = a(1, 1) - l10 * l10;
    if d1 <= floor {
        return None;
    }
    let l11 = d1.sqrt();
    let l21 = (a(2, 1) - l20 * l10) / l11;
    let d2 = a(2, 2) - l20 * l20 - l21 * l21;
    if d2 <= floor {
        return None;
    }
    Some(Mat3::from_cols(
        Vec3::new(l00, l10, l20),
        Vec3::new(0.0, l11, l21),
        Vec3::new(0.0, 0.0, d2.sqrt()),
    ))
}

/// Where a body's anchors (rest offsets, parent anchor first) lie: the farthest from the
/// first, the bone's direction, the one farthest off that line, and whether they are all
/// (nearly) on it.
struct Stick {
    ifar: usize,
    extent: f32,
    dir: Vec3,
    ioff: usize,
    line: bool,
}

impl Stick {
    fn of(rest: &[Vec3]) -> Self {
        let (ifar, extent) = rest
            .iter()
            .enumerate()
            .map(|(k, r)| (k, (*r - rest[0]).length()))
            .fold((0, 0.0f32), |a, b| if b.1 > a.1 { b } else { a });
        let dir = (rest[ifar] - rest[0]) / extent.max(1e-9);
        let (ioff, off) = rest
            .iter()
            .enumerate()
            .map(|(k, r)| (k, (*r - rest[0]).reject_from_normalized(dir).length()))
            .fold((0, 0.0f32), |a, b| if b.1 > a.1 { b } else { a });
        Stick {
            ifar,
            extent,
            dir,
            ioff,
            line: off < 1.0e-2 * extent,
        }
    }
}

/// A stick's anchor masses by the three-point rule about the centre's foot on the bone.
struct ThreePoint {
    /// Distances of the foot from the first anchor and from the far one.
    p: f32,
    q: f32,
    /// The masses of the first and the far anchor.
    ma: f32,
    mb: f32,
    /// The body's moment of inertia about the bone and across it.
    axial: f32,
    across: f32,
}

impl ThreePoint {
    fn of(rest0: Vec3, stick: &Stick, inertia: Mat3, mass: f32) -> Self {
        let (extent, dir) = (stick.extent, stick.dir);
        let t = ((-rest0).dot(dir) / extent).clamp(0.05, 0.95);
        let (p, q) = (t * extent, (1.0 - t) * extent);
        // Floors relative to the body's own inertia: an absolute one (1e-9 kg·m²) was
        // larger than a milligram hand's whole tensor, which made its anchors' masses
        // negative and the run NaN.
        let trace = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        let axial = dir
            .dot(inertia * dir)
            .max(1e-9 * trace)
            .max(f32::MIN_POSITIVE);
        let across = 0.5 * (inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z - axial);
        let (mut ma, mut mb) = (across / (p * (p + q)), across / (q * (p + q)));
        let room = (1.0 - MIN_CENTRE_SHARE - SIDE_SHARE.1) * mass;
        if ma + mb > room {
            ma = room * q / (p + q);
            mb = room * p / (p + q);
        }
        ThreePoint {
            p,
            q,
            ma,
            mb,
            axial,
            across,
        }
    }

    /// Whether the anchors carry less than `MIN_CARRIED_SHARE` of the moment across the
    /// bone (`ma p² + mb q²` is `across` unless the room ran out).
    fn too_short(&self) -> bool {
        let (p, q) = (self.p, self.q);
        self.ma * p * p + self.mb * q * q < MIN_CARRIED_SHARE * self.across
    }
}

/// The masses of a body's anchors and its side particle, and where the side particle
/// rests (body frame); the centre takes the rest of the mass.
struct SideAndShares {
    shares: Vec<f32>,
    side_rest: Vec3,
    side_share: f32,
}

/// [`SideAndShares`] for a body whose `count` anchors (and tip) rest at `rest`: along a
/// line, the three-point rule's anchor masses and a side particle carrying the inertia
/// about the bone; else equal anchors and a side particle off their plane.
fn side_and_shares(
    rest: &[Vec3],
    stick: &Stick,
    rule: Option<ThreePoint>,
    radius: f32,
    mass: f32,
    count: usize,
) -> SideAndShares {
    let mut shares = vec![0.0f32; count];
    let d = (0.5 * stick.extent).max(radius).max(MIN_STICK_M);
    if let Some(ThreePoint {
        p, ma, mb, axial, ..
    }) = rule
    {
        shares[0] = ma;
        shares[stick.ifar] = mb;
        let perp = Vec3::X
            .reject_from_normalized(stick.dir)
            .try_normalize()
            .unwrap_or_else(|| stick.dir.any_orthonormal_vector());
        SideAndShares {
            shares,
            side_rest: rest[0] + stick.dir * p + perp * d,
            side_share: (axial / (d * d)).clamp(SIDE_SHARE.0 * mass, SIDE_SHARE.1 * mass),
        }
    } else {
        let normal = stick.dir.cross(rest[stick.ioff] - rest[0]).normalize();
        shares.fill(0.5 * mass / count as f32);
        SideAndShares {
            shares,
            side_rest: normal * d,
            side_share: CLUSTER_SIDE_SHARE * mass,
        }
    }
}

impl ParticleBackend {
    /// Body `bi`'s particles: its anchors (the parent joint's first), a tip or two ends
    /// where it has fewer than two apart, a side particle and a centre; their masses, the
    /// distances that keep them rigid, and the weights of its capsule ends. A stick whose
    /// anchors cannot carry its inertia is laid out as an equimomental set instead.
    pub(super) fn build_body(
        &mut self,
        bi: usize,
        ragdoll: u32,
        desc: &BodyDesc,
        parent_anchor: Option<u32>,
        anchors: impl Iterator<Item = u32>,
    ) {
        let pose = desc.pose;
        let inv = pose.inverse();
        let (e, radius) = capsule_of(&desc.shape);
        let mass = desc.mass;
        let mut list = self.anchor_list(&pose, e, radius, parent_anchor, anchors);
        let rest_of = |s: &Self, i: u32| inv.transform_point(s.x[i as usize]);
        // The anchors' extent: a tip where they are (nearly) one point.
        let r0 = rest_of(self, list[0]);
        let extent = list
            .iter()
            .map(|&i| (rest_of(self, i) - r0).length())
            .fold(0.0f32, f32::max);
        let tip = (extent < MIN_STICK_M).then(|| pose.transform_point(leaf_tip(r0, e, radius)));
        let mut rest: Vec<Vec3> = list.iter().map(|&i| rest_of(self, i)).collect();
        rest.extend(tip.map(|t| inv.transform_point(t)));
        let stick = Stick::of(&rest);
        let inertia = crate::geometry::body_inertia(&desc.shape, &desc.extra_shapes, mass);
        let rule = stick
            .line
            .then(|| ThreePoint::of(rest[0], &stick, inertia, mass));
        if rule.as_ref().is_some_and(ThreePoint::too_short) {
            self.build_equimomental(bi, ragdoll, desc, &list, inertia);
            return;
        }
        list.extend(tip.map(|t| self.new_particle(t)));
        let masses = side_and_shares(&rest, &stick, rule, radius, mass, list.len());
        let side = self.new_particle(pose.transform_point(masses.side_rest));
        let centre_share = mass - masses.shares.iter().sum::<f32>() - masses.side_share;
        // The centre goes where the body's centre of mass (its origin) comes out right.
        let moment: Vec3 = rest
            .iter()
            .zip(&masses.shares)
            .map(|(r, s)| *r * *s)
            .sum::<Vec3>()
            + masses.side_rest * masses.side_share;
        let want_centre = -moment / centre_share.max(1e-9 * mass);
        // Rigidity: every pair of anchors and the side particle.
        let mut frame_pts = list.clone();
        frame_pts.push(side);
        let mut frame_rest = rest;
        frame_rest.push(masses.side_rest);
        self.rigid_set(&frame_pts, &frame_rest);
        // The centre as an affine combination of the triad and the side particle.
        let triad = if stick.line {
            [0, stick.ifar, list.len()]
        } else {
            [0, stick.ifar, stick.ioff]
        };
        let mut refs_k: Vec<usize> = triad.to_vec();
        if !stick.line {
            refs_k.push(list.len());
        }
        let (centre, centre_rest) =
            self.centre_particle(&pose, &frame_pts, &frame_rest, &refs_k, want_centre);
        // Masses.
        for (&i, &s) in list.iter().zip(&masses.shares) {
            self.m[i as usize] += s;
        }
        self.m[side as usize] += masses.side_share;
        self.m[centre as usize] += centre_share;
        // Rest offsets, affine rows of all its particles.
        let mut all = frame_pts;
        all.push(centre);
        let mut all_rest = frame_rest;
        all_rest.push(centre_rest);
        // Points of the body (contacts, pins) are combinations of its anchors and centre,
        // not of the light side particle: a push there would twist the body.
        let side_k = all.len() - 2;
        let spanning: Vec<Vec3> = all_rest
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != side_k)
            .map(|(_, r)| *r)
            .collect();
        let (rbar, mut rows) = affine_rows(&spanning);
        rows.insert(side_k, Vec4::ZERO);
        self.finish_body(bi, ragdoll, desc, &all, &all_rest, (rbar, rows), triad);
    }

    /// A body's anchor particles: its parent joint's first, then its other joints', each
    /// once; two new ones at its capsule's ends (a stick at least [`MIN_STICK_M`] long)
    /// where it has none.
    fn anchor_list(
        &mut self,
        pose: &Transform,
        e: [Vec3; 2],
        radius: f32,
        parent_anchor: Option<u32>,
        anchors: impl Iterator<Item = u32>,
    ) -> Vec<u32> {
        let mut list: Vec<u32> = parent_anchor.into_iter().collect();
        for p in anchors {
            if !list.contains(&p) {
                list.push(p);
            }
        }
        if list.is_empty() {
            let (mut a, mut c) = (e[0], e[1]);
            if (c - a).length() < MIN_STICK_M {
                let h = Vec3::Y * (0.5 * MIN_STICK_M).max(radius);
                (a, c) = (-h, h);
            }
            list.push(self.new_particle(pose.transform_point(a)));
            list.push(self.new_particle(pose.transform_point(c)));
        }
        list
    }

    /// The centre particle, placed so that the affine combination of the reference
    /// particles `refs_k` (of `frame_pts`, at `frame_rest`) that gives it lands at
    /// `want_centre` (body frame); returns it and its rest offset.
    fn centre_particle(
        &mut self,
        pose: &Transform,
        frame_pts: &[u32],
        frame_rest: &[Vec3],
        refs_k: &[usize],
        want_centre: Vec3,
    ) -> (u32, Vec3) {
        let ref_rest: Vec<Vec3> = refs_k.iter().map(|&k| frame_rest[k]).collect();
        let (rb, rows) = affine_rows(&ref_rest);
        let dq = (want_centre - rb).extend(1.0);
        let mut alpha = [0.0f32; 4];
        let mut refs = [frame_pts[refs_k[0]]; 4];
        for (s, (&k, row)) in refs_k.iter().zip(&rows).enumerate() {
            alpha[s] = row.dot(dq);
            refs[s] = frame_pts[k];
        }
        let centre_rest: Vec3 = ref_rest.iter().zip(alpha).map(|(r, a)| *r * a).sum();
        let centre = self.new_particle(pose.transform_point(centre_rest));
        self.affines.push(Affine {
            c: centre,
            refs,
            alpha,
        });
        (centre, centre_rest)
    }

    /// Body `bi` as its anchors `list`, holding `EQUIMOMENTAL_ANCHOR_SHARE` of its mass,
    /// and four particles of equal mass at the corners of a tetrahedron round its centre
    /// of mass, stretched so that the set has the body's mass, centre of mass and inertia
    /// exactly (Routh's equimomental system). Anchors whose share would leave the four
    /// less than the rest of the inertia (far from the centre of mass) carry less.
    fn build_equimomental(
        &mut self,
        bi: usize,
        ragdoll: u32,
        desc: &BodyDesc,
        list: &[u32],
        inertia: Mat3,
    ) {
        let pose = desc.pose;
        let inv = pose.inverse();
        let mass = desc.mass;
        let rest_a: Vec<Vec3> = list
            .iter()
            .map(|&i| inv.transform_point(self.x[i as usize]))
            .collect();
        // Second moment about the centre of mass (the body origin): Σ m r rᵀ.
        let trace = inertia.x_axis.x + inertia.y_axis.y + inertia.z_axis.z;
        let floor = MIN_SPREAD_SHARE * trace / 6.0;
        let second = Mat3::IDENTITY * (0.5 * trace) - inertia + Mat3::IDENTITY * floor;
        let mut share = EQUIMOMENTAL_ANCHOR_SHARE * mass / list.len() as f32;
        // The four carry what the anchors leave: mass `rest_m`, centre `mu`, and the
        // second moment left about `mu`, which must stay positive definite.
        let (mu, rest_m, spread) = loop {
            let rest_m = mass - share * list.len() as f32;
            let mu = -rest_a.iter().copied().sum::<Vec3>() * (share / rest_m);
            let mut left = second - outer(mu, rest_m);
            for r in &rest_a {
                left -= outer(*r, share);
            }
            // A regular tetrahedron of unit circumradius has Σ v vᵀ = 4/3: corners
            // `mu + L v` of mass `rest_m / 4` give `rest_m / 3 · L Lᵀ`.
            if let Some(l) = cholesky(left * (3.0 / rest_m), 3.0 * floor / mass) {
                break (mu, rest_m, l);
            }
            share *= 0.5;
            if share < 1.0e-6 * mass {
                // Anchors (nearly) weightless: only the floor is left to spread over.
                let l = cholesky(second * (3.0 / mass), 0.0).unwrap_or(Mat3::ZERO);
                break (Vec3::ZERO, mass, l);
            }
        };
        let k = 1.0 / 3.0f32.sqrt();
        let corners = [
            Vec3::new(k, k, k),
            Vec3::new(k, -k, -k),
            Vec3::new(-k, k, -k),
            Vec3::new(-k, -k, k),
        ];
        let mut all = list.to_vec();
        let mut all_rest = rest_a;
        for c in corners {
            let r = mu + spread * c;
            let id = self.new_particle(pose.transform_point(r));
            self.m[id as usize] += 0.25 * rest_m;
            all.push(id);
            all_rest.push(r);
        }
        let anchor_share = (mass - rest_m) / list.len() as f32;
        for &a in list {
            self.m[a as usize] += anchor_share;
        }
        self.rigid_set(&all, &all_rest);
        let n = list.len();
        let rows = affine_rows(&all_rest);
        self.finish_body(bi, ragdoll, desc, &all, &all_rest, rows, [n, n + 1, n + 2]);
    }

    /// Distances between every pair of `points` (rest offsets `rest`).
    fn rigid_set(&mut self, points: &[u32], rest: &[Vec3]) {
        for a in 0..points.len() {
            for b in a + 1..points.len() {
                self.distances.push(Distance {
                    a: points[a],
                    b: points[b],
                    len: (rest[b] - rest[a]).length(),
                    relax: 1.0,
                });
            }
        }
    }

    /// Registers body `bi` with its particles `all` (rest offsets `all_rest`), their
    /// affine rows and the three (indices into `all`) whose frame is the body's, and
    /// works out the weights of its capsule ends and origin.
    #[allow(clippy::too_many_arguments)]
    fn finish_body(
        &mut self,
        bi: usize,
        ragdoll: u32,
        desc: &BodyDesc,
        all: &[u32],
        all_rest: &[Vec3],
        (rbar, rows): (Vec3, Vec<Vec4>),
        triad: [usize; 3],
    ) {
        let pose = desc.pose;
        let (e, radius) = capsule_of(&desc.shape);
        let first = self.parts.len() as u32;
        self.parts.extend_from_slice(all);
        self.rest.extend_from_slice(all_rest);
        self.affine.extend_from_slice(&rows);
        let tri = triad.map(|k| all_rest[k]);
        self.bodies.push(Body {
            ragdoll,
            first,
            count: all.len() as u32,
            triad: triad.map(|k| all[k]),
            tri_inv: triad_frame(tri[0], tri[1], tri[2]).conjugate(),
            tri_origin: tri[0],
            shape: desc.shape,
            extras: desc.extra_shapes.clone(),
            e,
            radius,
            rbar,
            mass: desc.mass,
            com: Vec3::ZERO,
            inv_inertia: Mat3::IDENTITY,
            inv_mass: 0.0,
            rot: pose.rotation,
            pos: pose.translation,
            rot_prev: pose.rotation,
            kinematic: false,
            removed: false,
        });
        let count = all.len();
        let mut be = vec![vec![0.0f32; count]; 3];
        for (s, q) in [e[0], e[1], Vec3::ZERO].into_iter().enumerate() {
            self.weights(bi, q, &mut be[s]);
        }
        let resid = [0, 1].map(|s| {
            let recon: Vec3 = all_rest.iter().zip(&be[s]).map(|(r, b)| *r * *b).sum();
            let off = e[s] - recon;
            if off.length() < 1.0e-6 {
                Vec3::ZERO
            } else {
                off
            }
        });
        self.resid_e.push(resid);
        self.beta_e[0].extend_from_slice(&be[0]);
        self.beta_e[1].extend_from_slice(&be[1]);
        self.beta_o.extend_from_slice(&be[2]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_refuses_what_is_not_positive_definite() {
        let m = Mat3::from_cols(
            Vec3::new(4.0, 2.0, 0.0),
            Vec3::new(2.0, 3.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        );
        let l = cholesky(m, 0.0).unwrap();
        assert!(
            (l * l.transpose() - m)
                .abs()
                .to_cols_array()
                .iter()
                .all(|v| *v < 1e-6)
        );
        assert!(cholesky(Mat3::from_diagonal(Vec3::new(1.0, -1.0, 1.0)), 0.0).is_none());
        assert!(cholesky(Mat3::from_diagonal(Vec3::new(1.0, 1.0, 0.5)), 0.6).is_none());
    }
}
