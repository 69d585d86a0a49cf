//! Masses: de Leva's segment fractions for humanoids, volume × density for anything
//! else (the volume the skin encloses when it is closed enough, else the body shapes'),
//! then stabilised so no jointed pair is too unequal for an iterative solver.

use std::collections::HashMap;

use glam::{Vec3, Vec4};

use super::{Builder, Plan};
use crate::skeleton::SkinnedMesh;
use crate::spec::Role;
use crate::spec::anthropometry::*;

/// Largest mass ratio between a jointed parent and child. Strunk ("Stop my Constraints
/// from Blowing Up!", GDC 2013) shows iterative solvers converge badly as linked masses
/// diverge; Jolt's `RagdollSettings::Stabilize` clamps each child/parent ratio to
/// [0.8, 1.2], which flattens anatomy. 5 keeps de Leva's proportions except the lightest
/// links (neck, upper arms against a 12 kg chest), which are raised.
pub(super) const MAX_LINKED_MASS_RATIO: f32 = 5.0;

impl Builder<'_> {
    pub(super) fn masses(
        &self,
        plans: &[Plan],
        parents: &[usize],
        meshes: &[SkinnedMesh],
    ) -> Vec<f32> {
        let mut m: Vec<f32> = if self.roles.humanoid {
            let total = self.opts.total_mass_kg.unwrap_or(DEFAULT_HUMANOID_MASS_KG);
            self.humanoid_masses(plans, total)
        } else {
            let volumes = self.creature_volumes(plans, meshes);
            match self.opts.total_mass_kg {
                Some(total) => {
                    let v: f32 = volumes.iter().sum();
                    volumes.iter().map(|x| total * x / v).collect()
                }
                None => volumes.iter().map(|x| x * BODY_DENSITY_KG_M3).collect(),
            }
        };
        let total = match (self.roles.humanoid, self.opts.total_mass_kg) {
            (_, Some(t)) => t,
            (true, None) => DEFAULT_HUMANOID_MASS_KG,
            (false, None) => m.iter().sum(),
        };
        stabilize_masses(&mut m, parents, MAX_LINKED_MASS_RATIO);
        keep_total(&mut m, total);
        m
    }

    /// Each body's volume, m³: its share of what the skin encloses when the skin is closed
    /// enough ([`skin_volume`]); a body the skin does not carry, and every body of a
    /// creature without such a skin, gets its shape's volume.
    fn creature_volumes(&self, plans: &[Plan], meshes: &[SkinnedMesh]) -> Vec<f32> {
        let axes: Vec<(Vec3, Vec3)> = plans.iter().map(|p| (p.start, p.end)).collect();
        let owner = |js: &[u16; 4], ws: &Vec4| {
            let mut share: [(usize, f32); 4] = [(usize::MAX, 0.0); 4];
            for c in 0..4 {
                let Some(&o) = self.owner.get(js[c] as usize) else {
                    continue;
                };
                if let Some(s) = share.iter_mut().find(|s| s.0 == o || s.0 == usize::MAX) {
                    s.0 = o;
                    s.1 += ws[c].max(0.0);
                }
            }
            share
                .iter()
                .filter(|s| s.0 != usize::MAX && s.1 > 0.0)
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|s| s.0)
        };
        let skin = skin_volume(meshes, &axes, owner, self.rig.extent);
        plans
            .iter()
            .enumerate()
            .map(|(b, p)| match &skin {
                Some(s) if s.per_body_m3[b] > 0.0 => s.per_body_m3[b],
                _ => p.shape.volume(),
            })
            .collect()
    }

    /// de Leva's fractions of `total`, each segment on the body that carries it; segments
    /// without a body of their own (no spine joint, no hand joint…) go to the neighbour
    /// that spans them, so the total is kept exactly.
    fn humanoid_masses(&self, plans: &[Plan], total: f32) -> Vec<f32> {
        use Role::*;
        let fr = if self.opts.female {
            DE_LEVA_FEMALE
        } else {
            DE_LEVA_MALE
        };
        let kg = |percent: f32| total * percent / fr.total_percent();
        let has = |r: Role| plans.iter().any(|p| p.role == r);
        let mut mass = std::collections::HashMap::<Role, f32>::new();
        let mut give = |r: Role, m: f32| *mass.entry(r).or_insert(0.0) += m;

        give(Pelvis, kg(fr.trunk_lower));
        give(Chest, kg(fr.trunk_upper));
        if has(Spine) {
            give(Spine, kg(fr.trunk_middle));
        } else {
            // The abdomen lies between the pelvis and chest bodies: half to each.
            give(Pelvis, 0.5 * kg(fr.trunk_middle));
            give(Chest, 0.5 * kg(fr.trunk_middle));
        }
        let head_neck = kg(fr.head_neck);
        match (has(Neck), has(Head)) {
            (true, true) => {
                give(Neck, NECK_SHARE_OF_HEAD_NECK * head_neck);
                give(Head, (1.0 - NECK_SHARE_OF_HEAD_NECK) * head_neck);
            }
            (true, false) => give(Neck, head_neck),
            (false, true) => give(Head, head_neck),
            (false, false) => give(Chest, head_neck),
        }
        for side in [
            [UpperArmL, ForearmL, HandL, ThighL, ShinL, FootL],
            [UpperArmR, ForearmR, HandR, ThighR, ShinR, FootR],
        ] {
            let [ua, fa, hd, th, sh, ft] = side;
            give(ua, kg(fr.upper_arm));
            give(fa, kg(fr.forearm));
            give(if has(hd) { hd } else { fa }, kg(fr.hand));
            give(th, kg(fr.thigh));
            give(sh, kg(fr.shank));
            give(if has(ft) { ft } else { sh }, kg(fr.foot));
        }
        plans
            .iter()
            .map(|p| mass.get(&p.role).copied().unwrap_or(0.0))
            .collect()
    }
}

/// Raises the lighter of any jointed pair until no pair's mass ratio exceeds `max_ratio`,
/// then rescales everything so the total is what it was (Strunk, GDC 2013; Jolt's
/// `RagdollSettings::Stabilize` does the same with a tighter ratio). Raising only ever
/// lifts a body toward a heavier neighbour, so the loop ends; rescaling keeps the ratios.
pub fn stabilize_masses(masses: &mut [f32], parents: &[usize], max_ratio: f32) {
    let total: f32 = masses.iter().sum();
    for _ in 0..masses.len().max(1) * 4 {
        let mut changed = false;
        for (c, &p) in parents.iter().enumerate() {
            if c == p {
                continue;
            }
            let (mc, mp) = (masses[c], masses[p]);
            if mc * max_ratio < mp * (1.0 - 1e-6) {
                masses[c] = mp / max_ratio;
                changed = true;
            } else if mp * max_ratio < mc * (1.0 - 1e-6) {
                masses[p] = mc / max_ratio;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let now: f32 = masses.iter().sum();
    if now > 0.0 {
        for m in masses.iter_mut() {
            *m *= total / now;
        }
    }
    keep_total(masses, total);
}

/// Puts the rounding residue of a float sum on the first (root, heaviest-ish) body so the
/// masses add up to `total` as closely as f32 allows.
fn keep_total(masses: &mut [f32], total: f32) {
    let now: f32 = masses.iter().sum();
    if let Some(first) = masses.first_mut() {
        *first += total - now;
    }
}

/// A skin whose holes need caps covering more than this share of its surface is not
/// closed enough to enclose a volume (a cloth, a plane, a shell open at the back): the
/// creature is then weighed by its body shapes. Eye sockets, a mouth and a neck opening
/// of a real creature's skin are a few percent.
pub const MAX_SKIN_HOLE_FRACTION: f32 = 0.1;

/// Positions closer than this fraction of the character's size are one vertex when the
/// skin's edges are matched: exporters split vertices along UV and normal seams, which
/// would otherwise read as holes.
const WELD_FRACTION: f32 = 1e-5;

/// The volume a skin encloses, measured per body.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SkinVolume {
    /// Enclosed volume of every closed-enough mesh, m³.
    pub total_m3: f32,
    /// Each body's share of `total_m3`, m³ (zero for a body the skin does not carry).
    pub per_body_m3: Vec<f32>,
}

/// What one mesh adds: its volume, its surface and its holes' caps.
struct MeshVolume {
    volume: f32,
    per_body: Vec<f32>,
    area: f32,
    hole_area: f32,
}

/// The enclosed volume of the closed-enough meshes of a skin, split over the bodies.
///
/// The volume is the divergence theorem's sum of signed tetrahedra over the triangles,
/// exact for a closed surface whatever its shape. Holes (eyes, a mouth) are capped with a
/// fan from each hole's centre first. Each body's share is the same theorem with a field
/// radial from its own bone ([`flux_from_axis`]) over the triangles it carries: for a limb
/// that is the limb's own volume, which splitting the total by the loose-fit shape
/// volumes would not give. The shares are rescaled to the exact total, since a joint's
/// cut is not exactly across both bones.
///
/// `owner(joints, weights)` names the body a vertex moves with; `axes` are the bodies'
/// bone segments. `None` when no mesh is closed enough or the volume is not positive.
pub(crate) fn skin_volume(
    meshes: &[SkinnedMesh],
    axes: &[(Vec3, Vec3)],
    owner: impl Fn(&[u16; 4], &Vec4) -> Option<usize>,
    extent: f32,
) -> Option<SkinVolume> {
    let mut total = 0.0f32;
    let mut per_body = vec![0.0f32; axes.len()];
    let (mut closed_area, mut all_area) = (0.0f32, 0.0f32);
    for m in meshes {
        let Some(mv) = mesh_volume(m, axes, &owner, extent) else {
            continue;
        };
        all_area += mv.area;
        if mv.hole_area > MAX_SKIN_HOLE_FRACTION * mv.area {
            continue;
        }
        closed_area += mv.area;
        // A mesh wound inside out encloses a negative volume; its magnitude is the same.
        let sign = mv.volume.signum();
        total += mv.volume.abs();
        for (b, v) in per_body.iter_mut().zip(&mv.per_body) {
            *b += sign * v;
        }
    }
    // Open meshes (a cape, a plane) carry little volume; the closed ones must be most
    // of the skin for the skin to stand for the creature.
    if !(total.is_finite() && total > 0.0)
        || closed_area < (1.0 - MAX_SKIN_HOLE_FRACTION) * all_area
    {
        return None;
    }
    for v in per_body.iter_mut() {
        *v = v.max(0.0);
    }
    let sum: f32 = per_body.iter().sum();
    if sum <= 0.0 {
        return None;
    }
    for v in per_body.iter_mut() {
        *v *= total / sum;
    }
    Some(SkinVolume {
        total_m3: total,
        per_body_m3: per_body,
    })
}

fn mesh_volume(
    m: &SkinnedMesh,
    axes: &[(Vec3, Vec3)],
    owner: &impl Fn(&[u16; 4], &Vec4) -> Option<usize>,
    extent: f32,
) -> Option<MeshVolume> {
    let n = m.positions.len();
    if n == 0 || m.indices.len() < 3 {
        return None;
    }
    // Work about the mesh's centre: f32 tetrahedra from a far origin lose their digits.
    let (lo, hi) = m
        .positions
        .iter()
        .filter(|p| p.is_finite())
        .fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    if lo.x > hi.x {
        return None;
    }
    let o = 0.5 * (lo + hi);
    let q = (extent * WELD_FRACTION).max(f32::MIN_POSITIVE);
    let mut weld = HashMap::<[i64; 3], u32>::new();
    let mut welded = Vec::with_capacity(n);
    let mut at = Vec::new();
    for p in &m.positions {
        let key = ((*p - o) / q).round().as_i64vec3().to_array();
        let next = at.len() as u32;
        let id = *weld.entry(key).or_insert(next);
        if id == next {
            at.push(*p - o);
        }
        welded.push(id);
    }
    let body_of: Vec<Option<usize>> = (0..n)
        .map(|k| match (m.joints.get(k), m.weights.get(k)) {
            (Some(j), Some(w)) => owner(j, w).filter(|&b| b < axes.len()),
            _ => None,
        })
        .collect();
    let mut per_body = vec![0.0f32; axes.len()];
    let mut volume = 0.0f32;
    let mut area = 0.0f32;
    // Net count of each directed edge: a closed surface uses every edge once each way.
    let mut edges = HashMap::<(u32, u32), (i32, Option<usize>)>::new();
    let wedge = |body: Option<usize>, a: Vec3, b: Vec3, c: Vec3, times: f32, per: &mut [f32]| {
        if let Some(k) = body {
            per[k] += times * flux_from_axis(axes[k].0 - o, axes[k].1 - o, a, b, c);
        }
    };
    for t in m.indices.chunks_exact(3) {
        let [i, j, k] = [t[0] as usize, t[1] as usize, t[2] as usize];
        if i >= n || j >= n || k >= n {
            continue;
        }
        let w = [welded[i], welded[j], welded[k]];
        let [a, b, c] = w.map(|v| at[v as usize]);
        if w[0] == w[1] || w[1] == w[2] || w[2] == w[0] || !(a + b + c).is_finite() {
            continue;
        }
        let body = majority([body_of[i], body_of[j], body_of[k]]);
        volume += tetra(a, b, c);
        area += 0.5 * (b - a).cross(c - a).length();
        wedge(body, a, b, c, 1.0, &mut per_body);
        for (u, v) in [(w[0], w[1]), (w[1], w[2]), (w[2], w[0])] {
            let (key, d) = if u < v { ((u, v), 1) } else { ((v, u), -1) };
            let e = edges.entry(key).or_insert((0, body));
            e.0 += d;
        }
    }
    // Cap each hole: its unmatched edges, grouped by the vertices they share, closed by a
    // fan from the group's centre, wound to match the surface.
    let open: Vec<((u32, u32), i32, Option<usize>)> = edges
        .into_iter()
        .filter(|(_, (c, _))| *c != 0)
        .map(|(k, (c, b))| (k, c, b))
        .collect();
    let mut group = UnionFind::default();
    for ((u, v), _, _) in &open {
        group.union(*u, *v);
    }
    let mut centre = HashMap::<u32, (Vec3, f32)>::new();
    for ((u, v), _, _) in &open {
        for x in [*u, *v] {
            let e = centre.entry(group.find(x)).or_insert((Vec3::ZERO, 0.0));
            e.0 += at[x as usize];
            e.1 += 1.0;
        }
    }
    let mut hole_area = 0.0f32;
    for ((u, v), count, body) in &open {
        let (sum, k) = centre[&group.find(*u)];
        let c = sum / k;
        // The surface went u→v `count` times more than v→u: the cap goes v→u.
        let (a, b) = if *count > 0 { (*v, *u) } else { (*u, *v) };
        let (pa, pb) = (at[a as usize], at[b as usize]);
        let times = count.unsigned_abs() as f32;
        volume += times * tetra(c, pa, pb);
        hole_area += times * 0.5 * (pa - c).cross(pb - c).length();
        wedge(*body, c, pa, pb, times, &mut per_body);
    }
    Some(MeshVolume {
        volume,
        per_body,
        area,
        hole_area,
    })
}

/// Signed volume of the tetrahedron from the origin to the triangle `a b c`.
fn tetra(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    a.dot(b.cross(c)) / 6.0
}

/// The triangle's share of the volume around the bone `s`→`e`: the flux through it of
/// the field that points away from the bone's line, `(p − its foot on the line) / 2`.
/// That field has divergence 1, so over a closed surface its flux is the enclosed volume
/// whatever the line (the divergence theorem); over a limb's stretch of skin it is that
/// stretch's volume, since the cuts between bodies, across the bone, carry no flux. A
/// zero-length bone uses the field from its point, `(p − s) / 3`: the tetrahedra.
fn flux_from_axis(s: Vec3, e: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let Some(d) = (e - s).try_normalize() else {
        return tetra(a - s, b - s, c - s);
    };
    let g = (a + b + c) / 3.0 - s;
    let radial = g - d * g.dot(d);
    // The field is linear, so its flux is its value at the centroid times the area vector.
    0.25 * radial.dot((b - a).cross(c - a))
}

/// The body two or three corners of a triangle agree on, else the first corner's.
fn majority(b: [Option<usize>; 3]) -> Option<usize> {
    if b[1] == b[2] && b[1].is_some() {
        b[1]
    } else {
        b[0].or(b[1]).or(b[2])
    }
}

/// Disjoint sets of welded vertices, for grouping a hole's edges.
#[derive(Default)]
struct UnionFind {
    parent: HashMap<u32, u32>,
}

impl UnionFind {
    fn find(&mut self, x: u32) -> u32 {
        let mut r = x;
        while let Some(&p) = self.parent.get(&r)
            && p != r
        {
            r = p;
        }
        // Path compression keeps later finds short.
        let mut y = x;
        while y != r {
            let next = self.parent.get(&y).copied().unwrap_or(r);
            self.parent.insert(y, r);
            y = next;
        }
        r
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            self.parent.insert(ra, rb);
        }
    }
}
