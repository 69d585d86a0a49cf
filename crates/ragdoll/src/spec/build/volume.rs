//! The volume a character's skin encloses: what a creature weighs at the density of soft
//! tissue. Its bodies' shapes are no measure of it: shapes that hold the skin overlap at
//! every joint, and capsules round a flat part out (the Fox's bodies add up to 95 litres,
//! its skin encloses 66).

use std::collections::{BTreeMap, HashMap};

use glam::DVec3;

use crate::skeleton::SkinnedMesh;

/// Positions closer than this fraction of the meshes' extent are one point when the
/// surface is checked for holes: exporters split vertices along UV seams and hard edges
/// (each of the Fox's triangles has three of its own).
const WELD_FRACTION: f64 = 1e-6;
/// A surface with holes still encloses a volume when its holes are small: each hole's rim
/// is capped by a fan from its centre (a scanned statue open at its base, as the Stanford
/// dragon's 13k scan) while the caps together cover at most this fraction of the
/// surface's own area. A flat sheet or strip, whose "cap" would be as large as itself,
/// encloses nothing.
const MAX_CAP_AREA_FRACTION: f64 = 0.1;
/// At most one edge in this many may be crossed twice the same way (see [`cap_holes`]).
const MAX_TWICE_CROSSED_OF_EDGES: usize = 100;

/// The volume the meshes enclose, cubic metres (their positions are metres), by the
/// divergence theorem: the sum of the signed volumes of the tetrahedra each triangle
/// makes with a point, small holes capped ([`MAX_CAP_AREA_FRACTION`]). `None` when that is
/// not a volume: no triangles, a position that is not finite, an edge more than two
/// triangles cross the same way, or holes too large to cap (a flat strip, a head left
/// open at the neck).
pub(super) fn enclosed_volume_m3(meshes: &[SkinnedMesh]) -> Option<f32> {
    let points = meshes.iter().flat_map(|m| &m.positions);
    let (mut lo, mut hi) = (DVec3::splat(f64::MAX), DVec3::splat(f64::MIN));
    for p in points {
        if !p.is_finite() {
            return None;
        }
        lo = lo.min(p.as_dvec3());
        hi = hi.max(p.as_dvec3());
    }
    let extent = (hi - lo).length();
    if extent.is_nan() || extent <= 0.0 {
        return None;
    }
    let centre = 0.5 * (lo + hi);
    let cell = WELD_FRACTION * extent;
    let mut ids: HashMap<[i64; 3], u32> = HashMap::new();
    // Per undirected edge, how many more times it is crossed one way than the other.
    let mut balance: HashMap<(u32, u32), i32> = HashMap::new();
    let mut six_volume = 0.0f64;
    let mut area = 0.0f64;
    let mut at: Vec<DVec3> = Vec::new();
    for m in meshes {
        for tri in m.indices.chunks_exact(3) {
            let mut corner = [DVec3::ZERO; 3];
            let mut id = [0u32; 3];
            for k in 0..3 {
                let p = m.positions.get(tri[k] as usize)?.as_dvec3() - centre;
                let key = (p / cell).round().as_i64vec3().to_array();
                let next = ids.len() as u32;
                id[k] = *ids.entry(key).or_insert(next);
                if id[k] == next {
                    at.push(p);
                }
                corner[k] = p;
            }
            for (a, b) in [(id[0], id[1]), (id[1], id[2]), (id[2], id[0])] {
                if a != b {
                    let (key, way) = if a < b { ((a, b), 1) } else { ((b, a), -1) };
                    *balance.entry(key).or_insert(0) += way;
                }
            }
            six_volume += corner[0].dot(corner[1].cross(corner[2]));
            area += 0.5
                * (corner[1] - corner[0])
                    .cross(corner[2] - corner[0])
                    .length();
        }
    }
    if balance.is_empty() {
        return None;
    }
    let (cap_six_volume, cap_area) = cap_holes(&balance, &at)?;
    if cap_area > MAX_CAP_AREA_FRACTION * area {
        return None;
    }
    let volume = ((six_volume + cap_six_volume) / 6.0).abs() as f32;
    (volume > 0.0 && volume.is_finite()).then_some(volume)
}

/// Six times the signed volume and the area of the fans that close the surface's holes:
/// each rim, followed the way its triangles do not cross it, fanned from its centre.
/// `None` when an edge is crossed more than twice net the same way, or more than a few
/// twice (not a surface).
fn cap_holes(balance: &HashMap<(u32, u32), i32>, at: &[DVec3]) -> Option<(f64, f64)> {
    // Each rim edge as the cap crosses it (against the surface's own crossing), in a
    // fixed order: the same file always weighs the same.
    let mut edges: Vec<_> = balance.iter().filter(|e| *e.1 != 0).collect();
    edges.sort_unstable();
    // An edge two triangles cross the same way (a scan's folded sliver; one in the
    // 13k Stanford dragon) is two rim edges; a few are tolerated, many are no surface.
    let twice = edges.iter().filter(|e| e.1.abs() == 2).count();
    if twice * MAX_TWICE_CROSSED_OF_EDGES > balance.len() {
        return None;
    }
    let mut next: BTreeMap<u32, Vec<u32>> = BTreeMap::new();
    for (&(a, b), &way) in edges {
        let (from, to) = match way {
            1 | 2 => (b, a),
            -1 | -2 => (a, b),
            _ => return None,
        };
        for _ in 0..way.abs() {
            next.entry(from).or_default().push(to);
        }
    }
    let (mut six_volume, mut area) = (0.0f64, 0.0f64);
    while let Some(&first) = next.keys().next() {
        // Follow one rim until it closes (or runs out, where rims meet at a vertex);
        // each turn takes one edge out, so this ends.
        let mut rim = vec![first];
        let mut v = first;
        while let Some(out) = next.get_mut(&v) {
            let w = out.pop().unwrap_or(first);
            if out.is_empty() {
                next.remove(&v);
            }
            if w == first {
                break;
            }
            rim.push(w);
            v = w;
        }
        let centre = rim.iter().map(|&i| at[i as usize]).sum::<DVec3>() / rim.len() as f64;
        for k in 0..rim.len() {
            let (p, q) = (at[rim[k] as usize], at[rim[(k + 1) % rim.len()] as usize]);
            six_volume += p.dot(q.cross(centre));
            area += 0.5 * (q - p).cross(centre - p).length();
        }
    }
    Some((six_volume, area))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A closed box `size` (12 triangles, each with its own three vertices, as an
    /// exporter that splits every normal writes it), turned inside out when `flip`.
    fn box_mesh(size: Vec3, flip: bool) -> SkinnedMesh {
        let h = 0.5 * size;
        let c = |x: f32, y: f32, z: f32| Vec3::new(x * h.x, y * h.y, z * h.z);
        let quads = [
            [
                c(-1., -1., 1.),
                c(1., -1., 1.),
                c(1., 1., 1.),
                c(-1., 1., 1.),
            ],
            [
                c(1., -1., -1.),
                c(-1., -1., -1.),
                c(-1., 1., -1.),
                c(1., 1., -1.),
            ],
            [
                c(1., -1., 1.),
                c(1., -1., -1.),
                c(1., 1., -1.),
                c(1., 1., 1.),
            ],
            [
                c(-1., -1., -1.),
                c(-1., -1., 1.),
                c(-1., 1., 1.),
                c(-1., 1., -1.),
            ],
            [
                c(-1., 1., 1.),
                c(1., 1., 1.),
                c(1., 1., -1.),
                c(-1., 1., -1.),
            ],
            [
                c(-1., -1., -1.),
                c(1., -1., -1.),
                c(1., -1., 1.),
                c(-1., -1., 1.),
            ],
        ];
        let mut positions = Vec::new();
        for q in quads {
            for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                if flip {
                    positions.extend([t[0], t[2], t[1]]);
                } else {
                    positions.extend(t);
                }
            }
        }
        let n = positions.len();
        SkinnedMesh {
            name: "box".into(),
            positions,
            normals: Vec::new(),
            indices: (0..n as u32).collect(),
            joints: vec![[0; 4]; n],
            weights: vec![glam::Vec4::X; n],
        }
    }

    #[test]
    fn a_closed_box_encloses_its_volume_either_way_out() {
        for flip in [false, true] {
            let v = enclosed_volume_m3(&[box_mesh(Vec3::new(0.3, 0.5, 0.2), flip)]).unwrap();
            assert!((v - 0.03).abs() < 1e-6, "{v}");
        }
        // Two closed parts add up.
        let two = [
            box_mesh(Vec3::splat(1.0), false),
            box_mesh(Vec3::splat(0.5), false),
        ];
        let v = enclosed_volume_m3(&two).unwrap();
        assert!((v - 1.125).abs() < 1e-5, "{v}");
    }

    #[test]
    fn a_small_hole_is_capped_and_a_large_one_is_not() {
        // A box of 3 x 1 x 1 m open at one 1 x 1 m end (a hole 1/13 of the rest of its
        // surface): capped, it still holds its 3 m^3.
        let mut open_end = box_mesh(Vec3::new(3.0, 1.0, 1.0), false);
        open_end.indices.drain(12..18);
        let v = enclosed_volume_m3(&[open_end]).unwrap();
        assert!((v - 3.0).abs() < 1e-5, "{v}");
        // A box with a triangle turned the wrong way: three edges of eighteen crossed
        // twice the same way is no surface.
        let mut flipped = box_mesh(Vec3::new(3.0, 1.0, 1.0), false);
        flipped.indices.swap(0, 1);
        assert_eq!(enclosed_volume_m3(&[flipped]), None);
        // Without its 3 x 1 m bottom it is a tray, not a body.
        let mut tray = box_mesh(Vec3::new(3.0, 1.0, 1.0), false);
        tray.indices.truncate(tray.indices.len() - 6);
        assert_eq!(enclosed_volume_m3(&[tray]), None);
    }

    #[test]
    fn an_open_or_empty_surface_encloses_nothing() {
        let mut open = box_mesh(Vec3::splat(1.0), false);
        open.indices.truncate(open.indices.len() - 6);
        assert_eq!(enclosed_volume_m3(&[open]), None);
        assert_eq!(enclosed_volume_m3(&[]), None);
        let mut bad = box_mesh(Vec3::splat(1.0), false);
        bad.positions[0] = Vec3::NAN;
        assert_eq!(enclosed_volume_m3(&[bad]), None);
        let mut out_of_range = box_mesh(Vec3::splat(1.0), false);
        out_of_range.indices[0] = 1000;
        assert_eq!(enclosed_volume_m3(&[out_of_range]), None);
    }
}
