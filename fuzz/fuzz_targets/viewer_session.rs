//! A page's messages, one per line, checked and handled by the viewer's own session (through
//! `ragdoll_view::headless`, the server's code without the server), a step after each: the
//! path by which messages the checks accepted reached the particle broad phase and crashed
//! the server.
#![no_main]

use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use ragdoll::scene::Scene;
use ragdoll::skeleton::humanoid;
use ragdoll::spec::{BuildOptions, build_spec};
use ragdoll::world::WorldSettings;
use ragdoll_fuzz::WORLD_STEPS;
use ragdoll_view::headless::HeadlessSession;
use ragdoll_view::protocol::ClientMsg;

/// Messages read per input: each may rebuild and replay the world, which costs
/// milliseconds.
const MAX_MESSAGES: usize = 12;

fn start_scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        let character = humanoid();
        let spec = build_spec(&character, &BuildOptions::default()).expect("humanoid spec");
        Scene::single(character, spec, "built-in", 0.0, WorldSettings::default())
    })
}

/// Where Save writes (one file, `fuzz.toml`, replaced only when a message says so): beside
/// the shared scratch folder, which must stay empty.
fn save_dir() -> std::path::PathBuf {
    let dir = ragdoll_fuzz::scratch_dir().with_file_name("ragdoll-fuzz-saves");
    std::fs::create_dir_all(&dir).expect("save folder");
    dir
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(mut session) = HeadlessSession::new(start_scene().clone(), save_dir()) else {
        return;
    };
    let mut accepted = 0;
    for line in text.lines() {
        if accepted == MAX_MESSAGES {
            break;
        }
        if session.message(line) {
            accepted += 1;
            session.handle(ClientMsg::Step {});
        }
    }
    if accepted == 0 {
        return;
    }
    for _ in 0..WORLD_STEPS {
        session.handle(ClientMsg::Step {});
    }
});
