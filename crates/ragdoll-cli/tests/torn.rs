//! A run whose loads tear the ragdoll's joints apart is finite, so it is written, but the
//! user is told its motion is not physical; an ordinary blast says nothing of the kind.

mod common;

use common::*;

#[test]
fn a_kiloton_next_to_a_person_warns_that_the_joints_gave_way() {
    let dir = tempfile::tempdir().unwrap();
    let o = ragdoll(
        dir.path(),
        &["blast", "--tnt", "1e7", "--at", "2,1,0", "-o", "kt.glb"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("warning: humanoid: joints came")
            && err.contains("not physical")
            && err.contains("smaller charge"),
        "{err}"
    );
    let report = read_json(&dir.path().join("kt.report.json"));
    let separation = report["max_joint_separation_m"].as_f64().unwrap();
    let height = report["characters"][0]["height_m"].as_f64().unwrap();
    assert!(separation > 0.05 * height, "{separation} m of {height} m");

    let o = ragdoll(
        dir.path(),
        &["blast", "--tnt", "5", "--at", "2,0.5,1", "-o", "small.glb"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
}
