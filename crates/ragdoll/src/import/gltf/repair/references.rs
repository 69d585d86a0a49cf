//! References to materials, textures, images and samplers that do not exist. The importer
//! never reads these (they are left out of what the `gltf` crate validates, see
//! `parse_document`), so a file can carry dangling ones that every loader then trips on;
//! dropping the reference leaves what a viewer shows for it anyway: a primitive without a
//! material is drawn in the default one, a material without a texture in its factors.

use std::collections::HashSet;

use serde_json::{Map, Value};

use super::drop::drop_images;
use super::{count, listed};

/// Whether `v` is an index below `len`.
fn in_range(v: &Value, len: usize) -> bool {
    v.as_u64().is_some_and(|i| (i as usize) < len)
}

/// Removes `o[key]` when it holds no index below `len`, recording `place` and what it
/// pointed at; whether it was removed.
fn drop_if_dangling(
    o: &mut Map<String, Value>,
    key: &str,
    len: usize,
    what: &str,
    place: String,
    dropped: &mut Vec<String>,
) -> bool {
    match o.get(key) {
        Some(v) if !in_range(v, len) => {
            dropped.push(format!("{place} ({what} {v})"));
            o.remove(key);
            true
        }
        _ => false,
    }
}

/// Drops every reference to a material, texture, image, sampler or (from an image) buffer
/// view that does not exist; an image whose data is such a view goes, with the textures
/// that show it.
pub(super) fn drop_dangling(obj: &mut Map<String, Value>) -> Option<String> {
    let mut dropped = Vec::new();
    drop_imageless_images(obj, &mut dropped);
    drop_in_textures(obj, &mut dropped);
    drop_in_materials(obj, &mut dropped);
    let materials = count(obj, "materials");
    if let Some(Value::Array(meshes)) = obj.get_mut("meshes") {
        for (m, mesh) in meshes.iter_mut().enumerate() {
            let Some(Value::Array(prims)) = mesh.get_mut("primitives") else {
                continue;
            };
            for (p, prim) in prims.iter_mut().enumerate() {
                if let Some(o) = prim.as_object_mut() {
                    let place = format!("meshes[{m}].primitives[{p}].material");
                    drop_if_dangling(o, "material", materials, "material", place, &mut dropped);
                }
            }
        }
    }
    if dropped.is_empty() {
        return None;
    }
    let n = dropped.len();
    let s = if n == 1 { "" } else { "s" };
    Some(format!(
        "left out {n} reference{s} to entries that do not exist: {}",
        listed(&dropped)
    ))
}

/// Images whose `bufferView` does not exist hold no data: they go, with their textures.
fn drop_imageless_images(obj: &mut Map<String, Value>, dropped: &mut Vec<String>) {
    let views = count(obj, "bufferViews");
    let Some(Value::Array(images)) = obj.get("images") else {
        return;
    };
    let mut gone = HashSet::new();
    for (i, image) in images.iter().enumerate() {
        if let Some(v) = image.get("bufferView")
            && !in_range(v, views)
        {
            dropped.push(format!("images[{i}].bufferView (bufferView {v})"));
            gone.insert(i);
        }
    }
    if !gone.is_empty() {
        drop_images(obj, &gone);
    }
}

/// A texture's `source` and `sampler`, and the image an extension gives it (WebP, KTX2,
/// AVIF): an extension whose image does not exist is dropped whole, as it means nothing
/// without one.
fn drop_in_textures(obj: &mut Map<String, Value>, dropped: &mut Vec<String>) {
    let (images, samplers) = (count(obj, "images"), count(obj, "samplers"));
    let Some(Value::Array(textures)) = obj.get_mut("textures") else {
        return;
    };
    for (t, texture) in textures.iter_mut().enumerate() {
        let Some(o) = texture.as_object_mut() else {
            continue;
        };
        let place = format!("textures[{t}].source");
        drop_if_dangling(o, "source", images, "image", place, dropped);
        let place = format!("textures[{t}].sampler");
        drop_if_dangling(o, "sampler", samplers, "sampler", place, dropped);
        if let Some(Value::Object(exts)) = o.get_mut("extensions") {
            exts.retain(|name, e| match e.get("source") {
                Some(v) if !in_range(v, images) => {
                    dropped.push(format!("textures[{t}].extensions.{name} (image {v})"));
                    false
                }
                _ => true,
            });
            if exts.is_empty() {
                o.remove("extensions");
            }
        }
    }
}

/// Every texture info in a material (core or extension: an object under a key ending in
/// `Texture` with an `index`) whose texture does not exist. A stack, not recursion.
fn drop_in_materials(obj: &mut Map<String, Value>, dropped: &mut Vec<String>) {
    let textures = count(obj, "textures");
    let Some(Value::Array(materials)) = obj.get_mut("materials") else {
        return;
    };
    for (m, material) in materials.iter_mut().enumerate() {
        let mut stack = vec![(format!("materials[{m}]"), material)];
        while let Some((place, v)) = stack.pop() {
            match v {
                Value::Object(o) => {
                    o.retain(|k, x| match x.get("index") {
                        Some(i) if k.ends_with("Texture") && !in_range(i, textures) => {
                            dropped.push(format!("{place}.{k} (texture {i})"));
                            false
                        }
                        _ => true,
                    });
                    stack.extend(o.iter_mut().map(|(k, x)| (format!("{place}.{k}"), x)));
                }
                Value::Array(a) => {
                    stack.extend(a.iter_mut().map(|x| (place.clone(), x)));
                }
                _ => {}
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn dangling_references_are_dropped_and_named() {
        let mut doc = json!({
            "meshes": [{"primitives": [{"material": 0}, {"material": 3}]}],
            "materials": [{
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
                "extensions": {"KHR_materials_clearcoat": {"clearcoatTexture": {"index": 7}}}
            }],
            "textures": [{"source": 0, "sampler": 2, "extensions": {"EXT_texture_webp": {"source": 5}}}],
            "images": [{"uri": "a.png"}]
        });
        let w = drop_dangling(doc.as_object_mut().unwrap()).unwrap();
        assert_eq!(doc["meshes"][0]["primitives"][1], json!({}));
        assert_eq!(doc["textures"][0], json!({"source": 0}));
        assert_eq!(
            doc["materials"][0]["extensions"]["KHR_materials_clearcoat"],
            json!({})
        );
        assert_eq!(
            doc["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"],
            0
        );
        for says in [
            "4 references",
            "meshes[0].primitives[1].material (material 3)",
            "textures[0].sampler (sampler 2)",
            "textures[0].extensions.EXT_texture_webp (image 5)",
            "materials[0].extensions.KHR_materials_clearcoat.clearcoatTexture (texture 7)",
        ] {
            assert!(w.contains(says), "{says:?} not in {w}");
        }
        assert_eq!(drop_dangling(doc.as_object_mut().unwrap()), None);
    }

    #[test]
    fn an_image_without_data_goes_with_its_textures() {
        let mut doc = json!({
            "bufferViews": [{"buffer": 0, "byteLength": 4}],
            "images": [{"bufferView": 9, "mimeType": "image/png"}, {"bufferView": 0, "mimeType": "image/png"}],
            "textures": [{"source": 0}, {"source": 1}],
            "materials": [{"normalTexture": {"index": 0}, "occlusionTexture": {"index": 1}}]
        });
        let w = drop_dangling(doc.as_object_mut().unwrap()).unwrap();
        assert!(w.contains("images[0].bufferView (bufferView 9)"), "{w}");
        assert_eq!(
            doc["images"],
            json!([{"bufferView": 0, "mimeType": "image/png"}])
        );
        assert_eq!(doc["textures"], json!([{"source": 0}]));
        assert_eq!(
            doc["materials"][0],
            json!({"occlusionTexture": {"index": 0}})
        );
    }
}
