//! Skin weights on export: every primitive's `JOINTS_n`/`WEIGHTS_n` rewritten as the
//! importer repaired them, in place where the accessors serve nothing else.

use std::collections::{HashMap, HashSet};

use gltf::mesh::Semantic;
use serde_json::{Map, Value, json};

use super::{ARRAY_BUFFER, Bin, FLOAT, UNSIGNED_BYTE, UNSIGNED_SHORT, f32_bytes};
use crate::error::Result;
use crate::import::gltf::{AccessorReader, GltfSource, SkinSlots, read_influences};

/// Accessors read for something other than skin influences; those cannot be rewritten in
/// place.
fn other_accessor_uses(doc: &gltf::Document) -> HashSet<usize> {
    let mut used = HashSet::new();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            for (sem, a) in prim.attributes() {
                if !matches!(sem, Semantic::Joints(_) | Semantic::Weights(_)) {
                    used.insert(a.index());
                }
            }
            if let Some(a) = prim.indices() {
                used.insert(a.index());
            }
            for target in prim.morph_targets() {
                for a in [target.positions(), target.normals(), target.tangents()]
                    .into_iter()
                    .flatten()
                {
                    used.insert(a.index());
                }
            }
        }
    }
    for skin in doc.skins() {
        if let Some(a) = skin.inverse_bind_matrices() {
            used.insert(a.index());
        }
    }
    for anim in doc.animations() {
        for s in anim.samplers() {
            used.insert(s.input().index());
            used.insert(s.output().index());
        }
    }
    used
}

/// Rewrites every primitive's `JOINTS_n`/`WEIGHTS_n` so weights sum to 1 (over all sets),
/// a vertex's duplicate joints are merged, and unused slots hold joint 0 with weight 0.
///
/// A primitive with one influence set whose accessors serve nothing else is rewritten in
/// place (same accessor indices, new float data), so the file gains no unused accessors;
/// other cases get new accessors.
pub(super) fn renormalise_weights(
    obj: &mut Map<String, Value>,
    doc: &gltf::Document,
    bin: &mut Bin,
    src: &GltfSource,
) -> Result<()> {
    let reader = AccessorReader {
        buffers: &src.buffers,
        path: &src.path,
    };
    let (prims, keys_of) = influence_sets(doc);
    let other = other_accessor_uses(doc);
    let skin_of = skins_by_mesh(doc, src);
    let mut done: HashMap<Key, Key> = HashMap::new();
    for (m, p, key) in prims {
        if let Some(new_key) = done.get(&key) {
            set_influence_attributes(obj, m, p, new_key);
            continue;
        }
        let prim = doc
            .meshes()
            .nth(m)
            .and_then(|mesh| mesh.primitives().nth(p))
            .expect("indices come from the same document");
        let vertex_count = prim
            .get(&Semantic::Positions)
            .map(|a| a.count())
            .unwrap_or_else(|| doc.accessors().nth(key[0].1).map_or(0, |a| a.count()));
        let skin = skin_of.get(&m).copied().unwrap_or(SkinSlots {
            count: usize::MAX,
            root: 0,
        });
        let Some((influences, _)) =
            read_influences(&prim, vertex_count, skin, &reader, &|_| Ok(()))?
        else {
            continue;
        };
        let (joints, weights) = pack_influences(&influences, vertex_count, key.len());
        let in_place = key.len() == 1
            && [key[0].0, key[0].1]
                .iter()
                .all(|a| !other.contains(a) && keys_of.get(a).is_some_and(|k| k.len() == 1));
        let mut new_key = Vec::with_capacity(key.len());
        for (s, &(ja, wa)) in key.iter().enumerate() {
            let jtype = match doc.accessors().nth(ja).map(|a| a.data_type()) {
                Some(gltf::accessor::DataType::U8) => UNSIGNED_BYTE,
                _ => UNSIGNED_SHORT,
            };
            let jbytes: Vec<u8> = if jtype == UNSIGNED_BYTE {
                joints[s].iter().map(|&j| j as u8).collect()
            } else {
                joints[s]
                    .iter()
                    .flat_map(|&j| (j as u16).to_le_bytes())
                    .collect()
            };
            let wbytes = f32_bytes(weights[s].iter().copied());
            if in_place {
                rewrite_in_place(bin, ja, jtype, &jbytes, vertex_count);
                rewrite_in_place(bin, wa, FLOAT, &wbytes, vertex_count);
                new_key.push((ja, wa));
            } else {
                let jview = bin.push_view(&jbytes, Some(ARRAY_BUFFER));
                let wview = bin.push_view(&wbytes, Some(ARRAY_BUFFER));
                let jacc = json!({"bufferView": jview, "componentType": jtype, "count": vertex_count, "type": "VEC4"});
                let wacc = json!({"bufferView": wview, "componentType": FLOAT, "count": vertex_count, "type": "VEC4"});
                new_key.push((bin.push_accessor(jacc), bin.push_accessor(wacc)));
            }
        }
        set_influence_attributes(obj, m, p, &new_key);
        done.insert(key, new_key);
    }
    Ok(())
}

/// A primitive's influence sets: its (`JOINTS_n`, `WEIGHTS_n`) accessor pairs in order.
type Key = Vec<(usize, usize)>;

/// A skinned primitive: its mesh, its index in the mesh, and its influence sets.
type SkinnedPrimitive = (usize, usize, Key);

/// Every skinned primitive as (mesh, primitive, its sets), and for each accessor the
/// distinct sets it appears in (an accessor shared by two sets cannot be rewritten in
/// place for one of them).
fn influence_sets(doc: &gltf::Document) -> (Vec<SkinnedPrimitive>, HashMap<usize, HashSet<Key>>) {
    let mut prims: Vec<SkinnedPrimitive> = Vec::new();
    let mut keys_of: HashMap<usize, HashSet<Key>> = HashMap::new();
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let mut key = Vec::new();
            for k in 0.. {
                match (
                    prim.get(&Semantic::Joints(k)),
                    prim.get(&Semantic::Weights(k)),
                ) {
                    (Some(j), Some(w)) => key.push((j.index(), w.index())),
                    _ => break,
                }
            }
            if key.is_empty() {
                continue;
            }
            for &(j, w) in &key {
                keys_of.entry(j).or_default().insert(key.clone());
                keys_of.entry(w).or_default().insert(key.clone());
            }
            prims.push((mesh.index(), prim.index(), key));
        }
    }
    (prims, keys_of)
}

/// The repaired influences of `vertex_count` vertices laid out as `sets` VEC4 joint and
/// weight arrays, unused slots joint 0 with weight 0.
fn pack_influences(
    influences: &[Vec<(usize, f32)>],
    vertex_count: usize,
    sets: usize,
) -> (Vec<Vec<u32>>, Vec<Vec<f32>>) {
    let mut joints = vec![vec![0u32; vertex_count * 4]; sets];
    let mut weights = vec![vec![0f32; vertex_count * 4]; sets];
    for (v, infl) in influences.iter().enumerate() {
        for (slot, &(j, w)) in infl.iter().enumerate().take(4 * sets) {
            joints[slot / 4][v * 4 + slot % 4] = j as u32;
            weights[slot / 4][v * 4 + slot % 4] = w;
        }
    }
    (joints, weights)
}

/// Writes `bytes` (components of type `ctype`) as accessor `a`'s data: over its own
/// elements where they fit, else in a new view the accessor is pointed at; its bounds
/// are dropped, as they no longer hold.
fn rewrite_in_place(bin: &mut Bin, a: usize, ctype: u32, bytes: &[u8], vertex_count: usize) {
    if !overwrite_elements(bin, a, ctype, vertex_count, bytes) {
        let view = bin.push_view(bytes, Some(ARRAY_BUFFER));
        if let Some(o) = bin.accessors.get_mut(a).and_then(Value::as_object_mut) {
            for k in ["byteOffset", "normalized", "sparse"] {
                o.remove(k);
            }
            o.insert("bufferView".into(), json!(view));
            o.insert("componentType".into(), json!(ctype));
        }
    }
    if let Some(o) = bin.accessors.get_mut(a).and_then(Value::as_object_mut) {
        o.remove("min");
        o.remove("max");
    }
}

/// The skin each mesh is drawn with, so its weights are repaired against that skin's
/// joints exactly as the importer repaired them: the character's skin has the root the
/// importer chose; another skin (a prop's) its `skeleton` node when that is a joint, else
/// its first joint. A mesh drawn with several skins gets the smallest, so no joint index
/// written for it is out of range for any of them.
fn skins_by_mesh(doc: &gltf::Document, src: &GltfSource) -> HashMap<usize, SkinSlots> {
    let mut out: HashMap<usize, SkinSlots> = HashMap::new();
    for node in doc.nodes() {
        let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) else {
            continue;
        };
        let joints: Vec<usize> = skin.joints().map(|n| n.index()).collect();
        let root_node = if skin.index() == src.skin {
            src.joint_nodes.first().copied()
        } else {
            skin.skeleton().map(|n| n.index())
        };
        let slots = SkinSlots {
            count: joints.len(),
            root: root_node
                .and_then(|r| joints.iter().position(|&n| n == r))
                .unwrap_or(0),
        };
        out.entry(mesh.index())
            .and_modify(|s| {
                if slots.count < s.count {
                    *s = slots;
                }
            })
            .or_insert(slots);
    }
    out
}

/// Writes new element data over an accessor's own bytes in the merged binary, when it is
/// stored plainly (a buffer view, no sparse substitution) with the same component type:
/// the file then keeps its layout and gains no orphaned buffer views. Returns whether it
/// could.
fn overwrite_elements(
    bin: &mut Bin,
    accessor: usize,
    component_type: u32,
    count: usize,
    bytes: &[u8],
) -> bool {
    let Some(a) = bin.accessors.get(accessor) else {
        return false;
    };
    let same_type = a.get("componentType").and_then(Value::as_u64) == Some(component_type as u64);
    if !same_type || a.get("sparse").is_some() || count == 0 || bytes.len() % count != 0 {
        return false;
    }
    let elem = bytes.len() / count;
    let Some(view) = a
        .get("bufferView")
        .and_then(Value::as_u64)
        .and_then(|v| bin.views.get(v as usize))
    else {
        return false;
    };
    let int = |v: &Value, k: &str| v.get(k).and_then(Value::as_u64).map(|x| x as usize);
    let base = int(view, "byteOffset").unwrap_or(0) + int(a, "byteOffset").unwrap_or(0);
    let stride = int(view, "byteStride").unwrap_or(elem);
    let end = base + (count - 1) * stride + elem;
    let view_end = int(view, "byteOffset").unwrap_or(0) + int(view, "byteLength").unwrap_or(0);
    if stride < elem || end > view_end || end > bin.data.len() {
        return false;
    }
    for (i, e) in bytes.chunks_exact(elem).enumerate() {
        let at = base + i * stride;
        bin.data[at..at + elem].copy_from_slice(e);
    }
    true
}

fn set_influence_attributes(
    obj: &mut Map<String, Value>,
    mesh: usize,
    prim: usize,
    key: &[(usize, usize)],
) {
    let Some(attrs) = primitive_attributes(obj, mesh, prim) else {
        return;
    };
    for (k, &(j, w)) in key.iter().enumerate() {
        attrs.insert(format!("JOINTS_{k}"), json!(j));
        attrs.insert(format!("WEIGHTS_{k}"), json!(w));
    }
}

/// The `attributes` object of primitive `prim` of mesh `mesh`.
pub(super) fn primitive_attributes(
    obj: &mut Map<String, Value>,
    mesh: usize,
    prim: usize,
) -> Option<&mut Map<String, Value>> {
    obj.get_mut("meshes")
        .and_then(|m| m.get_mut(mesh))
        .and_then(|m| m.get_mut("primitives"))
        .and_then(|p| p.get_mut(prim))
        .and_then(|p| p.get_mut("attributes"))
        .and_then(Value::as_object_mut)
}
