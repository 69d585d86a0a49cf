//! An independent reading of a baked glTF: the file's own animation played node by node,
//! its meshes skinned on the CPU exactly as the glTF specification says a viewer does
//! (`Σ weight · joint world · inverse bind matrix · position`), and two measures of how
//! the mesh holds up: how far it goes below the floor and how far its edges stretch.
//!
//! Nothing here uses the ragdoll crate (its exporter, importer or skinning): a defect
//! shared by our writer and our reader would otherwise cancel out and go unseen. It reads
//! with the `gltf` crate and does the arithmetic itself.

#![allow(dead_code)] // each test binary uses its own subset

use std::collections::HashSet;
use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use gltf::animation::util::ReadOutputs;
use gltf::animation::{Interpolation, Property};

/// Edges shorter than this at frame 0 (metres) are left out of the stretch: a ratio over a
/// welded seam's zero length means nothing.
const MIN_EDGE_M: f32 = 1e-5;

/// What one baked file's mesh did over its animation.
#[derive(Debug, Clone, Copy)]
pub struct Metrics {
    /// Frames sampled (every key time of the animation).
    pub frames: usize,
    /// Vertices and distinct edges measured.
    pub vertices: usize,
    pub edges: usize,
    /// The mesh's vertical extent at frame 0, in metres: the "height" the limits scale with.
    pub height: f32,
    /// The lowest vertex's height over all frames, and at the last frame (metres; negative
    /// is below the floor).
    pub lowest: f32,
    pub lowest_last: f32,
    /// The highest vertex at the last frame (metres): how far the character fell, so a
    /// reading that missed the animation cannot pass for a mesh that kept its shape.
    pub highest_last: f32,
    /// Each edge's largest length over its frame-0 length across all frames: the 99th
    /// percentile over edges and the largest.
    pub stretch_p99: f32,
    pub stretch_max: f32,
}

impl Metrics {
    /// The deepest point as a fraction of the height (negative: below the floor).
    pub fn lowest_frac(&self) -> f32 {
        self.lowest / self.height
    }

    /// The last frame's lowest point as a fraction of the height.
    pub fn rest_frac(&self) -> f32 {
        self.lowest_last / self.height
    }
}

/// One channel of the chosen animation: key times, key values as 4-vectors (xyz for
/// translation and scale, xyzw for rotation), and whether it steps.
struct Channel {
    node: usize,
    property: Property,
    times: Vec<f32>,
    values: Vec<[f32; 4]>,
    step: bool,
}

impl Channel {
    /// The channel's value at `t`, clamped to its first and last keys.
    fn sample(&self, t: f32) -> [f32; 4] {
        let n = self.times.len();
        let i = self.times.partition_point(|&k| k <= t);
        if i == 0 {
            return self.values[0];
        }
        if i >= n || self.step {
            return self.values[i.min(n) - 1];
        }
        let (t0, t1) = (self.times[i - 1], self.times[i]);
        let s = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.0 };
        let (a, b) = (self.values[i - 1], self.values[i]);
        if self.property == Property::Rotation {
            let q = Quat::from_array(a).slerp(Quat::from_array(b), s);
            q.to_array()
        } else {
            std::array::from_fn(|k| a[k] + (b[k] - a[k]) * s)
        }
    }
}

/// A mesh primitive ready to skin: its vertices in the mesh's space, up to eight
/// (joint, weight) influences per vertex, and which node draws it.
struct Primitive {
    node: usize,
    positions: Vec<Vec3>,
    influences: Vec<Vec<(u16, f32)>>,
    /// The skin's joints (node indices) and inverse bind matrices; `None` for a rigid mesh.
    skin: Option<(Vec<usize>, Vec<Mat4>)>,
}

/// Reads `path` (a `.glb` written by `ragdoll simulate`), plays its `ragdoll` animation
/// (else its first), and measures every frame. Panics with the reason on a file it cannot
/// read: this is test code.
pub fn measure(path: &Path) -> Metrics {
    measure_clip(path, None)
}

/// How many animations the binary glTF `path` holds.
pub fn clip_count(path: &Path) -> usize {
    let gltf = gltf::Gltf::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    gltf.document.animations().count()
}

/// As [`measure`], playing the animation at index `clip` (`None`: the `ragdoll` one, else
/// the first): a character file's own clips, measured from their own first frames, say
/// how far its skin stretches under the motion its author made for it.
pub fn measure_clip(path: &Path, clip: Option<usize>) -> Metrics {
    let gltf = gltf::Gltf::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let blob = gltf.blob.as_deref();
    let buffers = bin(blob);
    let doc = &gltf.document;
    let nodes: Vec<gltf::Node> = doc.nodes().collect();
    let rest: Vec<[[f32; 4]; 3]> = nodes
        .iter()
        .map(|n| {
            let (t, r, s) = n.transform().decomposed();
            [[t[0], t[1], t[2], 0.0], r, [s[0], s[1], s[2], 0.0]]
        })
        .collect();
    let anim = match clip {
        Some(i) => doc.animations().nth(i),
        None => doc
            .animations()
            .find(|a| a.name() == Some("ragdoll"))
            .or_else(|| doc.animations().next()),
    };
    let channels = anim
        .map(|a| read_channels(&a, &buffers))
        .unwrap_or_default();
    let mut times: Vec<f32> = channels.iter().flat_map(|c| c.times.clone()).collect();
    times.sort_by(f32::total_cmp);
    times.dedup();
    if times.is_empty() {
        times.push(0.0);
    }
    let prims = read_primitives(doc, &buffers);
    let edges = edges_of(doc, &buffers);
    let parent = parents(doc);

    let mut first: Vec<Vec3> = Vec::new();
    let mut worst = vec![0.0f32; edges.len()];
    let (mut lowest, mut lowest_last, mut highest_last, mut height) =
        (f32::INFINITY, 0.0, 0.0, 0.0);
    for (f, &t) in times.iter().enumerate() {
        let mut trs = rest.clone();
        for c in &channels {
            let slot = match c.property {
                Property::Translation => 0,
                Property::Rotation => 1,
                Property::Scale => 2,
                Property::MorphTargetWeights => continue,
            };
            trs[c.node][slot] = c.sample(t);
        }
        let world = world_matrices(&trs, &parent);
        let verts = skin_all(&prims, &world);
        let low = verts.iter().map(|v| v.y).fold(f32::INFINITY, f32::min);
        lowest = lowest.min(low);
        lowest_last = low;
        highest_last = verts.iter().map(|v| v.y).fold(f32::NEG_INFINITY, f32::max);
        if f == 0 {
            height = highest_last - low;
            first = verts;
            continue;
        }
        for (e, &(a, b)) in edges.iter().enumerate() {
            let l0 = first[a].distance(first[b]);
            if l0 > MIN_EDGE_M {
                worst[e] = worst[e].max(verts[a].distance(verts[b]) / l0);
            }
        }
    }
    let mut stretch: Vec<f32> = edges
        .iter()
        .zip(&worst)
        .filter(|((a, b), _)| first[*a].distance(first[*b]) > MIN_EDGE_M)
        .map(|(_, &w)| w.max(1.0))
        .collect();
    stretch.sort_by(f32::total_cmp);
    let p99 = percentile(&stretch, 0.99);
    Metrics {
        frames: times.len(),
        vertices: first.len(),
        edges: stretch.len(),
        height,
        lowest,
        lowest_last,
        highest_last,
        stretch_p99: p99,
        stretch_max: stretch.last().copied().unwrap_or(1.0),
    }
}

/// The `q` quantile of sorted `v` (nearest rank); 1 for no edges.
fn percentile(v: &[f32], q: f32) -> f32 {
    if v.is_empty() {
        return 1.0;
    }
    let rank = ((q * v.len() as f32).ceil() as usize).clamp(1, v.len());
    v[rank - 1]
}

/// The buffer reader for a `.glb`: its binary chunk (ragdoll writes no external buffers).
fn bin<'s>(blob: Option<&'s [u8]>) -> impl Fn(gltf::Buffer) -> Option<&'s [u8]> + Clone {
    move |b: gltf::Buffer| match b.source() {
        gltf::buffer::Source::Bin => blob,
        gltf::buffer::Source::Uri(_) => None,
    }
}

fn read_channels<'s>(
    anim: &gltf::Animation,
    buffers: &(impl Fn(gltf::Buffer) -> Option<&'s [u8]> + Clone),
) -> Vec<Channel> {
    anim.channels()
        .filter_map(|ch| {
            let r = ch.reader(buffers.clone());
            let times: Vec<f32> = r.read_inputs()?.collect();
            let values: Vec<[f32; 4]> = match r.read_outputs()? {
                ReadOutputs::Translations(it) => it.map(|v| [v[0], v[1], v[2], 0.0]).collect(),
                ReadOutputs::Scales(it) => it.map(|v| [v[0], v[1], v[2], 0.0]).collect(),
                ReadOutputs::Rotations(it) => it.into_f32().collect(),
                ReadOutputs::MorphTargetWeights(_) => return None,
            };
            let interp = ch.sampler().interpolation();
            assert!(
                interp != Interpolation::CubicSpline,
                "the baked animation is cubic-spline: not what ragdoll writes"
            );
            assert_eq!(
                times.len(),
                values.len(),
                "a channel's keys and values differ"
            );
            (!times.is_empty()).then(|| Channel {
                node: ch.target().node().index(),
                property: ch.target().property(),
                times,
                values,
                step: interp == Interpolation::Step,
            })
        })
        .collect()
}

fn read_primitives<'s>(
    doc: &gltf::Document,
    buffers: &(impl Fn(gltf::Buffer) -> Option<&'s [u8]> + Clone),
) -> Vec<Primitive> {
    let mut out = Vec::new();
    for node in doc.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        let skin = node.skin().map(|s| {
            let joints: Vec<usize> = s.joints().map(|j| j.index()).collect();
            let ibm: Vec<Mat4> = s
                .reader(buffers.clone())
                .read_inverse_bind_matrices()
                .map(|it| it.map(|m| Mat4::from_cols_array_2d(&m)).collect())
                .unwrap_or_else(|| vec![Mat4::IDENTITY; joints.len()]);
            (joints, ibm)
        });
        for p in mesh.primitives() {
            let r = p.reader(buffers.clone());
            let positions: Vec<Vec3> = r
                .read_positions()
                .expect("a primitive without positions")
                .map(Vec3::from_array)
                .collect();
            let mut influences = vec![Vec::new(); positions.len()];
            for set in 0.. {
                let (Some(j), Some(w)) = (r.read_joints(set), r.read_weights(set)) else {
                    break;
                };
                for ((inf, j), w) in influences.iter_mut().zip(j.into_u16()).zip(w.into_f32()) {
                    inf.extend((0..4).filter(|&k| w[k] != 0.0).map(|k| (j[k], w[k])));
                }
            }
            out.push(Primitive {
                node: node.index(),
                positions,
                influences,
                skin: skin.clone(),
            });
        }
    }
    out
}

/// Every distinct triangle edge, as vertex indices into the concatenation of all
/// primitives' vertices (in [`read_primitives`]' order).
fn edges_of<'s>(
    doc: &gltf::Document,
    buffers: &(impl Fn(gltf::Buffer) -> Option<&'s [u8]> + Clone),
) -> Vec<(usize, usize)> {
    let mut set = HashSet::new();
    let mut base = 0;
    for node in doc.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        for p in mesh.primitives() {
            let r = p.reader(buffers.clone());
            let n = r.read_positions().map_or(0, |it| it.len());
            if p.mode() == gltf::mesh::Mode::Triangles {
                let idx: Vec<usize> = match r.read_indices() {
                    Some(it) => it.into_u32().map(|i| i as usize).collect(),
                    None => (0..n).collect(),
                };
                for t in idx.chunks_exact(3) {
                    for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                        if a != b && a < n && b < n {
                            set.insert((base + a.min(b), base + a.max(b)));
                        }
                    }
                }
            }
            base += n;
        }
    }
    let mut edges: Vec<_> = set.into_iter().collect();
    edges.sort_unstable();
    edges
}

/// Each node's parent, or `None` for a root.
fn parents(doc: &gltf::Document) -> Vec<Option<usize>> {
    let mut parent = vec![None; doc.nodes().len()];
    for n in doc.nodes() {
        for c in n.children() {
            parent[c.index()] = Some(n.index());
        }
    }
    parent
}

/// World matrices of every node from local (translation, rotation, scale).
fn world_matrices(trs: &[[[f32; 4]; 3]], parent: &[Option<usize>]) -> Vec<Mat4> {
    let local: Vec<Mat4> = trs
        .iter()
        .map(|[t, r, s]| {
            Mat4::from_scale_rotation_translation(
                Vec3::new(s[0], s[1], s[2]),
                Quat::from_array(*r).normalize(),
                Vec3::new(t[0], t[1], t[2]),
            )
        })
        .collect();
    let mut world: Vec<Option<Mat4>> = vec![None; local.len()];
    fn resolve(
        i: usize,
        local: &[Mat4],
        parent: &[Option<usize>],
        world: &mut [Option<Mat4>],
        depth: usize,
    ) -> Mat4 {
        if let Some(m) = world[i] {
            return m;
        }
        assert!(depth <= local.len(), "the node hierarchy has a cycle");
        let m = match parent[i] {
            Some(p) => resolve(p, local, parent, world, depth + 1) * local[i],
            None => local[i],
        };
        world[i] = Some(m);
        m
    }
    (0..local.len())
        .map(|i| resolve(i, &local, parent, &mut world, 0))
        .collect()
}

/// Every primitive's vertices in world space for one frame of node matrices.
fn skin_all(prims: &[Primitive], world: &[Mat4]) -> Vec<Vec3> {
    let mut out = Vec::new();
    for p in prims {
        match &p.skin {
            Some((joints, ibm)) => {
                let mats: Vec<Mat4> = joints
                    .iter()
                    .zip(ibm)
                    .map(|(&j, ibm)| world[j] * *ibm)
                    .collect();
                for (pos, inf) in p.positions.iter().zip(&p.influences) {
                    let m = inf
                        .iter()
                        .fold(Mat4::ZERO, |acc, &(j, w)| acc + mats[j as usize] * w);
                    out.push(m.transform_point3(*pos));
                }
            }
            None => out.extend(
                p.positions
                    .iter()
                    .map(|&v| world[p.node].transform_point3(v)),
            ),
        }
    }
    out
}
