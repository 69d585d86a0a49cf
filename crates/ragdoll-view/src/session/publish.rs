//! What the session sends out: the `scene` message (once), the `specs` message (after
//! every change), frames, the state endpoint's JSON, and notices.

use std::sync::PoisonError;

use glam::Vec3;
use ragdoll::math::Transform;
use ragdoll::spec::Resolved;
use serde::Serialize;
use serde_json::json;

use super::{Outlets, Session};

/// Converts a transform to `[tx, ty, tz, qx, qy, qz, qw]`, the layout the page reads.
fn push_transform(out: &mut Vec<f32>, t: &Transform) {
    out.extend_from_slice(&t.translation.to_array());
    out.extend_from_slice(&t.rotation.to_array());
}

impl Session {
    /// The `scene` message: what never changes (skeletons, rest poses, skinned meshes).
    pub fn scene_message(&self) -> String {
        #[derive(Serialize)]
        struct Mesh<'a> {
            name: &'a str,
            positions: Vec<f32>,
            normals: Vec<f32>,
            indices: &'a [u32],
            joints: Vec<u16>,
            weights: Vec<f32>,
        }
        let ragdolls: Vec<serde_json::Value> = self
            .scene
            .characters
            .iter()
            .map(|c| {
                let sk = &c.character.skeleton;
                let meshes: Vec<Mesh> = c
                    .character
                    .meshes
                    .iter()
                    .filter(|m| m.joints.len() == m.positions.len())
                    .map(|m| Mesh {
                        name: &m.name,
                        positions: m.positions.iter().flat_map(|p| p.to_array()).collect(),
                        normals: if m.normals.len() == m.positions.len() {
                            m.normals.iter().flat_map(|n| n.to_array()).collect()
                        } else {
                            Vec::new()
                        },
                        indices: &m.indices,
                        joints: m.joints.iter().flatten().copied().collect(),
                        weights: m.weights.iter().flat_map(|w| w.to_array()).collect(),
                    })
                    .collect();
                let parents: Vec<i64> = (0..sk.len())
                    .map(|j| sk.parent(j).map_or(-1, |p| p as i64))
                    .collect();
                // The meshes are skinned into the rest pose before the character is
                // placed; frames carry each joint's joint_now · rest⁻¹ (placement
                // included), which the page's vertex shader blends.
                json!({
                    "name": c.name,
                    "parents": parents,
                    "meshes": meshes,
                })
            })
            .collect();
        json!({
            "type": "scene",
            "dt": self.scene.settings.dt,
            "ground": self.scene.settings.ground,
            "ragdolls": ragdolls,
        })
        .to_string()
    }

    /// Publishes the `specs` message: every ragdoll's spec, which bone carries each body,
    /// each joint's frames in its bodies (for the limit overlays), and how far edits may go.
    pub(super) fn publish_specs(&self) {
        let ragdolls: Vec<serde_json::Value> = self
            .scene
            .characters
            .iter()
            .zip(&self.bounds)
            .map(|(c, bounds)| {
                let (bones, joints) = match Resolved::new(&c.spec, &c.character) {
                    Ok(r) => {
                        let joints: Vec<serde_json::Value> = r
                            .joints
                            .iter()
                            .map(|j| {
                                let (mut fp, mut fc) = (Vec::new(), Vec::new());
                                push_transform(&mut fp, &j.frame_parent);
                                push_transform(&mut fc, &j.frame_child);
                                json!({"parent": j.parent, "child": j.child,
                                       "frame_parent": fp, "frame_child": fc})
                            })
                            .collect();
                        (r.bone_of_body, joints)
                    }
                    Err(_) => (Vec::new(), Vec::new()),
                };
                json!({"spec": c.spec, "body_bones": bones, "joint_frames": joints,
                       "edit_bounds": bounds})
            })
            .collect();
        let msg = json!({
            "type": "specs",
            "backend": self.backend,
            "ragdolls": ragdolls,
        });
        self.out.specs.send_replace(msg.to_string().into());
    }

    /// Tells every page, and the log (within its ceiling).
    pub(crate) fn notice(&self, level: &str, message: &str) {
        self.log.line(|| message.to_string());
        Self::send_notice(&self.out, level, message);
    }

    /// [`Session::notice`] without a session (the supervisor's last word).
    pub(crate) fn notice_with(out: &Outlets, level: &str, message: &str) {
        eprintln!("viewer: {message}");
        Self::send_notice(out, level, message);
    }

    fn send_notice(out: &Outlets, level: &str, message: &str) {
        let msg = json!({"type": "notice", "level": level, "message": message});
        let _ = out.notices.send(msg.to_string().into());
    }

    /// Sends the shown step to the pages and updates the state endpoint.
    pub(super) fn publish(&self) {
        let k = self.cursor;
        let ragdolls: Vec<serde_json::Value> = self
            .rest_inverse
            .iter()
            .enumerate()
            .map(|(r, rest_inverse)| {
                let mut bodies = Vec::new();
                for t in self.recording.bodies(k, r) {
                    push_transform(&mut bodies, t);
                }
                let skin: Vec<f32> = self
                    .recording
                    .joints(k, r)
                    .iter()
                    .zip(rest_inverse)
                    .flat_map(|(t, inv)| (t.to_mat4() * *inv).to_cols_array())
                    .collect();
                json!({"bodies": bodies, "skin": skin})
            })
            .collect();
        let frame = json!({
            "type": "frame",
            "t": self.seconds(k),
            "step": k,
            "head_t": self.seconds(self.head()),
            "playing": self.playing,
            "ragdolls": ragdolls,
        });
        self.out.frames.send_replace(frame.to_string().into());
        let state = self.state();
        *self
            .out
            .state
            .lock()
            .unwrap_or_else(PoisonError::into_inner) = state;
    }

    /// What `GET /api/state` returns: the shown step's time, body positions and centres
    /// of mass, and what the session holds.
    fn state(&self) -> serde_json::Value {
        let k = self.cursor;
        let ragdolls: Vec<serde_json::Value> = self
            .scene
            .characters
            .iter()
            .enumerate()
            .map(|(r, c)| {
                let poses = self.recording.bodies(k, r);
                let total: f32 = c.spec.bodies.iter().map(|b| b.mass_kg).sum();
                let com = c
                    .spec
                    .bodies
                    .iter()
                    .zip(poses)
                    .fold(Vec3::ZERO, |acc, (b, p)| acc + p.translation * b.mass_kg)
                    / total.max(1e-9);
                let bodies: Vec<serde_json::Value> = c
                    .spec
                    .bodies
                    .iter()
                    .zip(poses)
                    .map(|(b, p)| json!({"name": b.name, "position": p.translation.to_array()}))
                    .collect();
                json!({"name": c.name, "centre_of_mass": com.to_array(), "bodies": bodies})
            })
            .collect();
        let edited = self
            .scene
            .characters
            .iter()
            .zip(&self.original_specs)
            .any(|(c, o)| c.spec != *o);
        json!({
            "time_s": self.seconds(k),
            "head_time_s": self.seconds(self.head()),
            "max_time_s": self.seconds(self.recording.max_steps - 1),
            "step": k,
            "playing": self.playing,
            "backend": self.backend,
            "events": self.events.len(),
            "dragging": self.drag.is_some(),
            "edited": edited,
            "ragdolls": ragdolls,
        })
    }
}
