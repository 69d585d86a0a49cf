//! `--preview`, `ragdoll preview` and `--obj-sequence` through the real binary: the files
//! exist with the size they claim, bad requests fail before anything is written.

use std::path::Path;

mod common;

use common::*;

/// Width and height from a GIF's logical screen descriptor.
fn gif_size(bytes: &[u8]) -> (u16, u16) {
    assert_eq!(&bytes[..6], b"GIF89a");
    (
        u16::from_le_bytes([bytes[6], bytes[7]]),
        u16::from_le_bytes([bytes[8], bytes[9]]),
    )
}

/// Width and height from a PNG's IHDR chunk.
fn png_size(bytes: &[u8]) -> (u32, u32) {
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(&bytes[12..16], b"IHDR");
    (
        u32::from_be_bytes(bytes[16..20].try_into().unwrap()),
        u32::from_be_bytes(bytes[20..24].try_into().unwrap()),
    )
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn demo_writes_a_gif_preview_and_preview_redraws_the_baked_result_as_png() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let o = ragdoll(
        dir,
        &[
            "demo",
            "-o",
            "out",
            "--seconds",
            "1",
            "--preview",
            "demo.gif",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let gif = std::fs::read(dir.join("demo.gif")).unwrap();
    assert_eq!(gif_size(&gif), (640, 480));
    // Several frames: each starts with an image descriptor after a graphic control block.
    let frames = gif.windows(2).filter(|w| w == &[0x21, 0xF9]).count();
    assert!(frames >= 10, "{frames} frames");

    let o = ragdoll(
        dir,
        &[
            "preview",
            "out/demo.glb",
            "-o",
            "again.png",
            "--size",
            "200x100",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let png = std::fs::read(dir.join("again.png")).unwrap();
    assert_eq!(png_size(&png), (200, 100));
}

#[test]
fn an_unknown_preview_extension_fails_before_simulating_and_writes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let o = ragdoll(dir, &["demo", "-o", "out", "--preview", "demo.jpg"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("--preview") && err.contains(".png") && err.contains(".gif"),
        "{err}"
    );
    assert!(files_in(dir).is_empty(), "{:?}", files_in(dir));

    let o = ragdoll(
        dir,
        &[
            "blast",
            "--tnt",
            "1",
            "--at",
            "1,0,0",
            "-o",
            "b.glb",
            "--preview",
            "b.bmp",
        ],
    );
    assert!(!o.status.success());
    assert!(files_in(dir).is_empty(), "{:?}", files_in(dir));
}

#[test]
#[ignore = "needs ../shared/data"]
fn preview_refuses_a_file_ragdoll_did_not_bake() {
    let data = data_dir();
    let tmp = tempfile::tempdir().unwrap();
    let input = data.join("gltf/CesiumMan.glb");
    let o = ragdoll(
        tmp.path(),
        &["preview", input.to_str().unwrap(), "-o", "cm.gif"],
    );
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("no animation named \"ragdoll\""),
        "{}",
        stderr(&o)
    );
    assert!(files_in(tmp.path()).is_empty());
}

#[test]
#[ignore = "needs ../shared/data"]
fn simulate_writes_one_obj_per_frame_and_a_png_of_a_skinned_mesh() {
    let data = data_dir();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let input = data.join("gltf/CesiumMan.glb");
    let o = ragdoll(
        dir,
        &[
            "simulate",
            input.to_str().unwrap(),
            "--seconds",
            "0.5",
            "-o",
            "cm.glb",
            "--obj-sequence",
            "objs",
            "--preview",
            "cm.png",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let report = read_json(&dir.join("cm.report.json"));
    let frames = report["frames"].as_u64().unwrap() as usize;
    let objs = files_in(&dir.join("objs"));
    assert_eq!(objs.len(), frames);
    assert_eq!(objs[0], "frame_0000.obj");
    // Every frame holds the whole mesh: as many vertices as the first.
    let count = |name: &str| {
        std::fs::read_to_string(dir.join("objs").join(name))
            .unwrap()
            .lines()
            .filter(|l| l.starts_with("v "))
            .count()
    };
    assert!(count(&objs[0]) > 1000);
    assert_eq!(count(&objs[0]), count(&objs[frames - 1]));
    assert_eq!(
        png_size(&std::fs::read(dir.join("cm.png")).unwrap()),
        (640, 480)
    );
}
