//! A glTF whose buffer is embedded as a `data:` URI is read in memory bounded by about
//! twice the file: a 1,000 MB file holding a 750 MiB URI once needed 4.9 GB and aborted.
//!
//! Alone in its test binary: the peak is read with `getrusage(RUSAGE_CHILDREN)`, the
//! largest of every child this process has waited for, so no other test may start one.

use std::io::Write;
use std::path::Path;
use std::process::Command;

/// Writes a skeleton of three joints whose inverse bind matrices open a buffer of `bytes`
/// bytes, embedded as base64, to `path`: streamed, so this process stays small (a child
/// forked from it counts its pages until the child runs the program).
fn write_gltf_with_data_uri(path: &Path, bytes: usize) {
    let head = serde_json::json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [
            {"name": "hips", "children": [1], "translation": [0.0, 1.0, 0.0]},
            {"name": "spine", "children": [2], "translation": [0.0, 0.3, 0.0]},
            {"name": "head", "translation": [0.0, 0.4, 0.0]},
        ],
        "skins": [{"joints": [0, 1, 2], "inverseBindMatrices": 0}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "MAT4"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 192}],
    })
    .to_string();
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    // The object without its closing brace, then the buffer.
    write!(
        out,
        "{},\"buffers\":[{{\"byteLength\":{bytes},\"uri\":\"data:application/octet-stream;base64,",
        &head[..head.len() - 1]
    )
    .unwrap();
    {
        let mut enc =
            base64::write::EncoderWriter::new(&mut out, &base64::engine::general_purpose::STANDARD);
        let identity: [f32; 16] = [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ];
        for _ in 0..3 {
            for x in identity {
                enc.write_all(&x.to_le_bytes()).unwrap();
            }
        }
        // Something other than zeros in the rest, so nothing could get away with a shortcut.
        let rest: Vec<u8> = (0..bytes - 192)
            .map(|i| (i * 7919 % 251) as u8)
            .take(1 << 16)
            .collect();
        let mut left = bytes - 192;
        while left > 0 {
            let n = left.min(rest.len());
            enc.write_all(&rest[..n]).unwrap();
            left -= n;
        }
        enc.finish().unwrap();
    }
    out.write_all(b"\"}]}").unwrap();
    out.flush().unwrap();
}

/// Largest resident set of any child waited for, bytes.
fn children_peak_bytes() -> u64 {
    // SAFETY: `getrusage` fills the struct it is handed and reads nothing else.
    let usage = unsafe {
        let mut usage: libc::rusage = std::mem::zeroed();
        assert_eq!(libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage), 0);
        usage
    };
    // Kilobytes on Linux.
    usage.ru_maxrss as u64 * 1024
}

#[test]
#[cfg(target_os = "linux")]
fn an_embedded_buffer_is_read_in_about_twice_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let file = tmp.path().join("embedded.gltf");
    write_gltf_with_data_uri(&file, 48 << 20);
    let size = std::fs::metadata(&file).unwrap().len();
    let out = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .args(["inspect", file.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let peak = children_peak_bytes();
    // The program itself, its libraries and the ragdoll it builds take a few tens of MB.
    let overhead = 40 << 20;
    assert!(
        peak < 2 * size + overhead,
        "peak {} MB reading a {} MB file",
        peak >> 20,
        size >> 20
    );
}
