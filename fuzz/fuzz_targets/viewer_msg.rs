//! The viewer's decoder and checks of a page's message (`parse_client_message`), against a
//! scene of two ragdolls (the humanoid's 15 bodies and 14 joints, and a small one).
#![no_main]

use libfuzzer_sys::fuzz_target;
use ragdoll_view::protocol::{SceneShape, parse_client_message};

fuzz_target!(|data: &[u8]| {
    // WebSocket text frames are UTF-8 by the protocol; the server never sees anything else.
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let shape = SceneShape {
        bodies: vec![15, 3],
        joints: vec![14, 2],
    };
    let _ = parse_client_message(text, &shape);
});
