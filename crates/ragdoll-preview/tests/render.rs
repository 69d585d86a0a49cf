//! The preview renderer, checked on its pixels: the body is drawn where it stands, the
//! ground shows its grid, nearer bodies hide farther ones whatever the drawing order, the
//! frame counter is the only thing that changes on a still scene, a fall gives GIF frames
//! that differ, and PNG and GIF decode back to the size asked for.

use std::io::Cursor;

use glam::Vec3;
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, Source, humanoid};
use ragdoll::spec::{self, BodySpec, BuildOptions, RagdollSpec, SPEC_FORMAT_VERSION, Shape};
use ragdoll::track::Track;
use ragdoll::world::{World, WorldSettings};
use ragdoll_preview::{Marker, Preview, PreviewOptions};

fn small() -> PreviewOptions {
    PreviewOptions {
        width: 320,
        height: 240,
        ..Default::default()
    }
}

/// A track that holds the character's rest pose for `n` frames at 30 fps.
fn still(character: &Character, n: usize) -> Track {
    Track {
        fps: 30.0,
        frames: vec![character.skeleton.rest_world(); n],
    }
}

fn is_body_orange(c: [u8; 3]) -> bool {
    c[0] as i32 > c[2] as i32 + 40 && c[0] as i32 > c[1] as i32 + 15
}

fn is_grey(c: [u8; 3]) -> bool {
    let (r, g, b) = (c[0] as i32, c[1] as i32, c[2] as i32);
    (r - g).abs() < 20 && (g - b).abs() < 25 && (r - b).abs() < 30
}

fn luma(c: [u8; 3]) -> i32 {
    (c[0] as i32 * 3 + c[1] as i32 * 4 + c[2] as i32) / 8
}

#[test]
fn the_standing_humanoid_is_drawn_where_it_stands_on_a_gridded_ground() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let track = still(&c, 3);
    let mut p = Preview::new(&[(&c, &spec, &track)], &[], &small()).unwrap();
    let rest = c.skeleton.rest_world();
    let at = |p: &Preview, point: Vec3| {
        let s = p.project(point).expect("in the picture");
        (s.x as usize, s.y as usize)
    };
    let joints = ["pelvis", "chest", "thigh_l", "shin_r"]
        .map(|name| at(&p, rest[c.skeleton.find(name).unwrap()].translation));
    // Two points on the ground clear of the body and of its shadow (the sun is behind the
    // camera's left, so shadows fall to the right and back): one on the grid line z = 0,
    // one in the middle of a cell.
    let on_line = at(&p, Vec3::new(-0.7, 0.0, 0.0));
    let mid_cell = at(&p, Vec3::new(-0.7, 0.0, 0.5));
    let image = p.render(1).unwrap();
    for (k, &(x, y)) in joints.iter().enumerate() {
        let px = image.pixel(x, y);
        assert!(is_body_orange(px), "joint {k} at ({x}, {y}) shows {px:?}");
    }
    let (line, cell) = (
        image.pixel(on_line.0, on_line.1),
        image.pixel(mid_cell.0, mid_cell.1),
    );
    assert!(is_grey(cell) && luma(cell) > 120, "ground {cell:?}");
    assert!(is_grey(line), "grid line {line:?}");
    assert!(
        luma(line) + 12 < luma(cell),
        "grid line {line:?} vs ground {cell:?}"
    );
    // The sky above the head: bluish, not ground.
    let sky = image.pixel(160, 2);
    assert!(sky[2] > sky[0] + 10, "sky {sky:?}");
}

#[test]
fn the_shadow_falls_on_the_ground_on_the_side_away_from_the_sun() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let track = still(&c, 1);
    let mut p = Preview::new(&[(&c, &spec, &track)], &[], &small()).unwrap();
    // The sun shines from (-0.45, 1, 0.35): the shadow of the pelvis (0.95 m up) lies
    // 0.95 × (0.45, -0.35) from the feet.
    let shadowed = p.project(Vec3::new(0.43, 0.0, -0.33)).unwrap();
    let lit = p.project(Vec3::new(-0.43, 0.0, 0.33)).unwrap();
    let image = p.render(0).unwrap();
    let (s, l) = (
        image.pixel(shadowed.x as usize, shadowed.y as usize),
        image.pixel(lit.x as usize, lit.y as usize),
    );
    assert!(luma(s) + 30 < luma(l), "shadow {s:?} vs lit ground {l:?}");
}

/// A one-capsule character standing at `at`.
fn capsule(name: &str, at: Vec3, radius_m: f32, length_m: f32) -> (Character, RagdollSpec) {
    let character = Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: name.into(),
        skeleton: Skeleton::new(vec![Joint {
            name: name.into(),
            parent: None,
            rest: Transform::from_translation(at),
            tip: None,
        }])
        .unwrap(),
        meshes: vec![],
        clips: vec![],
        source: Source::BuiltIn,
    };
    let spec = RagdollSpec {
        format_version: SPEC_FORMAT_VERSION,
        name: name.into(),
        bodies: vec![BodySpec {
            name: name.into(),
            bone: name.into(),
            role: None,
            shape: Shape::Capsule { radius_m, length_m },
            center_m: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
            mass_kg: 1.0,
            extra_shapes: Vec::new(),
        }],
        joints: vec![],
        collision: Default::default(),
    };
    (character, spec)
}

#[test]
fn a_body_in_front_hides_one_behind_whatever_order_they_are_drawn_in() {
    // Looking straight down −Z: a small capsule in front of a big one.
    let (front, front_spec) = capsule("front", Vec3::new(0.0, 1.0, 1.5), 0.15, 0.3);
    let (back, back_spec) = capsule("back", Vec3::new(0.0, 1.0, -1.5), 0.5, 0.8);
    let (tf, tb) = (still(&front, 1), still(&back, 1));
    let options = PreviewOptions {
        view_from: Vec3::Z,
        ..small()
    };
    // The first character is drawn orange, the second blue: try both orders.
    for front_first in [true, false] {
        let actors = if front_first {
            [(&front, &front_spec, &tf), (&back, &back_spec, &tb)]
        } else {
            [(&back, &back_spec, &tb), (&front, &front_spec, &tf)]
        };
        let mut p = Preview::new(&actors, &[], &options).unwrap();
        let centre = p.project(Vec3::new(0.0, 1.0, 1.5)).unwrap();
        // A point on the big capsule's rim, outside the small one's outline.
        let rim = p.project(Vec3::new(0.4, 1.0, -1.0)).unwrap();
        let image = p.render(0).unwrap();
        let (c, r) = (
            image.pixel(centre.x as usize, centre.y as usize),
            image.pixel(rim.x as usize, rim.y as usize),
        );
        let orange = |px: [u8; 3]| px[0] as i32 > px[2] as i32 + 30;
        let blue = |px: [u8; 3]| px[2] as i32 > px[0] as i32 + 30;
        // The front capsule's colour at its centre, the back one's on its rim.
        let (front_ok, back_ok) = if front_first {
            (orange(c), blue(r))
        } else {
            (blue(c), orange(r))
        };
        assert!(front_ok, "front_first {front_first}: centre shows {c:?}");
        assert!(back_ok, "front_first {front_first}: rim shows {r:?}");
    }
}

#[test]
fn on_a_still_scene_only_the_frame_counter_changes() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let track = still(&c, 12);
    let mut p = Preview::new(&[(&c, &spec, &track)], &[], &small()).unwrap();
    let a = p.render(1).unwrap().clone();
    let b = p.render(11).unwrap().clone();
    let mut changed = 0;
    for y in 0..a.height {
        for x in 0..a.width {
            if a.pixel(x, y) != b.pixel(x, y) {
                changed += 1;
                // The counter sits in the top-left corner.
                assert!(x < 120 && y < 20, "pixel ({x}, {y}) changed");
            }
        }
    }
    assert!(changed > 10, "the counter did not change");
}

/// Decodes a GIF and composites its frames (each is a changed rectangle with transparent
/// pixels over the previous picture), returning every full picture as RGBA.
fn gif_pictures(bytes: &[u8]) -> (usize, usize, Vec<Vec<u8>>) {
    let mut options = gif::DecodeOptions::new();
    options.set_color_output(gif::ColorOutput::RGBA);
    let mut d = options.read_info(Cursor::new(bytes)).unwrap();
    let (w, h) = (d.width() as usize, d.height() as usize);
    let mut canvas = vec![0u8; w * h * 4];
    let mut out = Vec::new();
    while let Some(f) = d.read_next_frame().unwrap() {
        for y in 0..f.height as usize {
            for x in 0..f.width as usize {
                let src = (y * f.width as usize + x) * 4;
                if f.buffer[src + 3] == 0 {
                    continue;
                }
                let dst = ((y + f.top as usize) * w + x + f.left as usize) * 4;
                canvas[dst..dst + 4].copy_from_slice(&f.buffer[src..src + 4]);
            }
        }
        out.push(canvas.clone());
    }
    (w, h, out)
}

#[test]
fn a_fall_makes_a_gif_whose_frames_differ_and_which_decodes_at_the_right_size() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let (mut world, _) = World::with_ragdoll(&c, &spec, &WorldSettings::default()).unwrap();
    world.run(1.5);
    let track = world.into_track();
    let options = PreviewOptions {
        width: 200,
        height: 150,
        gif_fps: 10.0,
        ..Default::default()
    };
    let bytes = ragdoll_preview::gif(&[(&c, &spec, &track)], &[], &options).unwrap();
    let (w, h, pictures) = gif_pictures(&bytes);
    assert_eq!((w, h), (200, 150));
    // 46 frames at 30 fps shown at most 10 a second: every third frame.
    assert_eq!(pictures.len(), track.frames.len().div_ceil(3));
    let differ = |a: &[u8], b: &[u8]| {
        a.chunks_exact(4)
            .zip(b.chunks_exact(4))
            .filter(|(p, q)| p != q)
            .count()
    };
    // Standing at the start, lying at the end: a good part of the picture changed, and not
    // only the counter.
    let (first, last) = (&pictures[0], &pictures[pictures.len() - 1]);
    assert!(differ(first, last) > w * h / 50, "{}", differ(first, last));
    // Every frame is a full opaque picture once composited.
    assert!(last.chunks_exact(4).all(|p| p[3] == 255));
}

#[test]
fn a_png_decodes_back_to_the_size_asked_for_and_matches_the_render() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let track = still(&c, 5);
    let options = PreviewOptions {
        width: 96,
        height: 64,
        png_frame: Some(2),
        ..Default::default()
    };
    let bytes = ragdoll_preview::png(&[(&c, &spec, &track)], &[], &options).unwrap();
    let mut reader = png::Decoder::new(Cursor::new(&bytes)).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width, info.height), (96, 64));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let mut p = Preview::new(&[(&c, &spec, &track)], &[], &options).unwrap();
    assert_eq!(&buf[..info.buffer_size()], &p.render(2).unwrap().rgb[..]);
}

#[test]
fn a_blast_shows_a_fireball_at_the_charge_only_after_it_goes_off() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let track = still(&c, 30);
    let charge = Vec3::new(1.5, 0.5, 1.0);
    let markers = [Marker::Blast {
        position: charge,
        time_s: 0.5,
        tnt_kg: 2.0,
    }];
    let mut p = Preview::new(&[(&c, &spec, &track)], &markers, &small()).unwrap();
    let s = p.project(charge).unwrap();
    let (x, y) = (s.x as usize, s.y as usize);
    let before = p.render(10).unwrap().pixel(x, y);
    let during = p.render(16).unwrap().pixel(x, y);
    // Fire: bright, red over blue; the dark charge before it.
    assert!(luma(before) < 90, "before {before:?}");
    assert!(
        luma(during) > 150 && during[0] as i32 > during[2] as i32 + 40,
        "{during:?}"
    );
}

#[test]
fn bad_requests_are_errors_that_say_what_is_wrong() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let track = still(&c, 3);
    let actors = [(&c, &spec, &track)];
    let err = ragdoll_preview::format_of(std::path::Path::new("out.jpg")).unwrap_err();
    assert!(err.to_string().contains(".png"), "{err}");
    assert!(Preview::new(&[], &[], &small()).is_err());
    for bad in [
        PreviewOptions {
            width: 0,
            ..small()
        },
        PreviewOptions {
            frames: Some((1, 9)),
            ..small()
        },
        PreviewOptions {
            view_from: Vec3::Y,
            ..small()
        },
        PreviewOptions {
            width: 4096,
            height: 4096,
            supersample: 2,
            ..small()
        },
    ] {
        assert!(Preview::new(&actors, &[], &bad).is_err(), "{bad:?}");
    }
    let png = PreviewOptions {
        png_frame: Some(3),
        ..small()
    };
    let err = ragdoll_preview::png(&actors, &[], &png).unwrap_err();
    assert!(err.to_string().contains("frame 3"), "{err}");
    let broken = Track {
        fps: 30.0,
        frames: vec![vec![Transform::IDENTITY; 2]],
    };
    assert!(Preview::new(&[(&c, &spec, &broken)], &[], &small()).is_err());
}

#[test]
fn a_shot_shows_a_tracer_around_its_time_and_a_spark_only_where_it_hit() {
    let c = humanoid();
    let spec = spec::build_spec(&c, &BuildOptions::default()).unwrap();
    let track = still(&c, 30);
    let (origin, end) = (Vec3::new(-1.5, 1.2, 3.0), Vec3::new(0.0, 1.25, 0.15));
    for hit in [true, false] {
        let markers = [Marker::Shot {
            origin,
            end,
            time_s: 0.5,
            hit,
        }];
        let mut p = Preview::new(&[(&c, &spec, &track)], &markers, &small()).unwrap();
        let mid = p.project((origin + end) * 0.5).unwrap();
        let tip = p.project(end).unwrap();
        let yellow = |px: [u8; 3]| px[0] > 200 && px[1] > 180 && px[2] < 150;
        let red = |px: [u8; 3]| px[0] > 200 && px[1] < 120 && px[2] < 100;
        let at =
            |img: &ragdoll_preview::Image, s: glam::Vec2| img.pixel(s.x as usize, s.y as usize);
        let during = p.render(15).unwrap().clone();
        assert!(yellow(at(&during, mid)), "tracer {:?}", at(&during, mid));
        assert_eq!(
            red(at(&during, tip)),
            hit,
            "hit {hit}: {:?}",
            at(&during, tip)
        );
        let later = p.render(29).unwrap();
        assert!(!yellow(at(later, mid)) && !red(at(later, tip)));
    }
}
