//! A glTF's buffers and images: `data:` URIs, files in the glTF's own folder, the GLB
//! binary chunk, and the budget they share.

use std::path::Path;

use super::format_err;
use crate::error::Result;
use crate::files::{MAX_INPUT_BYTES, Refusal};

/// Decodes `%XX` escapes, as glTF URIs are URI-encoded (`my%20model.bin`).
pub(crate) fn percent_decode(s: &str) -> Vec<u8> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push(h * 16 + l);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    out
}

fn hex(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        b'A'..=b'F' => Some(c - b'A' + 10),
        _ => None,
    }
}

/// Decodes a `data:` URI into its bytes and media type (empty when the URI gives none);
/// `None` when `uri` is not a data URI. A URI whose bytes could exceed `limit` is refused
/// before it is decoded.
pub(crate) fn decode_data_uri(
    uri: &str,
    limit: u64,
) -> Option<std::result::Result<(Vec<u8>, String), String>> {
    if !uri.starts_with("data:") {
        return None;
    }
    super::data_uri::decode_owned(uri.to_string(), limit).ok()
}

/// Most bytes a glTF's buffers may hold together, and, when it is exported, its images
/// together: [`MAX_INPUT_BYTES`] (1 GiB), so that many buffers naming one large file (or
/// the GLB binary chunk) cannot multiply it in memory.
pub const MAX_BUFFER_BYTES: u64 = MAX_INPUT_BYTES;

pub(super) const BUDGET_NOTE: &str = "a glTF's buffers, and its images, may hold 1024 MiB together";

/// Why an external URI was not read: a sentence naming the URI, and whether the file is
/// merely absent or unreadable (which a missing texture may be forgiven) rather than
/// refused (a URI that leaves the folder, a device, a file past the budget), which never is.
#[derive(Debug)]
pub(crate) struct UriError {
    /// The sentence, naming the URI.
    pub message: String,
    /// The file is not there, or the operating system could not read it.
    pub missing: bool,
}

impl From<UriError> for String {
    fn from(e: UriError) -> String {
        e.message
    }
}

/// Reads the file an external URI names, from `dir` (the glTF's folder) and nowhere else
/// (see [`crate::files::read_inside`]), at most `limit` bytes; the error is a sentence
/// naming the URI.
pub(crate) fn read_external(
    dir: &Path,
    uri: &str,
    limit: u64,
) -> std::result::Result<Vec<u8>, UriError> {
    let refused = |message: String| UriError {
        message,
        missing: false,
    };
    let has_scheme = uri.split_once(':').is_some_and(|(s, _)| {
        !s.is_empty()
            && s.chars()
                .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
    });
    if has_scheme {
        return Err(refused(format!(
            "the URI \"{uri}\" is not a relative file path, so it is not read"
        )));
    }
    let decoded = String::from_utf8(percent_decode(uri))
        .map_err(|_| refused(format!("the URI \"{uri}\" is not valid UTF-8 once decoded")))?;
    crate::files::read_inside(dir, &decoded, limit).map_err(|r| match r {
        Refusal::TooLarge(_) => refused(format!(
            "the URI \"{uri}\" names a file larger than the {limit} bytes still allowed ({BUDGET_NOTE})"
        )),
        Refusal::Io(e) => UriError {
            message: format!("the URI \"{uri}\" {}", Refusal::Io(e)),
            missing: true,
        },
        other => refused(format!("the URI \"{uri}\" {other}")),
    })
}

/// One warning for each image of a `.gltf` whose file, named by a relative URI, is not
/// in the file's folder: the exporter leaves such an image out (and the textures that use
/// it), so the user hears it when the file is read, not after the bake. Only the file's
/// presence is checked, not its bytes (a limit of 0 stops before reading), so import stays
/// as cheap as before; URIs that leave the folder are not warned about here, since the
/// exporter refuses them outright.
pub(crate) fn missing_images(json: &serde_json::Value, dir: &Path) -> Vec<String> {
    let images = json.get("images").and_then(serde_json::Value::as_array);
    let mut out = Vec::new();
    for (i, image) in images.into_iter().flatten().enumerate() {
        let Some(uri) = image.get("uri").and_then(serde_json::Value::as_str) else {
            continue;
        };
        if uri.starts_with("data:") {
            continue;
        }
        if let Err(e) = read_external(dir, uri, 0)
            && e.missing
        {
            out.push(missing_image_warning(i, image, &e));
        }
    }
    out
}

/// The sentence for an image left out because its file is missing.
fn missing_image_warning(index: usize, image: &serde_json::Value, e: &UriError) -> String {
    let name = image
        .get("name")
        .and_then(serde_json::Value::as_str)
        .map(|n| format!(" (\"{n}\")"))
        .unwrap_or_default();
    format!(
        "image {index}{name}: {}, so the baked glTF leaves it out, with the textures that use it",
        e.message
    )
}

/// Resolves every buffer: the GLB binary chunk, `data:` URIs (`lifted`: those already
/// taken out of the document by [`super::lift_data_buffers`], by buffer index), or files
/// in the glTF's folder. Each result is cut to the buffer's declared `byteLength`, so later bounds checks
/// hold against what the file promised, and together they hold at most
/// [`MAX_BUFFER_BYTES`].
pub(crate) fn resolve_buffers(
    doc: &gltf::Document,
    bin: Option<&[u8]>,
    mut lifted: Vec<Option<Vec<u8>>>,
    dir: &Path,
    path: &Path,
) -> Result<Vec<Vec<u8>>> {
    let mut out = Vec::new();
    let mut left = MAX_BUFFER_BYTES;
    for buffer in doc.buffers() {
        let place = format!("buffer {}", buffer.index());
        let declared = buffer.length();
        if declared as u64 > left {
            return Err(format_err(
                path,
                place,
                format!(
                    "declares {declared} bytes, more than the {left} bytes still allowed ({BUDGET_NOTE})"
                ),
            ));
        }
        let lifted = lifted.get_mut(buffer.index()).and_then(Option::take);
        let mut data = match (lifted, buffer.source()) {
            (Some(bytes), _) => bytes,
            (None, gltf::buffer::Source::Bin) => match bin {
                Some(b) => b.get(..declared).unwrap_or(b).to_vec(),
                None => {
                    return Err(format_err(
                        path,
                        place,
                        "has no URI but the file has no GLB binary chunk to take it from",
                    ));
                }
            },
            (None, gltf::buffer::Source::Uri(uri)) => match decode_data_uri(uri, left) {
                Some(Ok((bytes, _))) => bytes,
                Some(Err(message)) => return Err(format_err(path, place, message)),
                None => read_external(dir, uri, left).map_err(|m| format_err(path, &place, m))?,
            },
        };
        if data.len() < declared {
            return Err(format_err(
                path,
                place,
                format!(
                    "declares {declared} bytes but its data has only {}",
                    data.len()
                ),
            ));
        }
        data.truncate(declared);
        data.shrink_to_fit();
        left -= declared as u64;
        out.push(data);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_and_percent_escapes_decode() {
        let (bytes, mime) = decode_data_uri("data:application/octet-stream;base64,AAEC", 16)
            .unwrap()
            .unwrap();
        assert_eq!(bytes, vec![0, 1, 2]);
        assert_eq!(mime, "application/octet-stream");
        assert!(decode_data_uri("data:;base64,@@@", 16).unwrap().is_err());
        assert!(decode_data_uri("model.bin", 16).is_none());
        assert_eq!(percent_decode("a%20b%2"), b"a b%2");
    }

    #[test]
    fn data_uris_past_the_budget_are_refused_before_decoding() {
        let uri = format!("data:;base64,{}", "AAAA".repeat(100));
        assert!(decode_data_uri(&uri, 303).unwrap().is_ok());
        let e = decode_data_uri(&uri, 200).unwrap().unwrap_err();
        assert!(e.contains("more than the 200 bytes still allowed"), "{e}");
        let e = decode_data_uri("data:,abcdef", 5).unwrap().unwrap_err();
        assert!(e.contains("6 bytes"), "{e}");
    }

    #[test]
    fn external_uris_stay_in_the_folder_and_name_the_uri() {
        let root = std::env::temp_dir().join(format!("ragdoll-uri-{}", std::process::id()));
        let dir = root.join("m");
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("my x.bin"), [1u8, 2]).unwrap();
        std::fs::write(root.join("secret.bin"), [9u8]).unwrap();
        assert_eq!(read_external(&dir, "my%20x.bin", 16).unwrap(), [1, 2]);
        for (uri, says) in [
            ("https://example.com/x.bin", "not a relative file path"),
            ("../secret.bin", "climbs out of its folder"),
            ("%2E%2E/secret.bin", "climbs out of its folder"),
            ("/etc/passwd", "absolute path"),
            ("%2Fetc%2Fpasswd", "absolute path"),
            ("missing.bin", "cannot be read"),
        ] {
            let e = read_external(&dir, uri, 16).unwrap_err();
            assert!(
                e.message.contains(&format!("\"{uri}\"")) && e.message.contains(says),
                "{uri}: {e:?}"
            );
            // Only an absent file may be forgiven; a refusal never is.
            assert_eq!(e.missing, uri == "missing.bin", "{uri}");
        }
        let e = read_external(&dir, "my%20x.bin", 1).unwrap_err();
        assert!(
            e.message.contains("larger than the 1 bytes still allowed"),
            "{e:?}"
        );
        assert!(!e.missing);
        // A present file passes the presence check made with a limit of 0, unread.
        let e = read_external(&dir, "my%20x.bin", 0).unwrap_err();
        assert!(!e.missing);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
