//! The asset header and the extension lists: what a file demands of its loader (a glTF
//! version, required extensions), refused when we cannot honour it.

use std::path::Path;

use serde_json::Value;

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

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

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
}
