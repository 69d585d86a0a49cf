//! Removing entries from a glTF document's arrays (images, and the textures and texture
//! infos that show them) and renumbering every reference to what remains: shared by the
//! repairs of dangling references here and the exporter's handling of missing image files.

use std::collections::HashSet;

use serde_json::{Map, Value, json};

/// New indices after removing `gone` from `0..len`: `None` for a removed entry.
fn renumber(len: usize, gone: &HashSet<usize>) -> Vec<Option<usize>> {
    let mut next = 0;
    (0..len)
        .map(|i| {
            (!gone.contains(&i)).then(|| {
                next += 1;
                next - 1
            })
        })
        .collect()
}

/// Removes the entries of `obj[key]` in `gone` (the key itself when none is left: glTF
/// forbids empty arrays) and returns the survivors' new indices.
fn remove_entries(
    obj: &mut Map<String, Value>,
    key: &str,
    gone: &HashSet<usize>,
) -> Vec<Option<usize>> {
    let Some(Value::Array(items)) = obj.remove(key) else {
        return Vec::new();
    };
    let map = renumber(items.len(), gone);
    let kept: Vec<Value> = items
        .into_iter()
        .enumerate()
        .filter(|(i, _)| !gone.contains(i))
        .map(|(_, v)| v)
        .collect();
    if !kept.is_empty() {
        obj.insert(key.into(), Value::Array(kept));
    }
    map
}

/// Points `v[key]` at its entry's new index; false when that entry was removed.
fn remap(v: &mut Value, key: &str, map: &[Option<usize>]) -> bool {
    let Some(slot) = v.get_mut(key) else {
        return true;
    };
    match slot.as_u64().and_then(|i| map.get(i as usize).copied()) {
        Some(Some(new)) => {
            *slot = json!(new);
            true
        }
        Some(None) => false,
        // Not an index we know: left as it was (validation already passed it).
        None => true,
    }
}

/// Leaves out the images in `gone`, the textures that show one of them (as their core
/// source or an extension's: WebP, KTX2, DDS), and the texture infos that name those
/// textures, renumbering what remains.
pub(crate) fn drop_images(obj: &mut Map<String, Value>, gone: &HashSet<usize>) {
    let image_map = remove_entries(obj, "images", gone);
    if let Some(meta) = obj
        .get_mut("extensions")
        .and_then(|e| e.pointer_mut("/VRMC_vrm/meta"))
    {
        remap_or_remove(meta, "thumbnailImage", &image_map);
    }
    let mut dead_textures = HashSet::new();
    if let Some(Value::Array(textures)) = obj.get_mut("textures") {
        for (t, texture) in textures.iter_mut().enumerate() {
            let mut alive = remap(texture, "source", &image_map);
            if let Some(Value::Object(exts)) = texture.get_mut("extensions") {
                for e in exts.values_mut() {
                    alive &= remap(e, "source", &image_map);
                }
            }
            if !alive {
                dead_textures.insert(t);
            }
        }
    }
    if dead_textures.is_empty() {
        return;
    }
    let texture_map = remove_entries(obj, "textures", &dead_textures);
    if let Some(Value::Array(materials)) = obj.get_mut("materials") {
        materials
            .iter_mut()
            .for_each(|m| remap_texture_infos(m, &texture_map));
    }
    remap_vrm0_textures(obj, &texture_map);
}

/// Points `v[key]` at its entry's new index, removing the key when that entry is gone.
fn remap_or_remove(v: &mut Value, key: &str, map: &[Option<usize>]) {
    if !remap(v, key, map)
        && let Some(o) = v.as_object_mut()
    {
        o.remove(key);
    }
}

/// VRM 0.x names textures outside the core materials: the avatar's thumbnail
/// (`VRM.meta.texture`) and each MToon material's `textureProperties` (name → texture
/// index). Left unrenumbered they would show the wrong texture, or none that exists.
fn remap_vrm0_textures(obj: &mut Map<String, Value>, map: &[Option<usize>]) {
    let Some(vrm) = obj.get_mut("extensions").and_then(|e| e.get_mut("VRM")) else {
        return;
    };
    if let Some(meta) = vrm.get_mut("meta") {
        remap_or_remove(meta, "texture", map);
    }
    if let Some(Value::Array(materials)) = vrm.get_mut("materialProperties") {
        for m in materials {
            if let Some(Value::Object(props)) = m.get_mut("textureProperties") {
                props.retain(|_, index| {
                    match index.as_u64().and_then(|i| map.get(i as usize).copied()) {
                        Some(Some(new)) => {
                            *index = json!(new);
                            true
                        }
                        Some(None) => false,
                        None => true,
                    }
                });
            }
        }
    }
}

/// Renumbers every texture info in a material, core and extension alike (each an object
/// under a key ending in `Texture` with an `index`: `baseColorTexture`,
/// `clearcoatTexture`, …), and removes those whose texture is gone. A stack, not recursion.
fn remap_texture_infos(material: &mut Value, map: &[Option<usize>]) {
    let mut stack = vec![material];
    while let Some(v) = stack.pop() {
        match v {
            Value::Object(m) => {
                m.retain(|k, x| {
                    !(k.ends_with("Texture") && x.get("index").is_some()) || remap(x, "index", map)
                });
                stack.extend(m.values_mut());
            }
            Value::Array(a) => stack.extend(a.iter_mut()),
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_image_takes_its_textures_and_their_references_with_it() {
        let mut doc = json!({
            "images": [{"uri": "a.png"}, {"uri": "gone.png"}, {"uri": "c.png"}],
            "textures": [{"source": 0}, {"source": 1}, {"source": 2},
                         {"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}],
            "materials": [{
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}, "baseColorFactor": [1, 0, 0, 1]},
                "normalTexture": {"index": 2},
                "extensions": {"KHR_materials_clearcoat": {"clearcoatTexture": {"index": 3}}}
            }]
        });
        let obj = doc.as_object_mut().unwrap();
        drop_images(obj, &HashSet::from([1]));
        assert_eq!(doc["images"], json!([{"uri": "a.png"}, {"uri": "c.png"}]));
        assert_eq!(doc["textures"], json!([{"source": 0}, {"source": 1}]));
        assert_eq!(
            doc["materials"][0],
            json!({
                "pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]},
                "normalTexture": {"index": 1},
                "extensions": {"KHR_materials_clearcoat": {}}
            })
        );
    }

    #[test]
    fn vrm_thumbnails_and_mtoon_textures_follow_the_renumbering() {
        let mut doc = json!({
            "images": [{"uri": "gone.png"}, {"uri": "b.png"}, {"uri": "c.png"}],
            "textures": [{"source": 0}, {"source": 1}, {"source": 2}],
            "extensions": {
                "VRMC_vrm": {"meta": {"name": "x", "thumbnailImage": 2}},
                "VRM": {
                    "meta": {"title": "x", "texture": 0},
                    "materialProperties": [{"textureProperties": {"_MainTex": 2, "_ShadeTexture": 0}}]
                }
            }
        });
        drop_images(doc.as_object_mut().unwrap(), &HashSet::from([0]));
        assert_eq!(
            doc["extensions"]["VRMC_vrm"]["meta"],
            json!({"name": "x", "thumbnailImage": 1})
        );
        assert_eq!(doc["extensions"]["VRM"]["meta"], json!({"title": "x"}));
        assert_eq!(
            doc["extensions"]["VRM"]["materialProperties"][0]["textureProperties"],
            json!({"_MainTex": 1})
        );
        // The thumbnail image itself gone: the reference goes with it.
        let mut doc = json!({
            "images": [{"uri": "gone.png"}],
            "extensions": {"VRMC_vrm": {"meta": {"thumbnailImage": 0}}}
        });
        drop_images(doc.as_object_mut().unwrap(), &HashSet::from([0]));
        assert_eq!(doc["extensions"]["VRMC_vrm"]["meta"], json!({}));
    }

    #[test]
    fn when_every_image_is_missing_no_empty_array_is_left() {
        let mut doc = json!({
            "images": [{"uri": "gone.png"}],
            "textures": [{"source": 0, "sampler": 0}],
            "samplers": [{}],
            "materials": [{"normalTexture": {"index": 0}}]
        });
        drop_images(doc.as_object_mut().unwrap(), &HashSet::from([0]));
        assert!(doc.get("images").is_none() && doc.get("textures").is_none());
        assert_eq!(doc["materials"], json!([{}]));
    }
}
