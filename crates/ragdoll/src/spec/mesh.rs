//! Triangle meshes of the ragdoll's collision shapes, so a skeleton-only character (BVH,
//! the built-in humanoid) still shows something in a viewer, a preview or an OBJ
//! sequence: each body drawn as the capsule or box the simulation uses, bound rigidly to
//! its own bone.
//!
//! Rigid, because each shape *is* a rigid body: it moves exactly as the simulation moved
//! it, and shows it. Weights blended across bodies (they were once the automatic weights
//! of [`crate::rig`], by distance to the four nearest bones) put a pelvis vertex 25 % on a
//! forearm, so the capsules bent and sheared wherever limbs crossed (99th-percentile edge
//! stretch up to 7.3× on the data's BVH files, edges up to 41×, by the CLI's
//! `tests/mesh_check.rs`; bound rigidly, 1.00).
//!
//! It lives with the spec rather than with the skeleton or an exporter: it is drawn from a
//! spec, and the skeleton's skinning and every output read it without depending on each
//! other.

use std::f32::consts::{FRAC_PI_2, TAU};

use glam::{Vec3, Vec4};

use super::{RagdollSpec, Shape};
use crate::error::{Error, Result};
use crate::math::Transform;
use crate::skeleton::{Skeleton, SkinnedMesh};

/// Segments around a capsule's axis: round enough to read as a limb, cheap enough for
/// dozens of bodies.
const SEGMENTS: usize = 12;
/// Rings per hemisphere of a capsule.
const RINGS: usize = 4;

/// A capsule centred on the origin, its axis along Y: positions, outward normals, and
/// counter-clockwise (outward-facing) triangles.
fn capsule(radius: f32, length: f32) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let h = 0.5 * length;
    let mut pos = vec![Vec3::new(0.0, h + radius, 0.0)];
    let mut nrm = vec![Vec3::Y];
    // Latitudes from just below the top pole to the equator (top cap), then from the
    // equator down to just above the bottom pole (bottom cap).
    let mut rings: Vec<(f32, f32)> = (1..=RINGS)
        .map(|i| (FRAC_PI_2 * (1.0 - i as f32 / RINGS as f32), h))
        .collect();
    rings.extend((0..RINGS).map(|i| (-FRAC_PI_2 * i as f32 / RINGS as f32, -h)));
    for &(phi, cy) in &rings {
        for s in 0..SEGMENTS {
            let theta = TAU * s as f32 / SEGMENTS as f32;
            let n = Vec3::new(phi.cos() * theta.cos(), phi.sin(), phi.cos() * theta.sin());
            pos.push(Vec3::new(0.0, cy, 0.0) + n * radius);
            nrm.push(n);
        }
    }
    let bottom = pos.len() as u32;
    pos.push(Vec3::new(0.0, -h - radius, 0.0));
    nrm.push(-Vec3::Y);
    let ring = |k: usize, s: usize| (1 + k * SEGMENTS + s % SEGMENTS) as u32;
    let mut idx = Vec::new();
    for s in 0..SEGMENTS {
        idx.extend([0, ring(0, s + 1), ring(0, s)]);
    }
    for k in 0..rings.len() - 1 {
        for s in 0..SEGMENTS {
            let (a, b) = (ring(k, s), ring(k, s + 1));
            let (c, d) = (ring(k + 1, s), ring(k + 1, s + 1));
            idx.extend([a, d, c, a, b, d]);
        }
    }
    let last = rings.len() - 1;
    for s in 0..SEGMENTS {
        idx.extend([bottom, ring(last, s), ring(last, s + 1)]);
    }
    (pos, nrm, idx)
}

/// A box centred on the origin with full edge lengths `size`: flat-shaded, four vertices
/// per face so each face keeps its own normal.
fn cuboid(size: [f32; 3]) -> (Vec<Vec3>, Vec<Vec3>, Vec<u32>) {
    let half = Vec3::from_array(size) * 0.5;
    // (normal, u, v) with u × v = normal, so corners listed -u-v, +u-v, +u+v, -u+v wind
    // counter-clockwise seen from outside.
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (-Vec3::Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, Vec3::Y, Vec3::X),
    ];
    let (mut pos, mut nrm, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for (n, u, v) in faces {
        let base = pos.len() as u32;
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            pos.push((n + u * su + v * sv) * half);
            nrm.push(n);
        }
        idx.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
    }
    (pos, nrm, idx)
}

/// The ragdoll's bodies (capsules and boxes, as the simulation sees them) as one mesh in
/// the world rest pose, each vertex bound rigidly (weight 1) to its own body's bone, so
/// every shape moves exactly as its body did: what a character without a skinned mesh (BVH,
/// the built-in humanoid) is drawn as, in glTF, OBJ and previews alike.
///
/// ```
/// use ragdoll::{skeleton::humanoid, spec};
///
/// let character = humanoid();
/// let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
/// let mesh = spec::bodies_mesh(&character.skeleton, &spec).unwrap();
/// assert_eq!(mesh.positions.len(), mesh.weights.len());
/// assert!(mesh.weights.iter().all(|w| (w.x + w.y + w.z + w.w - 1.0).abs() < 1e-5));
/// ```
pub fn bodies_mesh(skeleton: &Skeleton, spec: &RagdollSpec) -> Result<SkinnedMesh> {
    let rest_world = skeleton.rest_world();
    let mut out = SkinnedMesh {
        name: format!("{} ragdoll bodies", spec.name),
        ..SkinnedMesh::default()
    };
    for body in &spec.bodies {
        let joint = (0..skeleton.len())
            .find(|&i| {
                skeleton.joints()[i].name == body.bone || skeleton.joint_label(i) == body.bone
            })
            .ok_or_else(|| Error::Spec {
                place: format!("body \"{}\".bone", body.name),
                message: format!("no skeleton joint is named \"{}\"", body.bone),
            })?;
        let w = rest_world[joint];
        let bone_frame = Transform::new(w.translation, w.rotation);
        let body_world = bone_frame.mul(&body.frame());
        // A skeleton too big for u16 joint indices cannot be written as a glTF skin either.
        let slot = u16::try_from(joint).map_err(|_| Error::Spec {
            place: format!("body \"{}\".bone", body.name),
            message: format!("joint {joint} is beyond the 65536 a skin can name"),
        })?;
        let extras = body.extra_offsets();
        let extras = extras.iter().map(|(s, at)| (s, body_world.mul(at)));
        for (shape, at) in std::iter::once((&body.shape, body_world)).chain(extras) {
            let (pos, nrm, idx) = match *shape {
                Shape::Capsule { radius_m, length_m } => capsule(radius_m, length_m),
                Shape::Box { size_m } => cuboid(size_m),
            };
            let base = out.positions.len() as u32;
            out.joints
                .extend(std::iter::repeat_n([slot, 0, 0, 0], pos.len()));
            out.weights.extend(std::iter::repeat_n(Vec4::X, pos.len()));
            out.positions
                .extend(pos.iter().map(|&p| at.transform_point(p)));
            out.normals.extend(nrm.iter().map(|&n| at.transform_dir(n)));
            out.indices.extend(idx.iter().map(|i| i + base));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle faces away from the centre and every normal points outward from the
    /// shape's axis: what a viewer needs to light the shape and cull its back faces.
    fn assert_outward(pos: &[Vec3], nrm: &[Vec3], idx: &[u32], axis_point: impl Fn(Vec3) -> Vec3) {
        assert_eq!(idx.len() % 3, 0);
        for t in idx.chunks_exact(3) {
            let (a, b, c) = (pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.length() > 1e-9, "degenerate triangle {t:?}");
            let centroid = (a + b + c) / 3.0;
            assert!(
                n.dot(centroid - axis_point(centroid)) > 0.0,
                "inward triangle {t:?}"
            );
        }
        for (p, n) in pos.iter().zip(nrm) {
            assert!((n.length() - 1.0).abs() < 1e-5);
            assert!(n.dot(*p - axis_point(*p)) > 0.0);
        }
    }

    #[test]
    fn capsule_is_closed_outward_and_the_right_size() {
        let (r, l) = (0.1, 0.4);
        let (pos, nrm, idx) = capsule(r, l);
        let on_axis = |p: Vec3| Vec3::new(0.0, p.y.clamp(-l / 2.0, l / 2.0), 0.0);
        assert_outward(&pos, &nrm, &idx, on_axis);
        for p in &pos {
            assert!(((*p - on_axis(*p)).length() - r).abs() < 1e-5);
        }
        let top = pos.iter().map(|p| p.y).fold(f32::MIN, f32::max);
        assert!((top - (l / 2.0 + r)).abs() < 1e-6);
        // Closed: every edge is shared by exactly two triangles, in opposite directions.
        let mut edges = std::collections::HashMap::new();
        for t in idx.chunks_exact(3) {
            for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1);
            assert_eq!(edges.get(&(b, a)), Some(&1), "open edge {a}-{b}");
        }
    }

    /// Each shape is bound wholly to its own body's bone: one joint, weight 1, so no
    /// vertex is pulled by a neighbouring body (a pelvis vertex once hung 25 % on a forearm).
    #[test]
    fn every_body_is_bound_rigidly_to_its_own_bone() {
        let character = crate::skeleton::humanoid();
        let spec =
            super::super::build_spec(&character, &super::super::BuildOptions::default()).unwrap();
        let mesh = bodies_mesh(&character.skeleton, &spec).unwrap();
        let mut v = 0;
        for body in &spec.bodies {
            let bone = (0..character.skeleton.len())
                .find(|&i| character.skeleton.joints()[i].name == body.bone)
                .unwrap();
            let count = match body.shape {
                Shape::Capsule { radius_m, length_m } => capsule(radius_m, length_m).0.len(),
                Shape::Box { size_m } => cuboid(size_m).0.len(),
            };
            for k in v..v + count {
                assert_eq!(mesh.joints[k][0] as usize, bone, "body {}", body.name);
                assert_eq!(mesh.weights[k], Vec4::X, "body {}", body.name);
            }
            v += count;
        }
        assert_eq!(v, mesh.positions.len());
        assert_eq!(mesh.joints.len(), v);
    }

    #[test]
    fn box_faces_point_outward() {
        let (pos, nrm, idx) = cuboid([0.2, 0.4, 0.1]);
        assert_eq!(pos.len(), 24);
        assert_outward(&pos, &nrm, &idx, |_| Vec3::ZERO);
        let max = pos.iter().fold(Vec3::MIN, |m, p| m.max(*p));
        assert!((max - Vec3::new(0.1, 0.2, 0.05)).length() < 1e-6);
    }
}
