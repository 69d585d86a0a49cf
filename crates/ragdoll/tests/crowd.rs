//! `[[crowd]]` tables: many characters from one description, placed and varied from a
//! seed, checked as `[[character]]` tables are, with mistakes named by table, line and key.

use std::path::Path;

use ragdoll::error::Error;
use ragdoll::scene::Scene;

fn parse(text: &str) -> Result<Scene, Error> {
    Scene::from_toml(text, Path::new("crowd.toml"))
}

const CROWD: &str = "
[[crowd]]
count = 9
spacing_m = 2.0
center = [10.0, 0.0, 0.0]
facing_spread_deg = 90
height = 1.7
height_spread = 0.1
mass_kg = 70
mass_spread = 0.2
female_share = 0.5
seed = 3
";

#[test]
fn a_crowd_is_its_characters_placed_and_varied_within_its_bounds() {
    let scene = parse(CROWD).unwrap();
    assert_eq!(scene.characters.len(), 9);
    for (k, c) in scene.characters.iter().enumerate() {
        assert_eq!(c.name, format!("crowd1-{}", k + 1));
        // A 3 × 3 grid 2 m apart round (10, 0, 0), row by row along X.
        let expect = glam::Vec3::new(
            10.0 + 2.0 * (k % 3) as f32 - 2.0,
            0.0,
            2.0 * (k / 3) as f32 - 2.0,
        );
        assert!(
            c.position.distance(expect) < 1e-5,
            "{}: {}",
            c.name,
            c.position
        );
        assert!(c.facing_deg.abs() <= 90.0, "{}", c.facing_deg);
        let h = c.character.skeleton.rest_height();
        assert!((1.7 * 0.9 - 1e-3..=1.7 * 1.1 + 1e-3).contains(&h), "{h}");
        let m = c.spec.total_mass_kg();
        assert!((70.0 * 0.8 - 1e-3..=70.0 * 1.2 + 1e-3).contains(&m), "{m}");
    }
    // They do vary, and both segment tables are used.
    let facings: Vec<f32> = scene.characters.iter().map(|c| c.facing_deg).collect();
    assert!(facings.windows(2).any(|w| w[0] != w[1]));
    let masses: Vec<f32> = scene
        .characters
        .iter()
        .map(|c| c.spec.total_mass_kg())
        .collect();
    assert!(masses.windows(2).any(|w| (w[0] - w[1]).abs() > 0.1));
}

#[test]
fn the_same_seed_gives_the_same_crowd_and_another_seed_another() {
    let looks = |text: &str| {
        parse(text)
            .unwrap()
            .characters
            .iter()
            .map(|c| {
                (
                    c.facing_deg,
                    c.spec.total_mass_kg(),
                    c.character.skeleton.rest_height(),
                )
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(looks(CROWD), looks(CROWD));
    assert_ne!(looks(CROWD), looks(&CROWD.replace("seed = 3", "seed = 4")));
}

#[test]
fn a_scattered_crowd_keeps_its_spacing() {
    let text = "[[crowd]]\ncount = 40\nformation = \"scatter\"\nspacing_m = 1.5\nseed = 9\n";
    let scene = parse(text).unwrap();
    let p: Vec<glam::Vec3> = scene.characters.iter().map(|c| c.position).collect();
    assert_eq!(p.len(), 40);
    for i in 0..p.len() {
        for j in 0..i {
            assert!(p[i].distance(p[j]) >= 1.5 - 1e-4, "{} and {}", p[i], p[j]);
        }
    }
}

#[test]
fn crowds_and_characters_share_a_scene_and_its_bounds() {
    let text = "[[character]]\nname = \"solo\"\nposition = [50.0, 0.0, 0.0]\n[[crowd]]\ncount = 4\n[[crowd]]\ncount = 2\ncenter = [0.0, 0.0, 20.0]\n";
    let names: Vec<String> = parse(text)
        .unwrap()
        .characters
        .iter()
        .map(|c| c.name.clone())
        .collect();
    assert_eq!(
        names,
        [
            "solo", "crowd1-1", "crowd1-2", "crowd1-3", "crowd1-4", "crowd2-1", "crowd2-2"
        ]
    );
    let max = ragdoll::scene::MAX_CHARACTERS;
    let e = parse(&format!("[[character]]\n[[crowd]]\ncount = {max}\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains(&format!("at most {max} characters")), "{e}");
}

#[test]
fn crowd_mistakes_name_the_line_and_the_key() {
    for (text, needle) in [
        (
            "[[crowd]]\ncount = 0\n",
            "line 2: [[crowd]] 1: count: must be between 1 and",
        ),
        (
            "[[crowd]]\ncount = 3\nspacing_m = 0.1\n",
            "line 3: [[crowd]] 1: spacing_m: must be between 0.3 and 100",
        ),
        (
            "[[crowd]]\ncount = 3\nheight_spread = 0.1\n",
            "[[crowd]] 1: height_spread: needs height",
        ),
        (
            "[[crowd]]\ncount = 3\nmass_spread = 0.1\n",
            "[[crowd]] 1: mass_spread: needs mass_kg",
        ),
        (
            "[[crowd]]\ncount = 3\nfemale_share = 2\n",
            "line 3: [[crowd]] 1: female_share: must be between 0 and 1",
        ),
        ("[[crowd]]\ncount = 3\nformation = \"ring\"\n", "formation"),
        ("[[crowd]]\nspacing_m = 2\n", "count"),
        ("[[crowd]]\ncount = 3\ncolour = 1\n", "colour"),
        (
            "[[crowd]]\ncount = 2\nfile = \"nowhere.glb\"\n",
            "line 3: [[crowd]] 1: file: nowhere.glb",
        ),
        (
            "[[crowd]]\ncount = 2\nheight = 0\n",
            "line 3: [[crowd]] 1: height: must be between",
        ),
        (
            "[[crowd]]\ncount = 2\nclip = 1\n",
            "[[crowd]] 1: clip: the built-in humanoid is not a file",
        ),
    ] {
        let e = parse(text).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains(needle), "{text}: {e}");
        assert!(e.starts_with("crowd.toml"), "{e}");
    }
}

#[test]
fn a_member_the_world_refuses_is_named_by_its_crowd() {
    // Two built-in humanoids 0.3 m apart start inside each other: the world's refusal
    // names the member and the crowd table it comes from, at the table's line.
    let scene = parse("duration_s = 1\n[[crowd]]\ncount = 2\nspacing_m = 0.3\n").unwrap();
    let e = scene.build_world().map(|_| ()).unwrap_err().to_string();
    assert!(
        e.contains("line 2: [[crowd]] 1 \"crowd1-2\": placement:"),
        "{e}"
    );
}
