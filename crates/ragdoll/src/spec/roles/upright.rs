//! Characters lying down in their file: a Z-up scene exported without its axis turned
//! (Blender's and 3ds Max's up is Z, glTF's and BVH's Y), or a figure modelled on its back.
//! Every check of the other passes reads "up" as +Y (knees below hips, a leg reaching the
//! ground), so such a character's names or bone table fail them and it was built as a
//! creature, weighed by its volume: the same knight lying down came out at 3.9 tonnes.
//!
//! Where the names or the table claim a pelvis and something above it (chest, neck or
//! head) and that trunk lies more than [`MIN_TILT_DEG`] off the vertical, the character is
//! turned so the trunk points up and the claims are checked again on the turned skeleton.
//! What they confirm there is its ragdoll: bodies and joints are kept in their bones'
//! frames, so the ragdoll built from the turned character fits the original, which falls
//! from the pose its file gives (lying).
//!
//! Without names or a table, the skeleton's shape is checked again turned by each quarter
//! or half turn, else by either end of its longest axis ([`stood_up_by_shape`]); it is
//! taken only when exactly one way stands a humanoid up, since nothing else says which way
//! is up.

use glam::{Quat, Vec3};

use super::confirm::{self, Claims, Source};
use super::{Rig, Role, Roles, first_frame, humanoid_roles, structure};
use crate::skeleton::Character;

/// A trunk tilted less than this from the vertical is standing: turning it upright would
/// not change what the checks see.
const MIN_TILT_DEG: f32 = 20.0;
/// A trunk within this of an axis is taken to lie along it: an exporter's axis swap turns
/// a scene by exactly 90° or 180°, and turning back by exactly that gives the ragdoll its
/// upright export gets, not one tilted by however far the trunk leans off the vertical.
const AXIS_SNAP_DEG: f32 = 15.0;

/// The roles `source` gives once `character` is stood up, if its trunk lies down in the
/// rest pose or the first animation frame (`rigs`, the caller's: the rest pose first) and
/// the claims hold on the turned skeleton.
pub(super) fn stood_up(
    character: &Character,
    rigs: &[(&Rig, &str)],
    source: Source,
) -> Option<Roles> {
    for (k, &(rig, pose)) in rigs.iter().enumerate() {
        let posed = k > 0;
        let Some(up) = trunk_up(rig, &source.claims(rig)) else {
            continue;
        };
        if up.angle_between(Vec3::Y) < MIN_TILT_DEG.to_radians() {
            continue;
        }
        let q = Quat::from_rotation_arc(snapped(up), Vec3::Y);
        let turned = character.rotated_start(q);
        let Some(turned_rig) = rig_in(&turned, posed) else {
            continue;
        };
        if let Ok(h) = confirm::confirm(&turned_rig, &source.claims(&turned_rig)) {
            let how = format!(
                "{}, checked with the character stood up (its {pose} lies with the head toward {})",
                source.words(),
                direction_words(up)
            );
            return Some(humanoid_roles(&turned_rig, &h, how, Some(q)));
        }
    }
    None
}

/// The roles the skeleton's shape alone gives the character stood up, when exactly one
/// way up gives a humanoid in the rest pose, else in the first animation frame (`rigs`,
/// the caller's: the rest pose first). The ways tried are the quarter and half turns an
/// exporter's axis swap makes, then, when none of them stands it up, either end of the
/// skeleton's longest axis (a figure lying at a slant). The turn kept is the one that
/// stands the found figure's own trunk and legs up ([`settled`]). An unnamed humanoid
/// lying down in its file (CesiumMan exported Z-up) then gets the ragdoll it gets
/// standing.
///
/// Only a single answer: without names nothing says which way is up, so the turned
/// skeleton must pass every check of the shape on its own, two legs reaching the ground
/// below a rising spine with two arms. A quadruped stood on end does not (its legs then
/// point along the ground, and on its back they point up); a figure two turns would both
/// stand up is not told apart from a creature and stays one.
pub(super) fn stood_up_by_shape(rigs: &[(&Rig, &str)]) -> Option<Roles> {
    for &(rig, pose) in rigs {
        let axes = [Vec3::X, Vec3::NEG_X, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z];
        let mut found = standing_shapes(rig, pose, &axes);
        if found.is_empty() {
            let weights = vec![1.0; rig.pos.len()];
            let (_, [long, ..], _) = crate::math::principal_axes(&rig.pos, &weights);
            found = standing_shapes(rig, pose, &[long, -long]);
        }
        match found.as_slice() {
            [] => continue,
            [(up, roles)] => return Some(settled(rig, pose, *up, roles.clone())),
            _ => return None,
        }
    }
    None
}

/// Each way up in `ups` (file axes) under which `rig`'s shape is a humanoid, with its roles
/// (two at most: a second answer already makes the shape ambiguous).
fn standing_shapes(rig: &Rig, pose: &str, ups: &[Vec3]) -> Vec<(Vec3, Roles)> {
    (ups.iter())
        .filter_map(|&up| Some((up, shape_stood_up(rig, pose, up)?)))
        .take(2)
        .collect()
}

/// The roles of `rig`'s shape turned so that `up` (file axes) points up, if it is a
/// humanoid then.
fn shape_stood_up(rig: &Rig, pose: &str, up: Vec3) -> Option<Roles> {
    let q = Quat::from_rotation_arc(up, Vec3::Y);
    let turned = rig.turned(q);
    // A skeleton's shape, or a blocky character's parts (one part a limb).
    let (h, shape) = match structure::find_humanoid(&turned) {
        Some(h) => (
            h,
            "the skeleton's shape in the {pose} (two legs to the ground, a spine, two arms)",
        ),
        None => (
            super::blocky::find_blocky(&turned)?,
            "its parts' shape in the {pose} (a trunk carrying a head and two legs and two arms of one part each)",
        ),
    };
    let how = format!(
        "from {}, checked with the character stood up (its {pose} lies with the head toward {})",
        shape.replace("{pose}", pose),
        direction_words(up)
    );
    Some(humanoid_roles(&turned, &h, how, Some(q)))
}

/// `roles`, found with `rig` turned so that `up` points up, found again with it turned so
/// that the figure's own trunk and legs do ([`body_up`], exactly along an axis within
/// [`AXIS_SNAP_DEG`]) when that differs: a figure lying at a slant, stood up by its
/// longest axis or by the nearest quarter turn, otherwise keeps the rest of its lean in
/// every joint frame. The same joints must carry the same roles (sides may change, as in
/// [`level`]).
fn settled(rig: &Rig, pose: &str, up: Vec3, roles: Roles) -> Roles {
    let Some(own) = body_up(&rig.pos, &roles).map(snapped) else {
        return roles;
    };
    if own.angle_between(up) < 1e-4 {
        return roles;
    }
    match shape_stood_up(rig, pose, own) {
        Some(better) if same_joints(&better, &roles) => better,
        _ => roles,
    }
}

/// Whether `a` and `b` give the same joints the same roles, sides aside.
fn same_joints(a: &Roles, b: &Roles) -> bool {
    let unsided = |r: &Option<Role>| {
        r.map(|r| {
            let s = r.as_str();
            s.strip_suffix("_l").or(s.strip_suffix("_r")).unwrap_or(s)
        })
    };
    (a.per_joint.iter().map(unsided)).eq(b.per_joint.iter().map(unsided))
}

/// `roles` found as the character stands in its file, or, where its rest pose leans more
/// than [`MIN_TILT_DEG`], the roles `again` finds on it stood up by a turn (given to it
/// too): the same joints, with the facing and the limits' frames measured upright. Every
/// joint frame is built from the vertical (a hip's cone opens downward and forward), so a
/// figure leaning 57° in its file got cones turned 57° off its own legs, which the rest
/// pose then widened to hold.
///
/// How far it leans is read from the trunk (pelvis to head) and the legs (each thigh to
/// its foot) together: a whole figure tilted turns both, while a hunched one (the orc's
/// trunk leans 20° over straight legs) is standing as it was made.
pub(super) fn level(
    character: &Character,
    roles: Roles,
    again: impl Fn(&Character, Quat) -> Roles,
) -> Roles {
    if !roles.humanoid || roles.upright.is_some() {
        return roles;
    }
    let rest: Vec<Vec3> = (character.skeleton.rest_world().iter())
        .map(|t| t.translation)
        .collect();
    let Some(up) = body_up(&rest, &roles) else {
        return roles;
    };
    let tilt = up.angle_between(Vec3::Y);
    if tilt < MIN_TILT_DEG.to_radians() {
        return roles;
    }
    let q = Quat::from_rotation_arc(snapped(up), Vec3::Y);
    let mut stood = again(&character.rotated_start(q), q);
    // The same joints must carry the same roles; only their sides may change: the side
    // checks read left and right across the vertical, so a figure tilted 41° (CesiumMan
    // turned about a diagonal) had its arms' sides swapped as it leaned, and stood up has
    // them right.
    if !(stood.humanoid && same_joints(&stood, &roles)) {
        return roles;
    }
    stood.why = format!(
        "{} Its rest pose leans {:.0}° off the vertical, so its ragdoll is built stood up.",
        stood.why,
        tilt.to_degrees()
    );
    stood
}

/// The way a recognised humanoid's body points up, its joints at `pos`: the mean of its
/// trunk's direction (pelvis to head, else neck or chest) and its legs' (each foot, else
/// shin, to its thigh). `None` without a pelvis, a top or a leg.
fn body_up(pos: &[Vec3], roles: &Roles) -> Option<Vec3> {
    let at = |r: Role| roles.joint(r).and_then(|j| pos.get(j).copied());
    let top = at(Role::Head)
        .or_else(|| at(Role::Neck))
        .or_else(|| at(Role::Chest))?;
    let trunk = (top - at(Role::Pelvis)?).try_normalize()?;
    let leg = |thigh: Role, shin: Role, foot: Role| {
        (at(thigh)? - at(foot).or_else(|| at(shin))?).try_normalize()
    };
    let legs = [
        leg(Role::ThighL, Role::ShinL, Role::FootL),
        leg(Role::ThighR, Role::ShinR, Role::FootR),
    ];
    let legs = legs.iter().flatten().sum::<Vec3>().try_normalize()?;
    (trunk + legs).try_normalize()
}

/// `c`'s rig in the rest pose, or in its first animation frame (`None` without one).
fn rig_in(c: &Character, posed: bool) -> Option<Rig<'_>> {
    if posed {
        first_frame(c).map(|w| Rig::posed(c, w))
    } else {
        Some(Rig::new(c))
    }
}

/// Which way the claimed trunk points: from the pelvis (else the middle of the thighs)
/// to the head (else the neck, else the chest). `None` without both ends.
fn trunk_up(rig: &Rig, c: &Claims) -> Option<Vec3> {
    let thighs = || match (c.legs[0][0], c.legs[1][0]) {
        (Some(l), Some(r)) => Some(0.5 * (rig.pos[l] + rig.pos[r])),
        _ => None,
    };
    let bottom = c.pelvis.map(|p| rig.pos[p]).or_else(thighs)?;
    let top = c.head.or(c.neck).or(c.chest).map(|j| rig.pos[j])?;
    (top - bottom).try_normalize()
}

/// `d`, or the axis it lies within [`AXIS_SNAP_DEG`] of.
fn snapped(d: Vec3) -> Vec3 {
    [Vec3::X, Vec3::NEG_X, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z]
        .into_iter()
        .find(|a| d.angle_between(*a) < AXIS_SNAP_DEG.to_radians())
        .unwrap_or(d)
}

/// A direction as a user reads it: the axis it lies nearest, signed (`-Z`).
fn direction_words(d: Vec3) -> &'static str {
    let a = d.abs();
    if a.x >= a.y && a.x >= a.z {
        if d.x > 0.0 { "+X" } else { "-X" }
    } else if a.y >= a.z {
        if d.y > 0.0 { "+Y" } else { "-Y" }
    } else if d.z > 0.0 {
        "+Z"
    } else {
        "-Z"
    }
}
