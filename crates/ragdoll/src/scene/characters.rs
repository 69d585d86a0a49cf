//! The `[[character]]` tables: each character's file loaded (relative to the scene file),
//! its ragdoll built or read, its placement, activation and motors checked.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use super::SceneCharacter;
use super::parse::{Ctx, Src, span_of};
use super::raw::{RawCharacter, RawPowered, S};
use crate::error::{Error, Result};
use crate::import::{self, ImportOptions};
use crate::skeleton::{self, Character};
use crate::spec::{self, BuildOptions, RagdollSpec, check_above, check_within};
use crate::world::{Activation, Motors};

/// Largest total mass of a character given as `mass_kg`, kilograms: ten of the heaviest
/// bodies a spec may hold ([`spec::MAX_BODY_KG`]); the ragdoll built from it is then
/// checked body by body.
pub const MAX_CHARACTER_KG: f32 = 1e9;

/// Largest turn of a character, degrees, either way: a full turn (any facing is within
/// it; larger numbers are typing mistakes).
pub const MAX_FACING_DEG: f32 = 360.0;

/// Longest character name, bytes: it names the character's BVH file.
pub const MAX_CHARACTER_NAME_BYTES: usize = 64;

/// A name safe as a file name on every system (it names the character's BVH file).
pub(super) fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_CHARACTER_NAME_BYTES
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.'))
}

/// Names given in the file, checked (safe, unique up to case), lowercased, so default
/// names can step around them.
fn explicit_names(src: &Src, raw: &[S<RawCharacter>]) -> Result<HashSet<String>> {
    let mut taken = HashSet::new();
    for (i, rc) in raw.iter().enumerate() {
        let Some(n) = &rc.get_ref().name else {
            continue;
        };
        let c = Ctx::new(src, format!("[[character]] {}", i + 1));
        if !valid_name(n.get_ref()) {
            return Err(c.err(
                &n.span(),
                "name",
                format!(
                    "\"{}\" must be 1 to {MAX_CHARACTER_NAME_BYTES} letters, digits, '_', '-' or '.' (not first), as it names a file",
                    n.get_ref()
                ),
            ));
        }
        if !taken.insert(n.get_ref().to_lowercase()) {
            return Err(c.err(
                &n.span(),
                "name",
                format!(
                    "two characters are named \"{}\" (names must differ by more than case: they name files)",
                    n.get_ref()
                ),
            ));
        }
    }
    Ok(taken)
}

/// Characters already loaded, by path and options: a crowd of one file is read once.
type Cache = Vec<((PathBuf, ImportOptions), Character)>;

/// The character a table names (its file, relative to the scene's folder, or the
/// built-in humanoid) and how to name its input in the report.
fn load(c: &Ctx, r: &RawCharacter, dir: &Path, cache: &mut Cache) -> Result<(Character, String)> {
    let is_bvh = r.file.as_ref().is_some_and(|f| {
        Path::new(f.get_ref())
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("bvh"))
    });
    if !is_bvh {
        c.refuse("units", span_of(&r.units), "applies to BVH files only")?;
        c.refuse("up", span_of(&r.up), "applies to BVH files only")?;
    }
    let opts = ImportOptions {
        units: r.units.as_ref().map(|u| *u.get_ref()),
        up: r.up.as_ref().map(|u| *u.get_ref()),
    };
    let Some(f) = &r.file else {
        return Ok((skeleton::humanoid(), "built-in".to_string()));
    };
    let path = regular_file(c, f, dir, "file")?;
    let key = (path, opts);
    if let Some((_, ch)) = cache.iter().find(|(k, _)| *k == key) {
        return Ok((ch.clone(), f.get_ref().clone()));
    }
    let ch = import::load(&key.0, &opts).map_err(|e| c.err(&f.span(), "file", e))?;
    cache.push((key, ch.clone()));
    Ok((ch, f.get_ref().clone()))
}

/// A file a table names, relative to the scene's folder (an absolute path as it is),
/// which must be a regular file: a FIFO would block the reader forever and a device such
/// as `/dev/zero` never ends.
fn regular_file(c: &Ctx, name: &S<String>, dir: &Path, key: &str) -> Result<PathBuf> {
    if name.get_ref().trim().is_empty() {
        return Err(c.err(&name.span(), key, "must name a file"));
    }
    let path = dir.join(name.get_ref());
    match std::fs::metadata(&path) {
        Ok(m) if m.is_file() => Ok(path),
        Ok(_) => Err(c.err(
            &name.span(),
            key,
            format!(
                "{} is not a regular file (a folder, device or FIFO), so it is not read",
                path.display()
            ),
        )),
        Err(e) => Err(c.err(&name.span(), key, Error::io(&path, e))),
    }
}

/// The character's ragdoll: read from its `spec` file, or built from the character with
/// the table's `mass_kg` and `female`.
fn ragdoll(
    c: &Ctx,
    r: &RawCharacter,
    rc: &S<RawCharacter>,
    character: &Character,
    dir: &Path,
) -> Result<RagdollSpec> {
    let mass = match &r.mass_kg {
        Some(m) => Some(c.checked(m, "mass_kg", |m| {
            check_above(m, 0.0, MAX_CHARACTER_KG, " kg")
        })?),
        None => None,
    };
    let female = r.female.as_ref().is_some_and(|f| *f.get_ref());
    match &r.spec {
        Some(s) => {
            let why = "set it in the spec file instead (masses are per body there)";
            c.refuse("mass_kg", span_of(&r.mass_kg), why)?;
            c.refuse("female", span_of(&r.female), why)?;
            let path = regular_file(c, s, dir, "spec")?;
            RagdollSpec::load(&path).map_err(|e| c.err(&s.span(), "spec", e))
        }
        None => spec::build_spec(
            character,
            &BuildOptions {
                total_mass_kg: mass,
                female,
            },
        )
        .map_err(|e| c.err(&rc.span(), "ragdoll", e)),
    }
}

/// Joint motors from `powered = { strength, fade_out, root_on_clip }`.
fn powered(c: &Ctx, p: &S<RawPowered>, character: &Character) -> Result<Motors> {
    let raw = p.get_ref();
    let mut motors = match raw.fade_out {
        Some([start, end]) => Motors::fade_out(raw.strength, start, end),
        None => Motors::constant(raw.strength),
    };
    motors.root_on_clip = raw.root_on_clip.unwrap_or(false);
    if let Err(Error::Setting { message, .. }) = motors.validate() {
        return Err(c.err(&p.span(), "powered", message));
    }
    if !character.clips.iter().any(|clip| !clip.frames.is_empty()) {
        return Err(c.err(
            &p.span(),
            "powered",
            "the character has no animation for the motors to track",
        ));
    }
    Ok(motors)
}

/// A default name: the character's own (when it is a safe file name) or `character`,
/// with `_2`, `_3`... until it is free.
fn default_name(character: &Character, taken: &mut HashSet<String>) -> String {
    let base = if valid_name(&character.name) {
        character.name.clone()
    } else {
        "character".to_string()
    };
    let mut name = base.clone();
    let mut k = 2;
    while taken.contains(&name.to_lowercase()) {
        name = format!("{base}_{k}");
        k += 1;
    }
    taken.insert(name.to_lowercase());
    name
}

/// Every `[[character]]` table, loaded and checked, in file order.
pub(super) fn characters(src: &Src, raw: &[S<RawCharacter>]) -> Result<Vec<SceneCharacter>> {
    let dir = src.path.parent().unwrap_or(Path::new(""));
    let mut taken = explicit_names(src, raw)?;
    let mut cache = Cache::new();
    let mut out = Vec::with_capacity(raw.len());
    for (i, rc) in raw.iter().enumerate() {
        let r = rc.get_ref();
        let mut c = Ctx::new(src, format!("[[character]] {}", i + 1));
        let (mut character, input) = load(&c, r, dir, &mut cache)?;
        let name = match &r.name {
            Some(n) => n.get_ref().clone(),
            None => default_name(&character, &mut taken),
        };
        c.place = format!("[[character]] \"{name}\"");
        character.name = name.clone();
        let mut spec = ragdoll(&c, r, rc, &character, dir)?;
        spec.name = name.clone();
        let position = match &r.position {
            Some(p) => c.point(p, "position")?,
            None => glam::Vec3::ZERO,
        };
        let facing_deg = c.opt_checked(&r.facing_deg, "facing_deg", 0.0, |a| {
            check_within(a, -MAX_FACING_DEG, MAX_FACING_DEG, " degrees")
        })?;
        let activation = r
            .activate
            .as_ref()
            .map_or(Activation::Immediately, |a| a.get_ref().0);
        if activation != Activation::Immediately
            && let Some(a) = &r.activate
            && !character.clips.iter().any(|clip| !clip.frames.is_empty())
        {
            return Err(c.err(
                &a.span(),
                "activate",
                format!(
                    "{} has no animation to play before physics takes over; use \"start\"",
                    if r.file.is_none() {
                        "the built-in humanoid"
                    } else {
                        input.as_str()
                    }
                ),
            ));
        }
        let motors = match &r.powered {
            Some(p) => Some(powered(&c, p, &character)?),
            None => None,
        };
        out.push(SceneCharacter {
            name,
            input,
            character,
            spec,
            position,
            facing_deg,
            activation,
            motors,
            line: src.line(rc.span().start),
        });
    }
    Ok(out)
}
