//! Roles given by hand in a roles file (`--roles FILE.toml`, a scene character's
//! `roles = "..."`), for the rare rig recognition still gets wrong:
//!
//! ```toml
//! ignore = ["l-LEGCONTROL", "MASTER"]   # joints that get no body (helpers); optional
//!
//! [roles]                               # role = "joint name", as `ragdoll inspect` prints
//! pelvis = "Hips"
//! thigh_l = "LeftUpLeg"
//! shin_l = "LeftLeg"
//! ```
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
use std::path::{Path, PathBuf};

use glam::Vec3;
use toml::de::{DeTable, DeValue};

use super::confirm::{self, Claims};
use super::rig::{Rig, horizontal};
use super::side::forward_from_sides;
use super::structure::Humanoid;
use super::{HUMANOID_ROLES, MIN_LEG_SEPARATION_H, Role, Roles, first_frame};
use crate::error::{Error, Result};
use crate::skeleton::Character;

/// Most entries (roles plus ignored joints) a roles file holds: a skeleton rarely has a
/// thousand joints, and each entry is looked up once, so the bound only stops a runaway
/// generated file.
pub const MAX_ROLE_FILE_ENTRIES: usize = 100_000;

/// A roles file as read: each role with its joint name, and the joints to ignore, every
/// one with the line it is written on.
#[derive(Clone, Debug, PartialEq)]
pub struct RoleFile {
    path: PathBuf,
    /// The line of the `[roles]` header (or 1), where a missing role is reported.
    roles_line: usize,
    entries: Vec<Entry>,
}

#[derive(Clone, Debug, PartialEq)]
struct Entry {
    /// `None`: listed in `ignore`.
    role: Option<Role>,
    joint: String,
    line: usize,
}

impl Entry {
    fn key(&self) -> &'static str {
        self.role.map_or("ignore", Role::as_str)
    }
}

impl RoleFile {
    /// Reads a roles file (at most [`crate::files::MAX_SETTINGS_BYTES`], a regular file).
    pub fn load(path: &Path) -> Result<RoleFile> {
        let text = crate::files::read_text_capped(path, crate::files::MAX_SETTINGS_BYTES)?;
        Self::from_toml(&text, path)
    }

    /// Reads a roles file from TOML text; `path` names it in errors, which give the line
    /// and the key.
    pub fn from_toml(text: &str, path: &Path) -> Result<RoleFile> {
        let err = |pos: usize, message: String| Error::Parse {
            path: path.to_path_buf(),
            line: crate::spec::line_at(text, pos),
            message,
        };
        let doc = DeTable::parse(text).map_err(|e| {
            let pos = e.span().map_or(0, |s| s.start);
            let mut message = e.message().trim().replace('\n', " ");
            // toml names neither the key nor why a repeated one matters here.
            if message == "duplicate key" {
                let before = text.get(..pos).unwrap_or("");
                let start = before.rfind('\n').map_or(0, |i| i + 1);
                let key = text
                    .get(start..)
                    .unwrap_or("")
                    .split(['=', '\n'])
                    .next()
                    .unwrap_or("")
                    .trim();
                message = format!("{key}: given twice; each role names one joint");
            }
            err(pos, message)
        })?;
        let mut file = RoleFile {
            path: path.to_path_buf(),
            roles_line: 1,
            entries: Vec::new(),
        };
        let push = |file: &mut RoleFile, e: Entry, pos: usize| {
            if file.entries.len() >= MAX_ROLE_FILE_ENTRIES {
                return Err(err(
                    pos,
                    format!("a roles file holds at most {MAX_ROLE_FILE_ENTRIES} entries"),
                ));
            }
            file.entries.push(e);
            Ok(())
        };
        for (k, v) in doc.get_ref() {
            match (k.get_ref().as_ref(), v.get_ref()) {
                ("roles", DeValue::Table(t)) => {
                    file.roles_line = crate::spec::line_at(text, k.span().start);
                    for (rk, rv) in t {
                        let key = rk.get_ref().as_ref();
                        if key == "ignore" {
                            for (joint, pos) in joint_list(rv, |m| err(rv.span().start, m))? {
                                let line = crate::spec::line_at(text, pos);
                                push(
                                    &mut file,
                                    Entry {
                                        role: None,
                                        joint,
                                        line,
                                    },
                                    pos,
                                )?;
                            }
                            continue;
                        }
                        let role = HUMANOID_ROLES
                            .iter()
                            .copied()
                            .find(|r| r.as_str() == key)
                            .ok_or_else(|| {
                                err(
                                    rk.span().start,
                                    format!("{key}: not a role; {}", role_names()),
                                )
                            })?;
                        let DeValue::String(joint) = rv.get_ref() else {
                            return Err(err(
                                rv.span().start,
                                format!(
                                    "{key}: must be a joint name in quotes, not a {}",
                                    rv.get_ref().type_str()
                                ),
                            ));
                        };
                        let (line, pos) =
                            (crate::spec::line_at(text, rk.span().start), rk.span().start);
                        let joint = joint.to_string();
                        push(
                            &mut file,
                            Entry {
                                role: Some(role),
                                joint,
                                line,
                            },
                            pos,
                        )?;
                    }
                }
                ("roles", other) => {
                    return Err(err(
                        k.span().start,
                        format!(
                            "roles: must be a table ([roles]), not a {}",
                            other.type_str()
                        ),
                    ));
                }
                ("ignore", _) => {
                    for (joint, pos) in joint_list(v, |m| err(v.span().start, m))? {
                        let line = crate::spec::line_at(text, pos);
                        push(
                            &mut file,
                            Entry {
                                role: None,
                                joint,
                                line,
                            },
                            pos,
                        )?;
                    }
                }
                (key, _) => {
                    return Err(err(
                        k.span().start,
                        format!(
                            "{key}: unknown key; a roles file holds a [roles] table and an ignore list"
                        ),
                    ));
                }
            }
        }
        if file.entries.is_empty() {
            return Err(err(
                0,
                "names no role and ignores no joint; write role = \"joint\" lines under [roles]"
                    .into(),
            ));
        }
        file.entries.sort_by_key(|e| e.line);
        Ok(file)
    }

    /// The file it was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn err(&self, line: usize, key: &str, message: impl std::fmt::Display) -> Error {
        Error::Parse {
            path: self.path.clone(),
            line,
            message: format!("{key}: {message}"),
        }
    }
}

/// `ignore = ["a", "b"]`: the names with their byte positions.
fn joint_list(
    v: &toml::Spanned<DeValue>,
    err: impl Fn(String) -> Error,
) -> Result<Vec<(String, usize)>> {
    let DeValue::Array(items) = v.get_ref() else {
        return Err(err(format!(
            "ignore: must be a list of joint names, not a {}",
            v.get_ref().type_str()
        )));
    };
    items
        .iter()
        .map(|i| match i.get_ref() {
            DeValue::String(s) => Ok((s.to_string(), i.span().start)),
            other => Err(err(format!(
                "ignore: must list joint names in quotes, not a {}",
                other.type_str()
            ))),
        })
        .collect()
}

fn role_names() -> String {
    let names: Vec<&str> = HUMANOID_ROLES.iter().map(|r| r.as_str()).collect();
    format!("the roles are {}", names.join(", "))
}

/// The roles the ragdoll is built from: recognised, or from `file` where it is given.
pub fn roles_for(character: &Character, file: Option<&RoleFile>) -> Result<Roles> {
    match file {
        Some(f) => roles_with_file(character, f),
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

/// Each entry's joint index; unknown, ambiguous or doubly given joints are errors.
fn resolve(character: &Character, file: &RoleFile) -> Result<Vec<usize>> {
    let s = &character.skeleton;
    let mut by_name: HashMap<&str, (usize, usize)> = HashMap::with_capacity(s.len());
    for (i, j) in s.joints().iter().enumerate() {
        by_name.entry(j.name.as_str()).or_insert((i, 0)).1 += 1;
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

/// What cannot be built, as (the role to blame, one clause); else the humanoid.
fn check(
    rig: &Rig,
    c: &Claims,
    ignored: &[bool],
    pose: &str,
) -> std::result::Result<Humanoid, (Option<Role>, String)> {
    let name = |j: usize| format!("\"{}\"", rig.skeleton.joint_label(j));
    let need = |j: Option<usize>, r: Role| {
        j.ok_or_else(|| {
            (
                Some(r),
                format!(
                    "names no joint for {0} and none was recognised; add {0} = \"...\" under [roles]",
                    r.as_str()
                ),
            )
        })
    };
    const LEGS: [[Role; 3]; 2] = [
        [Role::ThighL, Role::ShinL, Role::FootL],
        [Role::ThighR, Role::ShinR, Role::FootR],
    ];
    const ARMS: [[Role; 3]; 2] = [
        [Role::UpperArmL, Role::ForearmL, Role::HandL],
        [Role::UpperArmR, Role::ForearmR, Role::HandR],
    ];
    let mut legs = Vec::new();
    let mut arms = Vec::new();
    for s in 0..2 {
        for (limbs, claimed, roles) in [
            (&mut legs, c.legs[s], LEGS[s]),
            (&mut arms, c.arms[s], ARMS[s]),
        ] {
            let upper = need(claimed[0], roles[0])?;
            let lower = need(claimed[1], roles[1])?;
            if !rig.is_ancestor(upper, lower) {
                return Err((
                    Some(roles[1]),
                    format!(
                        "{} does not hang from {} ({}) in the skeleton, so no joint links them",
                        name(lower),
                        name(upper),
                        roles[0].as_str()
                    ),
                ));
            }
            limbs.push(confirm::limb(rig, upper, lower, claimed[2]));
        }
        let (thigh, shin) = (legs[s].upper, legs[s].lower);
        if rig.pos[shin].y >= rig.pos[thigh].y {
            return Err((
                Some(LEGS[s][1]),
                format!(
                    "the knee {} is not below the hip {} in the {pose}",
                    name(shin),
                    name(thigh)
                ),
            ));
        }
    }
    let pelvis = need(c.pelvis, Role::Pelvis)?;
    let chest = need(c.chest, Role::Chest)?;
    if !rig.is_ancestor(pelvis, chest) {
        return Err((
            Some(Role::Chest),
            format!(
                "{} does not rise from the pelvis {} in the skeleton",
                name(chest),
                name(pelvis)
            ),
        ));
    }
    let across = |a: [usize; 2], b: [usize; 2]| {
        horizontal((rig.pos[a[0]] + rig.pos[a[1]] - rig.pos[b[0]] - rig.pos[b[1]]) * 0.5)
    };
    let legs_across = across(
        [legs[0].upper, legs[0].lower],
        [legs[1].upper, legs[1].lower],
    );
    let arms_across = across(
        [arms[0].upper, arms[0].lower],
        [arms[1].upper, arms[1].lower],
    );
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
    let sides = |s: usize| [legs[s].upper, legs[s].lower, arms[s].upper, arms[s].lower];
    let forward = forward_from_sides(rig, &sides(0), &sides(1))
        .unwrap_or_else(|| legs_across.normalize_or(Vec3::X).cross(Vec3::Y));
    let (Ok(legs), Ok(arms)) = (<[_; 2]>::try_from(legs), <[_; 2]>::try_from(arms)) else {
        return Err((None, "not two legs and two arms".into()));
    };
    let h = Humanoid {
        pelvis,
        spine: c.spine.filter(|&s| s != chest && s != pelvis),
        chest,
        neck: c.neck.filter(|&n| Some(n) != c.head && n != chest),
        head: c.head,
        legs,
        arms,
        forward,
    };
    let mut seen: HashMap<usize, Role> = HashMap::new();
    for (j, r) in h.assignments() {
        if ignored[j] {
            return Err((
                Some(r),
                format!(
                    "{} is listed in ignore, but the {} needs it",
                    name(j),
                    r.as_str()
                ),
            ));
        }
        if let Some(other) = seen.insert(j, r) {
            return Err((
                Some(r),
                format!(
                    "{} would carry both {} and {}; name each of them under [roles]",
                    name(j),
                    other.as_str(),
                    r.as_str()
                ),
            ));
        }
    }
    Ok(h)
}
