//! OBJ-sequence export: one Wavefront OBJ per frame holding the deformed mesh, for tools
//! that read geometry caches rather than skins (Houdini, Blender's mesh-sequence cache,
//! simulation pipelines). A character with a skinned mesh writes that mesh, deformed by
//! linear blend skinning ([`crate::skeleton::skinning`]); one without (BVH, the built-in
//! humanoid) writes its ragdoll's capsules and boxes.
//!
//! Frames are produced one at a time ([`ObjSequence::frame`]) so a long run never holds
//! every frame's text in memory.

use std::fmt::Write;

use glam::{Mat4, Vec3};

use crate::error::Result;
use crate::math::Transform;
use crate::skeleton::{Character, SkinnedMesh, skinning};
use crate::spec::RagdollSpec;

/// Turns track frames into OBJ text, reusing its buffers from frame to frame.
///
/// ```
/// use ragdoll::{export::obj::ObjSequence, skeleton, spec};
///
/// let character = skeleton::humanoid();
/// let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
/// let mut obj = ObjSequence::new(&character, &spec).unwrap();
/// let text = obj.frame(&character.skeleton.rest_world()).unwrap();
/// assert!(text.lines().any(|l| l.starts_with("f ")));
/// ```
pub struct ObjSequence {
    rest_world: Vec<Transform>,
    meshes: Vec<SkinnedMesh>,
    matrices: Vec<Mat4>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
}

impl ObjSequence {
    /// Prepares the character's skinned meshes, or its ragdoll bodies when it has none.
    pub fn new(character: &Character, spec: &RagdollSpec) -> Result<Self> {
        let meshes = if character.meshes.is_empty() {
            vec![crate::spec::bodies_mesh(&character.skeleton, spec)?]
        } else {
            character.meshes.clone()
        };
        Ok(ObjSequence {
            rest_world: character.skeleton.rest_world(),
            meshes,
            matrices: Vec::new(),
            positions: Vec::new(),
            normals: Vec::new(),
        })
    }

    /// One frame as OBJ text: an `o` group per mesh, positions in metres (Y up), normals,
    /// and triangles. `pose_world` is one frame of a [`Track`](crate::track::Track).
    pub fn frame(&mut self, pose_world: &[Transform]) -> Result<String> {
        skinning::skin_matrices(&self.rest_world, pose_world, &mut self.matrices)?;
        let mut out = format!("# ragdoll {}\n", env!("CARGO_PKG_VERSION"));
        // OBJ indices are 1-based and count across the whole file.
        let mut base = 1usize;
        for mesh in &self.meshes {
            skinning::skin(mesh, &self.matrices, &mut self.positions, &mut self.normals)?;
            let name: String = mesh
                .name
                .chars()
                .map(|c| if c.is_whitespace() { '_' } else { c })
                .collect();
            // Writing to a String cannot fail.
            let _ = writeln!(out, "o {name}");
            for p in &self.positions {
                let _ = writeln!(out, "v {:.5} {:.5} {:.5}", p.x, p.y, p.z);
            }
            for n in &self.normals {
                let _ = writeln!(out, "vn {:.4} {:.4} {:.4}", n.x, n.y, n.z);
            }
            let with_normals = !self.normals.is_empty();
            for t in mesh.indices.chunks_exact(3) {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize + base);
                if with_normals {
                    let _ = writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}");
                } else {
                    let _ = writeln!(out, "f {a} {b} {c}");
                }
            }
            base += self.positions.len();
        }
        Ok(out)
    }
}

/// The file name of frame `frame` in a sequence of `count` frames: `frame_0007.obj`, zero
/// padded to at least four digits so the files sort in order.
pub fn file_name(frame: usize, count: usize) -> String {
    let digits = count.saturating_sub(1).to_string().len().max(4);
    format!("frame_{frame:0digits$}.obj")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_names_sort_in_frame_order() {
        assert_eq!(file_name(7, 90), "frame_0007.obj");
        assert_eq!(file_name(12345, 20000), "frame_12345.obj");
        let mut names: Vec<String> = (0..120).map(|f| file_name(f, 120)).collect();
        let sorted = {
            let mut s = names.clone();
            s.sort();
            s
        };
        assert_eq!(names, sorted);
        names.dedup();
        assert_eq!(names.len(), 120);
    }

    #[test]
    fn a_frame_lists_every_vertex_and_triangle_with_valid_indices() {
        let character = crate::skeleton::humanoid();
        let spec =
            crate::spec::build_spec(&character, &crate::spec::BuildOptions::default()).unwrap();
        let mesh = crate::spec::bodies_mesh(&character.skeleton, &spec).unwrap();
        let mut seq = ObjSequence::new(&character, &spec).unwrap();
        let text = seq.frame(&character.skeleton.rest_world()).unwrap();
        let v = text.lines().filter(|l| l.starts_with("v ")).count();
        let f: Vec<&str> = text.lines().filter(|l| l.starts_with("f ")).collect();
        assert_eq!(v, mesh.positions.len());
        assert_eq!(f.len(), mesh.indices.len() / 3);
        for line in f {
            for corner in line.split_whitespace().skip(1) {
                let i: usize = corner.split("//").next().unwrap().parse().unwrap();
                assert!((1..=v).contains(&i), "{line}");
            }
        }
        // The rest pose writes the rest mesh: the first vertex is where the mesh has it.
        let first = text.lines().find(|l| l.starts_with("v ")).unwrap();
        let xyz: Vec<f32> = first[2..]
            .split_whitespace()
            .map(|s| s.parse().unwrap())
            .collect();
        assert!((Vec3::from_slice(&xyz) - mesh.positions[0]).length() < 1e-4);
    }
}
