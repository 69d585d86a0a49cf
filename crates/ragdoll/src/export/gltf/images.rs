//! The input's images, moved into the binary chunk; those whose files are missing are left
//! out, with every texture that uses them, so the bake goes on and the file stays valid.

use std::collections::HashSet;

use serde_json::{Map, Value, json};

use super::Bin;
use crate::error::Result;
use crate::import::gltf::drop_images;
use crate::import::gltf::{
    GltfSource, MAX_BUFFER_BYTES, decode_data_uri, format_err, read_external,
};

/// The media type of encoded image bytes, from their magic numbers.
fn sniff_image(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else if bytes.starts_with(b"\xABKTX 20\xBB") {
        Some("image/ktx2")
    } else {
        None
    }
}

/// Moves every image given by URI into the binary chunk: a GLB travels alone, and relative
/// paths would break as soon as it is written somewhere else. Image files are read from the
/// source's folder only, as the importer reads buffers ([`read_external`]), and together
/// with `data:` images hold at most [`MAX_BUFFER_BYTES`].
///
/// An image whose file is missing (the importer warned about it) is left out, with the
/// textures that show it and every material's reference to those textures: a material
/// then falls back to its factors (a base colour, say), which is what a viewer shows for
/// a texture it cannot load, and the file stays valid. A URI that leaves the folder is
/// still refused: that is a hostile file, not a missing one.
pub(super) fn embed_images(
    obj: &mut Map<String, Value>,
    bin: &mut Bin,
    src: &GltfSource,
) -> Result<()> {
    let path = src.path.as_path();
    let Some(Value::Array(images)) = obj.get_mut("images") else {
        return Ok(());
    };
    let mut left = MAX_BUFFER_BYTES;
    let mut missing = HashSet::new();
    for (i, image) in images.iter_mut().enumerate() {
        let Some(o) = image.as_object_mut() else {
            continue;
        };
        let Some(uri) = o.get("uri").and_then(Value::as_str).map(str::to_string) else {
            continue;
        };
        let place = format!("image {i}");
        let (bytes, declared) = match decode_data_uri(&uri, left) {
            Some(Ok(x)) => x,
            Some(Err(m)) => return Err(format_err(path, place, m)),
            None => match read_external(&src.dir, &uri, left) {
                Ok(bytes) => (bytes, String::new()),
                Err(e) if e.missing => {
                    missing.insert(i);
                    continue;
                }
                Err(e) => return Err(format_err(path, place, e)),
            },
        };
        left = left.saturating_sub(bytes.len() as u64);
        let mime = match sniff_image(&bytes) {
            Some(m) => m.to_string(),
            None if declared.starts_with("image/") => declared,
            None => {
                return Err(format_err(
                    path,
                    place,
                    "is neither PNG, JPEG, WebP nor KTX2, so it cannot be embedded",
                ));
            }
        };
        let view = bin.push_view(&bytes, None);
        o.remove("uri");
        o.insert("bufferView".into(), json!(view));
        o.insert("mimeType".into(), json!(mime));
    }
    if !missing.is_empty() {
        drop_images(obj, &missing);
    }
    Ok(())
}
