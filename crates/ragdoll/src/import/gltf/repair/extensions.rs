//! The asset header and the extension lists: what a file demands of its loader (a glTF
//! version, required extensions), refused when we cannot honour it, and what it forgot to
//! declare, declared.

use std::collections::HashSet;
use std::path::Path;

use serde_json::{Map, Value, json};

use super::listed;
use crate::error::Result;
use crate::import::gltf::format_err;

/// Extensions a file may require and still be read and written back as its author meant.
///
/// The glTF spec says a loader must refuse a file that requires an extension it does not
/// support. These only change how materials, textures and lights look, or how metadata is
/// attached: the ragdoll never reads them and the exporter copies them through untouched
/// (renumbering the indices they hold when characters are merged into a scene), so a
/// viewer that reads our output honours them as it would the input. One concerns
/// geometry: `KHR_mesh_quantization` stores attributes as integers, which the importer's
/// accessor reader decodes like floats (normalised or not) and the exporter rewrites only
/// as floats, which the extension allows. Anything else that is required (compression, GPU
/// instancing, animation pointers, a vendor's own) changes what the geometry or motion
/// is, and is refused.
pub const ACCEPTED_REQUIRED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_anisotropy",
    "KHR_materials_clearcoat",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_dispersion",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_iridescence",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_variants",
    "KHR_materials_volume",
    "KHR_mesh_quantization",
    "KHR_texture_basisu",
    "KHR_texture_transform",
    "KHR_xmp_json_ld",
    "EXT_texture_avif",
    "EXT_texture_webp",
];

/// Extensions the validator refuses to see optional: a file that uses them cannot be read
/// without them.
const ALWAYS_REQUIRED: &[&str] = &["KHR_mesh_quantization"];

/// A `<major>.<minor>` version string as numbers.
fn parse_version(s: &str) -> Option<(u64, u64)> {
    let (major, minor) = s.split_once('.')?;
    let digits = |p: &str| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit());
    if !(digits(major) && digits(minor)) {
        return None;
    }
    Some((major.parse().ok()?, minor.parse().ok()?))
}

/// Refuses what a glTF 2.0 loader must not read: another major version of glTF (or a
/// version that is no version), an asset whose `minVersion` asks for a newer glTF than
/// 2.0, and a required extension outside [`ACCEPTED_REQUIRED_EXTENSIONS`]; each in one
/// sentence naming the file and the place.
pub(crate) fn refuse_unreadable(json: &Value, path: &Path) -> Result<()> {
    let asset = json.get("asset");
    let version = asset.and_then(|a| a.get("version")).and_then(Value::as_str);
    if let Some(v) = version {
        match parse_version(v) {
            Some((2, _)) => {}
            Some(_) => {
                return Err(format_err(
                    path,
                    "asset.version",
                    format!(
                        "is {v:?}, but this importer reads glTF 2.0 and cannot know what another major version means"
                    ),
                ));
            }
            None => {
                return Err(format_err(
                    path,
                    "asset.version",
                    format!("is {v:?}, not a glTF version such as \"2.0\""),
                ));
            }
        }
    }
    let min = asset
        .and_then(|a| a.get("minVersion"))
        .and_then(Value::as_str);
    if let (Some(min), Some(v)) = (min, version)
        && let (Some(m), Some(v)) = (parse_version(min), parse_version(v))
        && m > (2, 0)
        && m <= v
    {
        return Err(format_err(
            path,
            "asset.minVersion",
            format!("is {min:?}: the file needs a glTF newer than the 2.0 this importer reads"),
        ));
    }
    let required = json.get("extensionsRequired").and_then(Value::as_array);
    for ext in required.into_iter().flatten().filter_map(Value::as_str) {
        if matches!(
            ext,
            "KHR_draco_mesh_compression" | "EXT_meshopt_compression"
        ) {
            return Err(format_err(
                path,
                "extensionsRequired",
                format!("uses {ext}, which this importer cannot decode; export it uncompressed"),
            ));
        }
        if !ACCEPTED_REQUIRED_EXTENSIONS.contains(&ext) {
            return Err(format_err(
                path,
                "extensionsRequired",
                format!(
                    "requires {ext}, which this importer does not support, so the file cannot be read as its author meant; save it without that extension"
                ),
            ));
        }
    }
    Ok(())
}

/// Writes `asset.version` as "2.0", the glTF we write, and drops a `minVersion` above the
/// file's own version (the validator counts it as an error; a `minVersion` a loader must
/// honour was refused at import).
pub(super) fn repair_asset(obj: &mut Map<String, Value>) -> Option<String> {
    let asset = obj
        .entry("asset")
        .or_insert_with(|| json!({"version": "2.0"}));
    let Some(asset) = asset.as_object_mut() else {
        *asset = json!({"version": "2.0"});
        return Some("asset: was not an object; written as glTF 2.0".into());
    };
    let mut said = Vec::new();
    let version = asset.get("version").cloned();
    if version.as_ref().and_then(Value::as_str) != Some("2.0") {
        said.push(format!(
            "asset.version {} written as \"2.0\", the glTF this file is written in",
            version.as_ref().map_or("(none)".into(), Value::to_string)
        ));
        asset.insert("version".into(), json!("2.0"));
    }
    if let Some(min) = asset.get("minVersion") {
        let ok = min
            .as_str()
            .and_then(parse_version)
            .is_some_and(|m| m <= (2, 0));
        if !ok {
            let v = version.map_or("(none)".into(), |v| v.to_string());
            said.push(format!(
                "asset.minVersion {min} is above the file's own version {v}; removed"
            ));
            asset.remove("minVersion");
        }
    }
    (!said.is_empty()).then(|| said.join("; "))
}

/// The names of every extension object in the document (not inside `extras`, which hold
/// application data, not glTF). A stack, not recursion.
fn extensions_present(obj: &Map<String, Value>) -> Vec<String> {
    let mut found = Vec::new();
    let mut stack: Vec<&Map<String, Value>> = vec![obj];
    while let Some(o) = stack.pop() {
        for (k, v) in o {
            if k == "extras" {
                continue;
            }
            if k == "extensions"
                && let Some(exts) = v.as_object()
            {
                found.extend(exts.keys().cloned());
            }
            let mut values = vec![v];
            while let Some(v) = values.pop() {
                match v {
                    Value::Object(m) => stack.push(m),
                    Value::Array(a) => values.extend(a),
                    _ => {}
                }
            }
        }
    }
    found
}

/// Names in `list` once each, in order; whether any repeated.
fn unique(list: Vec<Value>) -> (Vec<Value>, bool) {
    let mut seen = HashSet::new();
    let before = list.len();
    let kept: Vec<Value> = list
        .into_iter()
        .filter(|v| seen.insert(v.to_string()))
        .collect();
    let repeated = kept.len() != before;
    (kept, repeated)
}

fn names(obj: &mut Map<String, Value>, key: &str) -> Vec<Value> {
    match obj.remove(key) {
        Some(Value::Array(a)) => a,
        _ => Vec::new(),
    }
}

/// Declares in `extensionsUsed` every extension the file uses or requires without
/// declaring it, lists each extension once, and requires those that cannot be optional:
/// the validator counts each of these as an error, and a loader may skip an extension
/// object the file never declared.
pub(super) fn declare_extensions(obj: &mut Map<String, Value>) -> Option<String> {
    let (mut used, used_repeated) = unique(names(obj, "extensionsUsed"));
    let (mut required, required_repeated) = unique(names(obj, "extensionsRequired"));
    let mut added = Vec::new();
    let present = extensions_present(obj);
    for name in required
        .iter()
        .filter_map(Value::as_str)
        .chain(present.iter().map(String::as_str))
    {
        let v = json!(name);
        if !used.contains(&v) {
            used.push(v);
            added.push(name.to_string());
        }
    }
    let mut now_required = Vec::new();
    for name in ALWAYS_REQUIRED {
        let v = json!(name);
        if used.contains(&v) && !required.contains(&v) {
            required.push(v);
            now_required.push(name.to_string());
        }
    }
    if !used.is_empty() {
        obj.insert("extensionsUsed".into(), Value::Array(used));
    }
    if !required.is_empty() {
        obj.insert("extensionsRequired".into(), Value::Array(required));
    }
    let mut said = Vec::new();
    if !added.is_empty() {
        said.push(format!(
            "declared {}, which the file uses without declaring",
            listed(&added)
        ));
    }
    if !now_required.is_empty() {
        said.push(format!(
            "required {}, which a file cannot use optionally",
            listed(&now_required)
        ));
    }
    if used_repeated || required_repeated {
        said.push("listed each extension once".into());
    }
    (!said.is_empty()).then(|| format!("extensionsUsed: {}", said.join("; ")))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refusal(json: Value) -> String {
        refuse_unreadable(&json, Path::new("f.glb"))
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn versions_a_gltf_2_loader_cannot_read_are_refused() {
        let ok = |j: Value| refuse_unreadable(&j, Path::new("f.glb")).is_ok();
        assert!(ok(json!({"asset": {"version": "2.0"}})));
        assert!(ok(json!({"asset": {"version": "2.1"}})));
        // Above its own version: a defect in the file, not a demand on the loader.
        assert!(ok(
            json!({"asset": {"version": "2.0", "minVersion": "2.5"}})
        ));
        let text = refusal(json!({"asset": {"version": "3.0"}}));
        assert!(
            text.starts_with("f.glb: asset.version: is \"3.0\""),
            "{text}"
        );
        assert!(refusal(json!({"asset": {"version": "two"}})).contains("not a glTF version"));
        let text = refusal(json!({"asset": {"version": "2.1", "minVersion": "2.1"}}));
        assert!(text.contains("asset.minVersion"), "{text}");
    }

    #[test]
    fn the_asset_is_written_as_gltf_2_0_with_one_warning() {
        let mut doc = json!({"asset": {"version": "2.1", "minVersion": "2.5", "copyright": "me"}});
        let w = repair_asset(doc.as_object_mut().unwrap()).unwrap();
        assert!(
            w.contains("asset.version \"2.1\"") && w.contains("asset.minVersion \"2.5\""),
            "{w}"
        );
        assert_eq!(doc["asset"], json!({"version": "2.0", "copyright": "me"}));
        assert_eq!(repair_asset(doc.as_object_mut().unwrap()), None);
        let mut doc = json!({"asset": {"version": "2.0", "minVersion": "2.0"}});
        assert_eq!(repair_asset(doc.as_object_mut().unwrap()), None);
    }

    #[test]
    fn undeclared_and_repeated_extensions_are_declared_once() {
        let mut doc = json!({
            "extensionsUsed": ["KHR_texture_transform", "KHR_texture_transform"],
            "extensionsRequired": ["KHR_mesh_quantization"],
            "materials": [{"extensions": {"KHR_materials_unlit": {}}, "extras": {"extensions": {"NOT_ONE": {}}}}]
        });
        let w = declare_extensions(doc.as_object_mut().unwrap()).unwrap();
        assert_eq!(
            doc["extensionsUsed"],
            json!([
                "KHR_texture_transform",
                "KHR_mesh_quantization",
                "KHR_materials_unlit"
            ])
        );
        assert!(
            w.contains("KHR_materials_unlit") && w.contains("once"),
            "{w}"
        );
        assert!(!w.contains("NOT_ONE"), "{w}");
        assert_eq!(declare_extensions(doc.as_object_mut().unwrap()), None);
        // Used optionally, quantization is made required.
        let mut doc = json!({"extensionsUsed": ["KHR_mesh_quantization"]});
        let w = declare_extensions(doc.as_object_mut().unwrap()).unwrap();
        assert_eq!(doc["extensionsRequired"], json!(["KHR_mesh_quantization"]));
        assert!(w.contains("required KHR_mesh_quantization"), "{w}");
    }
}
