//! glTF bytes into a character: the GLB container, the JSON (with `data:` URIs), accessors,
//! skins and clips, and the rigging of a mesh without a skin.
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll::import::gltf;
use ragdoll_fuzz::scratch_path;

fuzz_target!(|data: &[u8]| {
    // Named as a user would name it: a .glb refuses bytes without the GLB magic. Relative
    // URIs resolve in an empty scratch folder.
    let name = if data.starts_with(b"glTF") {
        "fuzz.glb"
    } else {
        "fuzz.gltf"
    };
    let _ = gltf::from_bytes(data, &scratch_path(name));
});
