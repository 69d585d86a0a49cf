//! The binary side of glTF: the GLB container, buffer resolution and accessor reads.
//!
//! The `gltf` crate is built without its `import` feature (which would pull in image
//! decoders), and its own readers trust offsets and lengths. Every read here is bounds
//! checked instead, so a truncated or hostile file gives an [`Error::Format`] that says where,
//! never a panic. The exporter reuses these readers to renormalise skin weights.

use std::path::Path;

use base64::Engine;
use glam::Mat4;
use gltf::accessor::{DataType, Dimensions};

use crate::error::{Error, Result};
use crate::files::{MAX_INPUT_BYTES, Refusal};

/// Builds an [`Error::Format`] for `path`.
pub(crate) fn format_err(
    path: &Path,
    place: impl Into<String>,
    message: impl Into<String>,
) -> Error {
    Error::Format {
        path: path.to_path_buf(),
        place: place.into(),
        message: message.into(),
    }
}

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

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

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
    let rest = uri.strip_prefix("data:")?;
    let Some((header, payload)) = rest.split_once(',') else {
        return Some(Err("a data: URI without a comma".into()));
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
        return Some(Err(format!(
            "a data: URI of up to {most} bytes, more than the {limit} bytes still allowed ({BUDGET_NOTE})"
        )));
    }
    if is_base64 {
        let cleaned: String = payload
            .chars()
            .filter(|c| !c.is_ascii_whitespace())
            .collect();
        Some(
            base64::engine::general_purpose::STANDARD
                .decode(cleaned.as_bytes())
                .map(|bytes| (bytes, mime))
                .map_err(|e| format!("bad base64 in a data: URI: {e}")),
        )
    } else {
        Some(Ok((percent_decode(payload), mime)))
    }
}

/// Most bytes a glTF's buffers may hold together, and, when it is exported, its images
/// together: [`MAX_INPUT_BYTES`] (1 GiB), so that many buffers naming one large file (or
/// the GLB binary chunk) cannot multiply it in memory.
pub const MAX_BUFFER_BYTES: u64 = MAX_INPUT_BYTES;

const BUDGET_NOTE: &str = "a glTF's buffers, and its images, may hold 1024 MiB together";

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
pub(crate) fn missing_image_warning(
    index: usize,
    image: &serde_json::Value,
    e: &UriError,
) -> String {
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

/// Resolves every buffer: the GLB binary chunk, `data:` URIs, or files in the glTF's
/// folder. Each result is cut to the buffer's declared `byteLength`, so later bounds checks
/// hold against what the file promised, and together they hold at most
/// [`MAX_BUFFER_BYTES`].
pub(crate) fn resolve_buffers(
    doc: &gltf::Document,
    bin: Option<&[u8]>,
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
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => match bin {
                Some(b) => b.get(..declared).unwrap_or(b).to_vec(),
                None => {
                    return Err(format_err(
                        path,
                        place,
                        "has no URI but the file has no GLB binary chunk to take it from",
                    ));
                }
            },
            gltf::buffer::Source::Uri(uri) => match decode_data_uri(uri, left) {
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

/// Most accessor components (a `VEC3` has three) read from one glTF file in all: 64 Mi,
/// about 512 MB while being decoded. A million-vertex skinned mesh with normals and
/// triangles needs about 20 Mi; the limit stops a small file from naming one large accessor
/// many times (a mesh instanced by thousands of nodes) or asking for a huge accessor that
/// has no data at all (one without a buffer view is all zeros).
pub const MAX_ACCESSOR_COMPONENTS: usize = 64 << 20;

/// What is left of [`MAX_ACCESSOR_COMPONENTS`] for one import; every read is charged
/// before it allocates anything.
pub(crate) struct ReadBudget {
    left: std::cell::Cell<usize>,
}

impl ReadBudget {
    pub fn new() -> Self {
        ReadBudget {
            left: std::cell::Cell::new(MAX_ACCESSOR_COMPONENTS),
        }
    }

    /// Takes `a`'s components from the budget, or says which accessor went past it.
    pub fn charge(&self, reader: &AccessorReader, a: &gltf::Accessor) -> Result<()> {
        let (cols, rows, _) = layout(a.dimensions(), 1);
        let want = a.count().saturating_mul(cols * rows);
        match self.left.get().checked_sub(want) {
            Some(rest) => {
                self.left.set(rest);
                Ok(())
            }
            None => Err(reader.err(
                a,
                format!(
                    "{want} more components would pass the {MAX_ACCESSOR_COMPONENTS} that one import reads in all (every use of an accessor counts)"
                ),
            )),
        }
    }
}

/// Reads accessors with bounds checks against the resolved buffers.
pub(crate) struct AccessorReader<'a> {
    /// Resolved buffers, each cut to its declared length.
    pub buffers: &'a [Vec<u8>],
    /// The file, for error messages.
    pub path: &'a Path,
}

fn layout(dims: Dimensions, component_size: usize) -> (usize, usize, usize) {
    let (cols, rows) = match dims {
        Dimensions::Scalar => (1, 1),
        Dimensions::Vec2 => (1, 2),
        Dimensions::Vec3 => (1, 3),
        Dimensions::Vec4 => (1, 4),
        Dimensions::Mat2 => (2, 2),
        Dimensions::Mat3 => (3, 3),
        Dimensions::Mat4 => (4, 4),
    };
    // Matrix columns start on 4-byte boundaries (glTF 2.0 §3.6.2.4).
    let col_stride = if cols > 1 {
        (rows * component_size).next_multiple_of(4)
    } else {
        rows * component_size
    };
    (cols, rows, col_stride)
}

fn component_size(dt: DataType) -> usize {
    match dt {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn component(bytes: &[u8], at: usize, dt: DataType) -> f64 {
    match dt {
        DataType::I8 => bytes[at] as i8 as f64,
        DataType::U8 => bytes[at] as f64,
        DataType::I16 => i16::from_le_bytes([bytes[at], bytes[at + 1]]) as f64,
        DataType::U16 => u16::from_le_bytes([bytes[at], bytes[at + 1]]) as f64,
        DataType::U32 => u32_at(bytes, at) as f64,
        DataType::F32 => {
            f32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]) as f64
        }
    }
}

impl AccessorReader<'_> {
    fn err(&self, a: &gltf::Accessor, message: String) -> Error {
        format_err(self.path, format!("accessor {}", a.index()), message)
    }

    /// The bytes of a buffer view, checked against its buffer.
    fn view_bytes(&self, view: &gltf::buffer::View) -> Result<&[u8]> {
        let buf_index = view.buffer().index();
        let place = format!("bufferView {}", view.index());
        let buf = self.buffers.get(buf_index).ok_or_else(|| {
            format_err(
                self.path,
                &place,
                format!("buffer {buf_index} does not exist"),
            )
        })?;
        let start = view.offset();
        let end = start
            .checked_add(view.length())
            .filter(|&e| e <= buf.len())
            .ok_or_else(|| {
                format_err(
                    self.path,
                    &place,
                    format!(
                        "bytes {start}..{} run past the end of buffer {buf_index} ({} bytes)",
                        start.saturating_add(view.length()),
                        buf.len()
                    ),
                )
            })?;
        Ok(&buf[start..end])
    }

    /// Every component as `f64`, element by element, with sparse substitution applied but
    /// no normalisation; also returns the number of components per element.
    fn raw(&self, a: &gltf::Accessor) -> Result<(Vec<f64>, usize)> {
        let dt = a.data_type();
        let cs = component_size(dt);
        let (cols, rows, col_stride) = layout(a.dimensions(), cs);
        let shape = Elements {
            dt,
            cs,
            cols,
            rows,
            col_stride,
            elem: cols * col_stride,
            comps: cols * rows,
        };
        let count = a.count();
        let total = count
            .checked_mul(shape.comps)
            .filter(|&t| t <= MAX_ACCESSOR_COMPONENTS)
            .ok_or_else(|| {
                self.err(
                    a,
                    format!(
                        "count {count} is too large: more than the {MAX_ACCESSOR_COMPONENTS} components an import reads"
                    ),
                )
            })?;
        let mut out = vec![0.0; total];
        if let Some(view) = a.view() {
            self.read_dense(a, &view, &shape, &mut out)?;
        }
        if let Some(sparse) = a.sparse() {
            self.apply_sparse(a, &sparse, &shape, &mut out)?;
        }
        Ok((out, shape.comps))
    }

    /// Accessor `a`'s elements from its buffer `view` into `out`, checked to fit the view.
    fn read_dense(
        &self,
        a: &gltf::Accessor,
        view: &gltf::buffer::View,
        shape: &Elements,
        out: &mut [f64],
    ) -> Result<()> {
        let count = a.count();
        let data = self.view_bytes(view)?;
        let elem = shape.elem;
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(self.err(
                a,
                format!(
                    "bufferView {} has byteStride {stride}, less than one element ({elem} bytes)",
                    view.index()
                ),
            ));
        }
        if count > 0 {
            let need = (count - 1)
                .checked_mul(stride)
                .and_then(|n| n.checked_add(a.offset()))
                .and_then(|n| n.checked_add(elem));
            match need {
                Some(n) if n <= data.len() => {}
                _ => {
                    return Err(self.err(
                        a,
                        format!(
                            "{count} elements from byte {} need more than the {} bytes of bufferView {}",
                            a.offset(),
                            data.len(),
                            view.index()
                        ),
                    ));
                }
            }
        }
        let comps = shape.comps;
        for i in 0..count {
            shape.read_into(
                &mut out[i * comps..(i + 1) * comps],
                data,
                a.offset() + i * stride,
            );
        }
        Ok(())
    }

    /// Accessor `a`'s sparse substitutions written over `out`, indices and values checked.
    fn apply_sparse(
        &self,
        a: &gltf::Accessor,
        sparse: &gltf::accessor::sparse::Sparse,
        shape: &Elements,
        out: &mut [f64],
    ) -> Result<()> {
        let (count, comps, elem) = (a.count(), shape.comps, shape.elem);
        let n = sparse.count();
        let idx = sparse.indices();
        let (isize, idt) = match idx.index_type() {
            gltf::accessor::sparse::IndexType::U8 => (1, DataType::U8),
            gltf::accessor::sparse::IndexType::U16 => (2, DataType::U16),
            gltf::accessor::sparse::IndexType::U32 => (4, DataType::U32),
        };
        let idata = self.view_bytes(&idx.view())?;
        let vals = sparse.values();
        let vdata = self.view_bytes(&vals.view())?;
        let fits = |offset: usize, size: usize, len: usize| {
            n.checked_mul(size)
                .and_then(|b| b.checked_add(offset))
                .is_some_and(|end| end <= len)
        };
        if !fits(idx.offset(), isize, idata.len()) || !fits(vals.offset(), elem, vdata.len()) {
            return Err(self.err(
                a,
                format!("its {n} sparse entries run past the end of their buffer views"),
            ));
        }
        for k in 0..n {
            let i = component(idata, idx.offset() + k * isize, idt) as usize;
            if i >= count {
                return Err(self.err(
                    a,
                    format!("sparse index {i} is not below the count {count}"),
                ));
            }
            shape.read_into(
                &mut out[i * comps..(i + 1) * comps],
                vdata,
                vals.offset() + k * elem,
            );
        }
        Ok(())
    }

    /// Components as `f32`, normalised integers mapped to [0, 1] or [−1, 1]; also returns the
    /// number of components per element.
    pub fn floats(&self, a: &gltf::Accessor) -> Result<(Vec<f32>, usize)> {
        let (out, comps) = self.floats_as_stored(a)?;
        if out.iter().any(|v| !v.is_finite()) {
            return Err(self.err(a, "holds a value that is not a finite number".into()));
        }
        Ok((out, comps))
    }

    /// [`Self::floats`] with NaN and infinities kept, for data that can be repaired
    /// (skin weights) rather than refused.
    pub fn floats_as_stored(&self, a: &gltf::Accessor) -> Result<(Vec<f32>, usize)> {
        let (raw, comps) = self.raw(a)?;
        let scale = if a.normalized() {
            match a.data_type() {
                DataType::I8 => Some(127.0),
                DataType::U8 => Some(255.0),
                DataType::I16 => Some(32767.0),
                DataType::U16 => Some(65535.0),
                DataType::U32 => Some(4_294_967_295.0),
                DataType::F32 => None,
            }
        } else {
            None
        };
        let out: Vec<f32> = match scale {
            Some(s) => raw.iter().map(|v| (v / s).max(-1.0) as f32).collect(),
            None => raw.iter().map(|&v| v as f32).collect(),
        };
        Ok((out, comps))
    }

    /// Components of an integer accessor (indices, joint indices); also returns the number
    /// of components per element.
    pub fn uints(&self, a: &gltf::Accessor) -> Result<(Vec<u32>, usize)> {
        if a.data_type() == DataType::F32 || a.normalized() {
            return Err(self.err(
                a,
                "must hold unsigned integers (it holds floats or normalised values)".into(),
            ));
        }
        if matches!(a.data_type(), DataType::I8 | DataType::I16) {
            return Err(self.err(
                a,
                "must hold unsigned integers (it holds signed ones)".into(),
            ));
        }
        let (raw, comps) = self.raw(a)?;
        Ok((raw.into_iter().map(|v| v as u32).collect(), comps))
    }

    /// A `MAT4` float accessor as matrices.
    pub fn mat4s(&self, a: &gltf::Accessor) -> Result<Vec<Mat4>> {
        if a.dimensions() != Dimensions::Mat4 {
            return Err(self.err(a, "must be of type MAT4".into()));
        }
        let (f, _) = self.floats(a)?;
        Ok(f.chunks_exact(16).map(Mat4::from_cols_slice).collect())
    }

    /// Checks that an accessor has the element type a use needs, e.g. `VEC3` for positions.
    pub fn expect_dims(&self, a: &gltf::Accessor, dims: &[Dimensions], what: &str) -> Result<()> {
        if dims.contains(&a.dimensions()) {
            Ok(())
        } else {
            Err(self.err(
                a,
                format!("used as {what} but its type is {:?}", a.dimensions()),
            ))
        }
    }
}

/// How an accessor's elements lie in bytes: component type and size, columns and rows
/// (a matrix pads each column to 4 bytes), bytes per element, components per element.
struct Elements {
    dt: DataType,
    cs: usize,
    cols: usize,
    rows: usize,
    col_stride: usize,
    elem: usize,
    comps: usize,
}

impl Elements {
    /// One element at byte `base` of `data` into `out`, column by column.
    fn read_into(&self, out: &mut [f64], data: &[u8], base: usize) {
        for c in 0..self.cols {
            for r in 0..self.rows {
                out[c * self.rows + r] =
                    component(data, base + c * self.col_stride + r * self.cs, self.dt);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
