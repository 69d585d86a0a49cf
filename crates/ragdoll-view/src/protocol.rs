//! The messages between the page and the server, and the checks every message from the
//! page passes before the simulation sees it.
//!
//! The page sends JSON text messages, one object each, tagged by `"type"`. A message is
//! accepted only when it is small ([`MAX_MESSAGE_BYTES`]), parses into [`ClientMsg`] with no
//! unknown field, carries finite numbers inside the ranges below, and names ragdolls,
//! bodies and joints that exist. Anything else is rejected with a reason (the server logs
//! it and drops the message; the connection stays open), so a hostile page or a buggy
//! script can neither crash the server nor push the simulation into NaNs. What an accepted
//! message then does is bounded again by the session (edit bounds relative to the file's
//! ragdoll, caps on charges, drags and the recording; see the guide's "The viewer" page).
//!
//! The server sends JSON text too, tagged the same way: `scene` (once: skeletons and
//! meshes), `specs` (on connect and after each change: the specs, the backend, and each
//! ragdoll's `edit_bounds`), `frame` (the step shown), `notice` (`level` `info`, `error`
//! or `progress`, and a `message` sentence) and, to the page that asked alone,
//! `confirm_overwrite` (the save files already there, before any is replaced).

use serde::Deserialize;

/// Largest message accepted from a page, bytes. The largest valid message (an edit) is a
/// few hundred bytes; 16 KiB leaves room for whitespace and future fields while keeping a
/// flood of megabyte messages from costing anything but the read.
pub const MAX_MESSAGE_BYTES: usize = 16 * 1024;

/// Farthest from the origin a point (a drag target, a charge) may be, metres.
pub const MAX_COORDINATE_M: f32 = 1000.0;

/// Largest charge the viewer places, kg of TNT (the library allows more; past this the
/// character leaves any view in one frame).
pub const MAX_TNT_KG: f32 = 1000.0;

/// Heaviest body an edit may set, kg.
pub const MAX_MASS_KG: f32 = 1.0e7;

/// Longest delay before a charge placed in the viewer goes off, seconds.
pub const MAX_DELAY_S: f32 = 60.0;

/// Which simulation backend the page asks for: the library's own choice, by the names
/// files and the command line use (`rigid`, `particle`, `fast`).
pub use ragdoll::world::BackendKind as BackendChoice;

/// A message from the page.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ClientMsg {
    /// Run in real time (from a scrubbed past time: drop what came after it and go on).
    Play {},
    /// Stop stepping.
    Pause {},
    /// Pause, then advance one step (through the recording when scrubbed back).
    Step {},
    /// Back to the file: time 0, paused, the file's specs, no events added in the viewer
    /// (the backend chosen is kept).
    Reset {},
    /// Pause and show the recorded state at this time, seconds.
    Scrub {
        /// Seconds from the start; clamped to what has been recorded.
        time_s: f64,
    },
    /// Grab a body by a point and start pulling it toward `target`.
    DragStart {
        /// Ragdoll index.
        ragdoll: usize,
        /// Body index in the ragdoll's spec.
        body: usize,
        /// The grabbed point in the body's frame, metres.
        local: [f32; 3],
        /// Where to pull it, world space, metres.
        target: [f32; 3],
    },
    /// Move the current drag's target (world space, metres).
    DragMove {
        /// New target.
        target: [f32; 3],
    },
    /// Let go.
    DragEnd {},
    /// Place a charge that goes off `delay_s` after now.
    Blast {
        /// Charge position, world space, metres.
        position: [f32; 3],
        /// TNT-equivalent mass, kg.
        tnt_kg: f32,
        /// Seconds from the current simulated time to the detonation.
        delay_s: f32,
    },
    /// Change one body's shape, placement on its bone, and mass.
    EditBody {
        /// Ragdoll index.
        ragdoll: usize,
        /// Body index in the ragdoll's spec.
        body: usize,
        /// Capsule radius (box: half the smallest edge is left as is), metres.
        radius_m: f32,
        /// Capsule length between the sphere centres (box: its Y edge), metres.
        length_m: f32,
        /// Centre of the shape in the bone's rest frame, metres.
        center_m: [f32; 3],
        /// Mass, kg.
        mass_kg: f32,
    },
    /// Change one joint's limits. Hinges take `min_deg`/`max_deg`; swing-twist joints take
    /// `swing_deg` and `twist_deg`. Fields of the other kind are refused.
    EditJoint {
        /// Ragdoll index.
        ragdoll: usize,
        /// Joint index in the ragdoll's spec.
        joint: usize,
        /// Hinge: lowest angle, degrees.
        #[serde(default)]
        min_deg: Option<f32>,
        /// Hinge: highest angle, degrees.
        #[serde(default)]
        max_deg: Option<f32>,
        /// Swing-twist: cone half-angle, degrees.
        #[serde(default)]
        swing_deg: Option<f32>,
        /// Swing-twist: twist range, degrees.
        #[serde(default)]
        twist_deg: Option<[f32; 2]>,
    },
    /// Write every edited spec into the save folder. A file already there is not
    /// overwritten unless `overwrite` is true: the server answers the page that asked with
    /// `{"type":"confirm_overwrite","files":[...]}`, and the page, once the user agrees,
    /// sends the message again with `overwrite`.
    Save {
        /// Replace files that exist.
        #[serde(default)]
        overwrite: bool,
    },
    /// Switch the simulation backend.
    Backend {
        /// The backend wanted.
        kind: BackendChoice,
    },
}

/// What the validator needs to know about the scene: body and joint counts per ragdoll.
/// These never change while the viewer runs (edits change sizes, not counts).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct SceneShape {
    /// Number of bodies of each ragdoll.
    pub bodies: Vec<usize>,
    /// Number of joints of each ragdoll.
    pub joints: Vec<usize>,
}

/// Why a message was refused: one sentence for the log line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rejected(pub String);

impl std::fmt::Display for Rejected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

fn reject<T>(why: impl Into<String>) -> Result<T, Rejected> {
    Err(Rejected(why.into()))
}

/// Parses and checks one text message from the page against the scene's `shape`.
///
/// ```
/// use ragdoll_view::protocol::{ClientMsg, SceneShape, parse_client_message};
///
/// let shape = SceneShape { bodies: vec![15], joints: vec![14] };
/// let ok = parse_client_message(r#"{"type":"blast","position":[1,0,0],"tnt_kg":5,"delay_s":0}"#, &shape);
/// assert!(matches!(ok, Ok(ClientMsg::Blast { .. })));
/// // A body the ragdoll does not have, an unknown field, a number too large for f32:
/// for bad in [
///     r#"{"type":"drag_start","ragdoll":0,"body":99,"local":[0,0,0],"target":[0,1,0]}"#,
///     r#"{"type":"pause","why":"because"}"#,
///     r#"{"type":"blast","position":[1e39,0,0],"tnt_kg":5,"delay_s":0}"#,
/// ] {
///     assert!(parse_client_message(bad, &shape).is_err());
/// }
/// ```
pub fn parse_client_message(text: &str, shape: &SceneShape) -> Result<ClientMsg, Rejected> {
    if text.len() > MAX_MESSAGE_BYTES {
        return reject(format!(
            "message of {} bytes is over the {MAX_MESSAGE_BYTES}-byte limit",
            text.len()
        ));
    }
    let msg: ClientMsg = match serde_json::from_str(text) {
        Ok(m) => m,
        Err(e) => return reject(format!("not a valid message: {e}")),
    };
    check(&msg, shape)?;
    Ok(msg)
}

/// A finite number inside `[lo, hi]`.
fn in_range(name: &str, v: f32, lo: f32, hi: f32) -> Result<(), Rejected> {
    if v.is_finite() && (lo..=hi).contains(&v) {
        Ok(())
    } else {
        reject(format!(
            "{name} must be a number from {lo} to {hi}, not {v}"
        ))
    }
}

fn point(name: &str, p: &[f32; 3]) -> Result<(), Rejected> {
    for v in p {
        in_range(name, *v, -MAX_COORDINATE_M, MAX_COORDINATE_M)?;
    }
    Ok(())
}

fn ragdoll_index(ragdoll: usize, shape: &SceneShape) -> Result<(), Rejected> {
    if ragdoll < shape.bodies.len() {
        Ok(())
    } else {
        reject(format!(
            "ragdoll {ragdoll} does not exist (there are {})",
            shape.bodies.len()
        ))
    }
}

fn body_index(ragdoll: usize, body: usize, shape: &SceneShape) -> Result<(), Rejected> {
    ragdoll_index(ragdoll, shape)?;
    if body < shape.bodies[ragdoll] {
        Ok(())
    } else {
        reject(format!(
            "ragdoll {ragdoll} has no body {body} (it has {})",
            shape.bodies[ragdoll]
        ))
    }
}

/// The range and index checks of each message.
fn check(msg: &ClientMsg, shape: &SceneShape) -> Result<(), Rejected> {
    match msg {
        ClientMsg::Play {}
        | ClientMsg::Pause {}
        | ClientMsg::Step {}
        | ClientMsg::Reset {}
        | ClientMsg::DragEnd {}
        | ClientMsg::Save { .. }
        | ClientMsg::Backend { .. } => Ok(()),
        ClientMsg::Scrub { time_s } => {
            if time_s.is_finite() && *time_s >= 0.0 && *time_s <= 1.0e6 {
                Ok(())
            } else {
                reject(format!("time_s must be 0 to 1e6 seconds, not {time_s}"))
            }
        }
        ClientMsg::DragStart {
            ragdoll,
            body,
            local,
            target,
        } => {
            body_index(*ragdoll, *body, shape)?;
            for v in local {
                in_range("local", *v, -10.0, 10.0)?;
            }
            point("target", target)
        }
        ClientMsg::DragMove { target } => point("target", target),
        ClientMsg::Blast {
            position,
            tnt_kg,
            delay_s,
        } => {
            point("position", position)?;
            in_range("tnt_kg", *tnt_kg, 1e-3, MAX_TNT_KG)?;
            in_range("delay_s", *delay_s, 0.0, MAX_DELAY_S)
        }
        ClientMsg::EditBody {
            ragdoll,
            body,
            radius_m,
            length_m,
            center_m,
            mass_kg,
        } => {
            body_index(*ragdoll, *body, shape)?;
            check_body_edit(*radius_m, *length_m, center_m, *mass_kg)
        }
        ClientMsg::EditJoint {
            ragdoll,
            joint,
            min_deg,
            max_deg,
            swing_deg,
            twist_deg,
        } => {
            ragdoll_index(*ragdoll, shape)?;
            if *joint >= shape.joints[*ragdoll] {
                return reject(format!(
                    "ragdoll {ragdoll} has no joint {joint} (it has {})",
                    shape.joints[*ragdoll]
                ));
            }
            check_joint_edit(*min_deg, *max_deg, *swing_deg, *twist_deg)
        }
    }
}

/// An edited body's sizes and mass. Wide bounds: some files are in centimetres read as
/// metres (Fox), and their bodies are that large; the spec's own validation judges the
/// result.
fn check_body_edit(
    radius_m: f32,
    length_m: f32,
    center_m: &[f32; 3],
    mass_kg: f32,
) -> Result<(), Rejected> {
    in_range("radius_m", radius_m, 1e-3, MAX_COORDINATE_M)?;
    in_range("length_m", length_m, 0.0, MAX_COORDINATE_M)?;
    for v in center_m {
        in_range("center_m", *v, -MAX_COORDINATE_M, MAX_COORDINATE_M)?;
    }
    in_range("mass_kg", mass_kg, 1e-3, MAX_MASS_KG)
}

/// An edited joint's limits: a hinge's range or a swing-twist's cone and twist range,
/// not both.
fn check_joint_edit(
    min_deg: Option<f32>,
    max_deg: Option<f32>,
    swing_deg: Option<f32>,
    twist_deg: Option<[f32; 2]>,
) -> Result<(), Rejected> {
    let hinge = min_deg.is_some() || max_deg.is_some();
    let cone = swing_deg.is_some() || twist_deg.is_some();
    if hinge == cone {
        return reject(
            "edit_joint takes either min_deg and max_deg (hinge) or swing_deg and twist_deg (swing-twist)",
        );
    }
    if hinge {
        let (Some(lo), Some(hi)) = (min_deg, max_deg) else {
            return reject("a hinge edit needs both min_deg and max_deg");
        };
        in_range("min_deg", lo, -180.0, 180.0)?;
        in_range("max_deg", hi, -180.0, 180.0)?;
        if lo > hi {
            return reject("min_deg must not be above max_deg");
        }
    } else {
        let (Some(swing), Some([lo, hi])) = (swing_deg, twist_deg) else {
            return reject("a swing-twist edit needs both swing_deg and twist_deg");
        };
        in_range("swing_deg", swing, 0.0, 180.0)?;
        in_range("twist_deg", lo, -180.0, 180.0)?;
        in_range("twist_deg", hi, -180.0, 180.0)?;
        if lo > hi {
            return reject("twist_deg must be [min, max]");
        }
    }
    Ok(())
}
