//! Any character file, told apart by its content, through role recognition and
//! `build_spec` into a world on every backend: what `ragdoll simulate FILE` does.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll::import::{ImportOptions, bvh, gltf, obj};
use ragdoll::rig::RigOptions;
use ragdoll::skeleton::Character;
use ragdoll::spec::{BuildOptions, build_spec};
use ragdoll_fuzz::{run_world, scratch_path};

fn import(data: &[u8]) -> Option<Character> {
    let opts = ImportOptions::default();
    if data.starts_with(b"glTF") {
        return gltf::from_bytes(data, &scratch_path("fuzz.glb")).ok();
    }
    if data.trim_ascii_start().starts_with(b"{") {
        return gltf::from_bytes(data, &scratch_path("fuzz.gltf")).ok();
    }
    let text = String::from_utf8_lossy(data);
    if text.trim_start().starts_with("HIERARCHY") {
        return bvh::parse(&text, &scratch_path("fuzz.bvh"), &opts).ok();
    }
    let path = scratch_path("fuzz.obj");
    let mesh = obj::parse(&text, &path, &opts).ok()?;
    let mut meshes = vec![mesh];
    let skeleton = ragdoll::rig::rig(&mut meshes, &RigOptions::default()).ok()?;
    Some(Character {
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        name: "fuzz".into(),
        skeleton,
        meshes,
        clips: Vec::new(),
        source: ragdoll::skeleton::Source::Mesh(path),
    })
}

fuzz_target!(|data: &[u8]| {
    let Some(character) = import(data) else {
        return;
    };
    let Ok(spec) = build_spec(&character, &BuildOptions::default()) else {
        return;
    };
    run_world(&character, &spec);
});
