//! `ragdoll bench --reference`: the plain rapier3d pile runs beside ours in the same run,
//! and it is a real workload, ragdolls that fall, hold together and come to rest on the
//! ground, so that the ratio to it compares like with like.

mod common;

use common::{ragdoll, stderr};
use serde_json::Value;

/// The first run of `ragdoll bench --json --reference ARGS` (space-separated).
fn reference_run(args: &str) -> Value {
    let tmp = tempfile::tempdir().unwrap();
    let mut all = vec!["bench", "--json", "--reference", "--threads", "1"];
    all.extend(args.split_whitespace());
    let o = ragdoll(tmp.path(), &all);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut out: Value = serde_json::from_slice(&o.stdout).unwrap();
    out["runs"][0].take()
}

#[test]
fn the_json_holds_the_plain_run_and_the_ratio_to_it() {
    let run = reference_run("--backend fast --ragdolls 4 --steps 20");
    let plain = &run["plain_rapier"];
    assert_eq!(plain["ragdolls"], 4, "{run}");
    assert_eq!(plain["steps"], 20, "{run}");
    assert_eq!(plain["bodies_per_ragdoll"], 11, "{run}");
    assert_eq!(plain["solver_iterations"], 4, "{run}");
    let per_cpu = |r: &Value| r["ragdoll_steps_per_cpu_second"].as_f64().unwrap();
    let ratio = run["cpu_ratio_to_plain_rapier"].as_f64().unwrap();
    assert!(
        (ratio - per_cpu(&run) / per_cpu(plain)).abs() < 1e-9 * ratio,
        "{run}"
    );
    for key in [
        "end_overlap_m",
        "end_fastest_body_mps",
        "end_joint_gap_m",
        "lowest_body_m",
    ] {
        assert!(plain[key].is_number(), "{key}: {run}");
    }
    // Beside --compare too: both references in one run.
    let run = reference_run("--backend particle --compare --ragdolls 2 --steps 5");
    assert_eq!(run["rigid"]["backend"], "rigid", "{run}");
    assert!(run["cpu_ratio_to_plain_rapier"].is_number(), "{run}");
}

/// After 10 s two piles of plain rapier ragdolls lie on the ground, not through it, at
/// rest (rapier puts them to sleep), every ragdoll in one piece.
#[test]
fn plain_ragdolls_come_to_rest_on_the_ground_in_one_piece() {
    let run = reference_run("--backend fast --ragdolls 8 --steps 600");
    let plain = &run["plain_rapier"];
    let reading = |key: &str| plain[key].as_f64().unwrap();
    assert_eq!(plain["non_finite"], false, "{run}");
    assert!(reading("lowest_body_m") > -0.1, "fell through: {run}");
    assert!(
        reading("lowest_body_m") < 0.05,
        "nothing on the ground: {run}"
    );
    assert!(reading("end_fastest_body_mps") < 0.1, "not at rest: {run}");
    assert!(reading("end_joint_gap_m") < 0.01, "torn apart: {run}");
    assert!(reading("end_overlap_m") < 0.05, "{run}");
    assert_eq!(plain["stable"], true, "{run}");
}

/// The plain run prints its own row under ours, and the ratio.
#[test]
fn the_table_prints_the_plain_row_and_the_ratio() {
    let tmp = tempfile::tempdir().unwrap();
    let o = ragdoll(
        tmp.path(),
        &[
            "bench",
            "--backend",
            "fast",
            "--reference",
            "--ragdolls",
            "2",
            "--steps",
            "5",
            "--threads",
            "1",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("pile  fast")
            && text.contains("pile  plain-rapier")
            && text.contains("fast / plain rapier: "),
        "{text}"
    );
}
