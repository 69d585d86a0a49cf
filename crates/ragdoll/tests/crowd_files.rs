//! Crowds drawn from several files (`files`, `weights`) and clips that start part-way in
//! (`clip_offset_s`, `clip_offset_spread_s`), on character files built in code.

#[path = "scene_keys_files/mod.rs"]
mod scene_keys_files;

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use ragdoll::scene::Scene;
use scene_keys_files::person;

/// Frames per second of the walking clip, and how fast its root moves along X, m/s.
const FPS: usize = 30;
const WALK_MPS: f32 = 3.0;

/// The BVH person with a 2 s clip whose root slides along X at [`WALK_MPS`].
fn walker() -> String {
    let still = person(false);
    let (head, _) = still.split_once("MOTION").unwrap();
    let channels = 6 + 3 * 15;
    let frames: Vec<String> = (0..=2 * FPS)
        .map(|f| {
            let mut v = vec!["0".to_string(); channels];
            v[0] = format!("{}", WALK_MPS * f as f32 / FPS as f32);
            v.join(" ")
        })
        .collect();
    format!(
        "{head}MOTION\nFrames: {}\nFrame Time: {}\n{}\n",
        frames.len(),
        1.0 / FPS as f32,
        frames.join("\n")
    )
}

/// A scratch folder with `walk.bvh` and `stand.bvh`, removed when dropped.
struct Folder(PathBuf);

impl Folder {
    fn new() -> Folder {
        static NEXT: AtomicUsize = AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, Ordering::Relaxed);
        let dir =
            std::env::temp_dir().join(format!("ragdoll-crowd-files-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("walk.bvh"), walker()).unwrap();
        std::fs::write(dir.join("stand.bvh"), person(false)).unwrap();
        Folder(dir)
    }

    fn scene(&self, text: &str) -> Result<Scene, String> {
        let path = self.0.join("scene.toml");
        std::fs::write(&path, text).unwrap();
        Scene::load(&path).map_err(|e| e.to_string())
    }
}

impl Drop for Folder {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn pelvis_x(scene: &Scene) -> Vec<f32> {
    let (world, ids) = scene.build_world().unwrap();
    ids.iter()
        .map(|&id| world.body_poses(id)[0].translation.x)
        .collect()
}

#[test]
fn members_are_drawn_from_the_files_by_their_weights() {
    let folder = Folder::new();
    let scene = folder
        .scene(
            "[[crowd]]\ncount = 200\nspacing_m = 1.0\nfiles = [\"walk.bvh\", \"stand.bvh\"]\nweights = [3, 1]\nseed = 5\n",
        )
        .unwrap();
    let walkers = scene
        .characters
        .iter()
        .filter(|c| c.input.ends_with("walk.bvh"))
        .count();
    let standers = scene
        .characters
        .iter()
        .filter(|c| c.input.ends_with("stand.bvh"))
        .count();
    assert_eq!(walkers + standers, 200);
    // 3 : 1 of 200 draws is 150 ± 6 (one standard deviation); 4 deviations either way.
    assert!((126..=174).contains(&walkers), "{walkers} of 200");
}

#[test]
fn files_and_offsets_leave_the_rest_of_a_crowd_as_it_was() {
    // The same seed with files and clip offsets added: facings, heights and masses are
    // drawn as before, so a scene does not reshuffle when a table gains a key.
    let folder = Folder::new();
    let base = "[[crowd]]\ncount = 6\nfacing_spread_deg = 90\nheight = 1.7\nheight_spread = 0.1\nseed = 2\nactivate = 1.0\n";
    let looks = |scene: Scene| {
        scene
            .characters
            .iter()
            .map(|c| (c.facing_deg, c.character.skeleton.rest_height()))
            .collect::<Vec<_>>()
    };
    let one = folder
        .scene(&format!("{base}file = \"walk.bvh\"\n"))
        .unwrap();
    let two = folder
        .scene(&format!(
            "{base}files = [\"walk.bvh\"]\nclip_offset_s = 0.2\nclip_offset_spread_s = 0.5\n"
        ))
        .unwrap();
    assert_eq!(looks(one), looks(two));
}

#[test]
fn a_clip_offset_starts_the_clip_that_far_in() {
    // The clip's root slides at 3 m/s: started 0.5 s in, the character stands 1.5 m
    // further along at time 0, and the hand-over a second later keeps the clip's speed.
    let folder = Folder::new();
    let text =
        |offset: &str| format!("[[character]]\nfile = \"walk.bvh\"\nactivate = 1.0\n{offset}");
    let from_start = folder.scene(&text("")).unwrap();
    let offset = folder.scene(&text("clip_offset_s = 0.5\n")).unwrap();
    assert_eq!(offset.characters[0].clip_offset_s, 0.5);
    let (x0, x1) = (pelvis_x(&from_start)[0], pelvis_x(&offset)[0]);
    assert!(((x1 - x0) - 0.5 * WALK_MPS).abs() < 1e-3, "{x0} -> {x1}");
    // Past the clip's end its last frame holds: 1.8 s in, the hand-over at 1 s finds the
    // clip over, so the character stands still when physics takes over.
    let (mut world, ids) = offset.build_world().unwrap();
    world.run(0.9);
    let v = world.body_velocities(ids[0])[0].0;
    assert!((v.x - WALK_MPS).abs() < 0.1, "{v}");
    let late = folder.scene(&text("clip_offset_s = 1.8\n")).unwrap();
    let (mut world, ids) = late.build_world().unwrap();
    world.run(1.1);
    assert!(world.activated_at(ids[0]).is_some());
    let v = world.body_velocities(ids[0])[0].0;
    assert!(v.x.abs() < 0.5, "{v}");
}

#[test]
fn a_crowd_spreads_its_members_over_the_clip() {
    let folder = Folder::new();
    let scene = folder
        .scene(
            "[[crowd]]\ncount = 8\nfile = \"walk.bvh\"\nactivate = 1.0\nclip_offset_s = 0.25\nclip_offset_spread_s = 0.5\nseed = 1\n",
        )
        .unwrap();
    let offsets: Vec<f32> = scene.characters.iter().map(|c| c.clip_offset_s).collect();
    assert!(
        offsets.iter().all(|o| (0.25..=0.75).contains(o)),
        "{offsets:?}"
    );
    assert!(offsets.windows(2).any(|w| w[0] != w[1]), "{offsets:?}");
}

#[test]
fn file_weight_and_offset_mistakes_name_the_line_and_the_key() {
    let folder = Folder::new();
    for (text, needle) in [
        (
            "[[crowd]]\ncount = 2\nfile = \"walk.bvh\"\nfiles = [\"stand.bvh\"]\n",
            "line 4: [[crowd]] 1: files: give either file",
        ),
        (
            "[[crowd]]\ncount = 2\nweights = [1, 2]\n",
            "line 3: [[crowd]] 1: weights: needs files",
        ),
        (
            "[[crowd]]\ncount = 2\nfiles = [\"walk.bvh\", \"stand.bvh\"]\nweights = [1]\n",
            "line 4: [[crowd]] 1: weights: must give one weight per file: 2 files, 1 weights",
        ),
        (
            "[[crowd]]\ncount = 2\nfiles = [\"walk.bvh\"]\nweights = [-1]\n",
            "weights: must be finite and not negative, not -1",
        ),
        (
            "[[crowd]]\ncount = 2\nfiles = [\"walk.bvh\", \"stand.bvh\"]\nweights = [0, 0]\n",
            "weights: must not all be 0",
        ),
        (
            "[[crowd]]\ncount = 2\nfiles = []\n",
            "line 3: [[crowd]] 1: files: must list 1 to",
        ),
        (
            "[[crowd]]\ncount = 2\nfiles = [\"nowhere.bvh\"]\n",
            "line 3: [[crowd]] 1: files: ",
        ),
        (
            "[[character]]\nfile = \"walk.bvh\"\nclip_offset_s = 0.5\n",
            "line 3: [[character]] \"walk\": clip_offset_s: needs activate or powered",
        ),
        (
            "[[character]]\nfile = \"walk.bvh\"\nactivate = 1.0\nclip_offset_s = -1\n",
            "clip_offset_s: must be between 0 and",
        ),
        (
            "[[crowd]]\ncount = 2\nfile = \"walk.bvh\"\nactivate = 1.0\nclip_offset_spread_s = 1e9\n",
            "clip_offset_spread_s: must be between 0 and",
        ),
    ] {
        let e = folder.scene(text).map(|_| ()).unwrap_err();
        assert!(e.contains(needle), "{text}: {e}");
    }
}

#[test]
fn the_walking_clip_is_what_the_tests_think() {
    // The fixture itself: two seconds at 30 fps, the root 6 m along at the end.
    let folder = Folder::new();
    let c = ragdoll::import::load(&folder.0.join("walk.bvh"), &Default::default()).unwrap();
    let clip = &c.clips[0];
    assert_eq!(clip.frames.len(), 2 * FPS + 1);
    assert!((clip.duration() - 2.0).abs() < 1e-4);
}
