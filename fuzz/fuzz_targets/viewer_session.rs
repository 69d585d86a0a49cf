//! A page's messages, one per line, decoded and checked as the server does, then applied
//! to the built-in humanoid's world the way the viewer's session applies them (edits and a
//! backend switch rebuild the world; blasts and drags go into the live one), with steps
//! in between: the path by which a message the checks accept reached the particle broad
//! phase and crashed the server.
//!
//! The session itself is private to ragdoll-view; this mirrors its `handle`, `apply` and
//! `edit` (crates/ragdoll-view/src/session.rs) without the recording and the timeline.
#![no_main]

use std::sync::OnceLock;

use glam::Vec3;
use libfuzzer_sys::fuzz_target;
use ragdoll::events::Blast;
use ragdoll::scene::Scene;
use ragdoll::skeleton::humanoid;
use ragdoll::spec::{BuildOptions, JointKind, RagdollSpec, Shape, build_spec};
use ragdoll::world::{BackendKind, DragId, RagdollId, World, WorldSettings};
use ragdoll_fuzz::WORLD_STEPS;
use ragdoll_view::protocol::{BackendChoice, ClientMsg, SceneShape, parse_client_message};
use ragdoll_view::single_character_scene;

/// Messages read per input: each may rebuild the world, which costs milliseconds.
const MAX_MESSAGES: usize = 12;

struct Live {
    scene: Scene,
    world: World,
    ids: Vec<RagdollId>,
    drag: Option<DragId>,
}

impl Live {
    fn new(scene: Scene) -> Option<Live> {
        let (mut world, ids) = scene.build_world().ok()?;
        world.run(0.0);
        Some(Live {
            scene,
            world,
            ids,
            drag: None,
        })
    }

    fn rebuild(&mut self) -> bool {
        let Ok((mut world, ids)) = self.scene.build_world() else {
            return false;
        };
        world.run(0.0);
        self.world = world;
        self.ids = ids;
        self.drag = None;
        true
    }

    /// The session's `edit`: refused unless the spec validates and the world builds.
    fn edit(&mut self, ragdoll: usize, spec: RagdollSpec) {
        if spec.validate().is_err() {
            return;
        }
        let old = std::mem::replace(&mut self.scene.characters[ragdoll].spec, spec);
        if !self.rebuild() {
            self.scene.characters[ragdoll].spec = old;
            self.rebuild();
        }
    }

    fn handle(&mut self, msg: ClientMsg) {
        match msg {
            ClientMsg::Play {} | ClientMsg::Step {} => self.world.step(),
            ClientMsg::Pause {} | ClientMsg::Scrub { .. } | ClientMsg::Save {} => {}
            ClientMsg::Reset {} => {
                self.rebuild();
            }
            ClientMsg::DragStart {
                ragdoll,
                body,
                local,
                target,
            } => {
                if let Some(d) = self.drag.take() {
                    self.world.drag_end(d);
                }
                let mass = self.scene.characters[ragdoll]
                    .spec
                    .bodies
                    .get(body)
                    .map_or(1.0, |b| b.mass_kg);
                let hz = (3.0 * (10.0 / mass.max(1e-3)).sqrt()).clamp(3.0, 12.0);
                let id = self.ids[ragdoll];
                let (local, target) = (Vec3::from_array(local), Vec3::from_array(target));
                self.drag = self.world.drag_start(id, body, local, target, hz, 1.0).ok();
            }
            ClientMsg::DragMove { target } => {
                if let Some(d) = self.drag {
                    let _ = self.world.drag_move(d, Vec3::from_array(target));
                }
            }
            ClientMsg::DragEnd {} => {
                if let Some(d) = self.drag.take() {
                    self.world.drag_end(d);
                }
            }
            ClientMsg::Blast {
                position,
                tnt_kg,
                delay_s,
            } => {
                let time = self.world.time() as f32 + delay_s;
                let blast = Blast::new(tnt_kg, Vec3::from_array(position), time);
                let _ = self.world.add_blast(blast);
            }
            ClientMsg::EditBody {
                ragdoll,
                body,
                radius_m,
                length_m,
                center_m,
                mass_kg,
            } => {
                let mut spec = self.scene.characters[ragdoll].spec.clone();
                let b = &mut spec.bodies[body];
                b.shape = match b.shape {
                    Shape::Capsule { .. } => Shape::Capsule { radius_m, length_m },
                    Shape::Box { size_m } => Shape::Box {
                        size_m: [size_m[0], length_m, size_m[2]],
                    },
                };
                b.center_m = center_m;
                b.mass_kg = mass_kg;
                self.edit(ragdoll, spec);
            }
            ClientMsg::EditJoint {
                ragdoll,
                joint,
                min_deg,
                max_deg,
                swing_deg,
                twist_deg,
            } => {
                let mut spec = self.scene.characters[ragdoll].spec.clone();
                let j = &mut spec.joints[joint];
                j.kind = match (j.kind, min_deg, max_deg, swing_deg, twist_deg) {
                    (JointKind::Hinge { .. }, Some(min_deg), Some(max_deg), ..) => {
                        JointKind::Hinge { min_deg, max_deg }
                    }
                    (JointKind::SwingTwist { cone_tilt_deg, .. }, _, _, Some(s), Some(t)) => {
                        JointKind::SwingTwist {
                            swing_deg: s,
                            twist_deg: t,
                            cone_tilt_deg,
                        }
                    }
                    _ => return,
                };
                self.edit(ragdoll, spec);
            }
            ClientMsg::Backend { kind } => {
                let backend = match kind {
                    BackendChoice::Rigid => BackendKind::Rigid,
                    BackendChoice::Particle => BackendKind::Particle,
                };
                if backend != self.scene.settings.backend {
                    let old = self.scene.settings.backend;
                    self.scene.settings.backend = backend;
                    if !self.rebuild() {
                        self.scene.settings.backend = old;
                        self.rebuild();
                    }
                }
            }
        }
    }
}

fn start_scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        let character = humanoid();
        let spec = build_spec(&character, &BuildOptions::default()).expect("humanoid spec");
        let defaults = WorldSettings::default();
        // As the viewer sets it up: one track frame per step.
        let settings = WorldSettings {
            fps: 1.0 / defaults.dt,
            ..defaults
        };
        single_character_scene(character, spec, "built-in", settings)
    })
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let scene = start_scene();
    let shape = SceneShape {
        bodies: scene
            .characters
            .iter()
            .map(|c| c.spec.bodies.len())
            .collect(),
        joints: scene
            .characters
            .iter()
            .map(|c| c.spec.joints.len())
            .collect(),
    };
    let mut messages = text
        .lines()
        .filter_map(|line| parse_client_message(line, &shape).ok())
        .take(MAX_MESSAGES)
        .peekable();
    if messages.peek().is_none() {
        return;
    }
    let Some(mut live) = Live::new(scene.clone()) else {
        return;
    };
    for msg in messages {
        live.handle(msg);
        live.world.step();
    }
    for _ in 0..WORLD_STEPS {
        live.world.step();
    }
});
