//! Recognising what each joint is (pelvis, thigh, …), in named passes each testable alone:
//!
//! 1. **Name hints** (`names.rs`): what each joint's name says across the naming styles
//!    rigs come in (Mixamo, Unreal, Rigify, Blender `.L/.R`, `l-`/`_l`, CMU, KayKit,
//!    Quaternius, VRM/Unity), and which bones are helpers (IK targets and poles, controls,
//!    twist bones, sockets, eyes) that never get a body.
//! 2. **Geometry** (`confirm.rs`): those hints, or a file's own humanoid bone table, are
//!    accepted only if the hierarchy and the pose agree (knees below hips, head above
//!    pelvis, the sides apart).
//! 3. **Structure** (`structure.rs`): where names say nothing (CesiumMan's joints have
//!    none) or fail the check, the skeleton's shape alone: two legs to the ground and a
//!    rising spine from one joint, two mirror-image arms off the spine. A blocky game
//!    character whose legs and arms are one rigid part each has no knee or elbow to find;
//!    its limbs are read from the skin each part carries (`blocky.rs`).
//! 4. **Side** (`side.rs`): which way the character faces, which knees and elbows hinge
//!    by: the body's own cues (feet, else knees) where they are clear. Names or a table
//!    give the sides; where the body faces the other way than they imply, the names were
//!    given from the viewer's side and are kept, with a warning.
//!
//! Each is tried on the rest pose and then on the first animation frame, since some
//! exporters' rest pose is not upright (Rokoko's bone-local BVH offsets lie along +X).
//! Where names or a bone table still fail because the whole character lies down in its
//! file (a Z-up scene exported without turning its axes), they are checked again with it
//! stood up by its trunk (`upright.rs`), and its ragdoll is built stood up; so is a
//! humanoid found leaning, since its joints' cones are placed from the vertical.
//! Anything that is not a humanoid becomes [`Role::Chain`] links (`chain.rs`).

mod blocky;
mod chain;
mod confirm;
mod manual;
mod names;
mod rig;
mod role_file;
mod side;
mod structure;
mod thresholds;
mod upright;

use glam::{Quat, Vec3};

use confirm::Source;

pub use manual::{roles_for, roles_with_file};
pub(crate) use names::{NameHint, Part, name_hint};
pub(crate) use rig::Rig;
pub use role_file::{MAX_ROLE_FILE_ENTRIES, RoleFile};
use thresholds::*;

use super::Role;
use crate::math::Transform;
use crate::skeleton::Character;

/// The outcome of role recognition.
#[derive(Clone, Debug, PartialEq)]
pub struct Roles {
    /// For each skeleton joint, its role, or `None` when the joint gets no body of its own
    /// (it rides on the body of its nearest ancestor that has one).
    pub per_joint: Vec<Option<Role>>,
    /// Whether the skeleton was recognised as a standing humanoid.
    pub humanoid: bool,
    /// The character's forward direction in the pose roles were measured in (unit,
    /// horizontal for humanoids).
    pub forward: Vec3,
    /// Standing height, metres: top of the skeleton (or skin) above its lowest point. Every
    /// proportion-based estimate is a fraction of it, which keeps them scale-free.
    pub height_m: f32,
    /// One sentence for the user: how the roles were found, or why the character is not
    /// taken for a humanoid.
    pub why: String,
    /// Set when the joint names promise a humanoid (both thighs, shins, upper arms and
    /// forearms named) but no check confirmed one: tools show it on every command, since
    /// the ragdoll will not be what the user expects. The same sentence as [`Roles::why`].
    pub warning: Option<String>,
    /// For each skeleton joint, whether a roles file ([`RoleFile`]) gave its role or listed
    /// it as a helper; all `false` when roles were only recognised.
    pub from_file: Vec<bool>,
    /// The turn about the origin that stands the character up, where its file has it
    /// lying down (a Z-up scene exported without turning its axes): the roles, `forward`
    /// and `height_m` were measured on the character turned by it
    /// ([`Character::rotated`]), and its ragdoll is built from that turned character.
    /// `None` for a character that stands as it is.
    pub upright: Option<Quat>,
}

/// The roles every humanoid is looked for, in the order reports list them.
pub const HUMANOID_ROLES: [Role; 17] = [
    Role::Pelvis,
    Role::Spine,
    Role::Chest,
    Role::Neck,
    Role::Head,
    Role::ThighL,
    Role::ShinL,
    Role::FootL,
    Role::ThighR,
    Role::ShinR,
    Role::FootR,
    Role::UpperArmL,
    Role::ForearmL,
    Role::HandL,
    Role::UpperArmR,
    Role::ForearmR,
    Role::HandR,
];

impl Roles {
    /// The first joint with `role` (for [`Role::Chain`], the first chain link).
    pub fn joint(&self, role: Role) -> Option<usize> {
        self.per_joint.iter().position(|r| *r == Some(role))
    }

    /// The character's left in the rest pose, `up × forward`, so a character facing +Z has
    /// its left toward +X.
    pub fn left(&self) -> Vec3 {
        Vec3::Y.cross(self.forward).normalize_or(Vec3::X)
    }

    /// The humanoid roles some joint carries, in report order (empty for a non-humanoid).
    pub fn found(&self) -> Vec<Role> {
        HUMANOID_ROLES
            .iter()
            .copied()
            .filter(|r| self.humanoid && self.joint(*r).is_some())
            .collect()
    }

    /// The humanoid roles no joint carries, each with a sentence saying why (empty for a
    /// non-humanoid, which has chain links instead).
    pub fn missing(&self) -> Vec<(Role, &'static str)> {
        if !self.humanoid {
            return Vec::new();
        }
        HUMANOID_ROLES
            .iter()
            .filter(|r| self.joint(**r).is_none())
            .map(|&r| {
                // A limb of one part: its upper role found, its lower one not.
                let whole = |upper: Role, lower: Role| {
                    self.joint(upper).is_some() && self.joint(lower).is_none()
                };
                let why = match r {
                    Role::Chest | Role::Spine if whole(Role::Pelvis, Role::Chest) => "the trunk is one part; the pelvis body is the whole trunk",
                    Role::Neck if whole(Role::Pelvis, Role::Chest) => "no joint between the trunk and the head; the head pivots on the trunk",
                    Role::ShinL | Role::FootL if whole(Role::ThighL, Role::ShinL) => "the leg is one part; the thigh body is the whole leg",
                    Role::ShinR | Role::FootR if whole(Role::ThighR, Role::ShinR) => "the leg is one part; the thigh body is the whole leg",
                    Role::ForearmL | Role::HandL if whole(Role::UpperArmL, Role::ForearmL) => "the arm is one part; the upper arm body is the whole arm",
                    Role::ForearmR | Role::HandR if whole(Role::UpperArmR, Role::ForearmR) => "the arm is one part; the upper arm body is the whole arm",
                    Role::Spine => "no joint between the pelvis and the chest; the chest body reaches down to the pelvis",
                    Role::Neck => "no joint between the chest and the head; the head pivots on the chest",
                    Role::Head => "nothing above the chest is named or shaped as a head",
                    Role::HandL | Role::HandR => "no hand joint past the forearm; fingers, if any, ride on the forearm",
                    Role::FootL | Role::FootR => "no foot joint past the shin; the shin reaches the ground",
                    _ => "no joint carries it",
                };
                (r, why)
            })
            .collect()
    }
}

/// Recognises roles; never fails: a skeleton that is not a humanoid gets chain links.
pub fn recognise_roles(character: &Character) -> Roles {
    with_size_warning(recognise_with_helpers(character, &[]))
}

/// Heights people stand at, metres. A character taken for a humanoid outside them is far
/// more likely read in the wrong units than a giant or a doll (a knight 5.6 m tall in its
/// file was thrown at 229 m/s by 5 kg of TNT, 17 m/s at 1.8 m), so it gets a warning.
pub const HUMANOID_HEIGHT_M: std::ops::RangeInclusive<f32> = 0.3..=3.0;

/// `roles` with a warning naming the height of a humanoid outside [`HUMANOID_HEIGHT_M`],
/// where nothing is to be said louder.
pub(super) fn with_size_warning(mut roles: Roles) -> Roles {
    let h = roles.height_m;
    if roles.humanoid && roles.warning.is_none() && h.is_finite() && !HUMANOID_HEIGHT_M.contains(&h)
    {
        let (lo, hi) = HUMANOID_HEIGHT_M.into_inner();
        roles.warning = Some(format!(
            "a humanoid {h:.2} m tall, where people stand {lo} to {hi} m: if its file is in other units, say so (--units), or give its height (--height); its ragdoll weighs what a humanoid of this size would (75 kg at 1.75 m, as the cube of the height)"
        ));
    }
    roles
}

/// [`recognise_roles`], taking the joints flagged in `helpers` (by index; a shorter slice
/// flags none past its end) for helper bones whatever their names say, as a roles file's
/// `ignore` list asks.
fn recognise_with_helpers(character: &Character, helpers: &[bool]) -> Roles {
    let roles = recognise_as_is(character, helpers, None);
    upright::level(character, roles, |c, q| {
        recognise_as_is(c, helpers, Some(q))
    })
}

/// [`recognise_with_helpers`] on the character as its file has it, standing it up only
/// where nothing holds otherwise; `turn` is the turn a caller already stood it up by
/// (see [`humanoid_roles`]).
fn recognise_as_is(character: &Character, helpers: &[bool], turn: Option<Quat>) -> Roles {
    let rest = Rig::new(character);
    let posed = first_frame(character).map(|w| Rig::posed(character, w));
    let rigs: Vec<(&Rig, &str)> = std::iter::once((&rest, "rest pose"))
        .chain(posed.as_ref().map(|r| (r, "first animation frame")))
        .collect();
    let hints = hints_of(character, helpers);
    let table =
        (!character.humanoid_bones.is_empty()).then_some(Source::Table(&character.humanoid_bones));
    let sources: Vec<Source> = table.into_iter().chain([Source::Names(&hints)]).collect();
    let mut doubts = Vec::new();
    // Why the file's own humanoid table was not used, when it was not: said on every
    // command, since the file claimed to know better.
    let mut table_doubt = None;
    for &source in &sources {
        for &(rig, pose) in &rigs {
            match confirm::confirm(rig, &source.claims(rig)) {
                Ok(h) => {
                    let roles = humanoid_roles(rig, &h, source.checked_in(pose), turn);
                    return with_table_doubt(roles, table_doubt);
                }
                Err(e) => {
                    let doubt = source.doubt(pose, &e);
                    if matches!(source, Source::Table(_)) && table_doubt.is_none() {
                        table_doubt = Some(doubt.clone());
                    }
                    doubts.push(doubt);
                }
            }
        }
    }
    for &(rig, pose) in &rigs {
        if let Some(h) = structure::find_humanoid(rig) {
            let roles = humanoid_roles(
                rig,
                &h,
                format!(
                    "from the skeleton's shape in the {pose} (two legs to the ground, a spine, two arms)"
                ),
                turn,
            );
            return with_table_doubt(roles, table_doubt);
        }
    }
    for &(rig, pose) in &rigs {
        if let Some(h) = blocky::find_blocky(rig) {
            let how = format!(
                "from its parts' shape in the {pose} (a trunk carrying a head and two legs and two arms of one part each)"
            );
            return with_table_doubt(humanoid_roles(rig, &h, how, turn), table_doubt);
        }
    }
    let promised = looks_humanoid(&hints);
    let named_on_fours = promised && on_all_fours(&rest, &hints);
    let standing = limbs_standing(&rest, &hints);
    let quadruped = named_on_fours || standing >= STANDING_LIMBS_OF_A_CREATURE;
    // A quadruped stood on its hind legs is not a person lying down.
    if !quadruped
        && turn.is_none()
        && let Some(roles) = sources
            .iter()
            .find_map(|&source| upright::stood_up(character, &rigs, source))
    {
        return roles;
    }
    if turn.is_none()
        && !quadruped
        && let Some(roles) = upright::stood_up_by_shape(&rigs)
    {
        return roles;
    }
    let table_warning = table_doubt.map(table_sentence);
    let why = match doubts.first() {
        _ if named_on_fours => "Not a humanoid: a quadruped, standing on the four limbs its names call legs and arms; its bones are chain links, and the leg joints it stands bent are hinges.".to_string(),
        _ if quadruped => format!("Not a humanoid: it stands on {standing} limbs, a creature, not a person lying down; its bones are chain links, and the leg joints it stands bent are hinges."),
        Some(d) if promised => format!("Not a humanoid: {d}, and no joint has two legs reaching the ground, a rising spine and two arms."),
        _ => "Not a humanoid: no joint has two legs reaching the ground, a rising spine and two arms, and the names do not say thigh, shin, upper arm and forearm on both sides.".to_string(),
    };
    Roles {
        per_joint: chain::chain_roles(&rest, &hints),
        humanoid: false,
        forward: chain::creature_forward(&rest),
        height_m: rest.height,
        // Names of a quadruped's legs borrow a person's (Rigify's dog: `thigh.L`,
        // `upper_arm.L`): standing on all four, it is what it looks like, not a humanoid
        // gone wrong.
        warning: (promised && !quadruped)
            .then(|| why.clone())
            .or(table_warning),
        why,
        from_file: vec![false; rest.len()],
        upright: None,
    }
}

/// The warning for a humanoid table the skeleton contradicts (`doubt` says how).
fn table_sentence(doubt: String) -> String {
    format!("{doubt}; the table is not used")
}

/// `roles` with the warning that the file's humanoid table was set aside, where it was
/// and nothing else is to be said louder.
fn with_table_doubt(mut roles: Roles, doubt: Option<String>) -> Roles {
    if roles.warning.is_none() {
        roles.warning = doubt.map(table_sentence);
    }
    roles
}

/// What each joint's name says, with the joints flagged in `helpers` taken for helpers.
fn hints_of(character: &Character, helpers: &[bool]) -> Vec<NameHint> {
    character
        .skeleton
        .joints()
        .iter()
        .enumerate()
        .map(|(i, j)| {
            let mut h = name_hint(&j.name);
            h.helper |= helpers.get(i).copied().unwrap_or(false);
            h
        })
        .collect()
}

/// Whether the limbs the names call legs and arms, all four, hang from well above the
/// ground down to it in the rest pose: a quadruped whose rig borrows a person's names
/// (not a person lying flat, whose limbs do not hang).
fn on_all_fours(rig: &Rig, hints: &[NameHint]) -> bool {
    let claims = confirm::claims_from_names(rig, hints);
    let reach = LEG_GROUND_TOLERANCE_H * rig.height;
    let stands = |j: usize| {
        rig.subtree_stats(j).0 <= rig.ground + reach
            && rig.pos[j].y >= rig.ground + LEG_MIN_DROP_H * rig.height
    };
    claims
        .legs
        .iter()
        .chain(&claims.arms)
        .all(|limb| limb[0].is_some_and(stands))
}

/// How many limbs `rig` stands on in its pose: each chain from a leaf reaching the ground
/// (not a helper's: an IK target or pole lies there too) up to where it branches off
/// something well above the ground ([`LIMB_MIN_DROP_OF_EXTENT`]), counted once per
/// branch. A dog stands on four, a spider on eight, a person on two (fingers and toes are
/// one limb with their arm or leg); a person lying flat on none, since nothing of them is
/// well above the ground, so a creature on four limbs or more is not a person lying down,
/// whatever its names.
fn limbs_standing(rig: &Rig, hints: &[NameHint]) -> usize {
    let reach = rig.ground + LEG_GROUND_TOLERANCE_H * rig.height;
    let high = rig.ground + LIMB_MIN_DROP_OF_EXTENT * rig.extent;
    // Marked, not searched: a star of 65,536 feet under one hub would make a list search
    // quadratic.
    let mut limb = vec![false; rig.len()];
    let feet = (0..rig.len()).filter(|&j| {
        rig.children[j].is_empty()
            && !hints.get(j).is_some_and(|h| h.helper)
            && rig.subtree_stats(j).0 <= reach
    });
    for foot in feet {
        // Up to the first branching joint well above the ground, a bounded walk.
        let mut at = foot;
        for _ in 0..MAX_LIMB_WALK {
            let Some(p) = rig.parent(at) else { break };
            if rig.pos[p].y >= high && rig.children[p].len() >= 2 {
                limb[at] = true;
                break;
            }
            at = p;
        }
    }
    limb.iter().filter(|&&l| l).count()
}

/// Whether the names alone promise a humanoid: both thighs, shins, upper arms and
/// forearms named. Such a character that fails every check deserves a warning.
pub fn looks_humanoid(hints: &[NameHint]) -> bool {
    [Part::Thigh, Part::Shin, Part::UpperArm, Part::Forearm]
        .iter()
        .all(|&p| {
            [1, -1].iter().all(|&s| {
                hints
                    .iter()
                    .any(|h| !h.helper && h.part == Some(p) && h.side == s)
            })
        })
}

/// The roles of the humanoid `h` found on `rig`. `turn` is the turn that stood the
/// character up before `rig` was made, if one did: the roles record it
/// ([`Roles::upright`]), and the facing a warning names is turned back to the file's axes,
/// which are the ones the user sees.
fn humanoid_roles(rig: &Rig, h: &structure::Humanoid, how: String, turn: Option<Quat>) -> Roles {
    let mut per_joint = vec![None; rig.len()];
    for (j, role) in h.assignments() {
        per_joint[j] = Some(role);
    }
    let mirrored = h.mirrored.then(|| {
        format!(
            "The sides in its joint names are mirrored: the body faces {} by its feet (or knees), so the limbs named as left ({}, ...) are on the character's right; the roles keep the names, and knees and elbows bend the way the body faces.",
            facing_words(turn.map_or(h.forward, |q| q.inverse() * h.forward)),
            rig.skeleton.joint_label(h.legs[0].upper)
        )
    });
    let why = match &mirrored {
        Some(m) => format!("Humanoid: roles {how}. {m}"),
        None => format!("Humanoid: roles {how}."),
    };
    Roles {
        per_joint,
        humanoid: true,
        forward: h.forward,
        height_m: rig.height,
        why,
        warning: mirrored,
        from_file: vec![false; rig.len()],
        upright: turn,
    }
}

/// A direction as a user reads it: `+Z` when it lies along an axis (`+Y` for a character
/// lying on its back in its file), else its components.
fn facing_words(forward: Vec3) -> String {
    let axes = [(Vec3::X, "X"), (Vec3::Y, "Y"), (Vec3::Z, "Z")];
    for (axis, name) in axes {
        let d = forward.dot(axis);
        if d.abs() > 0.99 {
            return format!("{}{name}", if d > 0.0 { "+" } else { "-" });
        }
    }
    format!("({:.2}, {:.2}, {:.2})", forward.x, forward.y, forward.z)
}

/// World transforms of the first frame of the first clip, when there is one that differs
/// from the rest pose.
fn first_frame(character: &Character) -> Option<Vec<Transform>> {
    let skeleton = &character.skeleton;
    let frame = character.clips.first()?.frames.first()?;
    if frame.len() != skeleton.len() {
        return None;
    }
    let mut world = vec![Transform::IDENTITY; skeleton.len()];
    skeleton.world_from_local(frame, &mut world);
    let rest = skeleton.rest_world();
    let moved = world
        .iter()
        .zip(&rest)
        .any(|(a, b)| a.translation.distance(b.translation) > 1e-6);
    (moved && world.iter().all(|t| t.translation.is_finite())).then_some(world)
}

#[cfg(test)]
pub(crate) mod tests;
