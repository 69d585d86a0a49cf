//! What a glTF input gets wrong that would make the file we write back invalid: mended
//! where a tool can mend it, refused where a loader must not read on.
//!
//! The exporter writes a glTF input back as it came, so without this every defect of the
//! input would be a defect of our output, and the Khronos validator would count errors
//! on a file our CLI reported as written. Each kind of repair gives one warning naming
//! what changed (places listed, a handful at most), because a user who sees their file
//! altered should be told where and why; what cannot be mended without guessing what the
//! author meant (a required extension we cannot honour, another major glTF version) is
//! refused at import, in one sentence naming the file and the place.
//!
//! The repairs run at import ([`repair_source`]), so their warnings reach
//! [`Character::warnings`](crate::skeleton::Character), which every command prints, and so
//! the importer itself reads the mended document (a zero node rotation would otherwise be
//! refused, and decreasing keyframe times on a joint refuse the file). The exporter runs
//! the repairs that need no binary data again on what it writes ([`repair_json`]): on a
//! document the importer already mended they find nothing, but a source built or edited
//! elsewhere still gets a valid document. The keys in the buffers are checked at import
//! only, where the buffers can be mended in place.

mod animations;
mod drop;
mod extensions;
mod nodes;
mod references;
mod skins;
mod tree;

use std::path::Path;

use serde_json::Value;

use super::parse_document;
use crate::error::Result;

pub(crate) use drop::drop_images;
pub use extensions::ACCEPTED_REQUIRED_EXTENSIONS;
pub(crate) use extensions::refuse_unreadable;

/// At most this many places are named in one warning; the rest are counted.
const MAX_PLACES: usize = 6;

/// How far from unit length a rotation may be before it is mended: well inside the
/// validator's own limit (it reports rotations off by more than 0.00769, the rounding of a
/// normalised byte), and far past the rounding of a float, which is left as written.
const UNIT_TOLERANCE: f64 = 0.005;

/// Every repair of an imported document: `json` and `buffers` mended in place, and one
/// warning per kind of repair made. `doc` is `json` as parsed before; a mended document is
/// parsed again, so what the importer reads next is what the exporter will write.
pub(crate) fn repair_source(
    mut json: Value,
    doc: gltf::Document,
    buffers: &mut [Vec<u8>],
    path: &Path,
) -> Result<(Value, gltf::Document, Vec<String>)> {
    let mut warnings = repair_json(&mut json);
    // `repair_json` moves no index an animation holds, so `doc` still reads its keys.
    warnings.extend(animations::repair_keys(&mut json, &doc, buffers, path)?);
    if warnings.is_empty() {
        return Ok((json, doc, warnings));
    }
    let doc = parse_document(&json, path)?;
    Ok((json, doc, warnings))
}

/// The repairs that need the JSON alone, one warning per kind made. Every change they make
/// is warned about, so no warning means the document was left as it was.
pub(crate) fn repair_json(json: &mut Value) -> Vec<String> {
    let Some(obj) = json.as_object_mut() else {
        return Vec::new();
    };
    [
        extensions::repair_asset(obj),
        references::drop_dangling(obj),
        // Before the skeletons and scenes: it adds the root they are checked against.
        skins::join_skin_roots(obj),
        skins::repair_skeletons(obj),
        nodes::repair_scenes(obj),
        nodes::normalise_rotations(obj),
        nodes::pair_influences(obj),
        // Last, so that it sees every extension object the other repairs leave.
        extensions::declare_extensions(obj),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// `places` joined for a warning: the first [`MAX_PLACES`], then how many more.
fn listed(places: &[String]) -> String {
    let mut s = places[..places.len().min(MAX_PLACES)].join(", ");
    if places.len() > MAX_PLACES {
        s.push_str(&format!(" and {} more", places.len() - MAX_PLACES));
    }
    s
}

/// `node 2 ("top")`, or `node 2` for a node without a name.
fn node_label(obj: &serde_json::Map<String, Value>, n: usize) -> String {
    let name = obj
        .get("nodes")
        .and_then(|v| v.get(n))
        .and_then(|v| v.get("name"))
        .and_then(Value::as_str);
    match name {
        Some(name) => format!("node {n} ({name:?})"),
        None => format!("node {n}"),
    }
}

/// The length of the top-level array `obj[key]` (0 when absent).
fn count(obj: &serde_json::Map<String, Value>, key: &str) -> usize {
    obj.get(key).and_then(Value::as_array).map_or(0, Vec::len)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A node tree the node and skin repairs are tested on: a hip with a leg and an arm
    /// under an `Armature`, and a `sword` outside it; three skins over them.
    pub(in crate::import::gltf::repair) fn tree() -> Value {
        serde_json::json!({
            "nodes": [
                {"name": "Armature", "children": [1]},
                {"name": "hip", "children": [2, 3]},
                {"name": "leg"},
                {"name": "arm"},
                {"name": "sword"}
            ],
            "skins": [{"joints": [2, 3], "skeleton": 2}, {"joints": [2, 4], "skeleton": 2}, {"joints": [1, 2], "skeleton": 0}]
        })
    }

    #[test]
    fn a_long_list_of_places_is_cut_and_counted() {
        let places: Vec<String> = (0..9).map(|i| format!("p{i}")).collect();
        assert_eq!(listed(&places), "p0, p1, p2, p3, p4, p5 and 3 more");
        assert_eq!(listed(&places[..2]), "p0, p1");
    }
}
