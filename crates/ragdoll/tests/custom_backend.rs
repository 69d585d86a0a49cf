//! A fourth backend written against the public seam alone ([`ragdoll::backend::Backend`]):
//! free rigid bodies (no joints, no collisions between them) over a ground that stops
//! them. Too simple for a ragdoll, enough to show that the world places, steps, blasts,
//! shoots and records through the trait, and hands each step's impulses over in one call
//! ([`Backend::apply`], a batch of [`Command`]s).

use std::sync::{Arc, Mutex};

use glam::{Quat, Vec3};
use ragdoll::backend::{
    Backend, BodyDesc, BodyId, BodyImpulse, BodyState, Command, JointDesc, JointId, PinId,
    StepReport,
};
use ragdoll::events::{Blast, Projectile};
use ragdoll::math::Transform;
use ragdoll::spec::{BuildOptions, build_spec};
use ragdoll::world::{World, WorldSettings};

/// What the test reads back of the backend after the world owns it.
#[derive(Default)]
struct Log {
    /// How many impulses each `apply` call that held any carried.
    batches: Vec<usize>,
    steps: usize,
    /// The deepest any body went under the ground before the engine stopped it, metres.
    deepest: f32,
    /// How many bodies the world moved (`Command::Pose`) once stepping had begun.
    poses_while_stepping: usize,
}

struct Ballistic {
    gravity: Vec3,
    ground: Option<f32>,
    bodies: Vec<(BodyState, f32, bool)>,
    /// The spin every other body of a ragdoll starts with, rad/s.
    spin: Vec3,
    log: Arc<Mutex<Log>>,
}

impl Ballistic {
    fn new(settings: &WorldSettings, log: Arc<Mutex<Log>>) -> Self {
        Ballistic {
            gravity: settings.gravity,
            ground: settings.ground,
            bodies: Vec::new(),
            spin: Vec3::ZERO,
            log,
        }
    }
}

impl Backend for Ballistic {
    fn add_ragdoll(
        &mut self,
        bodies: &[BodyDesc],
        _: &[JointDesc],
        _: &[(usize, usize)],
    ) -> BodyId {
        let first = self.bodies.len();
        for (i, b) in bodies.iter().enumerate() {
            let state = BodyState {
                pose: b.pose,
                linvel: b.linvel,
                angvel: b.angvel + if i % 2 == 1 { self.spin } else { Vec3::ZERO },
            };
            self.bodies.push((state, b.mass, false));
        }
        BodyId(first)
    }

    fn step(&mut self, dt: f32) -> StepReport {
        let mut deepest = 0.0f32;
        for (s, _, kinematic) in &mut self.bodies {
            if *kinematic {
                continue;
            }
            s.linvel += self.gravity * dt;
            s.pose.translation += s.linvel * dt;
            s.pose.rotation = (Quat::from_scaled_axis(s.angvel * dt) * s.pose.rotation).normalize();
            if let Some(g) = self.ground
                && s.pose.translation.y < g
            {
                deepest = deepest.max(g - s.pose.translation.y);
                s.pose.translation.y = g;
                s.linvel = Vec3::ZERO;
                s.angvel = Vec3::ZERO;
            }
        }
        let mut log = self.log.lock().unwrap();
        log.steps += 1;
        log.deepest = log.deepest.max(deepest);
        StepReport {
            max_penetration_m: deepest,
            ..Default::default()
        }
    }

    fn apply(&mut self, commands: &[Command]) {
        let impulses = commands
            .iter()
            .filter(|c| matches!(c, Command::Impulse(_)))
            .count();
        let mut log = self.log.lock().unwrap();
        if impulses > 0 {
            log.batches.push(impulses);
        }
        if log.steps > 0 {
            log.poses_while_stepping += commands
                .iter()
                .filter(|c| matches!(c, Command::Pose { .. }))
                .count();
        }
        drop(log);
        for command in commands {
            match *command {
                Command::Impulse(BodyImpulse::AtPoint {
                    body: BodyId(index),
                    impulse,
                    ..
                }) => {
                    let (s, m, _) = &mut self.bodies[index];
                    s.linvel += impulse / *m;
                }
                Command::Kinematic {
                    body: BodyId(index),
                    kinematic,
                } => self.bodies[index].2 = kinematic,
                Command::KinematicTarget {
                    body: BodyId(index),
                    pose,
                }
                | Command::Pose {
                    body: BodyId(index),
                    pose,
                } => self.bodies[index].0.pose = pose,
                Command::Velocity {
                    body: BodyId(index),
                    linvel,
                    angvel,
                } => {
                    self.bodies[index].0.linvel = linvel;
                    self.bodies[index].0.angvel = angvel;
                }
                Command::Gravity(g) => self.gravity = g,
                // No spin, joints, pins or solver substeps to change; a command added to
                // the enum later lands here too.
                _ => {}
            }
        }
    }

    fn body_states(&self, out: &mut Vec<BodyState>) {
        out.clear();
        out.extend(self.bodies.iter().map(|b| b.0));
    }

    fn kinetic_energy(&self) -> f64 {
        self.bodies
            .iter()
            .map(|(s, m, _)| 0.5 * (*m as f64) * s.linvel.length_squared() as f64)
            .sum()
    }

    fn cast_ray(&self, origin: Vec3, dir: Vec3, max_dist: f32) -> Option<(BodyId, f32)> {
        // Each body as a 10 cm ball about its centre: enough to be hit.
        self.bodies
            .iter()
            .enumerate()
            .filter_map(|(k, (s, _, _))| {
                let along = (s.pose.translation - origin).dot(dir);
                let miss = (s.pose.translation - origin - dir * along).length();
                (along > 0.0 && along < max_dist && miss < 0.1).then_some((BodyId(k), along))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    fn add_pin(&mut self, _: BodyId, _: Vec3, _: Vec3, _: Option<(f32, f32)>) -> PinId {
        PinId(0)
    }
    fn bodies_touching_other_ragdolls(&self, out: &mut Vec<bool>) {
        out.clear();
        out.resize(self.bodies.len(), false);
    }

    /// No drives: a powered ragdoll goes limp here.
    fn drive_joint(&mut self, _: JointId, _: Quat, _: Vec3, _: f32, _: f32) {}
}

fn world_with(settings: &WorldSettings) -> (World, Arc<Mutex<Log>>) {
    let log = Arc::new(Mutex::new(Log::default()));
    let engine = Ballistic::new(settings, log.clone());
    (
        World::with_backend(settings, Box::new(engine)).unwrap(),
        log,
    )
}

#[test]
fn the_world_steps_and_records_through_someone_elses_engine() {
    // Dropped from 2 m, the humanoid's bodies fall as free bodies do: 1/2 g t² after 0.4 s
    // (the ground is far below them by then), and the track records what the engine did.
    let settings = WorldSettings {
        ground: None,
        ..Default::default()
    };
    let (mut world, log) = world_with(&settings);
    let character = ragdoll::skeleton::humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let id = world
        .add_ragdoll(
            &character,
            &spec,
            Transform::from_translation(Vec3::Y * 2.0),
        )
        .unwrap();
    let start = world.body_poses(id);
    world.run(0.4);
    let g = settings.gravity.y.abs();
    // The world steps it once per step (its substeps would be its own): explicit Euler
    // on that step falls a little further than the exact parabola.
    let h = settings.dt;
    let steps = (0.4 / h).round();
    let expected = 0.5 * g * h * h * steps * (steps + 1.0);
    for (a, b) in start.iter().zip(world.body_poses(id)) {
        let fell = a.translation.y - b.translation.y;
        assert!(
            (fell - expected).abs() < 1e-3,
            "fell {fell} m, expected {expected}"
        );
    }
    assert_eq!(log.lock().unwrap().steps, steps as usize);
    assert_eq!(
        world.track(id).frames.len(),
        13,
        "0.4 s at 30 fps, both ends"
    );
    assert!(!world.metrics().nan);
}

#[test]
fn each_steps_impulses_arrive_in_one_call_and_add_up_to_the_events() {
    // A blast and a shot: every impulse the world's events give in a substep reaches the
    // engine in one `apply` call, and the momentum the engine holds afterwards is
    // what the blast report and the shot say they delivered.
    let settings = WorldSettings {
        ground: None,
        gravity: Vec3::ZERO,
        ..Default::default()
    };
    let (mut world, log) = world_with(&settings);
    let character = ragdoll::skeleton::humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let id = world
        .add_ragdoll(&character, &spec, Transform::IDENTITY)
        .unwrap();
    world
        .add_blast(Blast::new(50.0, Vec3::new(0.0, 1.0, 20.0), 0.0))
        .unwrap();
    let pelvis = world.body_poses(id)[0].translation;
    world
        .add_projectile(Projectile {
            origin: pelvis + Vec3::new(5.0, 0.0, 0.0),
            direction: Vec3::NEG_X,
            mass_kg: 0.1,
            speed_mps: 400.0,
            time_s: 0.1,
        })
        .unwrap();
    world.run(0.5);
    let log = log.lock().unwrap();
    assert!(!log.batches.is_empty());
    assert!(log.batches.iter().all(|&n| n > 0), "{:?}", log.batches);
    // At most two calls per substep: the events' before the step, a shot's after it.
    assert!(
        log.batches.len() <= 2 * log.steps,
        "{} calls",
        log.batches.len()
    );
    assert!(
        log.batches.iter().any(|&n| n >= 10),
        "a blast reaches many parts at once"
    );
    let blast: f64 = world.blast_reports()[0]
        .parts
        .iter()
        .map(|p| p.impulse_ns)
        .sum();
    let shot = world.projectile_reports()[0].impulse_ns as f64;
    assert!(world.projectile_reports()[0].body.is_some(), "the shot hit");
    let momentum: Vec3 = world
        .body_velocities(id)
        .iter()
        .zip(&spec.bodies)
        .map(|((v, _), b)| *v * b.mass_kg)
        .sum();
    // The blast pushes along -Z (away from the charge, 20 m off: each part's push is
    // within 3° of -Z, so their sum is within 0.2 % of the sum of their sizes, which the
    // report gives), the shot along -X.
    assert!(
        ((-momentum.z as f64) - blast).abs() < 2e-3 * blast,
        "{momentum} vs blast {blast}"
    );
    assert!(
        ((-momentum.x as f64) - shot).abs() < 1e-3 * shot,
        "{momentum} vs shot {shot}"
    );
}

/// Joint limits are the engine's to hold: this one has no joints, and as its bodies spin
/// apart the world measures how far past their limits they go, but moves no body to mend
/// them (it sends no pose once stepping has begun) and reads no clamp.
#[test]
fn the_world_measures_limits_and_never_clamps_them() {
    let settings = WorldSettings {
        ground: None,
        gravity: Vec3::ZERO,
        ..Default::default()
    };
    let log = Arc::new(Mutex::new(Log::default()));
    let mut engine = Ballistic::new(&settings, log.clone());
    engine.spin = Vec3::new(0.0, 0.0, 3.0);
    let mut world = World::with_backend(&settings, Box::new(engine)).unwrap();
    let character = ragdoll::skeleton::humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    world
        .add_ragdoll(&character, &spec, Transform::IDENTITY)
        .unwrap();
    world.run(0.5);
    let m = world.metrics();
    // Half a second at 3 rad/s turns every other body 86° against its neighbours.
    assert!(m.max_limit_violation_deg > 20.0, "{m:?}");
    assert_eq!(
        m.max_limit_violation_solver_deg, m.max_limit_violation_deg,
        "{m:?}"
    );
    assert_eq!(log.lock().unwrap().poses_while_stepping, 0);
}

#[test]
fn an_engine_that_cannot_remove_ragdolls_is_refused_in_a_sentence() {
    // The trait's default: the engine says it cannot, and the world keeps the ragdoll.
    let (mut world, log) = world_with(&WorldSettings::default());
    let character = ragdoll::skeleton::humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    let id = world
        .add_ragdoll(&character, &spec, Transform::IDENTITY)
        .unwrap();
    world.run(0.1);
    let err = world.remove_ragdoll(id).unwrap_err().to_string();
    assert!(err.contains("cannot remove ragdolls"), "{err}");
    let steps = log.lock().unwrap().steps;
    world.run(0.1);
    assert!(log.lock().unwrap().steps > steps, "the world steps on");
    assert_eq!(world.track(id).frames.len(), 7);
}

#[test]
fn what_the_engine_reports_of_a_step_reaches_the_metrics() {
    // Dropped from 1 m onto its ground, the ballistic engine's bodies pass under it by a
    // step's fall before it stops them; the world's penetration is what the engine saw
    // (the world cannot read it from the bodies, which end on the ground).
    let (mut world, log) = world_with(&WorldSettings::default());
    let character = ragdoll::skeleton::humanoid();
    let spec = build_spec(&character, &BuildOptions::default()).unwrap();
    world
        .add_ragdoll(&character, &spec, Transform::from_translation(Vec3::Y))
        .unwrap();
    world.run(1.0);
    let deepest = log.lock().unwrap().deepest;
    // At least one step's fall at the speed of a 1 m drop: 4.4 m/s over 1/60 s.
    assert!(deepest > 0.02, "{deepest}");
    assert_eq!(world.metrics().max_penetration_m, deepest);
}
