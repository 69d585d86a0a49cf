//! `--clip`, `--units`/`--height` on glTF and `.vrm` input, from the command line: what
//! `inspect` lists, what a run plays, and the one-line errors.

mod common;

use std::path::Path;

use common::{data_dir, ragdoll, stderr};

fn out(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// The demo's baked fall as a BVH with one clip, in a fresh folder.
fn bvh() -> tempfile::TempDir {
    let tmp = tempfile::tempdir().unwrap();
    let o = ragdoll(tmp.path(), &["demo", "-o", "made", "--seconds", "0.3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::rename(
        tmp.path().join("made/demo.bvh"),
        tmp.path().join("anim.bvh"),
    )
    .unwrap();
    tmp
}

#[test]
fn inspect_lists_the_clips_with_the_one_that_plays() {
    let tmp = bvh();
    let o = ragdoll(tmp.path(), &["inspect", "anim.bvh"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = out(&o);
    let listing = text.split("\nclips (").nth(1).expect("a clips section");
    let lines: Vec<&str> = listing.lines().skip(1).collect();
    assert_eq!(lines.len(), 1, "{listing}");
    assert!(lines[0].starts_with("*   0  (unnamed)"), "{}", lines[0]);
    assert!(lines[0].contains("frames at 30 fps"), "{}", lines[0]);
    let o = ragdoll(
        tmp.path(),
        &["inspect", "anim.bvh", "--json", "--clip", "0"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let clip = &v["clips"][0];
    assert_eq!(clip["index"], 0);
    assert_eq!(clip["played"], true);
    let frames = clip["frames"].as_f64().unwrap();
    let duration = clip["duration_s"].as_f64().unwrap();
    assert!((duration - (frames - 1.0) / 30.0).abs() < 1e-3, "{clip}");
}

#[test]
fn a_missing_clip_is_one_line_listing_the_clips_and_writes_nothing() {
    let tmp = bvh();
    let o = ragdoll(
        tmp.path(),
        &[
            "simulate",
            "anim.bvh",
            "--clip",
            "Dance",
            "-o",
            "out.glb",
            "--seconds",
            "0.1",
        ],
    );
    assert!(!o.status.success());
    let e = stderr(&o);
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(
        e.starts_with("error: --clip: anim.bvh: clip \"Dance\": no such clip; the file's 1 clips are 0 (unnamed)"),
        "{e}"
    );
    assert!(!tmp.path().join("out.glb").exists());
}

#[test]
fn up_is_refused_on_vrm_but_units_is_not() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ragdoll(tmp.path(), &["inspect", "a.vrm", "--up", "z"]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(
        e.starts_with("error: --up: a.vrm is glTF, which is Y up"),
        "{e}"
    );
    let o = ragdoll(tmp.path(), &["inspect", "a.vrm", "--units", "cm"]);
    let e = stderr(&o);
    assert!(!o.status.success());
    assert!(e.contains("a.vrm") && !e.contains("--units"), "{e}");
}

fn data(rel: &str) -> String {
    data_dir().join(rel).display().to_string()
}

#[test]
#[ignore = "needs ../shared/data"]
fn the_orc_simulates_the_clip_asked_for() {
    let tmp = tempfile::tempdir().unwrap();
    let orc = data("rigs/quaternius_um_orc_ikfeet.gltf");
    let o = ragdoll(tmp.path(), &["inspect", &orc]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = out(&o);
    assert!(text.contains("*   0  \"Death\""), "{text}");
    assert!(
        text.contains("    8  \"Punch\"                  0.87 s, 27 frames at 30 fps"),
        "{text}"
    );
    let o = ragdoll(tmp.path(), &["inspect", &orc, "--clip", "Punch"]);
    assert!(out(&o).contains("*   8  \"Punch\""), "{}", out(&o));
    let args = [
        "simulate",
        &orc,
        "--clip",
        "Punch",
        "--activate",
        "0.5",
        "-o",
        "out.glb",
        "--seconds",
        "0.6",
    ];
    let o = ragdoll(tmp.path(), &args);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = ragdoll(tmp.path(), &["inspect", &orc, "--clip", "13", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["clips"][13]["name"], "Yes");
    assert_eq!(v["clips"][13]["played"], true);
}

#[test]
#[ignore = "needs ../shared/data"]
fn the_fox_is_told_it_is_too_big_and_units_cm_makes_it_fox_sized() {
    let tmp = tempfile::tempdir().unwrap();
    let fox = data("gltf/Fox.glb");
    let mass = |extra: &[&str]| {
        let args = [&["inspect", fox.as_str(), "--json"][..], extra].concat();
        let o = ragdoll(tmp.path(), &args);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        (v["total_mass_kg"].as_f64().unwrap(), stderr(&o))
    };
    let (big, warned) = mass(&[]);
    assert!(
        warned.contains("the character is 79.0 m tall, implausibly large")
            && warned.contains("--units cm"),
        "{warned}"
    );
    let (cm, quiet) = mass(&["--units", "cm"]);
    assert!(!quiet.contains("warning"), "{quiet}");
    assert!((big / cm / 1e6 - 1.0).abs() < 0.01, "{big} {cm}");
    let (tall, _) = mass(&["--height", "0.395"]);
    assert!(
        (cm / tall / 8.0 - 1.0).abs() < 0.01,
        "half the height, an eighth of the mass: {cm} {tall}"
    );
}

#[test]
#[ignore = "needs ../shared/data"]
fn the_vrm_sample_is_read_by_its_extension() {
    let tmp = tempfile::tempdir().unwrap();
    let vrm = data("rigs/threevrm_sphere_vrm0.vrm");
    let o = ragdoll(tmp.path(), &["inspect", &vrm]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out(&o).starts_with("threevrm_sphere_vrm0 (humanoid), 22 joints"),
        "{}",
        out(&o)
    );
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let o = ragdoll(
        tmp.path(),
        &["simulate", &vrm, "-o", "out.glb", "--seconds", "0.2"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(Path::new(&tmp.path().join("out.glb")).is_file());
}
