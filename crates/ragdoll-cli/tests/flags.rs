//! Every flag of every subcommand, table-driven (the table is `flag_table/mod.rs`): given
//! a valid value it runs (and has its effect, where that is cheap to see); given an invalid
//! one it fails with one line naming the problem, never a panic, and leaves the folder as
//! it was. `every_flag_is_in_the_table` reads each subcommand's `--help` and fails on a
//! flag the table does not cover, so a new flag needs a row.

mod fixture;
mod flag_table;

use std::collections::BTreeSet;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Output, Stdio};

use fixture::{Fixture, assert_clean_failure, err, out, run};
use flag_table::{Case, table};

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
            "person.obj",
        ] {
            std::fs::copy(fx.path(name), dir.path().join(name)).unwrap();
        }
        // A one-character scene for the flags that apply to scene files.
        std::fs::write(
            dir.path().join("scene.toml"),
            "duration_s = 0.2\n[[character]]\nname = \"solo\"\n",
        )
        .unwrap();
        // Roles files for `--roles`: the fixture's joints are named by their roles.
        std::fs::write(dir.path().join("roles.toml"), "ignore = [\"hand_l\"]\n").unwrap();
        std::fs::write(
            dir.path().join("bad_roles.toml"),
            "[roles]\nthigh_l = \"no_such_joint\"\n",
        )
        .unwrap();
        // A two-variant wedge for the farm commands, planned for those that run a job.
        std::fs::write(
            dir.path().join("wedge.toml"),
            "duration_s = 0.2\nfps = 10\nbackend = \"fast\"\n[[character]]\nname = \"solo\"\n\
             [[wedge.vary]]\nkey = \"character[0].facing_deg\"\nvalues = [0, 90]\n",
        )
        .unwrap();
        if c.sub == "run-task" || c.sub == "merge" {
            let o = run(
                dir.path(),
                &["plan", "wedge.toml", "--tasks", "1", "-o", "job"],
            );
            assert!(o.status.success(), "{what}: plan: {}", err(&o));
        }
        if c.sub == "merge" && c.flag != "--help" {
            let o = run(dir.path(), &["run-task", "job/plan.json", "--task", "0"]);
            assert!(o.status.success(), "{what}: run-task: {}", err(&o));
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

#[test]
fn farm_flags() {
    check(
        ["wedge", "plan", "run-task", "merge"]
            .into_iter()
            .flat_map(rows)
            .collect(),
    );
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
