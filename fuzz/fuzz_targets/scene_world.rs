//! A scene that parses, run for a few steps and encoded to its outputs (glTF, BVH,
//! report) in memory: placements, events, pins and fields meet the world and exporters.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll::scene::Scene;
use ragdoll_fuzz::{MAX_WORLD_CHARACTERS, WORLD_STEPS, scratch_path};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(mut scene) = Scene::from_toml(text, &scratch_path("scene.toml")) else {
        return;
    };
    // The events and the world are what is under test, not the length of the run or the
    // size of a crowd: 803 built-in humanoids (a mutated crowd count) took 1.2 s to step 8
    // times and encode in a release build, past the 10 s a fuzz input may take under
    // AddressSanitizer. Parsing any crowd is still fuzzed (scene_toml, and above).
    if scene.characters.len() > MAX_WORLD_CHARACTERS {
        return;
    }
    scene.duration_s = scene.duration_s.min(WORLD_STEPS as f32 * scene.settings.dt);
    let Ok(result) = scene.run() else {
        return;
    };
    let _ = scene.encode(&result);
});
