//! The report of a single-character run says how many joints the solver worked on each
//! frame, as a scene's does: on the fast backend, every joint while the character is
//! thrown, fewer once its joints freeze and it sleeps; all of them with `--no-freeze`
//! until it sleeps.

mod fixture;

use fixture::{json, run};

/// The per-frame counts and the joint count of a 3 s fast blast run's report.
fn counts(extra: &[&str]) -> (Vec<u64>, u64) {
    let tmp = tempfile::tempdir().unwrap();
    let args = [
        &[
            "blast",
            "--tnt",
            "1",
            "--at",
            "1.5,1,0",
            "--backend",
            "fast",
            "--seconds",
            "3",
            "-o",
            "b.glb",
        ][..],
        extra,
    ]
    .concat();
    let o = run(tmp.path(), &args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = json(&tmp.path().join("b.report.json"));
    let active = report["active_joints_per_frame"]
        .as_array()
        .expect("a fast run's report counts its active joints")
        .iter()
        .map(|n| n.as_u64().unwrap())
        .collect::<Vec<_>>();
    assert_eq!(active.len() as u64, report["frames"].as_u64().unwrap());
    (active, report["characters"][0]["joints"].as_u64().unwrap())
}

#[test]
fn a_fast_run_reports_its_active_joints_and_frozen_ones_are_not_counted() {
    let (frozen, joints) = counts(&[]);
    let (all, _) = counts(&["--no-freeze"]);
    // Thrown at first: every joint works.
    assert_eq!(frozen[0], joints, "{frozen:?}");
    assert_eq!(all[0], joints, "{all:?}");
    // Once the character lies still its joints freeze, seconds before it would sleep.
    let working = |a: &[u64]| a.iter().sum::<u64>();
    assert!(working(&frozen) < working(&all), "{frozen:?}\n{all:?}");
    assert!(frozen.iter().all(|&n| n <= joints));
}
