//! BVH import and export against the real files in `../shared/data/bvh` and synthetic
//! files for the dialects those do not cover (Z up, CRLF with tabs, broken files).

mod common;

use std::path::Path;

use glam::{Quat, Vec3};
use ragdoll::Error;
use ragdoll::export::bvh::to_bvh;
use ragdoll::import::bvh::{self, BvhLayout};
use ragdoll::import::{ImportOptions, Units, UpAxis};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, Source, humanoid};
use ragdoll::track::Track;

fn parse(text: &str) -> ragdoll::Result<Character> {
    bvh::parse(text, Path::new("test.bvh"), &ImportOptions::default())
}

fn layout(c: &Character) -> &BvhLayout {
    match &c.source {
        Source::Bvh(l) => l,
        other => panic!("expected a BVH source, got {other:?}"),
    }
}

/// World transforms of every clip frame: the track a kinematic playback would bake.
fn track_of_clip(c: &Character) -> Track {
    let clip = &c.clips[0];
    let frames = clip
        .frames
        .iter()
        .map(|locals| {
            let mut w = vec![Transform::IDENTITY; c.skeleton.len()];
            c.skeleton.world_from_local(locals, &mut w);
            w
        })
        .collect();
    Track {
        fps: 1.0 / clip.frame_time,
        frames,
    }
}

/// Rest-pose height in metres: extent along Y over joints and tips.
fn height(s: &Skeleton) -> f32 {
    let world = s.rest_world();
    let mut ys: Vec<f32> = world.iter().map(|w| w.translation.y).collect();
    for (j, w) in s.joints().iter().zip(&world) {
        if let Some(t) = j.tip {
            ys.push(w.transform_point(t).y);
        }
    }
    let max = ys.iter().copied().fold(f32::MIN, f32::max);
    let min = ys.iter().copied().fold(f32::MAX, f32::min);
    max - min
}

/// Largest distance between corresponding joint positions, matched by the names the
/// exporter writes.
fn max_position_error(a: &Character, ta: &Track, b: &Character, tb: &Track) -> f32 {
    assert_eq!(ta.frames.len(), tb.frames.len());
    let map = name_map(a, b);
    let mut worst = 0.0f32;
    for (fa, fb) in ta.frames.iter().zip(&tb.frames) {
        for (i, &k) in map.iter().enumerate() {
            worst = worst.max((fa[i].translation - fb[k].translation).length());
        }
    }
    worst
}

/// For each joint of `a`, its index in `b`, a re-import of `a`'s BVH export.
fn name_map(a: &Character, b: &Character) -> Vec<usize> {
    BvhLayout::from_skeleton(&a.skeleton)
        .joints
        .iter()
        .map(|j| {
            b.skeleton
                .find(&j.name)
                .unwrap_or_else(|| panic!("joint {} missing after the round trip", j.name))
        })
        .collect()
}

#[test]
#[ignore = "needs ../shared/data"]
fn bvh_data_files_parse_with_expected_counts_and_heights() {
    let dir = common::shared_data().join("bvh");
    // (file, joints, frames, humanoid, metres per unit, up)
    let expected = [
        (
            "biovision_example_bvhio.bvh",
            18,
            2,
            true,
            0.0254,
            UpAxis::Y,
        ),
        ("cmu_pirouette_threejs.bvh", 43, 592, true, 0.01, UpAxis::Y),
        ("mocapbank_bvh-python.bvh", 19, 455, true, 0.01, UpAxis::Y),
        ("two_joint_bvh_anim.bvh", 2, 2, false, 0.01, UpAxis::Z),
    ];
    for (file, joints, frames, humanoid, unit, up) in expected {
        let c = bvh::load(&dir.join(file), &ImportOptions::default())
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        assert_eq!(c.skeleton.len(), joints, "{file}");
        assert_eq!(c.clips.len(), 1, "{file}");
        assert_eq!(c.clips[0].frames.len(), frames, "{file}");
        let l = layout(&c);
        assert_eq!(l.metres_per_unit, unit, "{file}");
        assert_eq!(l.up, up, "{file}");
        let h = height(&c.skeleton);
        eprintln!(
            "{file}: {joints} joints, {frames} frames, units {unit} m, up {up:?}, height {h:.3} m"
        );
        if humanoid {
            assert!((1.4..=2.0).contains(&h), "{file}: height {h} m");
        }
        for frame in &c.clips[0].frames {
            assert!(frame.iter().all(Transform::is_finite));
        }
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn bvh_pirouette_details() {
    let dir = common::shared_data().join("bvh");
    let c = bvh::load(
        &dir.join("cmu_pirouette_threejs.bvh"),
        &ImportOptions::default(),
    )
    .unwrap();
    let l = layout(&c);
    assert_eq!(l.joints[0].name, "hip");
    assert_eq!(
        l.joints[0]
            .channels
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>(),
        [
            "Xposition",
            "Yposition",
            "Zposition",
            "Zrotation",
            "Yrotation",
            "Xrotation"
        ]
    );
    assert_eq!(l.joints.iter().filter(|j| j.end_site.is_some()).count(), 14);
    assert!((c.clips[0].frame_time - 0.008_333_33).abs() < 1e-7);
    // First frame root position 15.3137 84.8855 152.037 cm.
    let root = c.clips[0].frames[0][0].translation;
    assert!((root - Vec3::new(0.153_137, 0.848_855, 1.520_37)).length() < 1e-6);
}

#[test]
#[ignore = "needs ../shared/data"]
fn bvh_round_trip_of_every_data_file_within_a_millimetre() {
    let dir = common::shared_data().join("bvh");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("bvh") {
            continue;
        }
        let a = bvh::load(&path, &ImportOptions::default()).unwrap();
        let ta = track_of_clip(&a);
        let text = to_bvh(&a, &ta).unwrap();
        let b = parse(&text).unwrap_or_else(|e| panic!("{}: re-import: {e}", path.display()));
        assert_eq!(layout(&a).joints, layout(&b).joints, "{}", path.display());
        assert_eq!(layout(&a).metres_per_unit, layout(&b).metres_per_unit);
        assert_eq!(layout(&a).up, layout(&b).up);
        assert!((a.clips[0].frame_time - b.clips[0].frame_time).abs() < 1e-7);
        let tb = track_of_clip(&b);
        let err = max_position_error(&a, &ta, &b, &tb);
        eprintln!(
            "{}: worst joint position error {:.2e} m",
            path.display(),
            err
        );
        assert!(err < 1e-3, "{}: {err} m", path.display());
        // Written again, the text is stable.
        assert_eq!(to_bvh(&b, &tb).unwrap().lines().next(), text.lines().next());
    }
}

const Z_UP: &str = "HIERARCHY
ROOT pelvis
{
  OFFSET 0 0 95
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT spine
  {
    OFFSET 0 2 30
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT head
    {
      OFFSET 0 0 30
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 0 20
      }
    }
  }
  JOINT thigh
  {
    OFFSET 10 0 -5
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 0 -90
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 0 95 0 0 0 0 0 0 0 0 0 0 0 0
10 20 90 90 0 0 0 0 0 0 0 0 0 0 0
";

#[test]
fn bvh_z_up_file_is_detected_and_converted() {
    let c = parse(Z_UP).unwrap();
    let l = layout(&c);
    assert_eq!(l.up, UpAxis::Z);
    assert_eq!(l.metres_per_unit, 0.01);
    let world = c.skeleton.rest_world();
    let head = c.skeleton.find("head").unwrap();
    assert!((world[head].translation - Vec3::new(0.0, 1.55, -0.02)).length() < 1e-5);
    let top = world[head].transform_point(c.skeleton.joints()[head].tip.unwrap());
    assert!((top - Vec3::new(0.0, 1.75, -0.02)).length() < 1e-5, "{top}");
    assert!((height(&c.skeleton) - 1.75).abs() < 1e-5);
    // Frame 2: root at file (10, 20, 90) cm, turned 90° about file Z (= world Y).
    let track = track_of_clip(&c);
    let root = track.frames[1][0];
    assert!((root.translation - Vec3::new(0.1, 0.9, -0.2)).length() < 1e-5);
    let head2 = track.frames[1][head].translation;
    // Spine's offset (0, 2, 30) turns to (−2, 0, 30) in file axes: world (−0.02, 0.6, 0).
    assert!(
        (head2 - Vec3::new(0.1 - 0.02, 0.9 + 0.6, -0.2)).length() < 1e-5,
        "{head2}"
    );
    // Written back in Z up, re-read to the same positions.
    let text = to_bvh(&c, &track).unwrap();
    assert!(text.contains("\tOFFSET 0 0 95\n"), "{text}");
    let back = parse(&text).unwrap();
    assert_eq!(layout(&back).up, UpAxis::Z);
    assert!(max_position_error(&c, &track, &back, &track_of_clip(&back)) < 1e-5);
    // Overrides win over detection.
    let opts = ImportOptions {
        units: Some(Units::M),
        up: Some(UpAxis::Y),
        ..Default::default()
    };
    let forced = bvh::parse(Z_UP, Path::new("z.bvh"), &opts).unwrap();
    assert_eq!(layout(&forced).up, UpAxis::Y);
    assert!((height(&forced.skeleton) - 2.0).abs() < 1e-5);
}

#[test]
fn bvh_crlf_tabs_and_lowercase_end_site() {
    let text = "\u{feff}HIERARCHY\r\n\r\nROOT\tHips\r\n{\r\n\tOFFSET\t0.00\t0.00\t0.00\r\n\
                \tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\r\n\
                \tJOINT Left Up Leg\r\n\t{\r\n\t\tOFFSET\t 3.91\t 0.00\t 0.00\r\n\r\n\
                \t\tCHANNELS 3 Zrotation Xrotation Yrotation\r\n\t\tEnd site\r\n\t\t{\r\n\
                \t\t\tOFFSET 0 -80 0\r\n\t\t}\r\n\t}\r\n\tJOINT Chest\r\n\t{\r\n\
                \t\tOFFSET 0 60 0\r\n\t\tCHANNELS 3 zrotation xrotation yrotation\r\n\
                \t\tEND SITE\r\n\t\t{\r\n\t\t\tOFFSET 0 30 0\r\n\t\t}\r\n\t}\r\n}\r\n\
                MOTION\r\n\r\nFrames:\t2\r\nFrame Time:\t0.033333\r\n\
                1\t90\t0\t0\t0\t0\t0\t0\t0\t0\t0\t0\r\n\r\n\
                2\t91\t0\t0\t0\t0\t0\t0\t0\t0\t0\t0\r\n\r\n";
    let c = parse(text).unwrap();
    assert_eq!(c.skeleton.len(), 3);
    assert_eq!(c.skeleton.joints()[1].name, "Left Up Leg");
    assert_eq!(c.clips[0].frames.len(), 2);
    let tip = c.skeleton.joints()[1].tip.unwrap();
    assert!((tip - Vec3::new(0.0, -0.8, 0.0)).length() < 1e-6);
    assert!((height(&c.skeleton) - 1.7).abs() < 1e-5);
    // Names with spaces are written with underscores, and the file reads back.
    let track = track_of_clip(&c);
    let out = to_bvh(&c, &track).unwrap();
    assert!(out.contains("JOINT Left_Up_Leg\n"));
    let back = parse(&out).unwrap();
    assert!(max_position_error(&c, &track, &back, &track_of_clip(&back)) < 1e-5);
}

fn expect_parse_error(text: &str) -> (usize, String) {
    match parse(text) {
        Err(Error::Parse { line, message, .. }) => (line, message),
        Err(other) => panic!("expected a parse error, got {other}"),
        Ok(_) => panic!("expected a parse error, got a character"),
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn bvh_errors_name_file_and_line() {
    let dir = common::shared_data().join("bvh");
    let path = dir.join("mocapbank_bvh-python.bvh");
    let text = std::fs::read_to_string(&path).unwrap();
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    // Frames start on line 120; keep 100 of the 455.
    let cut: String = lines[..219].concat();
    let (line, message) = expect_parse_error(&cut);
    assert_eq!(line, 220, "{message}");
    assert!(
        message.contains("100 frames") && message.contains("455"),
        "{message}"
    );
    // The same through the file system, with the file named in the sentence.
    let tmp = std::env::temp_dir().join(format!("ragdoll-bvh-test-{}.bvh", std::process::id()));
    std::fs::write(&tmp, &cut).unwrap();
    let e = bvh::load(&tmp, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    let _ = std::fs::remove_file(&tmp);
    assert!(
        e.contains(&tmp.display().to_string()) && e.contains("line 220"),
        "{e}"
    );
    // A value that is not a number, a short line, a missing brace.
    let bad = text.replacen("-44.0003 93.5663", "-44.0003 abc", 1);
    assert_eq!(expect_parse_error(&bad).0, 120);
    let short = text.replacen("-44.0003 93.5663 ", "", 1);
    assert!(expect_parse_error(&short).1.contains("58 values"));
    let unclosed = text.replacen("  }\r\n}\r\nMOTION", "  }\r\nMOTION", 1);
    assert_eq!(expect_parse_error(&unclosed).0, 116);
    let more = text.replacen("Frames:\t455", "Frames:\t456", 1);
    assert_eq!(expect_parse_error(&more).0, 575);
}

#[test]
fn bvh_a_missing_file_is_an_io_error() {
    assert!(matches!(
        bvh::load(Path::new("/nonexistent/x.bvh"), &ImportOptions::default()),
        Err(Error::Io { .. })
    ));
}

#[test]
#[ignore = "needs ../shared/data"]
fn bvh_never_panics_on_truncated_data_files() {
    let dir = common::shared_data().join("bvh");
    for (file, step) in [
        ("biovision_example_bvhio.bvh", 1),
        ("two_joint_bvh_anim.bvh", 1),
        ("mocapbank_bvh-python.bvh", 97),
    ] {
        let bytes = std::fs::read(dir.join(file)).unwrap();
        let trimmed = bytes.trim_ascii_end();
        // Every prefix that stops before the last frame line is missing data.
        let last_line_start = trimmed.iter().rposition(|&b| b == b'\n').unwrap() + 1;
        for len in (0..bytes.len()).step_by(step) {
            let text = String::from_utf8_lossy(&bytes[..len]);
            let r = parse(&text);
            if len < last_line_start {
                assert!(r.is_err(), "{file}: prefix of {len} bytes parsed");
            }
        }
    }
}

#[test]
fn bvh_never_panics_on_garbage_input() {
    // Random bytes, and random soup of BVH words.
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut rand = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let words = [
        "HIERARCHY",
        "ROOT",
        "JOINT",
        "End",
        "Site",
        "{",
        "}",
        "OFFSET",
        "CHANNELS",
        "3",
        "6",
        "-1",
        "0",
        "1e40",
        "nan",
        "Xposition",
        "Zrotation",
        "Yrotation",
        "MOTION",
        "Frames:",
        "Frame",
        "Time:",
        "0.1",
        "\n",
        "\r\n",
        "\t",
        "é",
        "99999999999999999999",
    ];
    for _ in 0..3000 {
        let n = (rand() % 80) as usize;
        let soup: String = (0..n)
            .map(|_| {
                let w = words[(rand() % words.len() as u64) as usize];
                format!("{w} ")
            })
            .collect();
        let _ = parse(&format!("HIERARCHY\nROOT a\n{{\n{soup}"));
        let _ = parse(&soup);
        let bytes: Vec<u8> = (0..n * 3).map(|_| (rand() % 256) as u8).collect();
        assert!(parse(&String::from_utf8_lossy(&bytes)).is_err());
    }
}

/// A two-level skeleton whose rest pose has rotations and a uniform scale, like a glTF.
fn gltf_like() -> Character {
    let rot = Quat::from_rotation_z(0.7) * Quat::from_rotation_x(-0.3);
    let joints = vec![
        Joint {
            name: String::new(),
            parent: None,
            rest: Transform {
                translation: Vec3::new(0.1, 1.0, 0.0),
                rotation: Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
                scale: Vec3::splat(0.5),
            },
            tip: None,
        },
        Joint {
            name: "arm".into(),
            parent: Some(0),
            rest: Transform::new(Vec3::new(0.0, 0.0, 1.2), rot),
            tip: None,
        },
        Joint {
            name: "arm".into(),
            parent: Some(0),
            rest: Transform::new(Vec3::new(0.3, 0.2, 0.4), rot.inverse()),
            tip: Some(Vec3::new(0.0, 0.5, 0.0)),
        },
        Joint {
            name: "hand".into(),
            parent: Some(1),
            rest: Transform::new(Vec3::new(0.0, 0.8, 0.0), rot),
            tip: Some(Vec3::new(0.0, 0.2, 0.0)),
        },
    ];
    Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: "gltf-like".into(),
        skeleton: Skeleton::new(joints).unwrap(),
        meshes: Vec::new(),
        clips: Vec::new(),
        source: Source::BuiltIn,
    }
}

/// Poses with every local rotation perturbed, so every channel moves.
fn wiggle_track(c: &Character, frames: usize) -> Track {
    let s = &c.skeleton;
    let frames = (0..frames)
        .map(|f| {
            let locals: Vec<Transform> = s
                .joints()
                .iter()
                .enumerate()
                .map(|(i, j)| {
                    let t = f as f32 * 0.37 + i as f32;
                    let wiggle =
                        Quat::from_euler(glam::EulerRot::XYZ, t.sin(), (1.3 * t).cos(), 0.5 * t);
                    let mut l = j.rest;
                    l.rotation = (l.rotation * wiggle).normalize();
                    if j.parent.is_none() {
                        l.translation += Vec3::new(t.sin(), 0.1 * t, -t.cos());
                    }
                    l
                })
                .collect();
            let mut w = vec![Transform::IDENTITY; s.len()];
            s.world_from_local(&locals, &mut w);
            w
        })
        .collect();
    Track { fps: 24.0, frames }
}

#[test]
fn bvh_export_of_non_bvh_characters_keeps_world_positions() {
    for (c, detect) in [(humanoid(), true), (gltf_like(), false)] {
        let track = wiggle_track(&c, 20);
        let text = to_bvh(&c, &track).unwrap();
        // The humanoid's real height is in the file, so detection finds centimetres; the
        // small made-up skeleton would read as inches, so it says what it is.
        let opts = if detect {
            ImportOptions::default()
        } else {
            ImportOptions {
                units: Some(Units::Cm),
                up: Some(UpAxis::Y),
                ..Default::default()
            }
        };
        let back = bvh::parse(&text, Path::new("back.bvh"), &opts)
            .unwrap_or_else(|e| panic!("{}: {e}\n{text}", c.name));
        let l = layout(&back);
        assert_eq!(l.metres_per_unit, 0.01, "{}", c.name);
        assert_eq!(l.up, UpAxis::Y);
        assert!((back.clips[0].frame_time - 1.0 / 24.0).abs() < 1e-7);
        let tb = track_of_clip(&back);
        let err = max_position_error(&c, &track, &back, &tb);
        assert!(err < 1e-4, "{}: {err} m", c.name);
        // The BVH rest pose is the character's rest pose (world positions, no rotations)...
        let map = name_map(&c, &back);
        let rest_a = c.skeleton.rest_world();
        let rest_b = back.skeleton.rest_world();
        for (i, &k) in map.iter().enumerate() {
            assert!((rest_a[i].translation - rest_b[k].translation).length() < 1e-5);
        }
        // ... so BVH joints turn by the track's rotation relative to the rest pose.
        for (fa, fb) in track.frames.iter().zip(&tb.frames) {
            for (i, &k) in map.iter().enumerate() {
                let expected = fa[i].rotation * rest_a[i].rotation.inverse();
                for v in [Vec3::X, Vec3::Y, Vec3::Z] {
                    assert!((expected * v - fb[k].rotation * v).length() < 1e-4);
                }
            }
        }
        // Tips survive, in world axes.
        for (i, &k) in map.iter().enumerate() {
            if let Some(t) = c.skeleton.joints()[i].tip {
                let tip_a = rest_a[i].transform_point(t);
                let tip_b = rest_b[k].transform_point(back.skeleton.joints()[k].tip.unwrap());
                assert!((tip_a - tip_b).length() < 1e-5);
            }
        }
    }
    let text = to_bvh(&gltf_like(), &wiggle_track(&gltf_like(), 1)).unwrap();
    assert!(
        text.contains("ROOT joint0\n") && text.contains("JOINT arm_2\n"),
        "{text}"
    );
}

#[test]
fn bvh_layout_from_skeleton_channels() {
    let l = BvhLayout::from_skeleton(&humanoid().skeleton);
    let names = |i: usize| {
        l.joints[i]
            .channels
            .iter()
            .map(|c| c.name())
            .collect::<Vec<_>>()
    };
    assert_eq!(
        names(0),
        [
            "Xposition",
            "Yposition",
            "Zposition",
            "Zrotation",
            "Xrotation",
            "Yrotation"
        ]
    );
    assert_eq!(names(1), ["Zrotation", "Xrotation", "Yrotation"]);
    let head = humanoid().skeleton.find("head").unwrap();
    assert!((l.joints[head].end_site.unwrap() - Vec3::new(0.0, 19.0, 0.0)).length() < 1e-4);
}

/// A Rokoko export's offsets are bone-local, so its rest pose lies along the ground and its
/// breadth once passed for its height (9.4 m tall, bodies five times too big); the first
/// frame, standing, gives the units.
#[test]
#[ignore = "needs ../shared/data"]
fn a_rest_pose_lying_down_takes_its_units_from_the_first_frame() {
    let path = common::shared_data().join("rigs/animdraw_rokoko_jesse_dance.bvh");
    let c = bvh::load(&path, &ImportOptions::default()).unwrap();
    let mut world = vec![Transform::IDENTITY; c.skeleton.len()];
    c.skeleton
        .world_from_local(&c.clips[0].frames[0], &mut world);
    let ys = world.iter().map(|t| t.translation.y);
    let h = ys.clone().fold(f32::MIN, f32::max) - ys.fold(f32::MAX, f32::min);
    assert!(
        (1.4..=2.0).contains(&h),
        "standing {h} m tall in its first frame"
    );
    assert_eq!(layout(&c).metres_per_unit, 0.01);
    // Units the user gives still win.
    let opts = ImportOptions {
        units: Some(Units::M),
        ..Default::default()
    };
    assert_eq!(
        layout(&bvh::load(&path, &opts).unwrap()).metres_per_unit,
        1.0
    );
}

/// A LAFAN1-style export (Ubisoft's mocap set, centimetres, Y up): offsets bone-local along
/// +X, so the zero-rotation pose lies along X, with the hips' and shoulders' offsets across
/// it, along Z, twice its height along Y. That once passed for a figure standing on Z: the
/// first frame was turned on its side, lay too, and the units came from the lying pose (a
/// character 6 m tall). A pose longer than it is tall stands on neither axis; the first
/// frame, upright along Y, gives axis and units.
const LAFAN_STYLE: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 95 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT LeftUpLeg
  {
    OFFSET 0.1 1.9 10.5
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT LeftLeg
    {
      OFFSET 43.5 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 42.4 0 0
      }
    }
  }
  JOINT RightUpLeg
  {
    OFFSET 0.1 1.9 -10.5
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT RightLeg
    {
      OFFSET 43.5 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 42.4 0 0
      }
    }
  }
  JOINT Spine
  {
    OFFSET 6.9 -2.6 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Neck
    {
      OFFSET 50.8 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 11.8 0 0
      }
    }
    JOINT LeftShoulder
    {
      OFFSET 44.7 -1.5 6
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 58.2 0 0
      }
    }
    JOINT RightShoulder
    {
      OFFSET 44.7 -1.5 -6
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 58.2 0 0
      }
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.033333
0 95 0 90 0 0 180 0 0 0 0 0 180 0 0 0 0 0 0 0 0 0 0 0 180 0 0 180 0 0
";

#[test]
fn a_rest_pose_lying_along_x_with_hips_across_it_stands_on_y() {
    let c = parse(LAFAN_STYLE).unwrap();
    assert_eq!(layout(&c).up, UpAxis::Y);
    assert_eq!(layout(&c).metres_per_unit, 0.01);
    let mut world = vec![Transform::IDENTITY; c.skeleton.len()];
    c.skeleton
        .world_from_local(&c.clips[0].frames[0], &mut world);
    let neck = c.skeleton.find("Neck").unwrap();
    let knee = c.skeleton.find("LeftLeg").unwrap();
    // Hips 0.95 m up, the neck 0.577 m above them, the knee 0.434 m below.
    assert!(
        (world[0].translation.y - 0.95).abs() < 1e-3,
        "{}",
        world[0].translation
    );
    let up = world[neck].translation.y - world[0].translation.y;
    assert!((up - 0.577).abs() < 1e-3, "{up}");
    let down = world[0].translation.y - world[knee].translation.y;
    assert!((down - 0.434).abs() < 1e-3, "{down}");
}

/// A dog in centimetres, 0.72 m from its paws to the top of its head: 72 units is a person's
/// height in inches, and was read so (a dog 1.8 m tall). Inches and CMU units are kept for
/// people; a creature in those bands is in centimetres.
const DOG: &str = "HIERARCHY
ROOT spine_base
{
  OFFSET 0 52 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT spine_mid
  {
    OFFSET 0 2 20
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT spine_neck
    {
      OFFSET 0 1 20
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT head
      {
        OFFSET 0 14 10
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 2 12
        }
      }
      JOINT front_left_upper
      {
        OFFSET 6 -4 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT front_left_lower
        {
          OFFSET 0 -17 6
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT front_left_foot
          {
            OFFSET 0 -30 -4
            CHANNELS 3 Zrotation Xrotation Yrotation
            End Site
            {
              OFFSET 0 -3 5
            }
          }
        }
      }
      JOINT front_right_upper
      {
        OFFSET -6 -4 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT front_right_lower
        {
          OFFSET 0 -17 6
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT front_right_foot
          {
            OFFSET 0 -30 -4
            CHANNELS 3 Zrotation Xrotation Yrotation
            End Site
            {
              OFFSET 0 -3 5
            }
          }
        }
      }
    }
  }
  JOINT tail
  {
    OFFSET 0 0 -8
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 -10 -25
    }
  }
  JOINT back_left_upper
  {
    OFFSET 6 -3 -2
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT back_left_lower
    {
      OFFSET 0 -17 6
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT back_left_foot
      {
        OFFSET 0 -30 -4
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -3 5
        }
      }
    }
  }
  JOINT back_right_upper
  {
    OFFSET -6 -3 -2
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT back_right_lower
    {
      OFFSET 0 -17 6
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT back_right_foot
      {
        OFFSET 0 -30 -4
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 0 -3 5
        }
      }
    }
  }
}
MOTION
Frames: 1
Frame Time: 0.033333
0 52 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0 0
";

#[test]
fn a_creature_as_tall_as_a_person_in_inches_is_in_centimetres() {
    let c = parse(DOG).unwrap();
    assert!(!ragdoll::spec::recognise_roles(&c).humanoid);
    assert_eq!(layout(&c).metres_per_unit, 0.01);
    let rest = c.skeleton.rest_world();
    let head = c.skeleton.find("head").unwrap();
    assert!(
        (rest[head].translation.y - 0.69).abs() < 1e-4,
        "{}",
        rest[head].translation
    );
    // Units the user gives still win.
    let opts = ImportOptions {
        units: Some(Units::In),
        ..Default::default()
    };
    let inches = bvh::parse(DOG, Path::new("dog.bvh"), &opts).unwrap();
    assert_eq!(layout(&inches).metres_per_unit, 0.0254);
}

/// Bone-local offsets (every bone along +X, as Rokoko writes them): the zero-rotation pose
/// lies on the ground, the first frame stands. The skeleton takes the first frame's
/// rotations as its rest, so the ragdoll is built standing, while every frame's world pose
/// stays what the file says, and survives a BVH round trip.
const LYING_REST: &str = "HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 20 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Head
    {
      OFFSET 40 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 20 0 0
      }
    }
  }
  JOINT LeftLeg
  {
    OFFSET -90 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 0 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.033333
0 90 0 90 0 0 0 0 0 0 0 0 0 0 0
0 90 0 90 0 0 30 0 0 0 0 0 0 0 0
";

#[test]
fn a_rest_pose_lying_down_stands_in_the_first_frame_and_keeps_every_world_pose() {
    let c = parse(LYING_REST).unwrap();
    let rest = c.skeleton.rest_world();
    let head = c.skeleton.find("Head").unwrap();
    let leg = c.skeleton.find("LeftLeg").unwrap();
    // Standing: the head 0.6 m above the hips, the leg's joint 0.9 m below them.
    let up = rest[head].translation - rest[0].translation;
    assert!((up - Vec3::new(0.0, 0.6, 0.0)).length() < 1e-4, "{up}");
    let down = rest[leg].translation - rest[0].translation;
    assert!((down.y + 0.9).abs() < 1e-4, "{down}");
    // The frames still put every joint where the file does: frame 1 turns the spine 30°.
    let track = track_of_clip(&c);
    let spine_to_head = track.frames[1][head].translation - track.frames[1][1].translation;
    let tilt = spine_to_head.angle_between(Vec3::Y).to_degrees();
    assert!((tilt - 30.0).abs() < 1e-3, "{tilt}");
    let text = to_bvh(&c, &track).unwrap();
    let again = parse(&text).unwrap();
    let err = max_position_error(&c, &track, &again, &track_of_clip(&again));
    assert!(err < 1e-3, "{err} m");
}

/// The one frame of the bone-local person below: the spine turned 90° to stand the trunk
/// up, each shoulder turned back so the arms reach sideways; everything turned by `turn`.
fn frame(turn: glam::DQuat) -> String {
    use ragdoll::import::bvh::{Axis, decompose_rotation};
    let zxy = [Axis::Z, Axis::X, Axis::Y];
    let channels = |q: glam::DQuat| {
        let local = turn * q * turn.inverse();
        decompose_rotation(local, &zxy)
            .iter()
            .map(|a| format!("{:.6}", a.to_degrees()))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let up = channels(glam::DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2));
    let back = channels(glam::DQuat::from_rotation_z(-std::f64::consts::FRAC_PI_2));
    let zero = "0 0 0";
    // Hips; spine, chest, neck, head; each arm's shoulder, upper arm, forearm, hand; each
    // leg's thigh, shin, foot.
    let mut v = vec![
        "0 95 0 0 0 0".to_string(),
        up,
        zero.into(),
        zero.into(),
        zero.into(),
    ];
    for _ in 0..2 {
        v.push(back.clone());
        v.extend(std::iter::repeat_n(zero.to_string(), 3));
    }
    v.extend(std::iter::repeat_n(zero.to_string(), 6));
    v.join(" ")
}

/// A person in centimetres whose offsets are bone-local, as Bandai Namco's motion dataset
/// writes them: the spine, neck and head along their bones' +X, the legs down, the arms
/// out along X, so the zero-rotation pose stands 95 units tall with its trunk lying
/// sideways; its first frame stands it up. Its height said inches (a 2.4 m person); its
/// span along the bones (toe to fingertip, 240 units) says centimetres whatever the
/// pose. Turned four ways about Y.
#[test]
fn bvh_centimetres_with_bone_local_offsets_are_not_read_as_inches() {
    for facing in [0.0f64, 90.0, 180.0, 270.0] {
        let turn = glam::DQuat::from_rotation_y(facing.to_radians());
        let o = |x: f64, y: f64, z: f64| {
            let v = turn * glam::DVec3::new(x, y, z);
            format!("OFFSET {:.4} {:.4} {:.4}", v.x, v.y, v.z)
        };
        let rot = "CHANNELS 3 Zrotation Xrotation Yrotation";
        let leg = |s: &str, x: f64| {
            format!(
                "JOINT UpperLeg_{s} {{ {} {rot} JOINT LowerLeg_{s} {{ {} {rot} JOINT Foot_{s} {{ {} {rot} End Site {{ {} }} }} }} }}",
                o(x, -5.0, 0.0),
                o(0.0, -42.0, 0.0),
                o(0.0, -42.0, 0.0),
                o(0.0, -6.0, 12.0)
            )
        };
        let arm = |s: &str, x: f64| {
            format!(
                "JOINT Shoulder_{s} {{ {} {rot} JOINT UpperArm_{s} {{ {} {rot} JOINT LowerArm_{s} {{ {} {rot} JOINT Hand_{s} {{ {} {rot} End Site {{ {} }} }} }} }} }}",
                o(18.0, 0.0, 0.0),
                o(15.0 * x, 0.0, 0.0),
                o(28.0 * x, 0.0, 0.0),
                o(26.0 * x, 0.0, 0.0),
                o(8.0 * x, 0.0, 0.0)
            )
        };
        let text = format!(
            "HIERARCHY\nROOT Hips {{ {} CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n\
             JOINT Spine {{ {} {rot} JOINT Chest {{ {} {rot}\n\
             JOINT Neck {{ {} {rot} JOINT Head {{ {} {rot} End Site {{ {} }} }} }}\n\
             {} {} }} }}\n{} {} }}\nMOTION\nFrames: 1\nFrame Time: 0.0333333\n{}\n",
            o(0.0, 95.0, 0.0),
            o(12.0, 0.0, 0.0),
            o(25.0, 0.0, 0.0),
            o(22.0, 0.0, 0.0),
            o(10.0, 0.0, 0.0),
            o(20.0, 0.0, 0.0),
            arm("L", 1.0),
            arm("R", -1.0),
            leg("L", 9.0),
            leg("R", -9.0),
            frame(turn)
        );
        let c = parse(&text).unwrap_or_else(|e| panic!("facing {facing}°: {e}"));
        let roles = ragdoll::spec::recognise_roles(&c);
        assert!(roles.humanoid, "facing {facing}°: {}", roles.why);
        assert_eq!(layout(&c).metres_per_unit, 0.01, "facing {facing}°");
        let world = c.skeleton.rest_world();
        let at = |name: &str| world[c.skeleton.find(name).unwrap()].translation;
        let shin = at("LowerLeg_L").distance(at("Foot_L"));
        assert!(
            (shin - 0.42).abs() < 1e-4,
            "facing {facing}°: shin {shin} m"
        );
    }
}
