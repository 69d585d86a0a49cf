//! Meshes into the rasteriser: projection, per-vertex lighting, and the few shapes the
//! markers are made of.

use glam::Vec3;

use crate::camera::{Camera, NEAR};
use crate::raster::Target;

/// Projects the vertices, giving each its screen position and `1/depth`; a vertex behind
/// the near plane gets NaN so its triangles are skipped.
pub(crate) fn project(cam: &Camera, positions: &[Vec3], screen: &mut Vec<Vec3>) {
    screen.clear();
    screen.extend(positions.iter().map(|&p| {
        let v = cam.view_space(p);
        if v.z < NEAR {
            Vec3::NAN
        } else {
            cam.screen_point(v).extend(1.0 / v.z)
        }
    }));
}

pub(crate) fn draw_triangles(
    target: &mut Target,
    screen: &[Vec3],
    indices: &[u32],
    colors: &[Vec3],
) {
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        let p = [screen[a], screen[b], screen[c]];
        if p.iter().any(|v| !v.is_finite()) {
            continue;
        }
        target.triangle(p, [colors[a], colors[b], colors[c]]);
    }
}

/// Draws a mesh lit by the sun and the sky, colours computed per vertex (Gouraud).
#[allow(clippy::too_many_arguments)]
pub(crate) fn draw_lit(
    target: &mut Target,
    cam: &Camera,
    light: Vec3,
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[u32],
    albedo: impl Fn(usize) -> Vec3,
    screen: &mut Vec<Vec3>,
    shade: &mut Vec<Vec3>,
) {
    project(cam, positions, screen);
    shade.clear();
    shade.extend(normals.iter().enumerate().map(|(k, n)| {
        let sky = 0.30 + 0.12 * n.y;
        let sun = 0.68 * n.dot(light).max(0.0);
        albedo(k) * (sky + sun)
    }));
    draw_triangles(target, screen, indices, shade);
}

/// Draws a mesh in its own colours, unlit (fire glows).
pub(crate) fn draw_flat(
    target: &mut Target,
    cam: &Camera,
    positions: &[Vec3],
    indices: &[u32],
    colors: &[Vec3],
    screen: &mut Vec<Vec3>,
) {
    project(cam, positions, screen);
    draw_triangles(target, screen, indices, colors);
}

/// Area-weighted vertex normals, for meshes that come without any.
pub(crate) fn vertex_normals(positions: &[Vec3], indices: &[u32], out: &mut Vec<Vec3>) {
    out.clear();
    out.resize(positions.len(), Vec3::ZERO);
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        for k in [a, b, c] {
            out[k] += n;
        }
    }
    for n in out.iter_mut() {
        *n = n.try_normalize().unwrap_or(Vec3::Y);
    }
}

/// A unit sphere: an icosahedron subdivided twice (320 triangles), vertices on the sphere
/// (so each is also its own normal).
pub(crate) fn icosphere() -> (Vec<Vec3>, Vec<u32>) {
    let p = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..2 {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f.into_iter().flatten().collect())
}

/// A cube of half-size 1 as 8 shared corners (normals along the corners: rounded shading
/// is fine for a marker this small).
pub(crate) fn cube() -> (Vec<Vec3>, Vec<u32>) {
    let v: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let idx = faces
        .iter()
        .flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]])
        .collect();
    (v, idx)
}
