//! Edits from the page (a body's shape, offset and mass, a joint's limits) and Save.
//!
//! An edited spec must pass the library's [`RagdollSpec::validate`] and the viewer's own
//! bounds, which are relative to the ragdoll as the file made it: no body may grow past
//! [`EDIT_SIZE_FACTOR`] times the file's largest body, nor its mass leave
//! [`EDIT_MASS_FACTOR`] times the file's range. The protocol's absolute ranges let a
//! centimetre-scale file (Fox) be edited at all; these keep any edit near what the
//! character was (one accepted edit of a 1000 m radius on the particle backend used to
//! abort the server). The bounds go to the page with the specs, and its sliders stop there.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use ragdoll::spec::{BodySpec, JointKind, RagdollSpec, Shape};
use serde_json::json;
use tokio::sync::mpsc;

use super::Session;

/// How much larger than the file's largest body an edited body may be (its longest
/// extent, and each coordinate of its offset on the bone). Twice the shin of the built-in
/// humanoid is a head 0.84 m across: room to play, while a single body 3 times that large
/// still aborted the particle backend's broad phase at the time of writing.
pub(crate) const EDIT_SIZE_FACTOR: f32 = 2.0;

/// How far an edited mass may go past the file's lightest and heaviest bodies (divided
/// and multiplied by this).
pub(crate) const EDIT_MASS_FACTOR: f32 = 100.0;

/// The longest extent of a body's shape, metres.
fn extent(shape: &Shape) -> f32 {
    match *shape {
        Shape::Capsule { radius_m, length_m } => 2.0 * radius_m + length_m,
        Shape::Box { size_m } => size_m.into_iter().fold(0.0, f32::max),
    }
}

/// How far edits to one ragdoll may go, from the file's spec (sent to the page too).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub(super) struct EditBounds {
    max_extent_m: f32,
    min_mass_kg: f32,
    max_mass_kg: f32,
}

impl EditBounds {
    pub fn of(spec: &RagdollSpec) -> EditBounds {
        let largest = spec
            .bodies
            .iter()
            .map(|b| extent(&b.shape))
            .fold(0.0, f32::max);
        let masses = spec.bodies.iter().map(|b| b.mass_kg);
        let lightest = masses.clone().fold(f32::INFINITY, f32::min);
        let heaviest = masses.fold(0.0, f32::max);
        EditBounds {
            max_extent_m: EDIT_SIZE_FACTOR * largest,
            min_mass_kg: lightest / EDIT_MASS_FACTOR,
            max_mass_kg: heaviest * EDIT_MASS_FACTOR,
        }
    }

    /// Why `body` is past the bounds, if it is.
    fn refuse(&self, body: &BodySpec) -> Option<String> {
        let size = extent(&body.shape);
        let offset = body.center_m.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let name = &body.name;
        let within = |v: f32| v.is_finite() && v <= self.max_extent_m;
        if !within(size) {
            Some(format!(
                "body \"{name}\" would be {size} m long, past this ragdoll's {} m ({EDIT_SIZE_FACTOR} times its largest body in the file)",
                self.max_extent_m
            ))
        } else if !within(offset) {
            Some(format!(
                "body \"{name}\" would sit {offset} m off its bone, past this ragdoll's {} m ({EDIT_SIZE_FACTOR} times its largest body in the file)",
                self.max_extent_m
            ))
        } else if !(self.min_mass_kg..=self.max_mass_kg).contains(&body.mass_kg) {
            Some(format!(
                "body \"{name}\" would weigh {} kg, outside this ragdoll's {} to {} kg ({EDIT_MASS_FACTOR} times past its lightest and heaviest bodies in the file)",
                body.mass_kg, self.min_mass_kg, self.max_mass_kg
            ))
        } else {
            None
        }
    }
}

/// Replaces the file at `path` with `bytes` only if there is none: `Ok(false)` when one
/// is there. Created exclusively, so a file that appears meanwhile is never overwritten; a
/// failed write removes what it created.
fn write_new(path: &Path, bytes: &[u8]) -> std::io::Result<bool> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)?;
    }
    let mut file = match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(path)
    {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => return Ok(false),
        Err(e) => return Err(e),
    };
    let written = file.write_all(bytes).and_then(|()| file.sync_all());
    if let Err(e) = written {
        drop(file);
        let _ = std::fs::remove_file(path);
        return Err(e);
    }
    Ok(true)
}

impl Session {
    /// Changes one body's shape (a box's Y edge), offset and mass.
    pub(super) fn edit_body(
        &mut self,
        ragdoll: usize,
        body: usize,
        radius_m: f32,
        length_m: f32,
        center_m: [f32; 3],
        mass_kg: f32,
    ) {
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

    /// Changes one joint's limits (of the kind the joint is).
    pub(super) fn edit_joint(
        &mut self,
        ragdoll: usize,
        joint: usize,
        min_deg: Option<f32>,
        max_deg: Option<f32>,
        swing_deg: Option<f32>,
        twist_deg: Option<[f32; 2]>,
    ) {
        let mut spec = self.scene.characters[ragdoll].spec.clone();
        let j = &mut spec.joints[joint];
        j.kind = match (j.kind, min_deg, max_deg, swing_deg, twist_deg) {
            (JointKind::Hinge { .. }, Some(min_deg), Some(max_deg), ..) => {
                JointKind::Hinge { min_deg, max_deg }
            }
            (
                JointKind::SwingTwist { cone_tilt_deg, .. },
                _,
                _,
                Some(swing_deg),
                Some(twist_deg),
            ) => JointKind::SwingTwist {
                swing_deg,
                twist_deg,
                cone_tilt_deg,
            },
            _ => {
                let msg = format!(
                    "joint \"{}\" is not of the kind this edit is for; nothing changed",
                    j.name
                );
                self.notice("error", &msg);
                return;
            }
        };
        self.edit(ragdoll, spec);
    }

    /// Replaces ragdoll `ragdoll`'s spec, rebuilding and replaying to the shown step; an
    /// edit past the bounds, or that the library refuses, changes nothing.
    fn edit(&mut self, ragdoll: usize, spec: RagdollSpec) {
        let bounds = self.bounds[ragdoll];
        let refused = spec
            .validate()
            .err()
            .map(|e| e.to_string())
            .or_else(|| spec.bodies.iter().find_map(|b| bounds.refuse(b)));
        if let Some(why) = refused {
            self.notice("error", &format!("edit refused: {why}"));
            return;
        }
        let old = std::mem::replace(&mut self.scene.characters[ragdoll].spec, spec);
        let at = self.cursor;
        if let Err(e) = self.rebuild_to(at) {
            self.scene.characters[ragdoll].spec = old;
            self.notice("error", &format!("edit refused: {e}"));
            let _ = self.rebuild_to(at);
        }
        self.publish_specs();
    }

    /// Every ragdoll's save file and its TOML. The file names come from the input's name
    /// and the characters' names with anything but letters, digits, `-` and `_` replaced,
    /// so nothing the page sends ends up in a path.
    fn save_files(&self) -> Vec<(PathBuf, String)> {
        let clean = |s: &str| -> String {
            s.chars()
                .map(|c| {
                    if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                        c
                    } else {
                        '_'
                    }
                })
                .collect()
        };
        let many = self.scene.characters.len() > 1;
        let stem = clean(&self.save.stem);
        self.scene
            .characters
            .iter()
            .map(|c| {
                let name = if many {
                    format!("{stem}.{}.spec.toml", clean(&c.name))
                } else {
                    format!("{stem}.spec.toml")
                };
                (self.save.dir.join(name), c.spec.to_toml())
            })
            .collect()
    }

    /// Writes every ragdoll's (edited) spec into the save folder. Files already there are
    /// replaced (atomically) only with `overwrite`; otherwise the page that asked is asked
    /// to confirm, and nothing is written.
    pub(super) fn save(&self, overwrite: bool, reply: &mpsc::Sender<Arc<str>>) {
        let files = self.save_files();
        let ask = |existing: Vec<String>| {
            let msg = json!({
                "type": "confirm_overwrite",
                "dir": self.save.dir.display().to_string(),
                "files": existing,
            });
            let _ = reply.try_send(msg.to_string().into());
        };
        let name = |p: &Path| {
            p.file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
        };
        if !overwrite {
            let existing: Vec<String> = files
                .iter()
                .filter(|(p, _)| std::fs::symlink_metadata(p).is_ok())
                .map(|(p, _)| name(p))
                .collect();
            if !existing.is_empty() {
                return ask(existing);
            }
        }
        let mut written = Vec::new();
        for (path, text) in &files {
            let result = if overwrite {
                ragdoll::export::write_atomic(path, text.as_bytes()).map(|()| true)
            } else {
                write_new(path, text.as_bytes()).map_err(|e| ragdoll::Error::io(path, e))
            };
            match result {
                Ok(true) => written.push(path.display().to_string()),
                // Appeared since the check: ask about it.
                Ok(false) => return ask(vec![name(path)]),
                Err(e) => {
                    self.notice("error", &format!("could not save: {e}"));
                    return;
                }
            }
        }
        self.notice("info", &format!("saved {}", written.join(", ")));
    }
}
