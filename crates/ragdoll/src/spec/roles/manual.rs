//! Roles given by hand in a roles file (`--roles FILE.toml`, a scene character's
//! `roles = "..."`, read in `role_file.rs`), for the rare rig recognition still gets
//! wrong, applied to a skeleton.
//!
//! What the file decides, and why:
//!
//! - **Partial.** The joints it names take its roles; every other role is still found as
//!   before (recognised roles, else what the names claim), and trunk roles the file leaves
//!   out follow its limbs (the chest is where the named upper arms meet). A rig that is
//!   wrong in one place (CMU arms shifted by one joint) is fixed with that place's lines,
//!   and a whole table works too.
//! - **Stronger than a file's bone table.** Geometry does not overrule it: a named shin
//!   need not be 8 % of the height below its thigh, nor shoulders above hips. Only what
//!   cannot be built is refused, with the key's line: a shin that does not hang from its
//!   thigh (or forearm from its upper arm, chest from pelvis), a knee at or above its hip
//!   in the rest pose and in the first frame, left and right limbs in one place, or legs
//!   and arms that disagree about which side is left.
//! - **Ignoring only** (no `[roles]`) keeps recognition, with the listed joints taken for
//!   helpers (a control bone named like a leg no longer misleads it) and given no body; a
//!   humanoid's trunk roles move off an ignored joint as they do off a named one.
//! - Naming any role makes the character a humanoid: the four limbs (thigh, shin, upper
//!   arm, forearm on each side), pelvis and chest must then be named or found.

use std::collections::HashMap;

use glam::Vec3;

use super::confirm::{self, Claims};
use super::rig::{Rig, horizontal};
use super::role_file::{Entry, RoleFile};
use super::side::forward_from_sides;
use super::structure::{Humanoid, Limb};
use super::{HUMANOID_ROLES, MIN_LEG_SEPARATION_H, Role, Roles, first_frame};
use crate::error::Result;
use crate::skeleton::Character;

/// The roles the ragdoll is built from: recognised, or from `file` where it is given.
pub fn roles_for(character: &Character, file: Option<&RoleFile>) -> Result<Roles> {
    match file {
        Some(f) => roles_with_file(character, f).map(super::with_size_warning),
        None => Ok(super::recognise_roles(character)),
    }
}

/// The roles of `character` with `file` applied (see the module documentation for what
/// the file decides); an error is one sentence naming the file, the line and the key.
pub fn roles_with_file(character: &Character, file: &RoleFile) -> Result<Roles> {
    let joints = resolve(character, file)?;
    let n = character.skeleton.len();
    let mut ignored = vec![false; n];
    let mut manual = Vec::new();
    for (e, &j) in file.entries.iter().zip(&joints) {
        match e.role {
            None => ignored[j] = true,
            Some(r) => manual.push((r, j, e)),
        }
    }
    let base = super::recognise_with_helpers(character, &ignored);
    let mut from_file = ignored.clone();
    for &(_, j, _) in &manual {
        from_file[j] = true;
    }
    if manual.is_empty() && !base.humanoid {
        let mut roles = base;
        for (r, _) in roles.per_joint.iter_mut().zip(&ignored).filter(|p| *p.1) {
            *r = None;
        }
        let count = ignored.iter().filter(|i| **i).count();
        roles.why = format!(
            "{} {count} joint(s) listed in {} get no body.",
            roles.why,
            file.path.display()
        );
        roles.from_file = from_file;
        return Ok(roles);
    }
    // A character its file has lying down is checked as recognition stood it up.
    let turned = base.upright.map(|q| character.rotated_start(q));
    let character = turned.as_ref().unwrap_or(character);
    let rest = Rig::new(character);
    let posed = first_frame(character).map(|w| Rig::posed(character, w));
    let mut first_error = None;
    for (rig, pose) in std::iter::once((&rest, "rest pose"))
        .chain(posed.as_ref().map(|r| (r, "first animation frame")))
    {
        let claims = claims(rig, &base, &manual, &ignored);
        match check(rig, &claims, &ignored, pose) {
            Ok(h) => {
                let mut per_joint = vec![None; n];
                for (j, role) in h.assignments() {
                    per_joint[j] = Some(role);
                }
                let how = if base.humanoid {
                    "as recognised"
                } else {
                    "from the joint names and the skeleton"
                };
                return Ok(Roles {
                    per_joint,
                    humanoid: true,
                    forward: h.forward,
                    height_m: rig.height,
                    why: format!(
                        "Humanoid: {} role(s) from {}, checked in the {pose} only for what cannot be built; the rest {how}.",
                        manual.len(),
                        file.path.display()
                    ),
                    warning: None,
                    from_file,
                    upright: base.upright,
                });
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    let (role, message) = first_error.unwrap_or((None, "no pose to check".into()));
    Err(match manual.iter().find(|m| Some(m.0) == role) {
        Some((r, _, e)) => file.err(e.line, r.as_str(), message),
        None => file.err(file.roles_line, "roles", message),
    })
}

/// Each entry's joint index; unknown, ambiguous or doubly given joints are errors. A joint
/// is named as `inspect` prints it: by its name, or `joint<i>` when it has none (CesiumMan's
/// joints are all unnamed).
fn resolve(character: &Character, file: &RoleFile) -> Result<Vec<usize>> {
    let s = &character.skeleton;
    let labels: Vec<String> = (0..s.len()).map(|i| s.joint_label(i)).collect();
    let mut by_name: HashMap<&str, (usize, usize)> = HashMap::with_capacity(s.len());
    for (i, label) in labels.iter().enumerate() {
        by_name.entry(label.as_str()).or_insert((i, 0)).1 += 1;
    }
    let mut owner: HashMap<usize, &Entry> = HashMap::new();
    let mut out = Vec::with_capacity(file.entries.len());
    for e in &file.entries {
        let Some(&(j, count)) = by_name.get(e.joint.as_str()) else {
            return Err(file.err(
                e.line,
                e.key(),
                format!(
                    "\"{}\" is not a joint of {}; the closest names are {}",
                    e.joint,
                    character.name,
                    closest(character, &e.joint)
                ),
            ));
        };
        if count > 1 {
            return Err(file.err(
                e.line,
                e.key(),
                format!(
                    "\"{}\" names {count} joints of {}, so it does not say which",
                    e.joint, character.name
                ),
            ));
        }
        if let Some(other) = owner.get(&j) {
            if other.role.is_none() && e.role.is_none() {
                out.push(j);
                continue;
            }
            let message = match (other.role, e.role) {
                (Some(a), Some(b)) if side_twin(a) == Some(b) => format!(
                    "\"{}\" is also {} (line {}): the left and right sides must be different joints",
                    e.joint,
                    a.as_str(),
                    other.line
                ),
                _ => format!(
                    "\"{}\" is already given as {} (line {}): a joint carries one role",
                    e.joint,
                    other.key(),
                    other.line
                ),
            };
            return Err(file.err(e.line, e.key(), message));
        }
        owner.insert(j, e);
        out.push(j);
    }
    Ok(out)
}

/// The same role on the other side (`thigh_l` ↔ `thigh_r`).
fn side_twin(r: Role) -> Option<Role> {
    let name = r.as_str();
    let twin = match name.rsplit_once('_') {
        Some((base, "l")) => format!("{base}_r"),
        Some((base, "r")) => format!("{base}_l"),
        _ => return None,
    };
    HUMANOID_ROLES.iter().copied().find(|x| x.as_str() == twin)
}

/// Up to three joint names nearest to `name` (edit distance, ignoring case), quoted.
fn closest(character: &Character, name: &str) -> String {
    /// Long names are compared by their start: enough to rank, bounded in time.
    const CHARS: usize = 64;
    let cut = |s: &str| s.chars().take(CHARS).collect::<String>().to_lowercase();
    let want = cut(name);
    let mut ranked: Vec<(usize, usize)> = (0..character.skeleton.len())
        .map(|i| {
            let label = character.skeleton.joint_label(i);
            (strsim::levenshtein(&cut(&label), &want), i)
        })
        .collect();
    ranked.sort();
    let names: Vec<String> = ranked
        .iter()
        .take(3)
        .map(|&(_, i)| format!("\"{}\"", character.skeleton.joint_label(i)))
        .collect();
    if names.is_empty() {
        "none (it has no joints)".into()
    } else {
        names.join(", ")
    }
}

/// The slot of `claims` that holds `role` (none for [`Role::Chain`]).
fn slot(c: &mut Claims, role: Role) -> Option<&mut Option<usize>> {
    Some(match role {
        Role::Pelvis => &mut c.pelvis,
        Role::Spine => &mut c.spine,
        Role::Chest => &mut c.chest,
        Role::Neck => &mut c.neck,
        Role::Head => &mut c.head,
        Role::ThighL => &mut c.legs[0][0],
        Role::ShinL => &mut c.legs[0][1],
        Role::FootL => &mut c.legs[0][2],
        Role::ThighR => &mut c.legs[1][0],
        Role::ShinR => &mut c.legs[1][1],
        Role::FootR => &mut c.legs[1][2],
        Role::UpperArmL => &mut c.arms[0][0],
        Role::ForearmL => &mut c.arms[0][1],
        Role::HandL => &mut c.arms[0][2],
        Role::UpperArmR => &mut c.arms[1][0],
        Role::ForearmR => &mut c.arms[1][1],
        Role::HandR => &mut c.arms[1][2],
        Role::Chain => return None,
    })
}

/// The claims to check: the recognised roles (else what the names claim), less the
/// joints the file names, plus the file's roles; trunk roles the file leaves out are
/// found again from its limbs where the old ones no longer fit.
fn claims(rig: &Rig, base: &Roles, manual: &[(Role, usize, &Entry)], ignored: &[bool]) -> Claims {
    let mut c = if base.humanoid {
        let mut c = Claims::default();
        for (j, r) in base.per_joint.iter().enumerate() {
            if let Some(s) = r.and_then(|r| slot(&mut c, r)) {
                *s = Some(j);
            }
        }
        c
    } else {
        let hints: Vec<_> = rig
            .skeleton
            .joints()
            .iter()
            .zip(ignored)
            .map(|(j, &ig)| {
                let mut h = super::name_hint(&j.name);
                h.helper |= ig;
                h
            })
            .collect();
        confirm::claims_from_names(rig, &hints)
    };
    let taken = |j: usize| ignored[j] || manual.iter().any(|m| m.1 == j);
    for r in HUMANOID_ROLES {
        if let Some(s) = slot(&mut c, r)
            && s.is_some_and(taken)
        {
            *s = None;
        }
    }
    for &(r, j, _) in manual {
        if let Some(s) = slot(&mut c, r) {
            *s = Some(j);
        }
    }
    let given = |r: Role| manual.iter().any(|m| m.0 == r);
    let below = |a: usize, b: usize| rig.is_ancestor(a, b);
    let uppers: Vec<usize> = c.arms.iter().filter_map(|a| a[0]).collect();
    if !given(Role::Chest)
        && let [a, b] = uppers[..]
        && !c.chest.is_some_and(|ch| below(ch, a) && below(ch, b))
    {
        c.chest = rig.common_ancestor(a, b).filter(|&ch| ch != a && ch != b);
    }
    let thighs: Vec<usize> = c.legs.iter().filter_map(|l| l[0]).collect();
    if !given(Role::Pelvis)
        && let Some(chest) = c.chest
        && !c.pelvis.is_some_and(|p| below(p, chest))
    {
        c.pelvis = match thighs[..] {
            [a, b] => rig.common_ancestor(a, b).filter(|&p| below(p, chest)),
            _ => None,
        }
        .or(rig.parent(chest));
    }
    if let (Some(p), Some(chest)) = (c.pelvis, c.chest) {
        if !given(Role::Spine) && !c.spine.is_some_and(|s| below(p, s) && below(s, chest)) {
            c.spine = confirm::path_down(rig, p, chest).first().copied();
        }
        if !given(Role::Head) && c.head.is_none() {
            c.head = confirm::unnamed_head(rig, chest, &uppers);
        }
        if let Some(head) = c.head
            && !given(Role::Neck)
            && !c.neck.is_some_and(|n| below(chest, n) && below(n, head))
        {
            c.neck = confirm::path_down(rig, chest, head).first().copied();
        }
    }
    c
}

/// What cannot be built: the role to blame, and one clause saying why.
type Blame = (Option<Role>, String);

const LEGS: [[Role; 3]; 2] = [
    [Role::ThighL, Role::ShinL, Role::FootL],
    [Role::ThighR, Role::ShinR, Role::FootR],
];
const ARMS: [[Role; 3]; 2] = [
    [Role::UpperArmL, Role::ForearmL, Role::HandL],
    [Role::UpperArmR, Role::ForearmR, Role::HandR],
];

/// What cannot be built, as (the role to blame, one clause); else the humanoid: its
/// limbs, its trunk, its sides, and no joint given two roles or ignored while needed.
fn check(
    rig: &Rig,
    c: &Claims,
    ignored: &[bool],
    pose: &str,
) -> std::result::Result<Humanoid, Blame> {
    let (legs, arms) = limbs(rig, c, pose)?;
    let pelvis = need(c.pelvis, Role::Pelvis)?;
    let chest = need(c.chest, Role::Chest)?;
    if !rig.is_ancestor(pelvis, chest) {
        return Err((
            Some(Role::Chest),
            format!(
                "{} does not rise from the pelvis {} in the skeleton",
                quoted(rig, chest),
                quoted(rig, pelvis)
            ),
        ));
    }
    let forward = facing(rig, &legs, &arms, pose)?;
    let h = c.humanoid([pelvis, chest], legs, arms, forward, false);
    one_role_each(rig, &h, ignored)?;
    Ok(h)
}

/// A joint's name as a message quotes it.
fn quoted(rig: &Rig, j: usize) -> String {
    format!("\"{}\"", rig.skeleton.joint_label(j))
}

/// The joint claimed for role `r`, or why there is none.
fn need(j: Option<usize>, r: Role) -> std::result::Result<usize, Blame> {
    j.ok_or_else(|| {
        (
            Some(r),
            format!(
                "names no joint for {0} and none was recognised; add {0} = \"...\" under [roles]",
                r.as_str()
            ),
        )
    })
}

/// Both legs and both arms, left first: each lower joint hangs from its upper one, and
/// each knee is below its hip in the `pose`.
fn limbs(rig: &Rig, c: &Claims, pose: &str) -> std::result::Result<([Limb; 2], [Limb; 2]), Blame> {
    let limb = |claimed: [Option<usize>; 3], roles: [Role; 3]| {
        let upper = need(claimed[0], roles[0])?;
        let lower = need(claimed[1], roles[1])?;
        if !rig.is_ancestor(upper, lower) {
            return Err((
                Some(roles[1]),
                format!(
                    "{} does not hang from {} ({}) in the skeleton, so no joint links them",
                    quoted(rig, lower),
                    quoted(rig, upper),
                    roles[0].as_str()
                ),
            ));
        }
        Ok(confirm::limb(rig, upper, lower, claimed[2]))
    };
    let mut legs = Vec::new();
    let mut arms = Vec::new();
    for s in 0..2 {
        legs.push(limb(c.legs[s], LEGS[s])?);
        arms.push(limb(c.arms[s], ARMS[s])?);
        let (thigh, shin) = (legs[s].upper, legs[s].lower_or_upper());
        if rig.pos[shin].y >= rig.pos[thigh].y {
            return Err((
                Some(LEGS[s][1]),
                format!(
                    "the knee {} is not below the hip {} in the {pose}",
                    quoted(rig, shin),
                    quoted(rig, thigh)
                ),
            ));
        }
    }
    match (<[_; 2]>::try_from(legs), <[_; 2]>::try_from(arms)) {
        (Ok(legs), Ok(arms)) => Ok((legs, arms)),
        _ => Err((None, "not two legs and two arms".into())),
    }
}

/// Where the body faces, from its sides; refused when the legs stand in one place or
/// the arms and legs disagree about which side is left.
fn facing(
    rig: &Rig,
    legs: &[Limb; 2],
    arms: &[Limb; 2],
    pose: &str,
) -> std::result::Result<Vec3, Blame> {
    let across = |a: &[Limb; 2]| {
        let mid = |l: &Limb| rig.pos[l.upper] + rig.pos[l.lower_or_upper()];
        horizontal((mid(&a[0]) - mid(&a[1])) * 0.5)
    };
    let (legs_across, arms_across) = (across(legs), across(arms));
    let apart = MIN_LEG_SEPARATION_H * rig.height;
    if legs_across.length() < apart {
        return Err((
            Some(Role::ThighR),
            format!("the left and right legs stand in one place in the {pose}"),
        ));
    }
    if arms_across.length() >= apart && arms_across.dot(legs_across) < 0.0 {
        return Err((
            Some(Role::UpperArmL),
            format!(
                "the left arm is on the right leg's side in the {pose}: the arms and the legs disagree about which side is left"
            ),
        ));
    }
    let sides = |s: usize| {
        let (l, a) = (&legs[s], &arms[s]);
        [l.upper, l.lower_or_upper(), a.upper, a.lower_or_upper()]
    };
    Ok(forward_from_sides(rig, &sides(0), &sides(1))
        .unwrap_or_else(|| legs_across.normalize_or(Vec3::X).cross(Vec3::Y)))
}

/// Refuses a joint that would carry two roles, or one the file ignores.
fn one_role_each(rig: &Rig, h: &Humanoid, ignored: &[bool]) -> std::result::Result<(), Blame> {
    let mut seen: HashMap<usize, Role> = HashMap::new();
    for (j, r) in h.assignments() {
        if ignored[j] {
            return Err((
                Some(r),
                format!(
                    "{} is listed in ignore, but the {} needs it",
                    quoted(rig, j),
                    r.as_str()
                ),
            ));
        }
        if let Some(other) = seen.insert(j, r) {
            return Err((
                Some(r),
                format!(
                    "{} would carry both {} and {}; name each of them under [roles]",
                    quoted(rig, j),
                    other.as_str(),
                    r.as_str()
                ),
            ));
        }
    }
    Ok(())
}
