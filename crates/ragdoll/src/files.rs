//! Reading the user's files safely: every file the library opens comes through here, so a
//! name that points at a stream (`/dev/zero`), a FIFO (which blocks forever on open) or a
//! multi-gigabyte file is refused with one sentence instead of hanging the tool or eating
//! the machine's memory.

use std::io::Read;
use std::path::Path;

use crate::error::{Error, Result};

/// Largest character file (glTF, GLB, VRM, BVH, OBJ, and a glTF's external buffers and
/// images) read, in bytes: 1 GiB. Real characters and long mocap takes are well under this;
/// the cap exists so a wrong path cannot exhaust memory.
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// Largest text settings file (ragdoll spec, scene, role map) read, in bytes: 16 MiB. A
/// spec of a thousand bodies is about 1 MiB.
pub const MAX_SETTINGS_BYTES: u64 = 16 << 20;

/// Reads a whole regular file of at most `limit` bytes.
///
/// Refuses anything that is not a regular file (directories, FIFOs, sockets, devices such
/// as `/dev/zero`) before opening it, since opening a FIFO blocks until a writer appears.
/// The size is checked both from the metadata and while reading, so a file that grows
/// under us is still cut off at `limit`.
///
/// ```
/// let dir = std::env::temp_dir().join(format!("ragdoll-files-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("a.txt");
/// std::fs::write(&path, "hello").unwrap();
/// assert_eq!(ragdoll::files::read_capped(&path, 16).unwrap(), b"hello");
/// assert!(ragdoll::files::read_capped(&path, 4).is_err());
/// assert!(ragdoll::files::read_capped(&dir, 16).is_err()); // a directory
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn read_capped(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, &meta));
    }
    if meta.len() > limit {
        return Err(too_large(path, limit));
    }
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| Error::io(path, e))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(path, limit));
    }
    Ok(bytes)
}

/// Reads a whole regular UTF-8 text file of at most `limit` bytes (see [`read_capped`]);
/// invalid UTF-8 is an error naming the byte where it starts.
pub fn read_text_capped(path: &Path, limit: u64) -> Result<String> {
    let bytes = read_capped(path, limit)?;
    String::from_utf8(bytes).map_err(|e| Error::Format {
        path: path.to_path_buf(),
        place: format!("byte {}", e.utf8_error().valid_up_to()),
        message: "the file is not UTF-8 text".into(),
    })
}

fn not_regular(path: &Path, meta: &std::fs::Metadata) -> Error {
    let what = if meta.is_dir() {
        "a folder"
    } else {
        "not a regular file (a device, FIFO or socket)"
    };
    Error::Refused {
        path: path.to_path_buf(),
        message: format!("is {what}, so it is not read"),
    }
}

fn too_large(path: &Path, limit: u64) -> Error {
    Error::Refused {
        path: path.to_path_buf(),
        message: format!(
            "is larger than the {} MiB this kind of file may be, so it is not read",
            limit >> 20
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_and_folders_are_refused_without_reading() {
        let err = read_capped(Path::new("/dev/zero"), MAX_INPUT_BYTES).unwrap_err();
        assert!(err.to_string().contains("not a regular file"), "{err}");
        let err = read_capped(Path::new("/"), MAX_INPUT_BYTES).unwrap_err();
        assert!(err.to_string().contains("folder"), "{err}");
    }

    #[test]
    fn a_file_over_the_limit_is_refused() {
        let dir = std::env::temp_dir().join(format!("ragdoll-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("big.bin");
        std::fs::write(&path, vec![0u8; 100]).unwrap();
        assert_eq!(read_capped(&path, 100).unwrap().len(), 100);
        let err = read_capped(&path, 99).unwrap_err();
        assert!(err.to_string().contains("larger than"), "{err}");
        std::fs::write(&path, [0xffu8, 0xfe]).unwrap();
        let err = read_text_capped(&path, 100).unwrap_err();
        assert!(err.to_string().contains("byte 0"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
