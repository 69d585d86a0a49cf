//! Scene TOML: settings, characters (the built-in humanoid and its spec, or files named
//! relative to an empty folder), events and outputs, all checked while parsing.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll::scene::Scene;
use ragdoll_fuzz::scratch_path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = Scene::from_toml(text, &scratch_path("scene.toml"));
});
