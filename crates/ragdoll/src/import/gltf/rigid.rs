//! Characters made of rigid parts: a file without a skin whose meshes sit on the nodes of
//! a hierarchy (a low-poly robot whose head, torso and upper arms are separate meshes, each
//! on a node that is a child of the one it hangs from), or a VRM avatar whose humanoid table
//! names a bare node hierarchy. The hierarchy is the skeleton and each part moves with the
//! body of its own node, so the parts neither bend nor get welded into one automatic rig.
//!
//! The rule, for a file without a skin (only the default scene's nodes count, or every
//! node when the file has no scene):
//! - **Parts** are the nodes whose mesh has a triangle primitive with positions.
//! - The node hierarchy is read as a skeleton when the file has a VRM humanoid table, or
//!   when parts sit on two or more nodes that do not all share one parent: then the
//!   hierarchy says how the parts hang together. One part (a scanned statue), or parts
//!   that are all siblings (a model split by material, a flat group of props), says
//!   nothing about joints, and goes to the automatic rig as before.
//! - **Joints** are the parts, the nodes the humanoid table names, and all their
//!   ancestors; leaves that carry nothing (empties, cameras, lights) are dropped. Mesh-less
//!   nodes at the top with a single such child (`Armature`, a Z-up correction, a scene
//!   root) are not joints: like the non-joint nodes above a skin, they are folded into the
//!   first joint's rest transform. Mesh-less nodes lower down stay joints without a mesh:
//!   the roles pass gives them no body and they follow their parent's.
//! - **Meshes**: one [`SkinnedMesh`] per triangle primitive of each part (a mesh instanced
//!   on several nodes is read once per node), in world space, every vertex bound with
//!   weight 1 to its node's joint: the inverse bind is the node's rest world transform.
//!   The exporter writes the file back with the nodes animated, so each part's own mesh and
//!   materials move with its body.

use std::collections::HashSet;

use glam::Vec4;

use super::data::format_err;
use super::mesh::{Reads, has_triangles, read_node_meshes};
use super::skin::{NodeGraph, Rig};
use crate::error::Result;
use crate::skeleton::SkinnedMesh;

/// The nodes that make the skeleton, in file order, or `None` when the file is one part
/// (or a flat group of parts) for the automatic rig, or has nothing to build from.
///
/// `table_nodes` are the nodes a humanoid table names (`None`: the file has no table).
/// Linear in the nodes: each node is walked up from at most once.
pub(super) fn part_nodes(
    doc: &gltf::Document,
    graph: &NodeGraph,
    in_scene: Option<&HashSet<usize>>,
    table_nodes: Option<&[usize]>,
) -> Option<Vec<usize>> {
    let n = graph.parent.len();
    let parts = part_list(doc, in_scene);
    if table_nodes.is_none() {
        let first_parent = graph.parent[*parts.first()?];
        if parts.iter().all(|&p| graph.parent[p] == first_parent) {
            return None;
        }
    }
    let mut marked = vec![false; n];
    for &m in parts.iter().chain(table_nodes.into_iter().flatten()) {
        marked[m] = true;
    }
    let mut kept = vec![false; n];
    for m in (0..n).filter(|&m| marked[m]) {
        let mut at = Some(m);
        while let Some(x) = at.filter(|&x| !kept[x]) {
            kept[x] = true;
            at = graph.parent[x];
        }
    }
    let mut kept_children = vec![0usize; n];
    let mut a_child = vec![0usize; n];
    for x in (0..n).filter(|&x| kept[x]) {
        if let Some(p) = graph.parent[x] {
            kept_children[p] += 1;
            a_child[p] = x;
        }
    }
    let roots: Vec<usize> = (0..n)
        .filter(|&r| kept[r] && graph.parent[r].is_none())
        .collect();
    let mut joint = kept;
    for root in roots {
        let mut at = root;
        while !marked[at] && kept_children[at] == 1 {
            joint[at] = false;
            at = a_child[at];
        }
    }
    let nodes: Vec<usize> = (0..n).filter(|&x| joint[x]).collect();
    (!nodes.is_empty()).then_some(nodes)
}

/// The part nodes: in the scene, with a triangle mesh.
fn part_list(doc: &gltf::Document, in_scene: Option<&HashSet<usize>>) -> Vec<usize> {
    doc.nodes()
        .filter(|node| is_part(node, in_scene))
        .map(|node| node.index())
        .collect()
}

fn is_part(node: &gltf::Node, in_scene: Option<&HashSet<usize>>) -> bool {
    in_scene.is_none_or(|s| s.contains(&node.index()))
        && node.mesh().is_some_and(|m| has_triangles(&m))
}

/// Each part's triangle primitives in world space, every vertex bound rigidly to the joint
/// of its node, or to the nearest joint above it: in a skinned file, meshes parented to
/// bones (a robot's head and torso under its head and spine bones, a helmet, a sword)
/// move with that bone, and size its body. Nodes with a skin are the skin's to read.
pub(super) fn read_parts(
    doc: &gltf::Document,
    rig: &Rig,
    graph: &NodeGraph,
    in_scene: Option<&HashSet<usize>>,
    reader: &Reads,
) -> Result<Vec<SkinnedMesh>> {
    // The joint of each node, or of its nearest joint ancestor, top down.
    let mut joint_of: Vec<Option<usize>> = vec![None; graph.parent.len()];
    for &x in &graph.order {
        joint_of[x] = rig
            .node_to_joint
            .get(&x)
            .copied()
            .or_else(|| graph.parent[x].and_then(|p| joint_of[p]));
    }
    let mut out = Vec::new();
    for node in doc
        .nodes()
        .filter(|node| node.skin().is_none() && is_part(node, in_scene))
    {
        let Some(j) = joint_of[node.index()] else {
            continue;
        };
        let joint = u16::try_from(j).map_err(|_| {
            format_err(
                reader.path(),
                format!("node {}", node.index()),
                "is a joint past the 65,536 a skinned mesh can name",
            )
        })?;
        for mut m in read_node_meshes(&node, graph, reader)? {
            if !m.positions.iter().all(|p| p.is_finite()) {
                return Err(format_err(
                    reader.path(),
                    format!("node {}", node.index()),
                    "puts its mesh's vertices at non-finite positions",
                ));
            }
            m.joints = vec![[joint, 0, 0, 0]; m.positions.len()];
            m.weights = vec![Vec4::X; m.positions.len()];
            out.push(m);
        }
    }
    Ok(out)
}
