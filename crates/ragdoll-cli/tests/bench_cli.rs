//! `ragdoll bench` from the command line: what its JSON reports (CPU-seconds beside wall
//! time, both limit readings, a settled pile apart from its impacts) and what it refuses.

mod common;

use serde_json::Value;

use common::{ragdoll, stderr};

#[test]
fn bench_compare_needs_a_backend_other_than_the_reference() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ragdoll(
        tmp.path(),
        &["bench", "--compare", "--ragdolls", "1", "--steps", "1"],
    );
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("choose that one with --backend"),
        "{}",
        stderr(&o)
    );
    // With one, the rigid run comes in the same output, and the ratio is of the two.
    let run = &bench_run("particle --compare --ragdolls 2 --steps 20 --threads 1");
    assert_eq!(run["backend"], "particle");
    assert_eq!(run["rigid"]["backend"], "rigid");
    let per_cpu = |r: &Value| r["ragdoll_steps_per_cpu_second"].as_f64().unwrap();
    let ratio = run["cpu_ratio_to_rigid"].as_f64().unwrap();
    assert!(
        (ratio - per_cpu(run) / per_cpu(&run["rigid"])).abs() < 1e-9 * ratio,
        "{run}"
    );
}

#[test]
fn bench_reports_cpu_seconds_and_both_limit_readings() {
    let run = &bench_run("rigid --ragdolls 4 --steps 30 --threads 1");
    let (wall, cpu) = (
        run["wall_seconds"].as_f64().unwrap(),
        run["cpu_seconds"].as_f64().unwrap(),
    );
    // One stepping thread: it cannot have used more CPU than wall time, beyond the
    // progress bar's thread and clock granularity.
    assert!(cpu > 0.0 && cpu <= 1.5 * wall + 0.05, "{run}");
    let per_cpu = run["ragdoll_steps_per_cpu_second"].as_f64().unwrap();
    assert!(
        (per_cpu * cpu - 120.0).abs() < 1e-6 * per_cpu.max(1.0),
        "{run}"
    );
    let m = &run["metrics"];
    assert!(
        m["max_limit_violation_solver_deg"].as_f64().unwrap()
            >= m["max_limit_violation_deg"].as_f64().unwrap(),
        "{run}"
    );
}

/// The target of 1 cm at rest, apart from impacts: after 10 s the fast backend's piles lie
/// still, and no body lies deeper than 1 cm in another or in the ground, measured from
/// the shapes rather than from the solver's contacts.
#[test]
fn bench_measures_a_settled_pile_apart_from_its_impacts() {
    let run = bench_run("fast --ragdolls 8 --steps 600 --threads 1");
    let fastest = run["end_fastest_body_mps"].as_f64().unwrap();
    let overlap = run["end_overlap_m"].as_f64().unwrap();
    assert!(fastest < 0.05, "not at rest: {run}");
    assert!((0.0..=0.01).contains(&overlap), "{run}");
    // Contacts carried over the substeps hold the pile as well.
    let run = bench_run("fast --ragdolls 8 --steps 600 --threads 1 --keep-contacts");
    assert_eq!(run["keep_contacts"], true, "{run}");
    let fastest = run["end_fastest_body_mps"].as_f64().unwrap();
    let overlap = run["end_overlap_m"].as_f64().unwrap();
    assert!(fastest < 0.05, "not at rest: {run}");
    assert!((0.0..=0.01).contains(&overlap), "{run}");
}

/// The first run of `ragdoll bench --json --backend ARGS` (a backend, then the rest of the
/// arguments, space-separated).
fn bench_run(args: &str) -> Value {
    let tmp = tempfile::tempdir().unwrap();
    let mut all = vec!["bench", "--json", "--backend"];
    all.extend(args.split_whitespace());
    let o = ragdoll(tmp.path(), &all);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut out: Value = serde_json::from_slice(&o.stdout).unwrap();
    out["runs"][0].take()
}
