//! What a spec may hold. Every value a user can write in a spec is checked here when the
//! spec is read (`ragdoll inspect`, `simulate --spec`, scenes, the viewer's edits) and
//! again when a world is made from it, against the bounds below, so nothing the engines
//! cannot simulate reaches them. Each bound's rustdoc says why it sits where it does; the
//! error names the body or joint, the key and the bound.

use std::collections::HashMap;

use super::{BodySpec, ExtraShape, JointKind, JointSpec, RagdollSpec, SPEC_FORMAT_VERSION, Shape};

/// Most bodies in one ragdoll.
///
/// Real characters need far fewer (a mocap skeleton with fingers gives about 60, `ragdoll
/// rig` makes at most a few hundred), while the cost of bodies that start inside each
/// other grows with the square of their number: 1 000 bodies on one spot took 46 s and
/// 2.1 GB of memory for 0.2 simulated seconds on rapier, and came apart on the particle
/// backend.
pub const MAX_BODIES: usize = 512;
/// Most extra shapes one body may carry ([`super::BodySpec::extra_shapes`]): each is a
/// contact shape of its own in every backend.
pub const MAX_EXTRA_SHAPES: usize = 16;

/// Most joints in one ragdoll: as many as bodies (a tree of them has one fewer).
pub const MAX_JOINTS: usize = MAX_BODIES;

/// Most `collision.disabled_pairs`: every pair of the most bodies, so a ragdoll may turn
/// off all its own collisions; the builder writes about two per body.
pub const MAX_DISABLED_PAIRS: usize = MAX_BODIES * (MAX_BODIES - 1) / 2;

/// Longest name (of the spec, a body, a bone or a joint), bytes. Names come from the
/// character file and end up in messages, reports and glTF node names; real rigs use a
/// few dozen bytes.
pub const MAX_NAME_BYTES: usize = 256;

/// Smallest capsule radius or box side, metres: 1 mm.
///
/// rapier lets contacts sink by up to its allowed linear error, 1 mm at our length unit of
/// a metre, so a thinner body can pass through others. A mouse's paw is still a few
/// millimetres thick; fingers and toes ride on their parents' bodies.
pub const MIN_SHAPE_M: f32 = 1e-3;

/// Largest capsule radius, capsule length or box side, metres: 100 m.
///
/// The largest character in our data, the Fox glTF read in centimetres as metres, is
/// 79 m tall with bodies up to 20 m; a 30 m whale or a dragon fits too. Larger shapes are
/// almost always a unit mistake (a file in millimetres read as metres), and they are what
/// broke the engines: a 10²⁰ m capsule panics in parry's contact code, a 1 km one exhausts
/// the particle backend's broad phase.
pub const MAX_SHAPE_M: f32 = 100.0;

/// Largest offset of a body's centre from its bone, or of a joint's anchor from the child
/// bone, metres (length of `center_m` or `anchor_m`): ten of the largest shapes. Offsets
/// are normally within a body's own size (at most 12 m for the 79 m Fox).
pub const MAX_OFFSET_M: f32 = 1000.0;

/// Lightest body, kilograms: 1 mg, an ant's leg.
///
/// Both backends were run with two 1 mg, 1 mm bodies and stayed finite; the
/// humanoid's lightest part is 0.45 kg, a mouse's about 0.1 g.
pub const MIN_BODY_KG: f32 = 1e-6;

/// Heaviest body, kilograms: 10⁸ kg (100 000 t).
///
/// Three times the heaviest part of the 79 m Fox built at the density of water (3.1·10⁷
/// kg); a blue whale is 1.5·10⁵ kg. The particle backend's arithmetic overflows near
/// 10¹⁰ kg on a body of the largest size (it was finite at 10⁹), so this leaves a hundred
/// times of room.
pub const MAX_BODY_KG: f32 = 1e8;

/// Largest ratio between the masses of two jointed bodies.
///
/// rapier keeps joints together less well as the ratio grows (measured on a two-body
/// chain: 0.2 mm apart at 100:1, 1 mm at 1 000:1, 14 mm at 10 000:1, 43 mm at 100 000:1);
/// it never produced NaN, so the bound keeps joints to about a millimetre. The builder
/// keeps jointed bodies within 5:1.
pub const MAX_JOINT_MASS_RATIO: f32 = 1000.0;

/// How far past half a turn a hinge's or a twist's limit may lie, degrees: ends within
/// ±190°.
///
/// A twist is measured within ±180°; the builder widens a limit 5° past the pose it must
/// take in, so a limit reaches ±185° where the first frame is twisted half a turn, and an
/// end past ±180° leaves that side free. A lower end above 180° or an upper end below
/// −180° would never contain any angle and is refused.
pub const MAX_LIMIT_END_DEG: f32 = 190.0;

/// Largest swing cone half-angle, degrees: 180° is no limit at all.
pub const MAX_SWING_DEG: f32 = 180.0;

/// Largest tilt of a swing cone, degrees: half a turn either way covers every direction.
pub const MAX_CONE_TILT_DEG: f32 = 180.0;

/// How far the length of a rotation or frame quaternion may be from 1: loose enough for
/// four decimals written by hand, tight enough to catch a quaternion that is not one.
pub const UNIT_QUATERNION_TOLERANCE: f32 = 1e-2;

/// Where in a spec a problem is: a top-level key, or a key (dotted path) of the body,
/// joint or disabled pair at an index.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Place {
    Top(&'static str),
    Body(usize, &'static str),
    Joint(usize, &'static str),
    Pair(usize),
}

/// A value a spec must not hold, and where it is.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Problem {
    pub place: Place,
    pub message: String,
}

impl Place {
    /// How the place reads in a message: `body "thigh_l".shape.length_m`.
    pub(super) fn describe(&self, spec: &RagdollSpec) -> String {
        match *self {
            Place::Top(key) => key.to_string(),
            Place::Body(i, key) => format!("body \"{}\".{key}", name_of(&spec.bodies[i].name)),
            Place::Joint(i, key) => {
                format!("joint \"{}\".{key}", name_of(&spec.joints[i].name))
            }
            Place::Pair(i) => format!("collision.disabled_pairs[{i}]"),
        }
    }
}

/// A name as it can be shown in a message (a name too long to be valid is cut).
fn name_of(name: &str) -> &str {
    if name.len() <= 64 {
        return name;
    }
    let mut end = 64;
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    &name[..end]
}

/// Shows a number the way a user would write it: `1e30` rather than thirty zeros.
pub(crate) fn show(x: f32) -> String {
    let a = x.abs();
    if a != 0.0 && a.is_finite() && !(1e-4..1e7).contains(&a) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// `x` finite and within `[lo, hi]`, or a message saying what it must be.
pub(crate) fn check_within(x: f32, lo: f32, hi: f32, unit: &str) -> Result<(), String> {
    if x.is_finite() && (lo..=hi).contains(&x) {
        Ok(())
    } else {
        Err(format!(
            "must be between {} and {}{unit}, not {}",
            show(lo),
            show(hi),
            show(x)
        ))
    }
}

/// `x` finite, more than `lo` and at most `hi`, or a message saying what it must be.
pub(crate) fn check_above(x: f32, lo: f32, hi: f32, unit: &str) -> Result<(), String> {
    if x.is_finite() && x > lo && x <= hi {
        Ok(())
    } else {
        Err(format!(
            "must be more than {} and at most {}{unit}, not {}",
            show(lo),
            show(hi),
            show(x)
        ))
    }
}

/// A vector of finite values whose length is at most `max`.
pub(crate) fn check_length(v: [f32; 3], max: f32, unit: &str) -> Result<(), String> {
    let len = glam::Vec3::from_array(v).length();
    if v.iter().all(|x| x.is_finite()) && len <= max {
        Ok(())
    } else if v.iter().all(|x| x.is_finite()) {
        Err(format!(
            "must be at most {}{unit} long, not {}",
            show(max),
            show(len)
        ))
    } else {
        Err("must be three finite numbers".into())
    }
}

fn check_name(name: &str) -> Result<(), String> {
    if name.is_empty() {
        Err("must not be empty".into())
    } else if name.len() > MAX_NAME_BYTES {
        Err(format!(
            "is {} bytes long, more than the {MAX_NAME_BYTES} a name may have",
            name.len()
        ))
    } else {
        Ok(())
    }
}

fn check_quaternion(q: [f32; 4]) -> Result<(), String> {
    let q = glam::Quat::from_array(q);
    if q.is_finite() && (q.length() - 1.0).abs() <= UNIT_QUATERNION_TOLERANCE {
        Ok(())
    } else {
        Err(format!(
            "must be a unit quaternion [x, y, z, w] (length within {UNIT_QUATERNION_TOLERANCE} of 1)"
        ))
    }
}

const M: &str = " m";
const KG: &str = " kg";
const DEG: &str = " degrees";

fn body_problem(b: &BodySpec) -> Option<(&'static str, String)> {
    let fail = |key: &'static str, r: Result<(), String>| r.err().map(|m| (key, m));
    fail("name", check_name(&b.name))
        .or_else(|| fail("bone", check_name(&b.bone)))
        .or_else(|| shape_problem(&b.shape))
        .or_else(|| fail("center_m", check_length(b.center_m, MAX_OFFSET_M, M)))
        .or_else(|| fail("rotation", check_quaternion(b.rotation)))
        .or_else(|| {
            fail(
                "mass_kg",
                check_within(b.mass_kg, MIN_BODY_KG, MAX_BODY_KG, KG),
            )
        })
        .or_else(|| extras_problem(&b.extra_shapes))
}

/// The first value of `shape` out of bounds, with its key under `shape.`.
fn shape_problem(shape: &Shape) -> Option<(&'static str, String)> {
    let fail = |key: &'static str, r: Result<(), String>| r.err().map(|m| (key, m));
    match *shape {
        Shape::Capsule { radius_m, length_m } => fail(
            "shape.radius_m",
            check_within(radius_m, MIN_SHAPE_M, MAX_SHAPE_M, M),
        )
        .or_else(|| {
            fail(
                "shape.length_m",
                check_within(length_m, 0.0, MAX_SHAPE_M, M),
            )
        }),
        Shape::Box { size_m } => size_m
            .iter()
            .find_map(|&s| fail("shape.size_m", check_within(s, MIN_SHAPE_M, MAX_SHAPE_M, M))),
    }
}

/// The first problem of a body's extra shapes: too many, or a value out of the bounds its
/// own shape has. The key is `extra_shapes` (the line of the list); the message says which.
fn extras_problem(extras: &[ExtraShape]) -> Option<(&'static str, String)> {
    if extras.len() > MAX_EXTRA_SHAPES {
        return Some((
            "extra_shapes",
            format!(
                "{} extra shapes, more than the {MAX_EXTRA_SHAPES} a body may carry",
                extras.len()
            ),
        ));
    }
    extras.iter().enumerate().find_map(|(k, e)| {
        let problem = shape_problem(&e.shape)
            .or_else(|| {
                check_length(e.center_m, MAX_OFFSET_M, M)
                    .err()
                    .map(|m| ("center_m", m))
            })
            .or_else(|| check_quaternion(e.rotation).err().map(|m| ("rotation", m)));
        problem.map(|(key, m)| ("extra_shapes", format!("[{k}].{key}: {m}")))
    })
}

fn kind_problem(kind: &JointKind) -> Option<(&'static str, String)> {
    let fail = |key: &'static str, r: Result<(), String>| r.err().map(|m| (key, m));
    let range = |lo_key: &'static str, hi_key: &'static str, lo: f32, hi: f32| {
        fail(lo_key, check_within(lo, -MAX_LIMIT_END_DEG, 180.0, DEG))
            .or_else(|| fail(hi_key, check_within(hi, -180.0, MAX_LIMIT_END_DEG, DEG)))
            .or_else(|| {
                (lo > hi).then(|| {
                    (
                        lo_key,
                        format!(
                            "the range must run from min to max, not {} to {}",
                            show(lo),
                            show(hi)
                        ),
                    )
                })
            })
    };
    match *kind {
        JointKind::Hinge { min_deg, max_deg } => range("min_deg", "max_deg", min_deg, max_deg),
        JointKind::SwingTwist {
            swing_deg,
            twist_deg,
            cone_tilt_deg,
        } => fail(
            "swing_deg",
            check_within(swing_deg, 0.0, MAX_SWING_DEG, DEG),
        )
        .or_else(|| range("twist_deg", "twist_deg", twist_deg[0], twist_deg[1]))
        .or_else(|| {
            cone_tilt_deg.iter().find_map(|&t| {
                fail(
                    "cone_tilt_deg",
                    check_within(t, -MAX_CONE_TILT_DEG, MAX_CONE_TILT_DEG, DEG),
                )
            })
        }),
        JointKind::Ball | JointKind::Fixed => None,
    }
}

fn joint_problem(
    j: &JointSpec,
    bodies: &HashMap<&str, usize>,
    spec: &RagdollSpec,
) -> Option<(&'static str, String)> {
    let fail = |key: &'static str, r: Result<(), String>| r.err().map(|m| (key, m));
    let body = |key: &'static str, name: &str| match bodies.get(name) {
        Some(&i) => Ok(i),
        None => Err((key, format!("no body is named \"{}\"", name_of(name)))),
    };
    if let Some(p) = fail("name", check_name(&j.name)) {
        return Some(p);
    }
    let (parent, child) = match (body("parent", &j.parent), body("child", &j.child)) {
        (Ok(p), Ok(c)) => (p, c),
        (Err(e), _) | (_, Err(e)) => return Some(e),
    };
    if parent == child {
        return Some(("child", "a joint cannot link a body to itself".into()));
    }
    let (mp, mc) = (spec.bodies[parent].mass_kg, spec.bodies[child].mass_kg);
    let ratio = mp.max(mc) / mp.min(mc);
    if ratio > MAX_JOINT_MASS_RATIO {
        return Some((
            "child",
            format!(
                "the masses of \"{}\" ({} kg) and \"{}\" ({} kg) differ {}-fold, more than the \
                 {} a joint holds together (edit mass_kg)",
                name_of(&j.parent),
                show(mp),
                name_of(&j.child),
                show(mc),
                show(ratio),
                show(MAX_JOINT_MASS_RATIO)
            ),
        ));
    }
    fail("anchor_m", check_length(j.anchor_m, MAX_OFFSET_M, M))
        .or_else(|| fail("frame", check_quaternion(j.frame)))
        .or_else(|| kind_problem(&j.kind))
}

/// The joints must make a tree (a forest, when some bodies hang from none): a body that
/// is the child of two joints, or joints that close a loop, leave the world no way to
/// place the bodies from their parents, and the solver fights itself. `bodies` names every
/// body, and every joint's bodies exist (checked before).
fn tree_problem(spec: &RagdollSpec, bodies: &HashMap<&str, usize>) -> Option<Problem> {
    let index = |name: &str| bodies.get(name).copied().unwrap_or(0);
    let mut parent_joint: Vec<Option<usize>> = vec![None; spec.bodies.len()];
    for (i, j) in spec.joints.iter().enumerate() {
        let child = index(&j.child);
        if let Some(other) = parent_joint[child] {
            return Some(Problem {
                place: Place::Joint(i, "child"),
                message: format!(
                    "body \"{}\" already hangs from joint \"{}\": a body has one parent joint",
                    name_of(&j.child),
                    name_of(&spec.joints[other].name)
                ),
            });
        }
        parent_joint[child] = Some(i);
    }
    // Each body has at most one parent now: walking up from every body ends at a root
    // unless it comes round to a body it has passed (state 1: on the current walk).
    let mut state = vec![0u8; spec.bodies.len()];
    for start in 0..spec.bodies.len() {
        let mut at = start;
        let mut walked = Vec::new();
        while state[at] == 0 {
            state[at] = 1;
            walked.push(at);
            match parent_joint[at] {
                Some(j) => at = index(&spec.joints[j].parent),
                None => break,
            }
        }
        if state[at] == 1
            && let Some(j) = parent_joint[at]
            && walked.contains(&at)
        {
            return Some(Problem {
                place: Place::Joint(j, "parent"),
                message: format!(
                    "the joints close a loop through body \"{}\": a ragdoll's joints form a tree",
                    name_of(&spec.bodies[at].name)
                ),
            });
        }
        for b in walked {
            state[b] = 2;
        }
    }
    None
}

/// Counts and the version, before anything is looked at body by body.
fn size_problem(spec: &RagdollSpec) -> Option<Problem> {
    let top = |key: &'static str, message: String| {
        Some(Problem {
            place: Place::Top(key),
            message,
        })
    };
    if spec.format_version != SPEC_FORMAT_VERSION {
        return top(
            "format_version",
            format!(
                "this spec is version {}; this ragdoll reads version {SPEC_FORMAT_VERSION}",
                spec.format_version
            ),
        );
    }
    if let Err(m) = check_name(&spec.name) {
        return top("name", m);
    }
    let counts = [
        ("bodies", spec.bodies.len(), MAX_BODIES),
        ("joints", spec.joints.len(), MAX_JOINTS),
        (
            "collision.disabled_pairs",
            spec.collision.disabled_pairs.len(),
            MAX_DISABLED_PAIRS,
        ),
    ];
    for (key, n, max) in counts {
        if n > max {
            return top(key, format!("a ragdoll has at most {max} {key}, not {n}"));
        }
    }
    if spec.bodies.is_empty() {
        return top("bodies", "a ragdoll needs at least one body".into());
    }
    None
}

impl RagdollSpec {
    /// The first value this spec must not hold, in file order, and where it is.
    pub(super) fn problem(&self) -> Option<Problem> {
        if let Some(p) = size_problem(self) {
            return Some(p);
        }
        let mut names: HashMap<&str, usize> = HashMap::with_capacity(self.bodies.len());
        for (i, b) in self.bodies.iter().enumerate() {
            let at = |key, message| {
                Some(Problem {
                    place: Place::Body(i, key),
                    message,
                })
            };
            if let Some((key, message)) = body_problem(b) {
                return at(key, message);
            }
            if names.insert(&b.name, i).is_some() {
                return at("name", "two bodies have this name".into());
            }
        }
        let mut joint_names = std::collections::HashSet::with_capacity(self.joints.len());
        for (i, j) in self.joints.iter().enumerate() {
            let problem = joint_problem(j, &names, self).or_else(|| {
                (!joint_names.insert(j.name.as_str()))
                    .then(|| ("name", "two joints have this name".to_string()))
            });
            if let Some((key, message)) = problem {
                return Some(Problem {
                    place: Place::Joint(i, key),
                    message,
                });
            }
        }
        if let Some(p) = tree_problem(self, &names) {
            return Some(p);
        }
        for (i, pair) in self.collision.disabled_pairs.iter().enumerate() {
            if let Some(name) = pair.iter().find(|n| !names.contains_key(n.as_str())) {
                return Some(Problem {
                    place: Place::Pair(i),
                    message: format!("no body is named \"{}\"", name_of(name)),
                });
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_a_user_writes_them() {
        assert_eq!(show(1e30), "1e30");
        assert_eq!(show(-1.0), "-1");
        assert_eq!(show(100.0), "100");
        assert_eq!(show(1e-6), "1e-6");
        assert_eq!(show(0.0), "0");
        assert_eq!(show(f32::NAN), "NaN");
    }

    #[test]
    fn messages_state_the_bound_and_the_value() {
        let m = check_within(1e30, 0.0, MAX_SHAPE_M, " m").unwrap_err();
        assert_eq!(m, "must be between 0 and 100 m, not 1e30");
        let m = check_above(0.0, 0.0, MAX_BODY_KG, " kg").unwrap_err();
        assert_eq!(m, "must be more than 0 and at most 1e8 kg, not 0");
        assert!(check_within(f32::NAN, 0.0, 1.0, "").is_err());
        assert!(check_length([f32::INFINITY, 0.0, 0.0], 1.0, " m").is_err());
        assert!(check_length([0.6, 0.8, 0.0], 1.0, " m").is_ok());
    }

    #[test]
    fn long_names_are_cut_on_a_character_boundary() {
        let name = "é".repeat(100);
        let cut = name_of(&name);
        assert!(cut.len() <= 64 && name.starts_with(cut));
    }
}
