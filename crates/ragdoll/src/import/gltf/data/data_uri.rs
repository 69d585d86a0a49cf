//! `data:` URIs decoded where they lie: a glTF may embed its buffers as base64 text of
//! hundreds of megabytes, and decoding a copy of a copy of that text took four times the
//! file's size. Here the URI's own bytes become the decoded bytes (base64 needs 4
//! characters for 3 bytes, so the output never overtakes the input), and the buffers'
//! URIs are taken out of the document before anything else copies it: a file costs about
//! its own size again, not four times.

use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use serde_json::Value;

use super::buffers::{BUDGET_NOTE, percent_decode};

/// What a buffer's `data:` URI leaves in the document once its bytes are taken out: an
/// empty one, so the document still says where the buffer came from.
const LIFTED_URI: &str = "data:application/octet-stream;base64,";

/// Characters of base64 decoded at a time: a multiple of 4, so only the last piece may end
/// in padding.
const PIECE: usize = 4 * 4096;

/// Decodes a `data:` URI, taking its text and turning it into the bytes it holds, with its
/// media type (empty when the URI gives none); `None` (and the text back) when `uri` is
/// not a data URI. A URI whose bytes could exceed `limit` is refused before it is decoded.
pub(crate) fn decode_owned(
    uri: String,
    limit: u64,
) -> std::result::Result<std::result::Result<(Vec<u8>, String), String>, String> {
    let Some(rest) = uri.strip_prefix("data:") else {
        return Err(uri);
    };
    let Some((header, payload)) = rest.split_once(',') else {
        return Ok(Err("a data: URI without a comma".into()));
    };
    let (mime, is_base64) = match header.strip_suffix(";base64") {
        Some(m) => (m, true),
        None => (header, false),
    };
    let mime = mime.split(';').next().unwrap_or("").to_string();
    // Base64 holds 3 bytes in 4 characters; percent-encoding at most one per character.
    let most = if is_base64 {
        payload.len() / 4 * 3 + 3
    } else {
        payload.len()
    };
    if most as u64 > limit {
        return Ok(Err(format!(
            "a data: URI of up to {most} bytes, more than the {limit} bytes still allowed ({BUDGET_NOTE})"
        )));
    }
    if !is_base64 {
        return Ok(Ok((percent_decode(payload), mime)));
    }
    let start = uri.len() - payload.len();
    let mut bytes = uri.into_bytes();
    Ok(base64_in_place(&mut bytes, start).map(|()| (bytes, mime)))
}

/// Decodes the base64 text `buf[start..]` (ASCII whitespace skipped) into `buf` itself,
/// which ends holding only the decoded bytes.
fn base64_in_place(buf: &mut Vec<u8>, start: usize) -> std::result::Result<(), String> {
    let mut piece = Vec::with_capacity(PIECE);
    let (mut read, mut written, mut seen) = (start, 0usize, 0usize);
    while read < buf.len() {
        piece.clear();
        while read < buf.len() && piece.len() < PIECE {
            let c = buf[read];
            read += 1;
            if !c.is_ascii_whitespace() {
                piece.push(c);
            }
        }
        // What is written ends at 3/4 of what was read from `start`, so before `read`:
        // the text still to decode is never overwritten.
        let n = STANDARD
            .decode_slice(&piece, &mut buf[written..read])
            .map_err(|e| {
                let e = match e {
                    base64::DecodeSliceError::DecodeError(base64::DecodeError::InvalidByte(
                        at,
                        byte,
                    )) => format!("invalid byte {byte} at character {}", seen + at),
                    other => other.to_string(),
                };
                format!("bad base64 in a data: URI: {e}")
            })?;
        written += n;
        seen += piece.len();
    }
    buf.truncate(written);
    buf.shrink_to_fit();
    Ok(())
}

/// Takes every buffer's `data:` URI out of the document `json`, decoded: entry `i` holds
/// buffer `i`'s bytes, `None` where it has no such URI. The URI's text is replaced by an
/// empty `data:` URI, so nothing later copies it. Buffers hold at most `budget` bytes
/// together; the first past it is refused, with the index of the buffer in the error.
pub(crate) fn lift_data_buffers(
    json: &mut Value,
    budget: u64,
) -> std::result::Result<Vec<Option<Vec<u8>>>, (usize, String)> {
    let Some(buffers) = json.get_mut("buffers").and_then(Value::as_array_mut) else {
        return Ok(Vec::new());
    };
    let mut left = budget;
    let mut out = Vec::with_capacity(buffers.len());
    for (i, buffer) in buffers.iter_mut().enumerate() {
        let Some(Value::String(uri)) = buffer.get_mut("uri") else {
            out.push(None);
            continue;
        };
        if !uri.starts_with("data:") {
            out.push(None);
            continue;
        }
        let text = std::mem::replace(uri, LIFTED_URI.into());
        match decode_owned(text, left) {
            Ok(Ok((bytes, _))) => {
                left = left.saturating_sub(bytes.len() as u64);
                out.push(Some(bytes));
            }
            Ok(Err(message)) => return Err((i, message)),
            Err(_) => out.push(None),
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base64(bytes: &[u8]) -> String {
        STANDARD.encode(bytes)
    }

    #[test]
    fn decodes_in_place_across_pieces_with_whitespace() {
        let bytes: Vec<u8> = (0..100_000u32).map(|i| (i * 7919 % 251) as u8).collect();
        let mut text = base64(&bytes);
        // Line breaks every 76 characters, as MIME writes base64.
        let wrapped: Vec<String> = text
            .as_bytes()
            .chunks(76)
            .map(|c| String::from_utf8(c.to_vec()).unwrap())
            .collect();
        text = wrapped.join("\r\n");
        let uri = format!("data:application/octet-stream;base64,{text}");
        let (got, mime) = decode_owned(uri, u64::MAX).unwrap().unwrap();
        assert_eq!(mime, "application/octet-stream");
        assert_eq!(got, bytes);
        assert!(got.capacity() == got.len(), "shrunk to its bytes");
    }

    #[test]
    fn every_length_and_padding_round_trips() {
        for n in 0..40usize {
            let bytes: Vec<u8> = (0..n as u8).collect();
            let uri = format!("data:;base64,{}", base64(&bytes));
            assert_eq!(decode_owned(uri, 1000).unwrap().unwrap().0, bytes, "{n}");
        }
    }

    #[test]
    fn bad_text_names_the_character_past_the_first_piece() {
        let mut text = base64(&vec![7u8; 3 * PIECE]);
        let at = PIECE + 10;
        text.replace_range(at..at + 1, "@");
        let e = decode_owned(format!("data:;base64,{text}"), u64::MAX)
            .unwrap()
            .unwrap_err();
        assert!(e.contains(&format!("character {at}")), "{e}");
        // Padding before the end is refused, as a whole-text decoder refuses it.
        let e = decode_owned("data:;base64,AA==AAAA".into(), 100)
            .unwrap()
            .unwrap_err();
        assert!(e.contains("bad base64"), "{e}");
    }

    #[test]
    fn buffers_are_lifted_out_of_the_document_within_the_budget() {
        let mut json = serde_json::json!({"buffers": [
            {"byteLength": 3, "uri": format!("data:;base64,{}", base64(&[1, 2, 3]))},
            {"byteLength": 4, "uri": "mesh.bin"},
            {"byteLength": 0},
        ]});
        let lifted = lift_data_buffers(&mut json, 100).unwrap();
        assert_eq!(lifted, vec![Some(vec![1, 2, 3]), None, None]);
        assert_eq!(json["buffers"][0]["uri"], LIFTED_URI);
        assert_eq!(json["buffers"][1]["uri"], "mesh.bin");
        let mut json = serde_json::json!({"buffers": [
            {"byteLength": 3, "uri": format!("data:;base64,{}", base64(&[1, 2, 3]))},
            {"byteLength": 3, "uri": format!("data:;base64,{}", base64(&[4, 5, 6]))},
        ]});
        let (i, e) = lift_data_buffers(&mut json, 7).unwrap_err();
        assert_eq!(i, 1, "{e}");
    }
}
