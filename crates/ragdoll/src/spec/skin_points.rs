//! Skin points: the skin a ragdoll's shapes leave loose, as points the backends can keep
//! above the ground (`Backend::add_skin_points`).
//!
//! A skinned vertex is the weighted blend of where each of its bodies carries it (linear
//! blend skinning). A body's shapes, its own and its extra ones (`build/extras.rs`), hold
//! the skin only as that body carries it; where several bodies share a vertex and bend
//! apart, the blend goes lower than any one shape holds. The automatically rigged 1.7k
//! Stanford dragon's foot is weighted 0.43, 0.27, 0.23 and 0.07 over four spine bones,
//! held by extra shapes on the two heaviest: the other two carried their share under the
//! floor as the spine bent, and the foot rested 10 % of the dragon's height in it.
//! Holding it on every body carrying a tenth instead lifted it, but held other rigged
//! dragons up by shares too small to matter, up to 4.8 % of their height above the
//! floor. A skin point is the vertex itself, as the skin places it.
//!
//! Made from the character's skin when a ragdoll is added to a world, not written in the
//! spec: a scan has thousands of such vertices, and they follow from the skin and the
//! bodies the spec already holds.

use std::collections::BTreeMap;

use glam::Vec3;

use super::build::shape_holds;
use super::roles::Rig;
use super::{RagdollSpec, Resolved, Shape};
use crate::math::Transform;
use crate::skeleton::Character;

/// One skin point: each body (index in the spec), its share (the shares sum to 1) and the
/// point in that body's frame.
pub(crate) type SkinPointParts = Vec<(usize, f32, Vec3)>;

/// A loose vertex: where it is, its bodies' shares, and the share the bodies whose shapes
/// do not hold it carry.
type Loose = (Vec3, Vec<(usize, f32)>, f32);

/// A vertex gets a skin point when the bodies whose shapes do not hold it carry at least
/// this share of it: below, they move it too little to matter.
const MIN_LOOSE_SHARE: f32 = 0.1;
/// A vertex counts as held within this fraction of H of a shape's surface (as the
/// builder's extra shapes count it).
const INSIDE_TOLERANCE_H: f32 = 0.005;
/// One skin point a cell of this fraction of H (the loosest vertex of each): a dense scan
/// is not solved vertex by vertex where a few millimetres apart are the same contact.
const CELL_H: f32 = 0.01;
/// A share below this is left out of a point (the others scaled to sum to 1).
const MIN_PART_SHARE: f32 = 1e-3;

/// The skin points of `character`'s skin that `spec`'s shapes leave loose, placed on
/// the character's rest pose by `resolved`; `body_of_joint` is the body each skeleton
/// joint rides on in the world (so the skin moves as the baked mesh will).
pub(crate) fn skin_points(
    character: &Character,
    spec: &RagdollSpec,
    resolved: &Resolved,
    body_of_joint: &[usize],
) -> Vec<SkinPointParts> {
    if character.meshes.is_empty() {
        return Vec::new();
    }
    let rig = Rig::new(character);
    if rig.verts.is_empty() {
        return Vec::new();
    }
    let owner: Vec<Option<usize>> = body_of_joint.iter().map(|&b| Some(b)).collect();
    let tolerance = INSIDE_TOLERANCE_H * rig.height;
    // Each body's shapes in the rest pose: where each is, inverted, and the shape.
    let shapes: Vec<Vec<(Transform, Shape)>> = spec
        .bodies
        .iter()
        .zip(&resolved.body_rest)
        .map(|(b, pose)| {
            std::iter::once((pose.inverse(), b.shape))
                .chain(
                    b.extra_offsets()
                        .into_iter()
                        .map(|(s, at)| (pose.mul(&at).inverse(), s)),
                )
                .collect()
        })
        .collect();
    let holds = |b: usize, p: Vec3| {
        shapes[b]
            .iter()
            .any(|(inv, s)| shape_holds(s, inv.transform_point(p), tolerance))
    };
    let mut loose: Vec<Loose> = Vec::new();
    for (p, js, ws) in &rig.verts {
        if !p.is_finite() {
            continue;
        }
        let Some(shares) = shares(&owner, js, ws) else {
            continue;
        };
        let free: f32 = shares.iter().filter(|s| !holds(s.0, *p)).map(|s| s.1).sum();
        if free >= MIN_LOOSE_SHARE {
            loose.push((*p, shares, free));
        }
    }
    spread(&loose, CELL_H * rig.height)
        .into_iter()
        .map(|k| {
            let (p, shares, _) = &loose[k];
            shares
                .iter()
                .map(|&(b, w)| (b, w, resolved.body_rest[b].inverse().transform_point(*p)))
                .collect()
        })
        .collect()
}

/// A vertex's shares per body (summed over its joints on one body), scaled to sum to 1;
/// `None` for a vertex without weight.
fn shares(owner: &[Option<usize>], js: &[u16; 4], ws: &glam::Vec4) -> Option<Vec<(usize, f32)>> {
    let mut share: Vec<(usize, f32)> = Vec::with_capacity(4);
    for c in 0..4 {
        let Some(Some(o)) = owner.get(js[c] as usize).copied() else {
            continue;
        };
        let w = ws[c];
        if !(w > 0.0 && w.is_finite()) {
            continue;
        }
        match share.iter_mut().find(|s| s.0 == o) {
            Some(s) => s.1 += w,
            None => share.push((o, w)),
        }
    }
    let total: f32 = share.iter().map(|s| s.1).sum();
    share.retain(|s| s.1 >= MIN_PART_SHARE * total);
    let total: f32 = share.iter().map(|s| s.1).sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    share.iter_mut().for_each(|s| s.1 /= total);
    Some(share)
}

/// Indices of `loose` vertices, one a cell `cell` wide: the loosest (the first of
/// equals), in the order of their cells.
fn spread(loose: &[Loose], cell: f32) -> Vec<usize> {
    if !(cell > 0.0 && cell.is_finite()) {
        return Vec::new();
    }
    let mut best: BTreeMap<[i32; 3], usize> = BTreeMap::new();
    for (k, (p, _, free)) in loose.iter().enumerate() {
        let key = (*p / cell).floor().as_ivec3().to_array();
        let slot = best.entry(key).or_insert(k);
        if *free > loose[*slot].2 {
            *slot = k;
        }
    }
    best.into_values().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_are_spread_one_a_cell_the_loosest() {
        let loose: Vec<Loose> = (0..1000)
            .map(|k| {
                let p = Vec3::new((k % 10) as f32, ((k / 10) % 10) as f32, (k / 100) as f32);
                (p * 0.1, vec![(0, 1.0)], (k % 7) as f32 * 0.1)
            })
            .collect();
        assert_eq!(spread(&loose, 0.05).len(), 1000, "one vertex a cell");
        assert_eq!(spread(&loose, 0.25).len(), 4 * 4 * 4);
        let one = spread(&loose[..5], 10.0);
        assert_eq!(one.len(), 1);
        assert_eq!(loose[one[0]].2, 0.4, "the loosest of the cell");
        assert!(spread(&loose, f32::NAN).is_empty());
    }

    #[test]
    fn shares_sum_to_one_over_bodies_and_drop_what_is_not_weight() {
        let owner = vec![Some(0), Some(0), Some(1), None];
        let s = shares(&owner, &[0, 1, 2, 3], &glam::Vec4::new(0.2, 0.2, 0.4, 0.2)).unwrap();
        assert_eq!(s.len(), 2);
        assert!((s[0].1 - 0.5).abs() < 1e-6 && (s[1].1 - 0.5).abs() < 1e-6);
        let nan = glam::Vec4::new(f32::NAN, -1.0, 0.0, 0.0);
        assert!(shares(&owner, &[0, 1, 2, 3], &nan).is_none());
        let far = shares(
            &owner,
            &[900, 2, 0, 0],
            &glam::Vec4::new(0.5, 0.5, 0.0, 0.0),
        )
        .unwrap();
        assert_eq!(far, vec![(1, 1.0)]);
    }
}
