//! The GLB container (a JSON chunk and an optional binary chunk) and the size of the JSON
//! document, checked before it is parsed.

use std::path::Path;

use super::{format_err, u32_at};
use crate::error::Result;

/// The JSON text of a glTF file and, for a GLB, its binary chunk.
pub(crate) struct Container<'a> {
    /// The JSON document.
    pub json: &'a [u8],
    /// Byte offset of the JSON in the file, so JSON errors can point into a GLB.
    pub json_offset: usize,
    /// The GLB `BIN` chunk, if any.
    pub bin: Option<&'a [u8]>,
}

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// Splits a file into JSON and binary chunk. A file is read as GLB when it starts with the
/// GLB magic or is named `.glb`, so that a damaged `.glb` reports its header rather than
/// a confusing JSON error.
pub(crate) fn split_container<'a>(bytes: &'a [u8], path: &Path) -> Result<Container<'a>> {
    let named_glb = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb") || e.eq_ignore_ascii_case("vrm"));
    if !bytes.starts_with(GLB_MAGIC) {
        let truncated_magic = !bytes.is_empty() && GLB_MAGIC.starts_with(bytes);
        if named_glb || truncated_magic {
            return Err(format_err(
                path,
                "byte 0",
                "not a binary glTF: the file does not start with the GLB magic \"glTF\"",
            ));
        }
        return Ok(Container {
            json: bytes,
            json_offset: 0,
            bin: None,
        });
    }
    let err = |at: usize, message: String| format_err(path, format!("byte {at}"), message);
    let data = glb_data(bytes, &err)?;
    let (json, json_end) = json_chunk(data, &err)?;
    Ok(Container {
        json,
        json_offset: 20,
        bin: bin_chunk(data, json_end, &err)?,
    })
}

/// An error at a byte offset of the file.
type ByteErr<'e> = &'e dyn Fn(usize, String) -> crate::error::Error;

/// The bytes a GLB's 12-byte header declares (version 2 only), which must all be there.
fn glb_data<'a>(bytes: &'a [u8], err: ByteErr) -> Result<&'a [u8]> {
    if bytes.len() < 12 {
        return Err(err(
            bytes.len(),
            format!(
                "truncated GLB header: the file has {} bytes, the header alone needs 12",
                bytes.len()
            ),
        ));
    }
    let version = u32_at(bytes, 4);
    if version != 2 {
        return Err(err(
            4,
            format!("GLB version {version}; only version 2 is supported"),
        ));
    }
    let length = u32_at(bytes, 8) as usize;
    if length > bytes.len() {
        return Err(err(
            8,
            format!(
                "the GLB header declares {length} bytes but the file has only {} (truncated?)",
                bytes.len()
            ),
        ));
    }
    Ok(&bytes[..length])
}

/// The JSON chunk, which must come first, and where it ends.
fn json_chunk<'a>(data: &'a [u8], err: ByteErr) -> Result<(&'a [u8], usize)> {
    if data.len() < 20 {
        return Err(err(12, "the GLB has no JSON chunk".into()));
    }
    let json_len = u32_at(data, 12) as usize;
    if u32_at(data, 16) != CHUNK_JSON {
        return Err(err(16, "the first GLB chunk is not JSON".into()));
    }
    let json_end = 20usize.saturating_add(json_len);
    if json_end > data.len() {
        return Err(err(
            12,
            format!(
                "the JSON chunk declares {json_len} bytes but only {} remain in the file",
                data.len() - 20
            ),
        ));
    }
    Ok((&data[20..json_end], json_end))
}

/// The first BIN chunk after the JSON one, if any; every chunk on the way must be whole.
fn bin_chunk<'a>(data: &'a [u8], json_end: usize, err: ByteErr) -> Result<Option<&'a [u8]>> {
    let mut bin = None;
    let mut at = json_end.next_multiple_of(4);
    while at < data.len() {
        if at + 8 > data.len() {
            return Err(err(at, "truncated GLB chunk header".into()));
        }
        let len = u32_at(data, at) as usize;
        let kind = u32_at(data, at + 4);
        let start = at + 8;
        let end = start.saturating_add(len);
        if end > data.len() {
            return Err(err(
                at,
                format!(
                    "a GLB chunk declares {len} bytes but only {} remain in the file",
                    data.len() - start
                ),
            ));
        }
        if kind == CHUNK_BIN && bin.is_none() {
            bin = Some(&data[start..end]);
        }
        at = end.next_multiple_of(4);
    }
    Ok(bin)
}

/// Most JSON values (numbers, strings, arrays, objects…) a glTF document may hold: 2 million.
/// The largest character in our data has 26 thousand; parsed, a value takes tens of bytes
/// and the document is held more than once, so a JSON chunk of a gigabyte of `[0,0,…]`
/// would otherwise take tens of gigabytes. Embedded `data:` buffers are single strings
/// and count as one.
pub const MAX_JSON_VALUES: usize = 2_000_000;

/// Most JSON objects (`{…}`) a glTF document may hold: 200,000. A parsed object takes
/// about 700 bytes however small it is, so objects get a tighter limit than other values;
/// a scene of 100,000 nodes fits.
pub const MAX_JSON_OBJECTS: usize = 200_000;

/// Refuses a JSON document past [`MAX_JSON_VALUES`] or [`MAX_JSON_OBJECTS`] before it is
/// parsed, counting on the bytes: values are at most the commas plus twice the brackets,
/// plus one.
pub(crate) fn check_json_size(json: &[u8], path: &Path) -> Result<()> {
    let (mut values, mut objects) = (1usize, 0usize);
    let (mut in_string, mut escaped) = (false, false);
    for &b in json {
        if in_string {
            if escaped {
                escaped = false;
            } else if b == b'\\' {
                escaped = true;
            } else if b == b'"' {
                in_string = false;
            }
            continue;
        }
        match b {
            b'"' => in_string = true,
            b',' => values += 1,
            b'[' => values += 2,
            b'{' => {
                values += 2;
                objects += 1;
            }
            _ => {}
        }
        if values > MAX_JSON_VALUES || objects > MAX_JSON_OBJECTS {
            return Err(format_err(
                path,
                "JSON",
                format!(
                    "holds more than the {MAX_JSON_VALUES} values or {MAX_JSON_OBJECTS} objects a glTF document may have"
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;

    fn glb(json: &[u8], bin: Option<&[u8]>) -> Vec<u8> {
        let mut out = Vec::new();
        let mut j = json.to_vec();
        while j.len() % 4 != 0 {
            j.push(b' ');
        }
        let mut total = 12 + 8 + j.len();
        if let Some(b) = bin {
            total += 8 + b.len().next_multiple_of(4);
        }
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(j.len() as u32).to_le_bytes());
        out.extend_from_slice(&CHUNK_JSON.to_le_bytes());
        out.extend_from_slice(&j);
        if let Some(b) = bin {
            let mut b = b.to_vec();
            b.resize(b.len().next_multiple_of(4), 0);
            out.extend_from_slice(&(b.len() as u32).to_le_bytes());
            out.extend_from_slice(&CHUNK_BIN.to_le_bytes());
            out.extend_from_slice(&b);
        }
        out
    }

    #[test]
    fn splits_a_well_formed_glb() {
        let bytes = glb(b"{}", Some(&[1, 2, 3]));
        let c = split_container(&bytes, Path::new("a.glb")).unwrap();
        assert_eq!(c.json, b"{}  ");
        assert_eq!(c.bin, Some(&[1u8, 2, 3, 0][..]));
    }

    #[test]
    fn every_truncation_of_a_glb_is_an_error_with_a_byte_offset() {
        let bytes = glb(b"{\"asset\":{\"version\":\"2.0\"}}", Some(&[7; 16]));
        for len in 0..bytes.len() {
            let e = split_container(&bytes[..len], Path::new("t.glb"));
            let Err(Error::Format { place, .. }) = e else {
                panic!("truncated at {len}: expected a format error");
            };
            assert!(place.starts_with("byte "), "{place}");
        }
    }

    #[test]
    fn bad_version_points_at_its_byte() {
        let mut bytes = glb(b"{}", None);
        bytes[4] = 1;
        let e = split_container(&bytes, Path::new("v.glb")).err().unwrap();
        assert!(e.to_string().contains("byte 4"), "{e}");
    }

    #[test]
    fn json_files_pass_through() {
        let c = split_container(b"{\"a\":1}", Path::new("x.gltf")).unwrap();
        assert_eq!(c.json, b"{\"a\":1}");
        assert!(c.bin.is_none());
    }

    #[test]
    fn json_with_too_many_values_is_refused_before_parsing() {
        let p = Path::new("big.gltf");
        assert!(check_json_size(br#"{"a":[1,2,3],"s":"[,,,,]"}"#, p).is_ok());
        let many = format!("[{}0]", "0,".repeat(MAX_JSON_VALUES));
        let e = check_json_size(many.as_bytes(), p).unwrap_err();
        assert!(e.to_string().contains("values"), "{e}");
        // Small objects cost far more parsed than numbers: 660,000 of them took 900 MB.
        let objects = format!("[{}{{}}]", "{},".repeat(MAX_JSON_OBJECTS));
        assert!(objects.len() < MAX_JSON_VALUES);
        assert!(check_json_size(objects.as_bytes(), p).is_err());
        let fewer = format!("[{}{{}}]", "{},".repeat(MAX_JSON_OBJECTS - 1));
        assert!(check_json_size(fewer.as_bytes(), p).is_ok());
        // Commas inside a string, escaped quotes included, are not values.
        let text = format!("{{\"s\":\"\\\"{}\"}}", ",".repeat(MAX_JSON_VALUES + 5));
        assert!(check_json_size(text.as_bytes(), p).is_ok());
    }
}
