//! Events, world settings and motors: every bound's edge, and the strongest accepted
//! events simulate on both backends.

use glam::Vec3;
use ragdoll::events::{self, Blast, Field, Pin, Projectile, Push};
use ragdoll::skeleton;
use ragdoll::world::{self, BackendKind, Motors, World, WorldSettings};

use super::{BACKENDS, humanoid_spec, past, run_finite, setting_of, world_with};

// --- Events ---------------------------------------------------------------------------------

#[test]
fn the_reported_bullet_at_1e30_mps_is_refused_with_its_bound() {
    let shot = Projectile {
        origin: Vec3::new(0.0, 1.2, 5.0),
        direction: Vec3::NEG_Z,
        mass_kg: 0.008,
        speed_mps: 1e30,
        time_s: 0.0,
    };
    let (setting, message) = setting_of(shot.validate());
    assert_eq!(setting, "speed");
    assert!(
        message.contains("3000 m/s") && message.contains("1e30"),
        "{message}"
    );
    let (mut world, _) = world_with(&skeleton::humanoid(), &humanoid_spec(), BackendKind::Rigid);
    assert!(world.add_projectile(shot).is_err());
}

/// Each event bound: accepted at its edge, refused just past it, naming the setting.
#[test]
fn every_event_bound_accepts_its_edge_and_refuses_past_it() {
    let blast = |tnt: f32, at: f32, time: f32, scale: f32| Blast {
        tnt_kg: tnt,
        position: Vec3::new(at, 0.5, 0.0),
        time_s: time,
        scale,
    };
    type Check = Box<dyn Fn(f32) -> ragdoll::Result<()>>;
    let edges: Vec<(&str, Check, f32)> = vec![
        (
            "tnt",
            Box::new(move |v| blast(v, 0.0, 0.0, 1.0).validate()),
            events::MAX_TNT_KG,
        ),
        (
            "at",
            Box::new(move |v| blast(1.0, v, 0.0, 1.0).validate()),
            world::MAX_COORDINATE_M,
        ),
        (
            "at",
            Box::new(move |v| blast(1.0, v, 0.0, 1.0).validate()),
            -world::MAX_COORDINATE_M,
        ),
        (
            "time",
            Box::new(move |v| blast(1.0, 0.0, v, 1.0).validate()),
            world::MAX_SECONDS,
        ),
        (
            "scale",
            Box::new(move |v| blast(1.0, 0.0, 0.0, v).validate()),
            events::MAX_BLAST_SCALE,
        ),
        (
            "mass",
            Box::new(|v| shot(v, 0.0).validate()),
            events::MAX_PROJECTILE_KG,
        ),
        (
            "speed",
            Box::new(|v| shot(0.001, v).validate()),
            events::MAX_PROJECTILE_SPEED_MPS,
        ),
        (
            "speed",
            Box::new(|v| shot(1.0, v).validate()),
            events::MAX_MOMENTUM_NS,
        ),
        (
            "impulse_ns",
            Box::new(|v| {
                Push::Impulse {
                    target: "head".into(),
                    impulse_ns: Vec3::new(0.0, 0.0, v),
                    time_s: 0.0,
                }
                .validate()
            }),
            events::MAX_MOMENTUM_NS,
        ),
        (
            "force_n",
            Box::new(|v| {
                Push::Force {
                    target: "head".into(),
                    force_n: Vec3::new(v, 0.0, 0.0),
                    start_s: 0.0,
                    end_s: 1.0,
                }
                .validate()
            }),
            events::MAX_FORCE_N,
        ),
        (
            "end_s",
            Box::new(|v| {
                Field::Drag {
                    rate_per_s: 1.0,
                    start_s: 0.0,
                    end_s: v,
                }
                .validate()
            }),
            world::MAX_SECONDS,
        ),
        (
            "rate_per_s",
            Box::new(|v| {
                Field::Drag {
                    rate_per_s: v,
                    start_s: 0.0,
                    end_s: 1.0,
                }
                .validate()
            }),
            events::MAX_DRAG_RATE_PER_S,
        ),
        (
            "velocity_mps",
            Box::new(|v| wind(v).validate()),
            events::MAX_WIND_MPS,
        ),
        (
            "keys",
            Box::new(|v| {
                Field::Gravity {
                    keys: vec![(0.0, Vec3::new(0.0, -v, 0.0))],
                }
                .validate()
            }),
            world::MAX_GRAVITY_MPS2,
        ),
        (
            "strength_mps2",
            Box::new(|v| radial(v, 3.0).validate()),
            world::MAX_GRAVITY_MPS2,
        ),
        (
            "strength_mps2",
            Box::new(|v| radial(v, 3.0).validate()),
            -world::MAX_GRAVITY_MPS2,
        ),
        (
            "radius_m",
            Box::new(|v| radial(1.0, v).validate()),
            2.0 * world::MAX_COORDINATE_M,
        ),
        (
            "stiffness_hz",
            Box::new(|v| pin(Some(v), 0.5).validate()),
            events::MAX_PIN_STIFFNESS_HZ,
        ),
        (
            "damping_ratio",
            Box::new(|v| pin(Some(events::MAX_PIN_STIFFNESS_HZ), v).validate()),
            events::MAX_PIN_DAMPING_HZ / events::MAX_PIN_STIFFNESS_HZ,
        ),
        (
            "damping_ratio",
            Box::new(|v| pin(Some(1.0), v).validate()),
            events::MAX_PIN_DAMPING_HZ,
        ),
        (
            "release_s",
            Box::new(|v| {
                Pin {
                    release_s: Some(v),
                    ..pin(None, 1.0)
                }
                .validate()
            }),
            world::MAX_SECONDS,
        ),
        (
            "keys",
            Box::new(|v| {
                Pin {
                    keys: vec![(0.0, Vec3::new(0.0, v, 0.0))],
                    ..pin(None, 1.0)
                }
                .validate()
            }),
            world::MAX_COORDINATE_M,
        ),
    ];
    for (setting, check, edge) in edges {
        check(edge).unwrap_or_else(|e| panic!("{setting}: the edge {edge} is refused: {e}"));
        let (got, message) = setting_of(check(past(edge)));
        assert_eq!(got, setting, "{message}");
    }
    // Tiny charges and shots, zero speeds and scales are fine; zero charges are not.
    blast(1e-9, 0.0, 0.0, 0.0).validate().unwrap();
    assert!(blast(0.0, 0.0, 0.0, 1.0).validate().is_err());
    assert!(blast(1.0, 0.0, -1.0, 1.0).validate().is_err());
    // Keys: at most MAX_KEYS, in order.
    let keys = |n: usize| Field::Gravity {
        keys: (0..n).map(|k| (k as f32 * 0.01, Vec3::NEG_Y)).collect(),
    };
    keys(events::MAX_KEYS).validate().unwrap();
    assert_eq!(setting_of(keys(events::MAX_KEYS + 1).validate()).0, "keys");
}

fn shot(mass_kg: f32, speed_mps: f32) -> Projectile {
    Projectile {
        origin: Vec3::new(0.0, 1.25, 5.0),
        direction: Vec3::NEG_Z,
        mass_kg,
        speed_mps,
        time_s: 0.05,
    }
}

fn wind(speed: f32) -> Field {
    Field::Wind {
        velocity_mps: Vec3::new(speed, 0.0, 0.0),
        start_s: 0.0,
        end_s: events::OPEN_END_S,
    }
}

fn radial(strength: f32, radius: f32) -> Field {
    Field::Radial {
        center: Vec3::new(0.0, 1.0, 0.0),
        strength_mps2: strength,
        radius_m: radius,
        start_s: 0.0,
        end_s: 0.3,
    }
}

fn pin(stiffness_hz: Option<f32>, damping_ratio: f32) -> Pin {
    Pin {
        target: "hand_l".into(),
        keys: vec![
            (0.0, Vec3::new(0.4, 0.9, 0.0)),
            (0.4, Vec3::new(0.4, 2.0, 0.0)),
        ],
        stiffness_hz,
        damping_ratio,
        release_s: None,
    }
}

/// The strongest accepted events, on the humanoid, on both backends: still finite.
#[test]
fn the_strongest_accepted_events_simulate_on_both_backends() {
    let character = skeleton::humanoid();
    let spec = humanoid_spec();
    for backend in BACKENDS {
        let pinned = pin(
            Some(events::MAX_PIN_STIFFNESS_HZ),
            events::MAX_PIN_DAMPING_HZ / events::MAX_PIN_STIFFNESS_HZ,
        );
        type Add = Box<dyn Fn(&mut World, world::RagdollId) -> ragdoll::Result<()>>;
        let adds: Vec<(&str, Add)> = vec![
            (
                "the largest momentum",
                Box::new(|w, _| w.add_projectile(shot(1.0, events::MAX_MOMENTUM_NS))),
            ),
            (
                "the largest impulse on a hand",
                Box::new(|w, id| {
                    w.add_push(
                        id,
                        Push::Impulse {
                            target: "hand_l".into(),
                            impulse_ns: Vec3::new(events::MAX_MOMENTUM_NS, 0.0, 0.0),
                            time_s: 0.05,
                        },
                    )
                }),
            ),
            (
                "the largest force on a hand",
                Box::new(|w, id| {
                    w.add_push(
                        id,
                        Push::Force {
                            target: "hand_l".into(),
                            force_n: Vec3::new(events::MAX_FORCE_N, 0.0, 0.0),
                            start_s: 0.0,
                            end_s: 0.3,
                        },
                    )
                }),
            ),
            (
                "the strongest wind",
                Box::new(|w, _| w.add_field(wind(events::MAX_WIND_MPS))),
            ),
            (
                "the strongest radial field",
                Box::new(|w, _| w.add_field(radial(world::MAX_GRAVITY_MPS2, 3.0))),
            ),
            (
                "the stiffest, most damped pin",
                Box::new(move |w, id| w.add_pin(id, pinned.clone())),
            ),
        ];
        for (what, add) in adds {
            let (mut world, id) = world_with(&character, &spec, backend);
            add(&mut world, id).unwrap_or_else(|e| panic!("{what}: {e}"));
            run_finite(world, 0.4, &format!("{what} on {backend:?}"));
        }
        let settings = WorldSettings {
            backend: backend.into(),
            gravity: Vec3::new(0.0, -world::MAX_GRAVITY_MPS2, 0.0),
            ..Default::default()
        };
        let (world, _) = World::with_ragdoll(&character, &spec, &settings).unwrap();
        run_finite(world, 0.4, &format!("the strongest gravity on {backend:?}"));
    }
    // The largest charge, on the character, on rigid (the particle backend's broad phase
    // is sized by the fastest body).
    let (mut world, _) = world_with(&character, &spec, BackendKind::Rigid);
    world
        .add_blast(Blast::new(
            events::MAX_TNT_KG,
            Vec3::new(0.0, 1.0, 0.0),
            0.05,
        ))
        .unwrap();
    run_finite(world, 0.4, "the largest charge on rigid");
}

// --- World settings and motors ----------------------------------------------------------

#[test]
fn world_settings_and_runs_are_bounded() {
    let ok = WorldSettings::default();
    type Set = fn(&mut WorldSettings, f32);
    let edges: Vec<(&str, Set, f32)> = vec![
        ("dt", |s, v| s.dt = v, world::STEP_RANGE_S[1]),
        ("fps", |s, v| s.fps = v, world::MAX_FPS),
        (
            "gravity",
            |s, v| s.gravity = Vec3::new(0.0, 0.0, v),
            world::MAX_GRAVITY_MPS2,
        ),
        (
            "ground",
            |s, v| s.ground = Some(v),
            -world::MAX_COORDINATE_M,
        ),
    ];
    for (setting, set, edge) in edges {
        let mut s = ok.clone();
        set(&mut s, edge);
        s.validate()
            .unwrap_or_else(|e| panic!("{setting}: the edge {edge} is refused: {e}"));
        set(&mut s, past(edge));
        assert_eq!(setting_of(s.validate()).0, setting);
    }
    let mut s = ok.clone();
    s.dt = world::STEP_RANGE_S[0];
    s.validate().unwrap();
    s.dt = world::STEP_RANGE_S[0].next_down();
    assert_eq!(setting_of(s.validate()).0, "dt");
    let mut s = ok.clone();
    s.backend = world::BackendConfig::Rigid(world::RigidConfig {
        substeps: world::MAX_SUBSTEPS + 1,
        ..Default::default()
    });
    assert_eq!(setting_of(s.validate()).0, "substeps");
    // A gap tolerance is a length: none below 0, none not finite; 0 is one.
    for (tolerance, ok_) in [
        (0.0, true),
        (-0.001, false),
        (f32::NAN, false),
        (f32::INFINITY, false),
    ] {
        s.backend = world::BackendConfig::Rigid(world::RigidConfig {
            gap_tolerance_m: Some(tolerance),
            ..Default::default()
        });
        if ok_ {
            s.validate().unwrap();
        } else {
            assert_eq!(setting_of(s.validate()).0, "gap_tolerance_m", "{tolerance}");
        }
    }

    // A run records at most MAX_TRACK_SAMPLES joint transforms: 100 s at 1000 fps is
    // 100 001 frames, so 99 joints fit and 100 do not.
    let fast = WorldSettings {
        fps: 1000.0,
        ..ok.clone()
    };
    assert_eq!(world::MAX_TRACK_SAMPLES / 100_001, 99);
    fast.validate_run(100.0, 99).unwrap();
    assert_eq!(setting_of(fast.validate_run(100.0, 100)).0, "seconds");
    ok.validate_run(world::MAX_SECONDS, 1).unwrap();
    assert!(ok.validate_run(past(world::MAX_SECONDS), 1).is_err());
    assert!(ok.validate_run(f32::NAN, 1).is_err());
}

#[test]
fn motor_keys_are_bounded() {
    let keys = |k: Vec<(f32, f32)>| Motors {
        strength_keys: k,
        root_on_clip: false,
    };
    keys(vec![(world::MAX_SECONDS, 1.0)]).validate().unwrap();
    for bad in [
        keys(vec![(past(world::MAX_SECONDS), 1.0)]),
        keys(vec![(-1.0, 1.0)]),
        keys(vec![(0.0, past(1.0))]),
        keys(
            (0..=events::MAX_KEYS)
                .map(|k| (k as f32 * 0.01, 1.0))
                .collect(),
        ),
    ] {
        assert!(bad.validate().is_err(), "{:?}", &bad.strength_keys[..1]);
    }
}
