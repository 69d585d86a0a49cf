//! What the fuzz targets share: a scratch folder to anchor file names in, and the run of
//! a ragdoll through a world on both backends (the deeper targets).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use ragdoll::skeleton::Character;
use ragdoll::spec::RagdollSpec;
use ragdoll::world::{BackendKind, World, WorldSettings};

/// Steps a deeper target runs per backend: enough for contacts, joints and the broad phase
/// to see the bodies, few enough to keep a run in milliseconds.
pub const WORLD_STEPS: usize = 8;

/// Most characters a scene target runs through the world: the example crowd's hundred fit
/// the time a fuzz input may take; larger scenes are parsed but not run.
pub const MAX_WORLD_CHARACTERS: usize = 128;

/// An empty folder (on tmpfs where there is one): the importers and the scene parser
/// resolve relative file names against the input's folder, so an input that names a file
/// next to itself finds nothing rather than a file of the repository. Nothing is ever
/// written into it, so every fuzzing process shares the one folder.
pub fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let dir = base.join("ragdoll-fuzz");
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    })
}

/// A file name in the scratch folder (never created: only named in errors and as the
/// anchor of relative names).
pub fn scratch_path(name: &str) -> PathBuf {
    scratch_dir().join(name)
}

/// Builds a world with `character` ragdolled by `spec` on each backend and steps it a
/// few times. Errors are fine (refusing an input is the point); panics, aborts, hangs and
/// runaway allocations are what the fuzzer reports.
pub fn run_world(character: &Character, spec: &RagdollSpec) {
    for backend in BackendKind::ALL {
        let settings = WorldSettings {
            backend: backend.into(),
            ..WorldSettings::default()
        };
        let Ok((mut world, _)) = World::with_ragdoll(character, spec, &settings) else {
            continue;
        };
        world.run(0.0);
        for _ in 0..WORLD_STEPS {
            world.step();
        }
    }
}
