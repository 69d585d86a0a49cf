//! OBJ text into a rigged character, as `obj::load` does: the parser, then the automatic
//! rig (centre line, skin weights) of whatever mesh it read, and the humanoid fit
//! (`rig --humanoid`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll::import::{ImportOptions, obj};
use ragdoll::rig::{RigOptions, rig};
use ragdoll_fuzz::scratch_path;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let Ok(mesh) = obj::parse(&text, &scratch_path("fuzz.obj"), &ImportOptions::default()) else {
        return;
    };
    let _ = rig(&mut [mesh.clone()], &RigOptions::default());
    let humanoid = RigOptions {
        humanoid: true,
        ..Default::default()
    };
    let _ = rig(&mut [mesh], &humanoid);
});
