//! The table `flags.rs` runs: one row per flag of each subcommand, a valid and an invalid
//! command line, what the valid run must show and what the error must mention. Rows are
//! kept one to a line (rustfmt would spread each over nine), so the table reads as one.

use std::path::Path;
use std::process::Output;

use crate::fixture::{json, out};

/// What a valid run must show beyond succeeding.
pub type Effect = fn(&Path, &Output);

/// One flag of one subcommand.
pub struct Case {
    pub sub: &'static str,
    pub flag: &'static str,
    /// A full command line where the flag has a valid value.
    pub valid: Vec<String>,
    pub effect: Option<Effect>,
    /// A full command line where it has an invalid one, and what the error must mention.
    pub invalid: Vec<String>,
    pub needle: &'static str,
}

/// A row: `base` + `valid`, `base` + `invalid`.
fn case(
    sub: &'static str,
    flag: &'static str,
    base: &[&str],
    valid: &[&str],
    effect: Option<Effect>,
    invalid: &[&str],
    needle: &'static str,
) -> Case {
    let join = |extra: &[&str]| base.iter().chain(extra).map(|s| s.to_string()).collect();
    Case {
        sub,
        flag,
        valid: join(valid),
        effect,
        invalid: join(invalid),
        needle,
    }
}

// What valid runs must show. Single-character runs write `out.glb` and
// `out.report.json`; demo writes `made/`; the runner saves what `inspect --json` printed
// as `inspect.json`.

fn report(dir: &Path) -> serde_json::Value {
    for name in ["out.report.json", "made/report.json", "inspect.json"] {
        if dir.join(name).exists() {
            return json(&dir.join(name));
        }
    }
    panic!("no report in {}", dir.display());
}

fn total_mass(dir: &Path) -> f64 {
    let r = report(dir);
    // A run's report lists its characters; `inspect --json` describes one.
    r["characters"][0]["total_mass_kg"]
        .as_f64()
        .or(r["total_mass_kg"].as_f64())
        .unwrap()
}

fn number(dir: &Path, pointer: &str) -> f64 {
    let r = report(dir);
    r.pointer(pointer)
        .and_then(|v| v.as_f64())
        .unwrap_or_else(|| panic!("no number at {pointer} in {r}"))
}

/// `inspect --json --roles roles.toml`: the ignored hand has no role, and says why.
fn hand_l_from_file(dir: &Path, _: &Output) {
    let r = report(dir);
    let hand = r["joints"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["name"] == "hand_l")
        .unwrap();
    assert_eq!(hand["role"], serde_json::Value::Null, "{hand}");
    assert_eq!(hand["role_from_file"], true, "{hand}");
}

fn helps(_: &Path, o: &Output) {
    assert!(out(o).contains("Usage:"), "{}", out(o));
}
fn mass_80(dir: &Path, _: &Output) {
    assert!((total_mass(dir) - 80.0).abs() < 0.01, "{}", total_mass(dir));
}
fn spec_90(dir: &Path, _: &Output) {
    assert!(
        (total_mass(dir) - 90.0).abs() < 0.01,
        "the spec says 90 kg: {}",
        total_mass(dir)
    );
}
fn particle(dir: &Path, _: &Output) {
    assert_eq!(report(dir)["backend"], "particle");
}
fn frames_16(dir: &Path, _: &Output) {
    assert_eq!(report(dir)["frames"], 16, "0.5 s at 30 fps");
}
fn frames_3(dir: &Path, _: &Output) {
    assert_eq!(report(dir)["frames"], 3, "0.2 s at 10 fps");
}
fn png_written(dir: &Path, o: &Output) {
    assert_eq!(&std::fs::read(dir.join("p.png")).unwrap()[..4], b"\x89PNG");
    assert!(out(o).contains("p.png"), "{}", out(o));
}
fn demo_written(dir: &Path, _: &Output) {
    assert!(dir.join("made/demo.glb").is_file());
}
fn bvh_written(dir: &Path, _: &Output) {
    let text = std::fs::read_to_string(dir.join("out.bvh")).unwrap();
    assert!(text.starts_with("HIERARCHY"));
}
fn glb_written(dir: &Path, _: &Output) {
    assert_eq!(&std::fs::read(dir.join("out.glb")).unwrap()[..4], b"glTF");
}
fn seven_objs(dir: &Path, _: &Output) {
    let n = std::fs::read_dir(dir.join("seq")).unwrap().count();
    assert_eq!(n, 7, "one OBJ per frame: 0.2 s at 30 fps");
}
fn tnt_2(dir: &Path, _: &Output) {
    assert_eq!(number(dir, "/blasts/0/tnt_kg"), 2.0);
}
fn at_minus_3(dir: &Path, _: &Output) {
    assert_eq!(
        report(dir)["blasts"][0]["position"],
        serde_json::json!([-3.0, 1.0, 0.0])
    );
}
fn blast_at_0_1(dir: &Path, _: &Output) {
    assert!((number(dir, "/blasts/0/time_s") - 0.1).abs() < 1e-6);
}
fn from_behind(dir: &Path, _: &Output) {
    assert_eq!(
        report(dir)["projectiles"][0]["origin"],
        serde_json::json!([0.0, 1.66, -5.0])
    );
}
fn hits_head(dir: &Path, _: &Output) {
    assert_eq!(report(dir)["projectiles"][0]["body"], "head");
}
fn heavier_bullet(dir: &Path, _: &Output) {
    let j = number(dir, "/projectiles/0/impulse_ns");
    assert!((j - 0.016 * 360.0).abs() < 1e-3, "{j}");
    assert!(
        (total_mass(dir) - 75.0).abs() < 0.01,
        "the character keeps its mass"
    );
}
fn slower_bullet(dir: &Path, _: &Output) {
    let j = number(dir, "/projectiles/0/impulse_ns");
    assert!((j - 0.008 * 100.0).abs() < 1e-3, "{j}");
}
fn shot_at_0_1(dir: &Path, _: &Output) {
    assert!((number(dir, "/projectiles/0/time_s") - 0.1).abs() < 1e-6);
}
fn json_bodies(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert!(v["bodies"].as_array().unwrap().len() >= 13);
}
fn spec_written(dir: &Path, _: &Output) {
    let text = std::fs::read_to_string(dir.join("built.toml")).unwrap();
    assert!(text.contains("[[bodies]]"));
}
fn seven_joints(_: &Path, o: &Output) {
    assert!(out(o).contains(": 7 joints"), "{}", out(o));
}
// The bar is symmetric end to end: the head goes to the end named.
fn head_at_minus_x(_: &Path, o: &Output) {
    assert!(out(o).contains("head joint at (-0.8"), "{}", out(o));
}
// A person's skeleton: pelvis, spine, chest, neck, head and three joints a limb.
fn person_joints(_: &Path, o: &Output) {
    assert!(out(o).contains(": 17 joints"), "{}", out(o));
}
fn rig_written(dir: &Path, _: &Output) {
    assert_eq!(&std::fs::read(dir.join("rig.glb")).unwrap()[..4], b"glTF");
}
fn mirrored_leg(_: &Path, o: &Output) {
    assert!(out(o).contains(": 18 joints"), "12 + 3 a side: {}", out(o));
}
fn single_leg(_: &Path, o: &Output) {
    assert!(out(o).contains(": 15 joints"), "12 + 3: {}", out(o));
}
fn two_sizes(_: &Path, o: &Output) {
    assert!(
        out(o).contains("N=1 ") && out(o).contains("N=3 "),
        "{}",
        out(o)
    );
}
fn two_thread_counts(_: &Path, o: &Output) {
    assert!(
        out(o).contains("threads=1 ") && out(o).contains("threads=2 "),
        "{}",
        out(o)
    );
}
fn bench_json(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["ragdolls"], 2);
}
fn bench_no_freeze(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["freeze_joints"], false);
}
fn bench_eight_substeps(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["fast_substeps"], 8);
}
fn bench_kept_contacts(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["keep_contacts"], true);
}
fn bench_two_passes(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["fast_iterations"], 2);
}
fn bench_no_impact_passes(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["fast_impact_passes"], 0);
}
fn bench_pile_of_two(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["pile_height"], 2);
}
fn bench_motors(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["runs"][0]["motors"], 0.5);
}
fn farm_bench(_: &Path, o: &Output) {
    let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
    assert_eq!(v["variants"], 2);
}
fn tables_only(dir: &Path, _: &Output) {
    assert!(dir.join("job/results.csv").is_file(), "no job/results.csv");
    assert!(
        !dir.join("job/contact-sheet-001.png").exists(),
        "a contact sheet written"
    );
}
fn bench_particle(_: &Path, o: &Output) {
    assert!(out(o).contains("particle"), "{}", out(o));
}
fn split_written(dir: &Path, _: &Output) {
    assert!(dir.join("sc/solo.glb").is_file(), "no sc/solo.glb");
    assert!(
        !dir.join("sc/scene.glb").exists(),
        "sc/scene.glb written too"
    );
}
fn bench_compare(_: &Path, o: &Output) {
    let text = out(o);
    assert!(
        text.contains("pile  particle")
            && text.contains("pile  rigid")
            && text.contains("particle / rigid: "),
        "{text}"
    );
}
fn bench_reference(_: &Path, o: &Output) {
    let text = out(o);
    assert!(
        text.contains("pile  plain-rapier") && text.contains("fast / plain rapier: "),
        "{text}"
    );
}
fn gif_written(dir: &Path, _: &Output) {
    assert_eq!(&std::fs::read(dir.join("p.gif")).unwrap()[..6], b"GIF89a");
}
fn png_64x48(dir: &Path, _: &Output) {
    let png = std::fs::read(dir.join("p.png")).unwrap();
    assert_eq!(&png[16..24], &[0, 0, 0, 64, 0, 0, 0, 48]);
}
fn commands_listed(_: &Path, o: &Output) {
    assert!(out(o).contains("Commands:"));
}
fn version(_: &Path, o: &Output) {
    assert!(out(o).starts_with("ragdoll "));
}

/// `--help` prints help; given a value it is an error.
fn help(sub: &'static str, base: &[&str]) -> Case {
    case(
        sub,
        "--help",
        base,
        &["--help"],
        Some(helps),
        &["--help=yes"],
        "--help",
    )
}

/// `--mass`, `--female`, `--spec`; with `effects`, the total mass reported is checked.
#[rustfmt::skip]
fn ragdoll_rows(sub: &'static str, base: &[&str], effects: bool) -> Vec<Case> {
    let (mass, spec): (Option<Effect>, Option<Effect>) =
        if effects { (Some(mass_80), Some(spec_90)) } else { (None, None) };
    vec![
        case(sub, "--mass", base, &["--mass", "80"], mass, &["--mass", "-5"], "--mass"),
        case(sub, "--female", base, &["--female"], None, &["--female", "--spec", "spec.toml"], "--female"),
        case(sub, "--spec", base, &["--spec", "spec.toml"], spec, &["--spec", "missing.toml"], "missing.toml"),
        // The runner writes roles.toml (`ignore = ["hand_l"]`) and bad_roles.toml (a role
        // given a joint the skeleton lacks, on line 2).
        case(sub, "--roles", base, &["--roles", "roles.toml"], (sub == "inspect").then_some(hand_l_from_file as Effect), &["--roles", "bad_roles.toml"], "bad_roles.toml: line 2: thigh_l"),
    ]
}

/// `--units` and `--up`, on a file that does not say (BVH, OBJ).
#[rustfmt::skip]
fn import_rows(sub: &'static str, base: &[&str]) -> Vec<Case> {
    vec![
        case(sub, "--units", base, &["--units", "m"], None, &["--units", "furlong"], "--units"),
        case(sub, "--up", base, &["--up", "y"], None, &["--up", "x"], "--up"),
    ]
}

/// [`import_rows`] and `--height`, `--clip`, for commands that read a character (not
/// `rig`, which reads a mesh). The fixture's BVH has one clip.
#[rustfmt::skip]
fn character_import_rows(sub: &'static str, base: &[&str]) -> Vec<Case> {
    let mut t = import_rows(sub, base);
    t.extend([
        case(sub, "--height", base, &["--height", "1.5"], None, &["--height", "0"], "--height"),
        case(sub, "--clip", base, &["--clip", "0"], None, &["--clip", "1"], "--clip"),
    ]);
    t
}

/// `--backend`, `--seconds`, `--fps`, `--joint-damping`, `--preview`, `--no-freeze`. clap refuses a flag given twice, so
/// `base` has no --seconds and each row adds one.
#[rustfmt::skip]
fn run_rows(sub: &'static str, base: &[&str]) -> Vec<Case> {
    const S: [&str; 2] = ["--seconds", "0.2"];
    vec![
        case(sub, "--backend", base, &[&S[..], &["--backend", "particle"]].concat(), Some(particle), &["--backend", "soft"], "--backend"),
        case(sub, "--seconds", base, &["--seconds", "0.5"], Some(frames_16), &["--seconds", "-1"], "--seconds"),
        case(sub, "--fps", base, &[&S[..], &["--fps", "10"]].concat(), Some(frames_3), &[&S[..], &["--fps", "0"]].concat(), "--fps"),
        case(sub, "--joint-damping", base, &[&S[..], &["--joint-damping", "1.5"]].concat(), None, &[&S[..], &["--backend", "particle", "--joint-damping", "1"]].concat(), "--joint-damping"),
        case(sub, "--preview", base, &[&S[..], &["--preview", "p.png"]].concat(), Some(png_written), &[&S[..], &["--preview", "p.jpg"]].concat(), "--preview"),
        case(sub, "--no-freeze", base, &[&S[..], &["--backend", "fast", "--no-freeze"]].concat(), None, &[&S[..], &["--no-freeze=yes"]].concat(), "--no-freeze"),
    ]
}

/// `--rest-pose`, `--activate`, `--powered`, `--fade-out`, `--root-on-clip`: `base` runs
/// an animated character (they need an animation).
#[rustfmt::skip]
fn anim_rows(sub: &'static str, base: &[&str]) -> Vec<Case> {
    vec![
        case(sub, "--rest-pose", base, &["--rest-pose"], None, &["--rest-pose=yes"], "--rest-pose"),
        case(sub, "--activate", base, &["--activate", "0.1"], None, &["--activate", "soon"], "--activate"),
        case(sub, "--powered", base, &["--powered", "0.5"], None, &["--powered", "2"], "--powered"),
        case(sub, "--fade-out", base, &["--powered", "1", "--fade-out", "0.05,0.15"], None, &["--powered", "1", "--fade-out", "1"], "--fade-out"),
        case(sub, "--root-on-clip", base, &["--powered", "1", "--root-on-clip"], None, &["--root-on-clip"], "--powered"),
    ]
}

#[rustfmt::skip]
fn demo() -> Vec<Case> {
    let short = &["demo", "-o", "made", "--seconds", "0.2"];
    let mut t = vec![
        help("demo", &["demo"]),
        case("demo", "--output", &["demo", "--seconds", "0.2"], &["--output", "made"], Some(demo_written), &["--output", "anim.bvh"], "anim.bvh"),
    ];
    t.extend(ragdoll_rows("demo", short, true));
    t.extend(run_rows("demo", &["demo", "-o", "made"]));
    t
}

#[rustfmt::skip]
fn simulate() -> Vec<Case> {
    let short = &["simulate", "anim.bvh", "-o", "out.glb", "--seconds", "0.2"];
    let mut t = vec![
        help("simulate", &["simulate"]),
        case("simulate", "--output", &["simulate", "anim.bvh", "--seconds", "0.2"], &["--output", "out.bvh"], Some(bvh_written), &["--output", "out.fbx"], "out.fbx"),
        case("simulate", "--obj-sequence", short, &["--obj-sequence", "seq"], Some(seven_objs), &["--obj-sequence", "anim.bvh"], "anim.bvh"),
        case("simulate", "--split", &["simulate", "scene.toml", "-o", "sc"], &["--split"], Some(split_written), &["--split=yes"], "--split"),
    ];
    t.extend(ragdoll_rows("simulate", short, true));
    t.extend(character_import_rows("simulate", short));
    t.extend(run_rows("simulate", &["simulate", "anim.bvh", "-o", "out.glb"]));
    t.extend(anim_rows("simulate", short));
    t
}

#[rustfmt::skip]
fn blast() -> Vec<Case> {
    let short = &["blast", "--tnt", "1", "--at", "3,1,0", "-o", "out.glb", "--seconds", "0.2"];
    let animated = &["blast", "anim.bvh", "--tnt", "1", "--at", "3,1,0", "-o", "out.glb", "--seconds", "0.2"];
    let mut t = vec![
        help("blast", &["blast"]),
        case("blast", "--tnt", &["blast", "--at", "3,1,0", "-o", "out.glb", "--seconds", "0.2"], &["--tnt", "2"], Some(tnt_2), &["--tnt", "-1"], "--tnt"),
        case("blast", "--at", &["blast", "--tnt", "1", "-o", "out.glb", "--seconds", "0.2"], &["--at", "-3,1,0"], Some(at_minus_3), &["--at", "3,1"], "--at"),
        case("blast", "--time", short, &["--time", "0.1"], Some(blast_at_0_1), &["--time", "5"], "--time"),
        case("blast", "--scale", short, &["--scale", "2"], None, &["--scale", "-1"], "--scale"),
        case("blast", "--output", &["blast", "--tnt", "1", "--at", "3,1,0", "--seconds", "0.2"], &["--output", "out.glb"], Some(glb_written), &["--output", "out.fbx"], "out.fbx"),
    ];
    t.extend(ragdoll_rows("blast", short, true));
    t.extend(character_import_rows("blast", animated));
    t.extend(run_rows("blast", &["blast", "--tnt", "1", "--at", "3,1,0", "-o", "out.glb"]));
    t.extend(anim_rows("blast", animated));
    t
}

#[rustfmt::skip]
fn shoot() -> Vec<Case> {
    let short = &["shoot", "--from", "0,1.66,5", "--toward", "0,1.66,0", "-o", "out.glb", "--seconds", "0.2"];
    let animated = &["shoot", "anim.bvh", "--from", "0,1.66,5", "--toward", "0,1.66,0", "-o", "out.glb", "--seconds", "0.2"];
    let mut t = vec![
        help("shoot", &["shoot"]),
        case("shoot", "--from", &["shoot", "--toward", "0,1.66,0", "-o", "out.glb", "--seconds", "0.2"], &["--from", "0,1.66,-5"], Some(from_behind), &["--from", "0,1.66"], "--from"),
        case("shoot", "--toward", &["shoot", "--from", "0,1.66,5", "-o", "out.glb", "--seconds", "0.2"], &["--toward", "0,1.66,0"], Some(hits_head), &["--toward", "0,1.66,5"], "--toward"),
        case("shoot", "--bullet-mass", short, &["--bullet-mass", "0.016"], Some(heavier_bullet), &["--bullet-mass", "0"], "--bullet-mass"),
        case("shoot", "--speed", short, &["--speed", "100"], Some(slower_bullet), &["--speed", "-5"], "--speed"),
        case("shoot", "--time", short, &["--time", "0.1"], Some(shot_at_0_1), &["--time", "1"], "--time"),
        case("shoot", "--output", &["shoot", "--from", "0,1.66,5", "--toward", "0,1.66,0", "--seconds", "0.2"], &["--output", "out.bvh"], Some(bvh_written), &["--output", "out"], "out"),
    ];
    t.extend(ragdoll_rows("shoot", short, true));
    t.extend(character_import_rows("shoot", animated));
    t.extend(run_rows("shoot", &["shoot", "--from", "0,1.66,5", "--toward", "0,1.66,0", "-o", "out.glb"]));
    t.extend(anim_rows("shoot", animated));
    t
}

#[rustfmt::skip]
fn inspect_and_build() -> Vec<Case> {
    let inspect = &["inspect", "anim.bvh"];
    let build = &["build", "anim.bvh", "-o", "built.toml"];
    let mut t = vec![
        help("inspect", inspect),
        case("inspect", "--json", inspect, &["--json"], Some(json_bodies), &["--json=yes"], "--json"),
        help("build", build),
        case("build", "--output", &["build", "anim.bvh"], &["--output", "built.toml"], Some(spec_written), &["--output", "anim.bvh/built.toml"], "anim.bvh"),
    ];
    t.extend(ragdoll_rows("inspect", &["inspect", "anim.bvh", "--json"], true));
    t.extend(character_import_rows("inspect", inspect));
    t.extend(ragdoll_rows("build", build, false));
    t.extend(character_import_rows("build", build));
    t
}

#[rustfmt::skip]
fn rig() -> Vec<Case> {
    let base = &["rig", "bar.obj", "-o", "rig.glb"];
    let leg = "leg=0.5,0.55,-0.1/0.6,0.2,-0.2/0.6,0,-0.2";
    let mut t = vec![
        help("rig", base),
        case("rig", "--joints", base, &["--joints", "7"], Some(seven_joints), &["--joints", "0"], "--joints"),
        case("rig", "--head", base, &["--head", "-1,0.7,0"], Some(head_at_minus_x), &["--head", "v99999"], "--head"),
        // The flag that panicked inside clap.
        case("rig", "--spine", base, &["--spine", "v0/v40"], Some(rig_written), &["--spine", "v0"], "--spine"),
        case("rig", "--branch", base, &["--branch", leg], Some(mirrored_leg), &["--branch", "leg"], "--branch"),
        case("rig", "--no-mirror", base, &["--branch", leg, "--no-mirror"], Some(single_leg), &["--no-mirror"], "--branch"),
        case("rig", "--output", &["rig", "bar.obj"], &["--output", "rig.glb"], Some(rig_written), &["--output", "rig.obj"], "rig.obj"),
        case("rig", "--humanoid", &["rig", "person.obj", "-o", "rig.glb"], &["--humanoid"], Some(person_joints), &["--humanoid", "--joints", "7", "--spine", "v0/v8"], "--humanoid"),
    ];
    t.extend(import_rows("rig", base));
    t
}

#[rustfmt::skip]
fn bench() -> Vec<Case> {
    let base = &["bench", "--ragdolls", "2", "--steps", "2", "--threads", "1"];
    vec![
        help("bench", &["bench"]),
        case("bench", "--ragdolls", &["bench", "--steps", "2", "--threads", "1"], &["--ragdolls", "1,3"], Some(two_sizes), &["--ragdolls", "0"], "--ragdolls"),
        case("bench", "--steps", &["bench", "--ragdolls", "2", "--threads", "1"], &["--steps", "3"], None, &["--steps", "0"], "--steps"),
        case("bench", "--threads", &["bench", "--ragdolls", "8", "--steps", "2"], &["--threads", "1,2"], Some(two_thread_counts), &["--threads", "0"], "--threads"),
        case("bench", "--json", base, &["--json"], Some(bench_json), &["--json=yes"], "--json"),
        case("bench", "--backend", base, &["--backend", "particle"], Some(bench_particle), &["--backend", "soft"], "--backend"),
        case("bench", "--no-freeze", &[&base[..], &["--backend", "fast", "--json"]].concat(), &["--no-freeze"], Some(bench_no_freeze), &["--no-freeze=yes"], "--no-freeze"),
        case("bench", "--fast-substeps", &[&base[..], &["--backend", "fast", "--json"]].concat(), &["--fast-substeps", "8"], Some(bench_eight_substeps), &["--fast-substeps", "0"], "--fast-substeps"),
        case("bench", "--keep-contacts", &[&base[..], &["--backend", "fast", "--json"]].concat(), &["--keep-contacts"], Some(bench_kept_contacts), &["--keep-contacts=yes"], "--keep-contacts"),
        case("bench", "--fast-iterations", &[&base[..], &["--backend", "fast", "--json"]].concat(), &["--fast-iterations", "2"], Some(bench_two_passes), &["--fast-iterations", "0"], "--fast-iterations"),
        case("bench", "--impact-passes", &[&base[..], &["--backend", "fast", "--json"]].concat(), &["--impact-passes", "0"], Some(bench_no_impact_passes), &["--impact-passes", "9"], "--impact-passes"),
        case("bench", "--pile-height", &[&base[..], &["--json"]].concat(), &["--pile-height", "2"], Some(bench_pile_of_two), &["--pile-height", "0"], "--pile-height"),
        case("bench", "--motors", &[&base[..], &["--backend", "fast", "--json"]].concat(), &["--motors", "0.5"], Some(bench_motors), &["--motors", "2"], "--motors"),
        case("bench", "--farm", &["bench", "--json"], &["--farm", "2"], Some(farm_bench), &["--farm", "0"], "--farm"),
        case("bench", "--compare", &[&base[..], &["--backend", "particle"]].concat(), &["--compare"], Some(bench_compare), &["--compare=yes"], "--compare"),
        case("bench", "--reference", &[&base[..], &["--backend", "fast"]].concat(), &["--reference"], Some(bench_reference), &["--reference=yes"], "--reference"),
    ]
}

#[rustfmt::skip]
fn preview() -> Vec<Case> {
    let png = &["preview", "baked.glb", "-o", "p.png", "--size", "64x48"];
    vec![
        help("preview", &["preview"]),
        case("preview", "--output", &["preview", "baked.glb", "--size", "64x48"], &["--output", "p.gif"], Some(gif_written), &["--output", "p.jpg"], "p.jpg"),
        case("preview", "--size", &["preview", "baked.glb", "-o", "p.png"], &["--size", "64x48"], Some(png_64x48), &["--size", "10x10"], "--size"),
        case("preview", "--gif-fps", &["preview", "baked.glb", "-o", "p.gif", "--size", "64x48"], &["--gif-fps", "5"], None, &["--gif-fps", "0"], "--gif-fps"),
        case("preview", "--frame", png, &["--frame", "0"], None, &["--frame", "9999"], "--frame"),
    ]
}

/// `view` serves until stopped: the runner starts a valid row, waits for its URL and
/// stops it.
#[rustfmt::skip]
fn view() -> Vec<Case> {
    let base = &["view", "--port", "0", "--no-open"];
    let file = &["view", "anim.bvh", "--port", "0", "--no-open"];
    let mut t = vec![
        help("view", base),
        case("view", "--port", &["view", "--no-open"], &["--port", "0"], None, &["--port", "70000"], "--port"),
        case("view", "--host", base, &["--host", "127.0.0.1"], None, &["--host", "nowhere"], "--host"),
        case("view", "--no-open", &["view", "--port", "0"], &["--no-open"], None, &["--no-open=yes"], "--no-open"),
        case("view", "--save-dir", base, &["--save-dir", "."], None, &["--save-dir"], "--save-dir"),
        case("view", "--rest-pose", file, &["--rest-pose"], None, &["--rest-pose=yes"], "--rest-pose"),
    ];
    t.extend(ragdoll_rows("view", file, false));
    t.extend(character_import_rows("view", file));
    t
}

fn variant_written(dir: &Path, _: &Output) {
    let text = std::fs::read_to_string(dir.join("v.toml")).unwrap();
    assert!(
        !text.contains("wedge") && text.contains("facing_deg"),
        "{text}"
    );
}
fn job_planned(dir: &Path, _: &Output) {
    assert_eq!(
        json(&dir.join("job/plan.json"))["tasks"]
            .as_array()
            .unwrap()
            .len(),
        2
    );
}

/// `wedge`, `plan`, `run-task` and `merge`, on the runner's `wedge.toml` (two variants;
/// planned into `job/` for `run-task` and `merge`).
#[rustfmt::skip]
fn farm() -> Vec<Case> {
    let list = &["wedge", "wedge.toml", "--list"];
    vec![
        help("wedge", &["wedge"]),
        case("wedge", "--list", &["wedge", "wedge.toml"], &["--list"], None, &["--list=yes"], "--list"),
        case("wedge", "--json", list, &["--json"], None, &["--json=yes"], "--json"),
        case("wedge", "--variant", &["wedge", "wedge.toml", "-o", "v.toml"], &["--variant", "1"], Some(variant_written), &["--variant", "9"], "no variant is called"),
        case("wedge", "--output", &["wedge", "wedge.toml", "--variant", "0"], &["--output", "v.toml"], Some(variant_written), &["--output", "."], "is a folder"),
        help("plan", &["plan"]),
        case("plan", "--tasks", &["plan", "wedge.toml", "-o", "job"], &["--tasks", "2"], Some(job_planned), &["--tasks", "0"], "--tasks"),
        case("plan", "--output", &["plan", "wedge.toml", "--tasks", "2"], &["--output", "job"], Some(job_planned), &["--output", "job.json"], "job.json"),
        help("run-task", &["run-task"]),
        case("run-task", "--task", &["run-task", "job/plan.json"], &["--task", "0"], None, &["--task", "1"], "--task 1"),
        help("merge", &["merge"]),
        case("merge", "--no-sheet", &["merge", "job"], &["--no-sheet"], Some(tables_only), &["--no-sheet=yes"], "--no-sheet"),
    ]
}

#[rustfmt::skip]
fn top() -> Vec<Case> {
    vec![
        case("", "--help", &[], &["--help"], Some(commands_listed), &["--help=yes"], "--help"),
        case("", "--version", &[], &["--version"], Some(version), &["--version=yes"], "--version"),
    ]
}

/// Every row.
pub fn table() -> Vec<Case> {
    [
        top(),
        demo(),
        simulate(),
        blast(),
        shoot(),
        inspect_and_build(),
        rig(),
        bench(),
        preview(),
        view(),
        farm(),
    ]
    .into_iter()
    .flatten()
    .collect()
}
