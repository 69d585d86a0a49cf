//! The per-character summary of a scene's report: how fast each character's centre of mass
//! went and how long it flew, checked against free fall.

use std::path::Path;

use ragdoll::report::AIRBORNE_CLEARANCE_M;
use ragdoll::scene::Scene;

const G: f32 = 9.80665;

fn run(text: &str) -> ragdoll::report::Report {
    Scene::from_toml(text, Path::new("summary.toml"))
        .unwrap()
        .run()
        .unwrap()
        .report
}

#[test]
fn a_drop_flies_as_long_as_free_fall_takes_and_lands_at_its_speed() {
    // Feet 2 m up: they fall 2 m less the clearance before anything is near the ground.
    let report = run("duration_s = 1.5\n[[character]]\nposition = [0.0, 2.0, 0.0]\n");
    let c = &report.characters[0];
    let fall = 2.0 - AIRBORNE_CLEARANCE_M;
    let flight = (2.0 * fall / G).sqrt();
    let airborne = c.airborne_s.unwrap();
    assert!(
        (airborne - flight).abs() < 2.0 / 60.0,
        "{airborne} s, free fall takes {flight} s"
    );
    // The centre of mass is as fast as free fall when the feet land, and never faster than
    // a fall from its own start (about 1 m above the feet) to the ground.
    let landing = (2.0 * G * fall).sqrt();
    let ceiling = (2.0 * G * 3.0f32).sqrt();
    assert!(
        (landing - 0.1..=ceiling).contains(&c.max_speed_mps),
        "{} m/s, landing at {landing}",
        c.max_speed_mps
    );
    // The head stops from about the landing speed on the floor within the 0.87 s left,
    // held up against gravity: on average it feels at least (6.2 / 0.87 + 9.8) m/s², 1.7 g,
    // and its peak is no less than its average.
    let felt = c.peak_head_accel_g.unwrap();
    assert!(felt > 1.5, "{felt} g");
}

#[test]
fn a_collapse_never_leaves_the_ground_and_no_ground_means_no_flight_time() {
    let report = run("duration_s = 1.5\n[[character]]\n");
    let c = &report.characters[0];
    assert_eq!(c.airborne_s, Some(0.0), "{c:?}");
    // It fell over: its centre of mass moved, at less than a free fall from its height.
    assert!(
        c.max_speed_mps > 0.5 && c.max_speed_mps < (2.0 * G * 1.0f32).sqrt(),
        "{c:?}"
    );
    let report = run("duration_s = 0.5\nground = \"none\"\n[[character]]\n");
    assert_eq!(report.characters[0].airborne_s, None);
    let v = report.characters[0].max_speed_mps;
    assert!((v - G * 0.5).abs() < 0.1, "free fall for 0.5 s: {v} m/s");
    // A falling head feels nothing, as an accelerometer in free fall reads nothing.
    let felt = report.characters[0].peak_head_accel_g.unwrap();
    assert!(felt < 0.05, "{felt} g in free fall");
}
