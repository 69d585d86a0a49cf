//! The node tree and the skin: parents, world transforms, and the skeleton a skin's joints
//! make, all computed parents first in single passes (no recursion, nothing per joint that
//! walks the tree), so a node chain a million deep costs no more than a flat one.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use gltf::mesh::Semantic;

use super::format_err;
use crate::error::Result;
use crate::math::Transform;
use crate::skeleton::Joint;

/// A node's TRS, decomposing a `matrix` when that is what the node has.
fn node_transform(node: &gltf::Node, path: &Path) -> Result<(Transform, Mat4)> {
    let (t, m) = match node.transform() {
        gltf::scene::Transform::Matrix { matrix } => {
            let m = Mat4::from_cols_array_2d(&matrix);
            (Transform::from_mat4(m), m)
        }
        gltf::scene::Transform::Decomposed {
            translation,
            rotation,
            scale,
        } => {
            let t = Transform {
                translation: Vec3::from(translation),
                rotation: Quat::from_array(rotation).normalize(),
                scale: Vec3::from(scale),
            };
            (t, t.to_mat4())
        }
    };
    if !t.is_finite() || !m.is_finite() {
        return Err(format_err(
            path,
            format!("node {}", node.index()),
            "its transform is not finite (or its rotation is a zero quaternion)",
        ));
    }
    Ok((t, m))
}

/// The node hierarchy, flattened: parents, local and world transforms.
pub(super) struct NodeGraph {
    pub(super) parent: Vec<Option<usize>>,
    pub(super) local: Vec<Transform>,
    pub(super) world: Vec<Mat4>,
    /// Every node, parents before children.
    pub(super) order: Vec<usize>,
}

impl NodeGraph {
    /// Linear in the nodes, with no recursion: a file may nest nodes a million deep.
    pub(super) fn new(doc: &gltf::Document, path: &Path) -> Result<Self> {
        let n = doc.nodes().len();
        if n == 0 {
            return Err(format_err(
                path,
                "nodes",
                "the file has no nodes, so no skeleton",
            ));
        }
        let mut parent = vec![None; n];
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut local = Vec::with_capacity(n);
        let mut local_mat = Vec::with_capacity(n);
        for node in doc.nodes() {
            for child in node.children() {
                let c = child.index();
                if parent[c].is_some() || c == node.index() {
                    return Err(format_err(
                        path,
                        format!("node {c}"),
                        "has more than one parent (the node hierarchy must be a tree)",
                    ));
                }
                parent[c] = Some(node.index());
                children[node.index()].push(c);
            }
            let (t, m) = node_transform(&node, path)?;
            local.push(t);
            local_mat.push(m);
        }
        // Breadth first from the roots; a node never reached is on a cycle, or below one.
        let mut order: Vec<usize> = (0..n).filter(|&i| parent[i].is_none()).collect();
        let mut k = 0;
        while k < order.len() {
            order.extend_from_slice(&children[order[k]]);
            k += 1;
        }
        if order.len() < n {
            let mut reached = vec![false; n];
            order.iter().for_each(|&i| reached[i] = true);
            let i = reached.iter().position(|r| !r).unwrap_or(0);
            return Err(format_err(
                path,
                format!("node {i}"),
                "is its own ancestor (a cycle)",
            ));
        }
        let mut world = vec![Mat4::IDENTITY; n];
        for &i in &order {
            world[i] = match parent[i] {
                Some(p) => world[p] * local_mat[i],
                None => local_mat[i],
            };
        }
        Ok(NodeGraph {
            parent,
            local,
            world,
            order,
        })
    }
}

/// The skin used by the most vertices (ties: the lowest index).
pub(super) fn choose_skin(doc: &gltf::Document, path: &Path) -> Result<usize> {
    let n = doc.skins().len();
    if n == 0 {
        return Err(format_err(
            path,
            "skins",
            "has no skin: no skeleton to build a ragdoll from",
        ));
    }
    let mut verts = vec![0usize; n];
    for node in doc.nodes() {
        if let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) {
            for prim in mesh.primitives() {
                if let Some(a) = prim.get(&Semantic::Positions) {
                    verts[skin.index()] = verts[skin.index()].saturating_add(a.count());
                }
            }
        }
    }
    let best = verts.iter().copied().max().unwrap_or(0);
    Ok(verts.iter().position(|&v| v == best).unwrap_or(0))
}

/// The skins that make one character with the chosen skin `chosen`, chosen first, then the
/// others in file order. Many exporters write one skin per mesh, each listing only the
/// bones that mesh uses (the head's skin may be the only one with the head bone), so the
/// character is every skin joined to the chosen one: two skins are joined when they share
/// a joint node, or when a joint of one hangs below a joint of the other. A skin joined to
/// nothing (a prop, a second character) is left out: it is written back as it came.
///
/// Linear in the nodes and joints: one pass over the tree, and a union-find over skins.
pub(super) fn attached_skins(doc: &gltf::Document, graph: &NodeGraph, chosen: usize) -> Vec<usize> {
    let n = graph.parent.len();
    let skins = doc.skins().len();
    let mut group: Vec<usize> = (0..skins).collect();
    fn find(group: &mut [usize], mut s: usize) -> usize {
        while group[s] != s {
            group[s] = group[group[s]];
            s = group[s];
        }
        s
    }
    // A skin that has each node as a joint (the first found; the others sharing it are
    // joined to it on the way).
    let mut owner: Vec<Option<usize>> = vec![None; n];
    for skin in doc.skins() {
        for joint in skin.joints() {
            let slot = &mut owner[joint.index()];
            match *slot {
                Some(o) => {
                    let (a, b) = (find(&mut group, o), find(&mut group, skin.index()));
                    group[a] = b;
                }
                None => *slot = Some(skin.index()),
            }
        }
    }
    // The nearest strict ancestor of each node that is some skin's joint, top down.
    let mut above: Vec<Option<usize>> = vec![None; n];
    for &x in &graph.order {
        if let Some(p) = graph.parent[x] {
            above[x] = if owner[p].is_some() {
                Some(p)
            } else {
                above[p]
            };
        }
        if let (Some(o), Some(a)) = (owner[x], above[x])
            && let Some(oa) = owner[a]
        {
            let (a, b) = (find(&mut group, oa), find(&mut group, o));
            group[a] = b;
        }
    }
    let home = find(&mut group, chosen);
    let mut out = vec![chosen];
    out.extend((0..skins).filter(|&s| s != chosen && find(&mut group, s) == home));
    out
}

/// The skeleton built from a skin, with the bookkeeping that maps it back to nodes.
pub(super) struct Rig {
    pub(super) joints: Vec<Joint>,
    /// Node of each skeleton joint.
    pub(super) nodes: Vec<usize>,
    /// Static transforms from the parent joint (or world) to each joint node's parent.
    pub(super) offsets: Vec<Transform>,
    /// Skeleton index of each joint node.
    pub(super) node_to_joint: HashMap<usize, usize>,
    /// Each joint node's own TRS.
    pub(super) node_rest: Vec<Transform>,
}

impl Rig {
    /// The skeleton of the chosen `skin` and of the skins `attached` to it (see
    /// [`attached_skins`]): the chosen skin's joints first, in its order, then each other
    /// skin's joints not yet listed, so a file with one skin reads exactly as it did.
    pub(super) fn new(
        doc: &gltf::Document,
        skin: &gltf::Skin,
        attached: &[usize],
        graph: &NodeGraph,
        path: &Path,
    ) -> Result<Self> {
        let place = format!("skin {}", skin.index());
        let mut slots: Vec<usize> = skin.joints().map(|n| n.index()).collect();
        if slots.is_empty() {
            return Err(format_err(path, place, "has no joints"));
        }
        let mut seen = HashSet::new();
        for &n in &slots {
            if !seen.insert(n) {
                return Err(format_err(
                    path,
                    place,
                    format!("lists node {n} twice among its joints"),
                ));
            }
        }
        for other in doc.skins().filter(|s| attached.contains(&s.index())) {
            slots.extend(
                other
                    .joints()
                    .map(|n| n.index())
                    .filter(|&n| seen.insert(n)),
            );
        }
        Ok(Self::from_nodes(doc, slots, graph))
    }

    /// The skeleton of these nodes (distinct, each a valid node index), as if they were
    /// the joints of a skin in this order: what a file without a skin gets from its node
    /// hierarchy (`rigid.rs`).
    pub(super) fn from_nodes(doc: &gltf::Document, slots: Vec<usize>, graph: &NodeGraph) -> Self {
        // Nearest ancestor joint of each slot, then the skin's own order with any joint
        // listed before its parent moved after it: files already in parent-first order
        // (most, and every file we write) keep their joint order through a round trip.
        let slot_of: HashMap<usize, usize> =
            slots.iter().enumerate().map(|(s, &n)| (n, s)).collect();
        let above = JointsAbove::new(graph, &slot_of);
        let parent_slot: Vec<Option<usize>> = slots.iter().map(|&n| above.slot[n]).collect();
        let mut order = Vec::with_capacity(slots.len());
        let mut placed = vec![false; slots.len()];
        for s in 0..slots.len() {
            let mut pending = Vec::new();
            let mut at = Some(s);
            while let Some(x) = at.filter(|&x| !placed[x]) {
                pending.push(x);
                at = parent_slot[x];
            }
            for &x in pending.iter().rev() {
                placed[x] = true;
                order.push(x);
            }
        }
        let mut slot_to_joint = vec![0; slots.len()];
        let mut node_to_joint = HashMap::new();
        for (j, &s) in order.iter().enumerate() {
            slot_to_joint[s] = j;
            node_to_joint.insert(slots[s], j);
        }
        let names: Vec<&str> = doc.nodes().map(|n| n.name().unwrap_or("")).collect();
        let mut joints = Vec::with_capacity(slots.len());
        let mut nodes = Vec::with_capacity(slots.len());
        let mut offsets = Vec::with_capacity(slots.len());
        let mut node_rest = Vec::with_capacity(slots.len());
        for &s in &order {
            let node = slots[s];
            let parent = parent_slot[s].map(|ps| slot_to_joint[ps]);
            let offset = above.offset[node];
            let rest = if above.direct[node] {
                graph.local[node]
            } else {
                offset.mul(&graph.local[node])
            };
            joints.push(Joint {
                name: names[node].to_string(),
                parent,
                rest,
                tip: None,
            });
            nodes.push(node);
            offsets.push(offset);
            node_rest.push(graph.local[node]);
        }
        Rig {
            joints,
            nodes,
            offsets,
            node_to_joint,
            node_rest,
        }
    }

    /// A joint's skeleton-space local transform from its node's own (animated) TRS.
    pub(super) fn local(&self, j: usize, node_trs: &Transform) -> Transform {
        if self.offsets[j] == Transform::IDENTITY {
            *node_trs
        } else {
            self.offsets[j].mul(node_trs)
        }
    }
}

/// For every node, what lies between it and its nearest ancestor that is a joint of the
/// skin, computed parents first in one pass (walking up from every joint would cost the
/// depth of the tree per joint).
struct JointsAbove {
    /// Skin slot of the nearest joint ancestor.
    slot: Vec<Option<usize>>,
    /// Product of the non-joint nodes from below that ancestor (or from the world) down to
    /// the node's parent.
    offset: Vec<Transform>,
    /// Whether there are no such nodes (the parent is a joint, or there is no parent).
    direct: Vec<bool>,
}

impl JointsAbove {
    fn new(graph: &NodeGraph, slot_of: &HashMap<usize, usize>) -> Self {
        let n = graph.parent.len();
        let mut out = JointsAbove {
            slot: vec![None; n],
            offset: vec![Transform::IDENTITY; n],
            direct: vec![true; n],
        };
        for &x in &graph.order {
            let Some(p) = graph.parent[x] else { continue };
            if let Some(&ps) = slot_of.get(&p) {
                out.slot[x] = Some(ps);
            } else {
                // The same left fold, top down, that a walk up from `x` would build.
                out.slot[x] = out.slot[p];
                let above = if out.direct[p] {
                    Transform::IDENTITY
                } else {
                    out.offset[p]
                };
                out.offset[x] = above.mul(&graph.local[p]);
                out.direct[x] = false;
            }
        }
        out
    }
}
