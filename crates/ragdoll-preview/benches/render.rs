//! Time per preview frame (a preview must stay under 50 ms a frame at 640×480):
//! `cargo bench -p ragdoll-preview`. A timing print, not a test; a few seconds long.

use std::time::Instant;

use ragdoll::events::Blast;
use ragdoll::world::{World, WorldSettings};
use ragdoll::{skeleton, spec};
use ragdoll_preview::{Marker, Preview, PreviewOptions};

fn main() {
    let character = skeleton::humanoid();
    let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
    let (mut world, _) = World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
    let blast = Blast::new(5.0, glam::Vec3::new(2.0, 0.5, 1.0), 0.2);
    world.add_blast(blast).unwrap();
    world.run(3.0);
    let track = world.into_track();
    let markers = [Marker::Blast {
        position: blast.position,
        time_s: blast.time_s,
        tnt_kg: blast.tnt_kg,
    }];
    let actors = [(&character, &spec, &track)];
    for supersample in [1, 2] {
        let options = PreviewOptions {
            supersample,
            ..Default::default()
        };
        let mut preview = Preview::new(&actors, &markers, &options).unwrap();
        let n = preview.frame_count();
        preview.render(0).unwrap();
        let started = Instant::now();
        for f in 0..n {
            std::hint::black_box(preview.render(f).unwrap());
        }
        let ms = started.elapsed().as_secs_f64() * 1000.0 / n as f64;
        println!(
            "render 640x480, supersample {supersample}: {ms:.1} ms/frame over {n} frames (humanoid, 5 kg blast)"
        );
    }
    // A skinned mesh (CesiumMan, 3 273 vertices, 4 672 triangles), when the shared data is there.
    let data = std::env::var_os("RAGDOLL_DATA")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data")
        });
    let cesium = data.join("gltf/CesiumMan.glb");
    if cesium.is_file() {
        let man = ragdoll::import::load(&cesium, &Default::default()).unwrap();
        let man_spec = spec::build_spec(&man, &spec::BuildOptions::default()).unwrap();
        let (mut world, _) =
            World::with_ragdoll(&man, &man_spec, &WorldSettings::default()).unwrap();
        world.run(3.0);
        let man_track = world.into_track();
        let mut preview = Preview::new(
            &[(&man, &man_spec, &man_track)],
            &[],
            &PreviewOptions::default(),
        )
        .unwrap();
        let n = preview.frame_count();
        let started = Instant::now();
        for f in 0..n {
            std::hint::black_box(preview.render(f).unwrap());
        }
        let ms = started.elapsed().as_secs_f64() * 1000.0 / n as f64;
        println!(
            "render 640x480, supersample 2: {ms:.1} ms/frame over {n} frames (CesiumMan skinned mesh)"
        );
    }
    let started = Instant::now();
    let gif = ragdoll_preview::gif(&actors, &markers, &PreviewOptions::default()).unwrap();
    println!(
        "whole GIF (render + palette + encode, every 2nd frame): {:.2} s, {} KiB",
        started.elapsed().as_secs_f64(),
        gif.len() / 1024
    );
}
