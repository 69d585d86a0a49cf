//! Spec TOML: parsing, the joint-key checks and `RagdollSpec::validate`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll::spec::RagdollSpec;
use ragdoll_fuzz::scratch_path;

fuzz_target!(|data: &[u8]| {
    // Specs are read as UTF-8 text; other bytes are refused before parsing.
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = RagdollSpec::from_toml(text, &scratch_path("fuzz.spec.toml"));
});
