//! Every flag of every subcommand, table-driven: given a valid value it runs (and has its
//! effect, where that is cheap to see); given an invalid one it fails with one line naming
//! the problem, never a panic. `every_flag_is_in_the_table` reads each subcommand's
//! `--help` and fails on a flag the table does not cover, so a new flag needs a row.

mod fixture;

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Output, Stdio};

use fixture::{Fixture, assert_clean_failure, err, json, out, run};

/// What a valid run must show beyond succeeding.
type Effect = fn(&Path, &Output);

/// One flag of one subcommand.
struct Case {
    sub: &'static str,
    flag: &'static str,
    /// A full command line where the flag has a valid value.
    valid: Vec<String>,
    effect: Option<Effect>,
    /// A full command line where it has an invalid one, and what the error must mention.
    invalid: Vec<String>,
    needle: &'static str,
}

fn strings(parts: &[&[&str]]) -> Vec<String> {
    parts
        .iter()
        .flat_map(|p| p.iter().map(|s| s.to_string()))
        .collect()
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
    Case {
        sub,
        flag,
        valid: strings(&[base, valid]),
        effect,
        invalid: strings(&[base, invalid]),
        needle,
    }
}

/// `--help`: prints help and succeeds; given a value it is an error.
fn help_case(sub: &'static str, base: &[&str]) -> Case {
    case(
        sub,
        "--help",
        base,
        &["--help"],
        Some(|_, o| assert!(out(o).contains("Usage:"), "{}", out(o))),
        &["--help=yes"],
        "--help",
    )
}

fn report(dir: &Path, name: &str) -> serde_json::Value {
    json(&dir.join(name))
}

/// The report of a single-character run written as `out.glb`.
fn out_report(dir: &Path) -> serde_json::Value {
    report(dir, "out.report.json")
}

/// The flags `--mass`, `--female` and `--spec`; with `effects`, the total mass the run
/// reports is checked.
fn ragdoll_cases(sub: &'static str, base: &[&str], effects: bool) -> Vec<Case> {
    let mass: Option<Effect> = if effects {
        Some(|dir, _| {
            let total = total_mass(dir);
            assert!((total - 80.0).abs() < 0.01, "{total}");
        })
    } else {
        None
    };
    let spec: Option<Effect> = if effects {
        Some(|dir, _| {
            let total = total_mass(dir);
            assert!((total - 90.0).abs() < 0.01, "the spec says 90 kg: {total}");
        })
    } else {
        None
    };
    vec![
        case(
            sub,
            "--mass",
            base,
            &["--mass", "80"],
            mass,
            &["--mass", "-5"],
            "--mass",
        ),
        case(
            sub,
            "--female",
            base,
            &["--female"],
            None,
            &["--female", "--spec", "spec.toml"],
            "--female",
        ),
        case(
            sub,
            "--spec",
            base,
            &["--spec", "spec.toml"],
            spec,
            &["--spec", "missing.toml"],
            "missing.toml",
        ),
    ]
}

/// The total mass a run reported: `out.report.json`, `made/report.json` (demo) or the
/// JSON `inspect` printed (saved as `inspect.json` by the runner).
fn total_mass(dir: &Path) -> f64 {
    for name in ["out.report.json", "made/report.json", "inspect.json"] {
        if dir.join(name).exists() {
            return report(dir, name)["total_mass_kg"].as_f64().unwrap();
        }
    }
    panic!("no report in {}", dir.display());
}

/// `--units` and `--up` on a file that has none of its own (BVH, OBJ).
fn import_cases(sub: &'static str, base: &[&str]) -> Vec<Case> {
    vec![
        case(
            sub,
            "--units",
            base,
            &["--units", "m"],
            None,
            &["--units", "furlong"],
            "--units",
        ),
        case(
            sub,
            "--up",
            base,
            &["--up", "y"],
            None,
            &["--up", "x"],
            "--up",
        ),
    ]
}

/// `--backend`, `--seconds`, `--fps` and `--preview`; `base` runs 0.2 s.
fn run_cases(sub: &'static str, base: &[&str]) -> Vec<Case> {
    vec![
        case(
            sub,
            "--backend",
            base,
            &["--backend", "particle"],
            Some(|dir, _| assert_eq!(any_report(dir)["backend"], "particle")),
            &["--backend", "soft"],
            "--backend",
        ),
        // clap refuses a flag given twice, so `base` leaves --seconds out and each row adds
        // it.
        case(
            sub,
            "--seconds",
            base,
            &["--seconds", "0.5"],
            Some(|dir, _| assert_eq!(any_report(dir)["frames"], 16, "0.5 s at 30 fps")),
            &["--seconds", "-1"],
            "--seconds",
        ),
        case(
            sub,
            "--fps",
            base,
            &["--seconds", "0.2", "--fps", "10"],
            Some(|dir, _| assert_eq!(any_report(dir)["frames"], 3, "0.2 s at 10 fps")),
            &["--seconds", "0.2", "--fps", "0"],
            "--fps",
        ),
        case(
            sub,
            "--preview",
            base,
            &["--seconds", "0.2", "--preview", "p.png"],
            Some(|dir, o| {
                let png = std::fs::read(dir.join("p.png")).unwrap();
                assert_eq!(&png[..4], b"\x89PNG");
                assert!(out(o).contains("p.png"));
            }),
            &["--seconds", "0.2", "--preview", "p.jpg"],
            "--preview",
        ),
    ]
}

fn any_report(dir: &Path) -> serde_json::Value {
    if dir.join("made/report.json").exists() {
        report(dir, "made/report.json")
    } else {
        out_report(dir)
    }
}

/// `--rest-pose`, `--activate`, `--powered`, `--fade-out`, `--root-on-clip`: `base` runs an
/// animated character for 0.2 s (the flags need an animation).
fn anim_cases(sub: &'static str, base: &[&str]) -> Vec<Case> {
    vec![
        case(
            sub,
            "--rest-pose",
            base,
            &["--rest-pose"],
            None,
            &["--rest-pose=yes"],
            "--rest-pose",
        ),
        case(
            sub,
            "--activate",
            base,
            &["--activate", "0.1"],
            None,
            &["--activate", "soon"],
            "--activate",
        ),
        case(
            sub,
            "--powered",
            base,
            &["--powered", "0.5"],
            None,
            &["--powered", "2"],
            "--powered",
        ),
        case(
            sub,
            "--fade-out",
            base,
            &["--powered", "1", "--fade-out", "0.05,0.15"],
            None,
            &["--powered", "1", "--fade-out", "1"],
            "--fade-out",
        ),
        case(
            sub,
            "--root-on-clip",
            base,
            &["--powered", "1", "--root-on-clip"],
            None,
            &["--root-on-clip"],
            "--powered",
        ),
    ]
}

fn demo_table() -> Vec<Case> {
    let base = &["demo", "-o", "made"];
    let short = &["demo", "-o", "made", "--seconds", "0.2"];
    let mut t = vec![
        help_case("demo", &["demo"]),
        case(
            "demo",
            "--output",
            &["demo", "--seconds", "0.2"],
            &["--output", "made"],
            Some(|dir, _| assert!(dir.join("made/demo.glb").is_file())),
            &["--output", "anim.bvh"],
            "anim.bvh",
        ),
    ];
    t.extend(ragdoll_cases("demo", short, true));
    t.extend(run_cases("demo", base));
    t
}

fn simulate_table() -> Vec<Case> {
    let base = &["simulate", "anim.bvh", "-o", "out.glb"];
    let short = &["simulate", "anim.bvh", "-o", "out.glb", "--seconds", "0.2"];
    let mut t = vec![
        help_case("simulate", &["simulate"]),
        case(
            "simulate",
            "--output",
            &["simulate", "anim.bvh", "--seconds", "0.2"],
            &["--output", "out.bvh"],
            Some(|dir, _| {
                let text = std::fs::read_to_string(dir.join("out.bvh")).unwrap();
                assert!(text.starts_with("HIERARCHY"));
            }),
            &["--output", "out.fbx"],
            "out.fbx",
        ),
        case(
            "simulate",
            "--obj-sequence",
            short,
            &["--obj-sequence", "seq"],
            Some(|dir, _| {
                let n = std::fs::read_dir(dir.join("seq")).unwrap().count();
                assert_eq!(n, 7, "one OBJ per frame: 0.2 s at 30 fps");
            }),
            &["--obj-sequence", "anim.bvh"],
            "anim.bvh",
        ),
    ];
    t.extend(ragdoll_cases("simulate", short, true));
    t.extend(import_cases("simulate", short));
    t.extend(run_cases("simulate", base));
    t.extend(anim_cases("simulate", short));
    t
}

fn blast_table() -> Vec<Case> {
    let base = &["blast", "--tnt", "1", "--at", "3,1,0", "-o", "out.glb"];
    let short = &[
        "blast",
        "--tnt",
        "1",
        "--at",
        "3,1,0",
        "-o",
        "out.glb",
        "--seconds",
        "0.2",
    ];
    let animated = &[
        "blast",
        "anim.bvh",
        "--tnt",
        "1",
        "--at",
        "3,1,0",
        "-o",
        "out.glb",
        "--seconds",
        "0.2",
    ];
    let mut t = vec![
        help_case("blast", &["blast"]),
        case(
            "blast",
            "--tnt",
            &[
                "blast",
                "--at",
                "3,1,0",
                "-o",
                "out.glb",
                "--seconds",
                "0.2",
            ],
            &["--tnt", "2"],
            Some(|dir, _| assert_eq!(out_report(dir)["blasts"][0]["tnt_kg"], 2.0)),
            &["--tnt", "-1"],
            "--tnt",
        ),
        case(
            "blast",
            "--at",
            &["blast", "--tnt", "1", "-o", "out.glb", "--seconds", "0.2"],
            &["--at", "-3,1,0"],
            Some(|dir, _| {
                assert_eq!(
                    out_report(dir)["blasts"][0]["position"],
                    serde_json::json!([-3.0, 1.0, 0.0])
                )
            }),
            &["--at", "3,1"],
            "--at",
        ),
        case(
            "blast",
            "--time",
            short,
            &["--time", "0.1"],
            Some(|dir, _| {
                let t = out_report(dir)["blasts"][0]["time_s"].as_f64().unwrap();
                assert!((t - 0.1).abs() < 1e-6, "{t}");
            }),
            &["--time", "5"],
            "--time",
        ),
        case(
            "blast",
            "--scale",
            short,
            &["--scale", "2"],
            None,
            &["--scale", "-1"],
            "--scale",
        ),
        case(
            "blast",
            "--output",
            &["blast", "--tnt", "1", "--at", "3,1,0", "--seconds", "0.2"],
            &["--output", "out.glb"],
            Some(|dir, _| assert!(dir.join("out.glb").is_file())),
            &["--output", "out.fbx"],
            "out.fbx",
        ),
    ];
    t.extend(ragdoll_cases("blast", short, true));
    t.extend(import_cases("blast", animated));
    t.extend(run_cases("blast", base));
    t.extend(anim_cases("blast", animated));
    t
}

fn shoot_table() -> Vec<Case> {
    let aim = &["--from", "0,1.66,5", "--toward", "0,1.66,0"];
    let base: Vec<&str> = [&["shoot"][..], aim, &["-o", "out.glb"]].concat();
    let short: Vec<&str> = [&base[..], &["--seconds", "0.2"]].concat();
    let animated: Vec<&str> = [
        &["shoot", "anim.bvh"][..],
        aim,
        &["-o", "out.glb", "--seconds", "0.2"],
    ]
    .concat();
    let mut t = vec![
        help_case("shoot", &["shoot"]),
        case(
            "shoot",
            "--from",
            &[
                "shoot",
                "--toward",
                "0,1.66,0",
                "-o",
                "out.glb",
                "--seconds",
                "0.2",
            ],
            &["--from", "0,1.66,-5"],
            Some(|dir, _| {
                let r = out_report(dir);
                assert_eq!(
                    r["projectiles"][0]["origin"],
                    serde_json::json!([0.0, 1.66, -5.0])
                );
            }),
            &["--from", "0,1.66"],
            "--from",
        ),
        case(
            "shoot",
            "--toward",
            &[
                "shoot",
                "--from",
                "0,1.66,5",
                "-o",
                "out.glb",
                "--seconds",
                "0.2",
            ],
            &["--toward", "0,1.66,0"],
            Some(|dir, _| assert_eq!(out_report(dir)["projectiles"][0]["body"], "head")),
            &["--toward", "0,1.66,5"],
            "--toward",
        ),
        case(
            "shoot",
            "--bullet-mass",
            &short,
            &["--bullet-mass", "0.016"],
            Some(|dir, _| {
                let j = out_report(dir)["projectiles"][0]["impulse_ns"]
                    .as_f64()
                    .unwrap();
                assert!((j - 0.016 * 360.0).abs() < 1e-3, "{j}");
                // The character keeps its own mass.
                assert!((total_mass(dir) - 75.0).abs() < 0.01);
            }),
            &["--bullet-mass", "0"],
            "--bullet-mass",
        ),
        case(
            "shoot",
            "--speed",
            &short,
            &["--speed", "100"],
            Some(|dir, _| {
                let j = out_report(dir)["projectiles"][0]["impulse_ns"]
                    .as_f64()
                    .unwrap();
                assert!((j - 0.008 * 100.0).abs() < 1e-3, "{j}");
            }),
            &["--speed", "-5"],
            "--speed",
        ),
        case(
            "shoot",
            "--time",
            &short,
            &["--time", "0.1"],
            Some(|dir, _| {
                let t = out_report(dir)["projectiles"][0]["time_s"]
                    .as_f64()
                    .unwrap();
                assert!((t - 0.1).abs() < 1e-6, "{t}");
            }),
            &["--time", "1"],
            "--time",
        ),
        case(
            "shoot",
            "--output",
            &[&["shoot"][..], aim, &["--seconds", "0.2"]].concat(),
            &["--output", "out.bvh"],
            Some(|dir, _| assert!(dir.join("out.bvh").is_file())),
            &["--output", "out"],
            "out",
        ),
    ];
    t.extend(ragdoll_cases("shoot", &short, true));
    t.extend(import_cases("shoot", &animated));
    t.extend(run_cases("shoot", &base));
    t.extend(anim_cases("shoot", &animated));
    t
}

fn inspect_table() -> Vec<Case> {
    let base = &["inspect", "anim.bvh"];
    let json_base = &["inspect", "anim.bvh", "--json"];
    let mut t = vec![
        help_case("inspect", base),
        case(
            "inspect",
            "--json",
            base,
            &["--json"],
            Some(|_, o| {
                let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
                assert!(v["bodies"].as_array().unwrap().len() >= 13);
            }),
            &["--json=yes"],
            "--json",
        ),
    ];
    t.extend(ragdoll_cases("inspect", json_base, true));
    t.extend(import_cases("inspect", base));
    t
}

fn build_table() -> Vec<Case> {
    let base = &["build", "anim.bvh", "-o", "built.toml"];
    let mut t = vec![
        help_case("build", base),
        case(
            "build",
            "--output",
            &["build", "anim.bvh"],
            &["--output", "built.toml"],
            Some(|dir, _| {
                let text = std::fs::read_to_string(dir.join("built.toml")).unwrap();
                assert!(text.contains("[[bodies]]"));
            }),
            &["--output", "anim.bvh/built.toml"],
            "anim.bvh",
        ),
    ];
    t.extend(ragdoll_cases("build", base, false));
    t.extend(import_cases("build", base));
    t
}

fn rig_table() -> Vec<Case> {
    let base = &["rig", "bar.obj", "-o", "rig.glb"];
    let leg = "leg=0.5,0.55,-0.1/0.6,0.2,-0.2/0.6,0,-0.2";
    let mut t = vec![
        help_case("rig", base),
        case(
            "rig",
            "--joints",
            base,
            &["--joints", "7"],
            Some(|_, o| assert!(out(o).contains(": 7 joints"), "{}", out(o))),
            &["--joints", "0"],
            "--joints",
        ),
        case(
            "rig",
            "--head",
            base,
            // The bar is symmetric end to end; the head goes to the end named.
            &["--head", "-1,0.7,0"],
            Some(|_, o| assert!(out(o).contains("head joint at (-0.8"), "{}", out(o))),
            &["--head", "v99999"],
            "--head",
        ),
        // The flag that panicked inside clap (issue 10).
        case(
            "rig",
            "--spine",
            base,
            &["--spine", "v0/v40"],
            Some(|dir, _| assert!(dir.join("rig.glb").is_file())),
            &["--spine", "v0"],
            "--spine",
        ),
        case(
            "rig",
            "--branch",
            base,
            &["--branch", leg],
            Some(|_, o| assert!(out(o).contains(": 18 joints"), "12 + 3 a side: {}", out(o))),
            &["--branch", "leg"],
            "--branch",
        ),
        case(
            "rig",
            "--no-mirror",
            base,
            &["--branch", leg, "--no-mirror"],
            Some(|_, o| assert!(out(o).contains(": 15 joints"), "12 + 3: {}", out(o))),
            &["--no-mirror"],
            "--branch",
        ),
        case(
            "rig",
            "--output",
            &["rig", "bar.obj"],
            &["--output", "rig.glb"],
            Some(|dir, _| assert!(dir.join("rig.glb").is_file())),
            &["--output", "rig.obj"],
            "rig.obj",
        ),
    ];
    t.extend(import_cases("rig", base));
    t
}

fn bench_table() -> Vec<Case> {
    let base = &["bench", "--ragdolls", "2", "--steps", "2", "--threads", "1"];
    vec![
        help_case("bench", &["bench"]),
        case(
            "bench",
            "--ragdolls",
            &["bench", "--steps", "2", "--threads", "1"],
            &["--ragdolls", "1,3"],
            Some(|_, o| {
                let text = out(o);
                assert!(text.contains("N=1 ") && text.contains("N=3 "), "{text}");
            }),
            &["--ragdolls", "0"],
            "--ragdolls",
        ),
        case(
            "bench",
            "--steps",
            &["bench", "--ragdolls", "2", "--threads", "1"],
            &["--steps", "3"],
            None,
            &["--steps", "0"],
            "--steps",
        ),
        case(
            "bench",
            "--threads",
            &["bench", "--ragdolls", "8", "--steps", "2"],
            &["--threads", "1,2"],
            Some(|_, o| {
                let text = out(o);
                assert!(
                    text.contains("threads=1 ") && text.contains("threads=2 "),
                    "{text}"
                );
            }),
            &["--threads", "0"],
            "--threads",
        ),
        case(
            "bench",
            "--json",
            base,
            &["--json"],
            Some(|_, o| {
                let v: serde_json::Value = serde_json::from_str(&out(o)).unwrap();
                assert_eq!(v["runs"][0]["ragdolls"], 2);
            }),
            &["--json=yes"],
            "--json",
        ),
        case(
            "bench",
            "--backend",
            base,
            &["--backend", "particle"],
            Some(|_, o| assert!(out(o).contains("particle"), "{}", out(o))),
            &["--backend", "soft"],
            "--backend",
        ),
    ]
}

fn preview_table() -> Vec<Case> {
    let base = &["preview", "baked.glb", "-o", "p.png"];
    vec![
        help_case("preview", &["preview"]),
        case(
            "preview",
            "--output",
            &["preview", "baked.glb", "--size", "64x48"],
            &["--output", "p.gif"],
            Some(|dir, _| assert_eq!(&std::fs::read(dir.join("p.gif")).unwrap()[..6], b"GIF89a")),
            &["--output", "p.jpg"],
            "p.jpg",
        ),
        case(
            "preview",
            "--size",
            base,
            &["--size", "64x48"],
            Some(|dir, _| {
                let png = std::fs::read(dir.join("p.png")).unwrap();
                assert_eq!(&png[16..24], &[0, 0, 0, 64, 0, 0, 0, 48]);
            }),
            &["--size", "10x10"],
            "--size",
        ),
        case(
            "preview",
            "--gif-fps",
            &["preview", "baked.glb", "-o", "p.gif", "--size", "64x48"],
            &["--gif-fps", "5"],
            None,
            &["--gif-fps", "0"],
            "--gif-fps",
        ),
        case(
            "preview",
            "--frame",
            &["preview", "baked.glb", "-o", "p.png", "--size", "64x48"],
            &["--frame", "0"],
            None,
            &["--frame", "9999"],
            "--frame",
        ),
    ]
}

/// `view` serves until stopped: a valid row is started, must print its URL, and is killed.
fn view_table() -> Vec<Case> {
    let base = &["view", "--port", "0", "--no-open"];
    let file = &["view", "anim.bvh", "--port", "0", "--no-open"];
    let mut t = vec![
        help_case("view", base),
        case(
            "view",
            "--port",
            &["view", "--no-open"],
            &["--port", "0"],
            None,
            &["--port", "70000"],
            "--port",
        ),
        case(
            "view",
            "--host",
            base,
            &["--host", "127.0.0.1"],
            None,
            &["--host", "nowhere"],
            "--host",
        ),
        case(
            "view",
            "--no-open",
            &["view", "--port", "0"],
            &["--no-open"],
            None,
            &["--no-open=yes"],
            "--no-open",
        ),
        case(
            "view",
            "--save-dir",
            base,
            &["--save-dir", "."],
            None,
            &["--save-dir"],
            "--save-dir",
        ),
        case(
            "view",
            "--rest-pose",
            file,
            &["--rest-pose"],
            None,
            &["--rest-pose=yes"],
            "--rest-pose",
        ),
    ];
    t.extend(ragdoll_cases("view", file, false));
    t.extend(import_cases("view", file));
    t
}

fn top_table() -> Vec<Case> {
    vec![
        case(
            "",
            "--help",
            &[],
            &["--help"],
            Some(|_, o| assert!(out(o).contains("Commands:"))),
            &["--help=yes"],
            "--help",
        ),
        case(
            "",
            "--version",
            &[],
            &["--version"],
            Some(|_, o| assert!(out(o).starts_with("ragdoll "))),
            &["--version=yes"],
            "--version",
        ),
    ]
}

fn table() -> Vec<Case> {
    [
        top_table(),
        demo_table(),
        simulate_table(),
        blast_table(),
        shoot_table(),
        inspect_table(),
        build_table(),
        rig_table(),
        bench_table(),
        preview_table(),
        view_table(),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// Runs each row in a fresh copy of the fixture's inputs.
fn check(rows: Vec<Case>) {
    let fx = Fixture::new();
    for c in rows {
        let what = format!("{} {}", c.sub, c.flag);
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "anim.bvh",
            "baked.glb",
            "baked.report.json",
            "spec.toml",
            "bar.obj",
        ] {
            std::fs::copy(fx.path(name), dir.path().join(name)).unwrap();
        }
        let valid: Vec<&str> = c.valid.iter().map(String::as_str).collect();
        let o = if c.sub == "view" && c.flag != "--help" {
            serve_briefly(dir.path(), &valid)
        } else {
            run(dir.path(), &valid)
        };
        assert!(o.status.success(), "{what}: {valid:?}: {}", err(&o));
        if c.sub == "inspect" && valid.contains(&"--json") {
            std::fs::write(dir.path().join("inspect.json"), &o.stdout).unwrap();
        }
        if let Some(effect) = c.effect {
            effect(dir.path(), &o);
        }
        let invalid: Vec<&str> = c.invalid.iter().map(String::as_str).collect();
        let before = fixture::listing(dir.path());
        let o = run(dir.path(), &invalid);
        assert_clean_failure(&o, c.needle, &format!("{what}: {invalid:?}"));
        assert_eq!(
            fixture::listing(dir.path()),
            before,
            "{what}: {invalid:?} changed the folder"
        );
    }
}

/// Starts `ragdoll view ...`, waits for the line with its URL, stops it; a successful
/// output when the URL came.
fn serve_briefly(dir: &Path, args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    if line.contains("http://") {
        child.kill().unwrap();
        let mut o = child.wait_with_output().unwrap();
        o.stdout = line.into_bytes();
        // Killed on purpose: the URL was the success.
        o.status = std::os::unix::process::ExitStatusExt::from_raw(0);
        o
    } else {
        child.wait_with_output().unwrap()
    }
}

fn rows(sub: &str) -> Vec<Case> {
    table().into_iter().filter(|c| c.sub == sub).collect()
}

#[test]
fn top_level_flags() {
    check(rows(""));
}

#[test]
fn demo_flags() {
    check(rows("demo"));
}

#[test]
fn simulate_flags() {
    check(rows("simulate"));
}

#[test]
fn blast_flags() {
    check(rows("blast"));
}

#[test]
fn shoot_flags() {
    check(rows("shoot"));
}

#[test]
fn inspect_and_build_flags() {
    check(rows("inspect"));
    check(rows("build"));
}

#[test]
fn rig_flags() {
    check(rows("rig"));
}

#[test]
fn bench_flags() {
    check(rows("bench"));
}

#[test]
fn preview_flags() {
    check(rows("preview"));
}

#[test]
fn view_flags() {
    check(rows("view"));
}

/// The long flags `ragdoll [SUB] --help` lists.
fn flags_in_help(sub: &str) -> BTreeSet<String> {
    let dir = tempfile::tempdir().unwrap();
    let args: Vec<&str> = if sub.is_empty() {
        vec!["--help"]
    } else {
        vec![sub, "--help"]
    };
    let o = run(dir.path(), &args);
    assert!(o.status.success(), "{}", err(&o));
    out(&o)
        .lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l
                .strip_prefix("-")
                .filter(|r| r.len() > 2 && &r[1..3] == ", ")
                .map_or(l, |r| &r[3..]);
            l.strip_prefix("--").map(|r| {
                format!(
                    "--{}",
                    r.split(|c: char| !(c.is_alphanumeric() || c == '-'))
                        .next()
                        .unwrap()
                )
            })
        })
        .collect()
}

/// The subcommands `ragdoll --help` lists.
fn subcommands() -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let o = run(dir.path(), &["--help"]);
    let text = out(&o);
    let commands = text
        .split("Commands:")
        .nth(1)
        .unwrap()
        .split("\n\n")
        .next()
        .unwrap();
    commands
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_string)
        .collect()
}

#[test]
fn every_flag_is_in_the_table() {
    let table = table();
    let covered: BTreeSet<(String, String)> = table
        .iter()
        .map(|c| (c.sub.to_string(), c.flag.to_string()))
        .collect();
    let mut missing = Vec::new();
    let mut subs = subcommands();
    assert!(subs.len() >= 10, "{subs:?}");
    subs.push(String::new());
    for sub in &subs {
        let flags = flags_in_help(sub);
        assert!(flags.contains("--help"), "{sub}: {flags:?}");
        for flag in flags {
            if !covered.contains(&(sub.clone(), flag.clone())) {
                missing.push(format!("{sub} {flag}"));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "flags without a row in the table: {missing:?}"
    );
    // And no row for a flag that is gone.
    for (sub, flag) in &covered {
        assert!(
            flags_in_help(sub).contains(flag),
            "row for a flag that does not exist: {sub} {flag}"
        );
    }
}
