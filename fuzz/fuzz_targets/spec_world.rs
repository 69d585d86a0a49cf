//! A spec that parses, applied to the built-in humanoid and stepped on every backend: the
//! shapes and limits a user may write meet parry, rapier and the particle broad phase.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use ragdoll::skeleton::{Character, humanoid};
use ragdoll::spec::RagdollSpec;
use ragdoll_fuzz::{run_world, scratch_path};

fuzz_target!(|data: &[u8]| {
    static HUMANOID: OnceLock<Character> = OnceLock::new();
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(spec) = RagdollSpec::from_toml(text, &scratch_path("fuzz.spec.toml")) else {
        return;
    };
    run_world(HUMANOID.get_or_init(humanoid), &spec);
});
