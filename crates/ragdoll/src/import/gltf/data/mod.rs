//! The binary side of glTF: the GLB container (`container.rs`), the buffers its URIs name
//! (`buffers.rs`) and accessor reads (`accessor.rs`).
//!
//! The `gltf` crate is built without its `import` feature (which would pull in image
//! decoders), and its own readers trust offsets and lengths. Every read here is bounds
//! checked instead, so a truncated or hostile file gives an [`Error::Format`] that says where,
//! never a panic. The exporter reuses these readers to renormalise skin weights.

mod accessor;
mod buffers;
mod container;
mod data_uri;

use std::path::Path;

use crate::error::Error;

pub use accessor::MAX_ACCESSOR_COMPONENTS;
pub(crate) use accessor::{AccessorReader, ReadBudget};
pub use buffers::MAX_BUFFER_BYTES;
pub(crate) use buffers::{decode_data_uri, missing_images, read_external, resolve_buffers};
pub(crate) use container::{Container, check_json_size, split_container};
pub use container::{MAX_JSON_OBJECTS, MAX_JSON_VALUES};
pub(crate) use data_uri::lift_data_buffers;

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

/// The little-endian `u32` at byte `at` (the caller checked the bounds).
pub(super) fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}
