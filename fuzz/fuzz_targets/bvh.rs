//! BVH text into a character: the hierarchy and motion parser, unit and up-axis detection.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll::import::{ImportOptions, bvh};
use ragdoll_fuzz::scratch_path;

fuzz_target!(|data: &[u8]| {
    // As `bvh::load` reads a file: any bytes, invalid UTF-8 replaced.
    let text = String::from_utf8_lossy(data);
    let _ = bvh::parse(&text, &scratch_path("fuzz.bvh"), &ImportOptions::default());
});
