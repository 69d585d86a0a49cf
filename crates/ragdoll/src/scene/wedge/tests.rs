use super::*;

const BASE: &str = r#"
duration_s = 0.3
backend = "fast"

[[character]]
name = "ann"
file = "chars/ann.glb"

[[crowd]]
count = 3
seed = 1

[[blast]]
tnt_kg = 1.0
position = [0.0, 0.5, 0.0]
"#;

fn wedge(vary: &str) -> Result<Option<Wedge>> {
    Wedge::from_toml(&format!("{BASE}{vary}"), Path::new("dir/shot.toml"))
}

fn message(vary: &str) -> String {
    wedge(vary).unwrap_err().to_string()
}

#[test]
fn a_scene_without_a_wedge_has_none() {
    assert!(wedge("").unwrap().is_none());
}

#[test]
fn cross_makes_every_combination_and_zip_pairs() {
    let vary = r#"
[[wedge.vary]]
key = "blast[0].tnt_kg"
values = [1, 2.5, 4]
[[wedge.vary]]
key = "blast[0].time_s"
range = { from = 0.1, to = 0.3, step = 0.1 }
"#;
    let w = wedge(vary).unwrap().unwrap();
    assert_eq!(w.len(), 9);
    let names: Vec<String> = w.variants().map(|v| v.name).collect();
    assert_eq!(names[0], "0_tnt_kg=1_time_s=0.1");
    assert_eq!(names[5], "5_tnt_kg=2.5_time_s=0.3");
    let unique: std::collections::HashSet<_> = names.iter().collect();
    assert_eq!(unique.len(), 9);
    let zipped = wedge(&format!("[wedge]\nmode = \"zip\"\n{vary}"))
        .unwrap()
        .unwrap();
    assert_eq!(zipped.len(), 3);
    assert_eq!(zipped.variant(2).name, "2_tnt_kg=4_time_s=0.3");
    assert_eq!(zipped.find("1_tnt_kg=2.5_time_s=0.2").unwrap().index, 1);
    assert_eq!(zipped.find("2").unwrap().index, 2);
    assert!(zipped.find("nope").is_none());
}

#[test]
fn the_variant_scene_has_the_values_and_no_wedge() {
    let w = wedge(
        r#"
[[wedge.vary]]
key = "blast[0].position[1]"
label = "height"
values = [0.25, 1.0]
[[wedge.vary]]
key = "backend"
values = ["rigid", "fast"]
"#,
    )
    .unwrap()
    .unwrap();
    let v = w.variant(1);
    assert_eq!(v.name, "1_height=0.25_backend=fast");
    let t = w.scene_table(&v);
    assert!(t.get("wedge").is_none());
    assert_eq!(t["backend"].as_str(), Some("fast"));
    assert_eq!(t["blast"][0]["position"][1].as_float(), Some(0.25));
    assert_eq!(t["blast"][0]["tnt_kg"].as_float(), Some(1.0));
}

#[test]
fn random_draws_repeat_with_the_seed_and_stay_in_bounds() {
    let vary = r#"
[[wedge.vary]]
key = "crowd[0].seed"
random = { count = 50, min = 1, max = 6, seed = 3 }
[[wedge.vary]]
key = "blast[0].position"
random = { count = 50, min = [-1.0, 0.0, -1.0], max = [1.0, 1.0, 1.0], seed = 3 }
"#;
    let (a, b) = (wedge(vary).unwrap().unwrap(), wedge(vary).unwrap().unwrap());
    assert_eq!(a.keys[0].values, b.keys[0].values);
    assert_eq!(a.len(), 2500);
    assert_eq!(
        a.seeds(&a.variant(51)),
        [(
            "crowd[0].seed".to_string(),
            a.keys[0].values[1].as_integer().unwrap()
        )]
    );
    let seeds: Vec<i64> = a.keys[0]
        .values
        .iter()
        .map(|v| v.as_integer().unwrap())
        .collect();
    assert!(seeds.iter().all(|s| (1..=6).contains(s)), "{seeds:?}");
    assert!(seeds.contains(&1) && seeds.contains(&6), "{seeds:?}");
    for v in &a.keys[1].values {
        let p = v.as_array().unwrap();
        let y = p[1].as_float().unwrap();
        assert!((0.0..=1.0).contains(&y));
    }
}

#[test]
fn mistakes_name_the_line_and_the_key() {
    let cases = [
        (
            "[[wedge.vary]]\nkey = \"blast[3].tnt_kg\"\nvalues = [1]\n",
            "blast[3]: the scene has 1",
        ),
        (
            "[[wedge.vary]]\nkey = \"blast[0].tnt_kg\"\nvalues = [\"big\"]\n",
            "does not fit",
        ),
        (
            "[[wedge.vary]]\nkey = \"blast[0].position\"\nvalues = [[1.0, 2.0]]\n",
            "does not fit",
        ),
        (
            "[[wedge.vary]]\nkey = \"bl ast\"\nvalues = [1]\n",
            "is not a key path",
        ),
        (
            "[[wedge.vary]]\nkey = \"duration_s\"\n",
            "give one of values, range or random",
        ),
        (
            "[[wedge.vary]]\nkey = \"duration_s\"\nrange = { from = 1, to = 0, step = 1 }\n",
            "never goes",
        ),
        (
            "[[wedge.vary]]\nkey = \"duration_s\"\nvalues = []\n",
            "has no values",
        ),
        (
            "[[wedge.vary]]\nkey = \"duration_s\"\nvalues = [1]\ncolour = 2\n",
            "unknown field",
        ),
        (
            "[wedge]\nmode = \"zip\"\n[[wedge.vary]]\nkey = \"duration_s\"\nvalues = [1]\n[[wedge.vary]]\nkey = \"fps\"\nvalues = [1, 2]\n",
            "pairs lists of one length",
        ),
        (
            "[[wedge.vary]]\nkey = \"blast[0].time_s\"\nvalues = [1]\n[[wedge.vary]]\nkey = \"crowd[0].time_s\"\nvalues = [1]\n",
            "give one of them another label",
        ),
        (
            "[[wedge.vary]]\nkey = \"duration_s\"\nrange = { from = 0, to = 1000000, step = 1 }\n",
            "more than 100000",
        ),
        ("[wedge]\n", "has no [[wedge.vary]]"),
    ];
    for (vary, expected) in cases {
        let m = message(vary);
        assert!(m.starts_with("dir/shot.toml: line "), "{m}");
        assert!(m.contains(expected), "{vary}: {m}");
    }
    let cross = (0..6)
        .map(|i| format!("[[wedge.vary]]\nkey = \"k{i}\"\nvalues = [1,2,3,4,5,6,7,8,9,10]\n"))
        .collect::<String>();
    assert!(message(&cross).contains("every combination makes more than"));
    let line = message("\n\n[[wedge.vary]]\nkey = \"nothing.x\"\nvalues = [1]\n");
    assert!(
        line.contains("line 18: [[wedge.vary]] 1: key: nothing.x: the scene has no nothing"),
        "{line}"
    );
}

#[test]
fn files_are_rebased_and_listed() {
    let root = std::env::temp_dir().join(format!("ragdoll-wedge-{}", std::process::id()));
    let (scene_dir, out) = (root.join("scenes"), root.join("job/v"));
    std::fs::create_dir_all(&scene_dir).unwrap();
    std::fs::create_dir_all(&out).unwrap();
    let text = format!(
        "{BASE}[[wedge.vary]]\nkey = \"character[0].file\"\nvalues = [\"a.glb\", \"/abs/b.glb\"]\n"
    );
    let w = Wedge::from_toml(&text, &scene_dir.join("shot.toml"))
        .unwrap()
        .unwrap();
    let scene = w.scene_text(&w.variant(0), &out).unwrap();
    assert!(scene.contains("file = \"../../scenes/a.glb\""), "{scene}");
    assert!(!scene.contains("wedge"), "{scene}");
    let abs = w.scene_text(&w.variant(1), &out).unwrap();
    assert!(abs.contains("file = \"/abs/b.glb\""), "{abs}");
    let inputs = w.input_files();
    assert_eq!(
        inputs,
        [
            scene_dir.join("shot.toml"),
            scene_dir.join("chars/ann.glb"),
            scene_dir.join("a.glb"),
            PathBuf::from("/abs/b.glb"),
        ]
    );
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn a_scene_with_a_wedge_still_reads_as_its_base() {
    let text = "duration_s = 0.3\n[[character]]\nname = \"a\"\n[[wedge.vary]]\nkey = \"duration_s\"\nvalues = [0.2]\n";
    let scene = crate::scene::Scene::from_toml(text, Path::new("s.toml")).unwrap();
    assert_eq!(scene.duration_s, 0.3);
}

#[test]
fn relative_paths_climb_to_the_common_folder() {
    let rel = |t: &str, b: &str| relative_path(Path::new(t), Path::new(b));
    assert_eq!(rel("/a/b/c.glb", "/a/b"), PathBuf::from("c.glb"));
    assert_eq!(rel("/a/b/c.glb", "/a/x/y"), PathBuf::from("../../b/c.glb"));
    assert_eq!(rel("/a/./c.glb", "/a"), PathBuf::from("c.glb"));
    assert_eq!(rel("/c.glb", "/"), PathBuf::from("c.glb"));
}

#[test]
fn job_files_store_relative_paths_with_forward_slashes() {
    let built: PathBuf = ["..", "chars", "a.glb"].iter().collect();
    assert_eq!(portable_path(&built), "../chars/a.glb");
    assert_eq!(portable_path(Path::new("a.glb")), "a.glb");
    assert_eq!(portable_path(Path::new("/abs/a.glb")), "/abs/a.glb");
}

#[test]
fn covering_variants_hold_every_value_of_every_key() {
    let vary = r#"
[[wedge.vary]]
key = "blast[0].tnt_kg"
values = [1, 2, 3, 4]
[[wedge.vary]]
key = "blast[0].time_s"
values = [0.1, 0.2]
[[wedge.vary]]
key = "crowd[0].seed"
values = [5, 6, 7]
"#;
    let w = wedge(vary).unwrap().unwrap();
    let cover = w.covering_variants(64);
    assert_eq!(cover.first(), Some(&0));
    assert_eq!(cover.last(), Some(&(w.len() - 1)));
    for (k, key) in w.keys.iter().enumerate() {
        for value in &key.values {
            assert!(
                cover.iter().any(|&i| &w.variant(i).values[k].1 == value),
                "{} = {value} in none of {cover:?}",
                key.key
            );
        }
    }
    assert!(cover.len() <= 4, "{cover:?}");
    // Capped: evenly spread, the ends kept.
    let many = wedge(
        "[[wedge.vary]]\nkey = \"blast[0].tnt_kg\"\nrange = { from = 1, to = 1000, step = 1 }\n",
    )
    .unwrap()
    .unwrap();
    let few = many.covering_variants(10);
    assert_eq!(few.len(), 10);
    assert_eq!((few[0], few[9]), (0, 999));
    assert!(few.windows(2).all(|p| p[1] - p[0] >= 100), "{few:?}");
    let zipped = wedge(&format!("[wedge]\nmode = \"zip\"\n{}", "[[wedge.vary]]\nkey = \"blast[0].tnt_kg\"\nvalues = [1, 2]\n[[wedge.vary]]\nkey = \"blast[0].time_s\"\nvalues = [0.1, 0.2]\n"))
        .unwrap()
        .unwrap();
    assert_eq!(zipped.covering_variants(64), vec![0, 1]);
}
