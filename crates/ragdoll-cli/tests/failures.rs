//! How the tool fails: every failure path leaves the output folder as it was,
//! a panic anywhere ends as one sentence that says it is a bug, a run that went non-finite
//! is an error, flag combinations that could have no effect are refused, and progress is
//! drawn on a terminal but never into a pipe.

mod fixture;

use std::process::Command;

use fixture::{Fixture, assert_clean_failure, err, json, listing, out, run};

/// Runs `args` in the fixture's folder and checks it fails cleanly mentioning `needle`
/// and leaves the folder exactly as it was.
fn fails_leaving_nothing(fx: &Fixture, args: &[&str], needle: &str) {
    let before = listing(fx.dir());
    let o = run(fx.dir(), args);
    assert_clean_failure(&o, needle, &format!("{args:?}"));
    assert_eq!(listing(fx.dir()), before, "{args:?} changed the folder");
}

#[test]
fn an_output_that_cannot_be_written_fails_before_simulating_and_writes_nothing() {
    let fx = Fixture::new();
    std::fs::write(fx.path("taken"), b"a file").unwrap();
    std::fs::create_dir(fx.path("p.png")).unwrap();
    // --obj-sequence onto an existing file used to leave the .glb and its report behind.
    fails_leaving_nothing(
        &fx,
        &[
            "simulate",
            "anim.bvh",
            "-o",
            "o.glb",
            "--obj-sequence",
            "taken",
        ],
        "taken",
    );
    // So did a --preview that could not be written.
    fails_leaving_nothing(
        &fx,
        &["simulate", "anim.bvh", "-o", "o.glb", "--preview", "p.png"],
        "p.png",
    );
    fails_leaving_nothing(&fx, &["simulate", "anim.bvh", "-o", "taken/o.glb"], "taken");
    fails_leaving_nothing(&fx, &["demo", "-o", "taken"], "taken");
    fails_leaving_nothing(
        &fx,
        &["blast", "--tnt", "1", "--at", "2,1,0", "-o", "taken/b.glb"],
        "taken",
    );
    fails_leaving_nothing(&fx, &["build", "anim.bvh", "-o", "taken/s.toml"], "taken");
    fails_leaving_nothing(&fx, &["rig", "bar.obj", "-o", "taken/r.glb"], "taken");
    fails_leaving_nothing(&fx, &["preview", "baked.glb", "-o", "taken/p.png"], "taken");
    let scene = fx.path("s.toml");
    std::fs::write(&scene, "duration_s = 0.2\n[[character]]\nname = \"a\"\n").unwrap();
    fails_leaving_nothing(&fx, &["simulate", "s.toml", "-o", "taken"], "taken");
    fails_leaving_nothing(
        &fx,
        &["simulate", "s.toml", "-o", "out", "--preview", "p.png"],
        "p.png",
    );
}

/// The last line of defence: a panic (forced at a debug point, since every real one found
/// is fixed where it happens) after some outputs are staged.
#[test]
fn a_panic_is_one_sentence_naming_the_command_with_no_output() {
    let fx = Fixture::new();
    std::fs::write(
        fx.path("s.toml"),
        "duration_s = 0.2\n[[character]]\nname = \"a\"\n",
    )
    .unwrap();
    let runs: [&[&str]; 4] = [
        &[
            "simulate",
            "anim.bvh",
            "--seconds",
            "0.2",
            "-o",
            "new/o.glb",
            "--preview",
            "p.gif",
            "--obj-sequence",
            "seq",
        ],
        &["demo", "--seconds", "0.2", "-o", "made"],
        &[
            "blast",
            "--tnt",
            "1",
            "--at",
            "2,1,0",
            "--seconds",
            "0.2",
            "-o",
            "b.bvh",
        ],
        &[
            "simulate",
            "s.toml",
            "--seconds",
            "0.2",
            "-o",
            "scene",
            "--preview",
            "s.png",
        ],
    ];
    for args in runs {
        let before = listing(fx.dir());
        let o = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
            .current_dir(fx.dir())
            .args(args)
            .env("RAGDOLL_DEBUG_PANIC", "staged")
            .env("RUST_BACKTRACE", "1")
            .output()
            .unwrap();
        let e = err(&o);
        assert_eq!(o.status.code(), Some(70), "{args:?}: {e}");
        assert_eq!(e.trim_end().lines().count(), 1, "{args:?}: {e}");
        let command = format!("`ragdoll {}`", args[0]);
        assert!(e.starts_with("error: internal error in "), "{e}");
        assert!(
            e.contains(&command) && e.contains("bug") && e.contains("report"),
            "{e}"
        );
        assert!(!e.contains("stack backtrace"), "{e}");
        assert_eq!(listing(fx.dir()), before, "{args:?} left files");
    }
    // On a rayon worker too.
    let o = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(fx.dir())
        .args(["bench", "--ragdolls", "8", "--steps", "2", "--threads", "2"])
        .env("RAGDOLL_DEBUG_PANIC", "worker")
        .output()
        .unwrap();
    let e = err(&o);
    assert_eq!(o.status.code(), Some(70), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(
        e.contains("`ragdoll bench`") && e.contains("RAGDOLL_DEBUG_PANIC=worker"),
        "{e}"
    );
}

/// A run whose numbers went non-finite writes nothing and says so. The reproducer is a
/// spec with one absurd mass on the particle backend; should the spec checks come to refuse
/// that mass, the run must still fail cleanly, naming it.
#[test]
fn a_run_that_goes_non_finite_is_an_error_with_no_output() {
    let fx = Fixture::new();
    let text = std::fs::read_to_string(fx.path("spec.toml")).unwrap();
    let start = text.find("mass_kg = ").unwrap();
    let end = start + text[start..].find('\n').unwrap();
    let absurd = format!("{}mass_kg = 1e36{}", &text[..start], &text[end..]);
    std::fs::write(fx.path("absurd.toml"), absurd).unwrap();
    let before = listing(fx.dir());
    let o = run(
        fx.dir(),
        &[
            "simulate",
            "anim.bvh",
            "--spec",
            "absurd.toml",
            "--backend",
            "particle",
            "--seconds",
            "1",
            "-o",
            "n.glb",
        ],
    );
    let e = err(&o);
    assert_clean_failure(&o, "", "NaN run");
    assert!(
        e.contains("non-finite") && e.contains("nothing was written") || e.contains("mass_kg"),
        "{e}"
    );
    assert_eq!(listing(fx.dir()), before);
}

#[test]
fn a_missing_file_names_its_cause_once() {
    let fx = Fixture::new();
    let o = run(fx.dir(), &["inspect", "nope.glb"]);
    assert_eq!(
        err(&o),
        "error: nope.glb: No such file or directory (os error 2)\n"
    );
    assert_eq!(o.status.code(), Some(1));
}

#[test]
fn flags_that_could_have_no_effect_are_refused() {
    let fx = Fixture::new();
    let cases: [(&[&str], &str); 12] = [
        (
            &["simulate", "anim.bvh", "-o", "o.glb", "--activate", "blast"],
            "no blast",
        ),
        (
            &[
                "simulate",
                "anim.bvh",
                "-o",
                "o.glb",
                "--activate",
                "contact",
            ],
            "nothing but the ground",
        ),
        (
            &[
                "blast",
                "anim.bvh",
                "--tnt",
                "1",
                "--at",
                "2,1,0",
                "-o",
                "o.glb",
                "--activate",
                "contact",
            ],
            "--activate contact",
        ),
        (
            &[
                "simulate",
                "anim.bvh",
                "-o",
                "o.glb",
                "--seconds",
                "1",
                "--activate",
                "1",
            ],
            "after the end",
        ),
        (
            // --units applies to glTF (files exported in centimetres); --up does not.
            &["simulate", "baked.glb", "-o", "o.glb", "--up", "z"],
            "glTF",
        ),
        (&["inspect", "baked.glb", "--up", "z"], "glTF"),
        (
            &[
                "blast", "--tnt", "1", "--at", "2,1,0", "-o", "o.glb", "--units", "cm",
            ],
            "built-in humanoid",
        ),
        (
            &[
                "shoot",
                "--from",
                "0,1,5",
                "--toward",
                "0,1,0",
                "-o",
                "o.glb",
                "--rest-pose",
            ],
            "no animation",
        ),
        (&["demo", "-o", "d", "--powered", "1"], "--powered"),
        (
            &[
                "simulate",
                "anim.bvh",
                "-o",
                "o.glb",
                "--female",
                "--spec",
                "spec.toml",
            ],
            "--female",
        ),
        (
            &["preview", "baked.glb", "-o", "p.gif", "--frame", "1"],
            "--frame",
        ),
        (
            &["preview", "baked.glb", "-o", "p.png", "--gif-fps", "5"],
            "--gif-fps",
        ),
    ];
    for (args, needle) in cases {
        fails_leaving_nothing(&fx, args, needle);
    }
    std::fs::write(
        fx.path("s.toml"),
        "duration_s = 0.2\n[[character]]\nname = \"a\"\n",
    )
    .unwrap();
    for flag in [
        &["--powered", "1"][..],
        &["--powered", "1", "--root-on-clip"],
    ] {
        let mut args = vec!["simulate", "s.toml", "-o", "out"];
        args.extend(flag);
        fails_leaving_nothing(&fx, &args, "--powered");
    }
}

/// `--mass` is the character's everywhere: with `--spec` it scales the spec's masses to
/// the total (their proportions kept); `shoot` takes the bullet's as `--bullet-mass`.
#[test]
fn mass_is_the_characters_and_scales_a_spec() {
    let fx = Fixture::new();
    let masses = |v: &serde_json::Value| -> Vec<f64> {
        v["bodies"]
            .as_array()
            .unwrap()
            .iter()
            .map(|b| b["mass_kg"].as_f64().unwrap())
            .collect()
    };
    let o = run(
        fx.dir(),
        &[
            "inspect",
            "anim.bvh",
            "--spec",
            "spec.toml",
            "--mass",
            "60",
            "--json",
        ],
    );
    assert!(o.status.success(), "{}", err(&o));
    let v: serde_json::Value = serde_json::from_str(&out(&o)).unwrap();
    assert!(
        (v["total_mass_kg"].as_f64().unwrap() - 60.0).abs() < 1e-3,
        "{}",
        v["total_mass_kg"]
    );
    let original: Vec<f64> = std::fs::read_to_string(fx.path("spec.toml"))
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("mass_kg = "))
        .map(|m| m.parse().unwrap())
        .collect();
    assert_eq!(original.len(), masses(&v).len());
    for (scaled, was) in masses(&v).iter().zip(&original) {
        assert!(
            (scaled / was - 60.0 / 90.0).abs() < 1e-4,
            "{scaled} from {was}"
        );
    }
    let o = run(
        fx.dir(),
        &[
            "shoot",
            "--from",
            "0,1.66,5",
            "--toward",
            "0,1.66,0",
            "--mass",
            "80",
            "--seconds",
            "0.2",
            "-o",
            "s.glb",
        ],
    );
    assert!(o.status.success(), "{}", err(&o));
    let r = json(&fx.path("s.report.json"));
    assert!((r["characters"][0]["total_mass_kg"].as_f64().unwrap() - 80.0).abs() < 0.01);
    let j = r["projectiles"][0]["impulse_ns"].as_f64().unwrap();
    assert!((j - 0.008 * 360.0).abs() < 1e-3, "the default bullet: {j}");
}

/// Progress goes to a terminal only: piped, stderr holds no bar; through a pseudo-terminal
/// (`script`, where installed) the bar shows. The second's wait before a bar appears is
/// set to nothing, so the test does not depend on how fast the machine is.
#[test]
fn progress_shows_on_a_terminal_and_never_in_a_pipe() {
    let fx = Fixture::new();
    let args = [
        "bench",
        "--ragdolls",
        "16",
        "--steps",
        "100",
        "--threads",
        "1",
    ];
    let o = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(fx.dir())
        .args(args)
        .env("RAGDOLL_PROGRESS_DELAY_MS", "0")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", err(&o));
    assert_eq!(err(&o), "", "a pipe gets no progress");
    let line = format!("{} {}", env!("CARGO_BIN_EXE_ragdoll"), args.join(" "));
    let Ok(o) = Command::new("script")
        .args(["-qec", &line, "/dev/null"])
        .current_dir(fx.dir())
        .env("RAGDOLL_PROGRESS_DELAY_MS", "0")
        .output()
    else {
        eprintln!("SKIPPING the terminal half: no `script` here");
        return;
    };
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{text}");
    assert!(
        text.contains("stepping ["),
        "no progress bar on a terminal: {text}"
    );
}

/// `bench`'s cap is on the whole run: counts that each fit but add up past it, or one that
/// fits run once per thread count, are refused before any work, naming the total.
#[test]
fn bench_refuses_a_run_whose_counts_add_up_past_its_cap() {
    let fx = Fixture::new();
    for args in [
        [
            "--ragdolls",
            "5000,5000,5000",
            "--steps",
            "1000",
            "--threads",
            "1",
        ],
        ["--ragdolls", "6000", "--steps", "1000", "--threads", "1,2"],
    ] {
        let started = std::time::Instant::now();
        let o = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
            .current_dir(fx.dir())
            .arg("bench")
            .args(args)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{args:?} ran");
        let e = err(&o);
        assert!(e.contains("12000000") || e.contains("15000000"), "{e}");
        assert!(e.contains("ragdoll-steps in all"), "{e}");
        assert!(
            started.elapsed().as_secs() < 10,
            "refused only after work: {e}"
        );
    }
    // Within the cap in all, it runs.
    let o = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(fx.dir())
        .args([
            "bench",
            "--ragdolls",
            "1,2",
            "--steps",
            "2",
            "--threads",
            "1,2",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", err(&o));
}

/// Errors from the builder's checks name the input file: a BVH whose joints all sit at one
/// point builds bodies too thin to simulate, and the user must learn which file it was.
#[test]
fn a_ragdoll_that_cannot_be_built_names_its_file() {
    let fx = Fixture::new();
    let flat = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT Chest\n  {\n    OFFSET 0 0 0\n    CHANNELS 3 Zrotation Xrotation Yrotation\n    End Site\n    {\n      OFFSET 0 0 0\n    }\n  }\n}\nMOTION\nFrames: 1\nFrame Time: 0.033333\n0 0 0 0 0 0 0 0 0\n";
    std::fs::write(fx.dir().join("flat.bvh"), flat).unwrap();
    for args in [
        &["simulate", "flat.bvh", "-o", "flat.glb"][..],
        &["inspect", "flat.bvh"][..],
    ] {
        let cmd = args[0];
        let o = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
            .current_dir(fx.dir())
            .args(args)
            .output()
            .unwrap();
        assert!(!o.status.success(), "{cmd} ran");
        let e = err(&o);
        assert!(e.contains("flat.bvh") && e.contains("spec:"), "{cmd}: {e}");
        assert_eq!(e.matches("flat.bvh").count(), 1, "named once: {e}");
    }
    assert!(!fx.dir().join("flat.glb").exists());
}
