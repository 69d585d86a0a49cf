//! The `[[character]]` tables: each character's file loaded (relative to the scene file),
//! its ragdoll built or read, its placement, activation and motors checked.

use std::collections::HashSet;
use std::path::Path;

use super::SceneCharacter;
use super::load::{Files, regular_file};
use super::parse::{Ctx, span_of};
use super::raw::{RawCharacter, RawPowered, S};
use super::source::Src;
use crate::error::{Error, Result};
use crate::skeleton::{Character, Source};
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

/// Most bytes of character data one scene holds, every character's copy counted (meshes,
/// clips, a glTF's JSON and buffers): 1 GiB.
///
/// Each character owns its copy of its file's data (the world names and moves each one),
/// so a crowd of one 50 MB glTF would need 50 GB; the bound refuses such a crowd before
/// the copies are made. Measured: a CesiumMan holds 0.7 MB, the Fox 0.4 MB, a mocap take
/// 1 to 2.4 MB, the built-in humanoid 2 kB.
pub const MAX_SCENE_CHARACTER_BYTES: u64 = 1 << 30;

/// About how many bytes a character holds in memory.
pub fn character_bytes(c: &Character) -> u64 {
    let transform = std::mem::size_of::<crate::math::Transform>() as u64;
    let meshes: u64 = c
        .meshes
        .iter()
        .map(|m| {
            (m.positions.len() + m.normals.len()) as u64 * 12
                + m.joints.len() as u64 * 8
                + m.weights.len() as u64 * 16
                + m.indices.len() as u64 * 4
        })
        .sum();
    let clips: u64 = c
        .clips
        .iter()
        .flat_map(|k| &k.frames)
        .map(|f| f.len() as u64 * transform)
        .sum();
    let source = match &c.source {
        Source::Gltf(g) => {
            let mut counter = ByteCounter(0);
            // Writing to a counter cannot fail; a failure would only undercount.
            let _ = serde_json::to_writer(&mut counter, &g.json);
            counter.0 + g.buffers.iter().map(|b| b.len() as u64).sum::<u64>()
        }
        _ => 0,
    };
    meshes + clips + c.skeleton.len() as u64 * (transform + 64) + source
}

/// Counts the bytes written to it.
struct ByteCounter(u64);

impl std::io::Write for ByteCounter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0 += buf.len() as u64;
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// A name safe as a file name on every system (it names the character's BVH file).
pub(super) fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_CHARACTER_NAME_BYTES
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.'))
}

/// The table a character comes from, to name it in errors: its own `[[character]]`, or
/// the `[[crowd]]` it is one of (indices from 0).
#[derive(Clone, Copy, Debug)]
pub(super) enum Table {
    Character(usize),
    Crowd(usize),
}

impl Table {
    /// The table, before the character has a name.
    fn place(self) -> String {
        match self {
            Table::Character(i) => format!("[[character]] {}", i + 1),
            Table::Crowd(i) => format!("[[crowd]] {}", i + 1),
        }
    }

    /// The character by name, and the crowd it belongs to.
    fn named(self, name: &str) -> String {
        match self {
            Table::Character(_) => format!("[[character]] \"{name}\""),
            Table::Crowd(i) => format!("[[crowd]] {} \"{name}\"", i + 1),
        }
    }
}

/// Names given in the file, checked (safe, unique up to case), lowercased, so default
/// names can step around them.
fn explicit_names(src: &Src, raw: &[S<RawCharacter>], tables: &[Table]) -> Result<HashSet<String>> {
    let mut taken = HashSet::new();
    for (rc, table) in raw.iter().zip(tables) {
        let Some(n) = &rc.get_ref().name else {
            continue;
        };
        let c = Ctx::new(src, table.place());
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

/// The character's ragdoll: read from its `spec` file, or built from the character with
/// the table's `mass_kg`, `female` and `roles`. A built ragdoll's roles warning (names
/// that promise a humanoid the skeleton denies) joins the character's warnings, which
/// tools show the user as they do for a lone character.
fn ragdoll(
    c: &Ctx,
    r: &RawCharacter,
    rc: &S<RawCharacter>,
    character: &mut Character,
    files: &mut Files,
    dir: &Path,
) -> Result<RagdollSpec> {
    let mass = match &r.mass_kg {
        Some(m) => Some(c.checked(m, "mass_kg", |m| {
            check_above(m, 0.0, MAX_CHARACTER_KG, " kg")
        })?),
        None => None,
    };
    let female = r.female.as_ref().is_some_and(|f| *f.get_ref());
    if let Some(s) = &r.spec {
        let why = "set it in the spec file instead (masses are per body there)";
        c.refuse("mass_kg", span_of(&r.mass_kg), why)?;
        c.refuse("female", span_of(&r.female), why)?;
        c.refuse(
            "roles",
            span_of(&r.roles),
            "the spec file already says which joint each body rides on",
        )?;
        let path = regular_file(c, s, dir, "spec")?;
        return RagdollSpec::load(&path).map_err(|e| c.err(&s.span(), "spec", e));
    }
    let roles = files.roles(c, r, dir)?;
    let roles = roles.as_ref();
    let found = spec::roles_for(character, roles).map_err(|e| match &r.roles {
        Some(k) => c.err(&k.span(), "roles", e),
        None => c.err(&rc.span(), "ragdoll", e),
    })?;
    if r.file.is_some()
        && let Some(w) = found.warning
    {
        character.warnings.push(w);
    }
    spec::build_spec_with_roles(
        character,
        &BuildOptions {
            total_mass_kg: mass,
            female,
        },
        roles,
    )
    .map_err(|e| c.err(&rc.span(), "ragdoll", e))
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

/// A character name that is free in `taken` (names lower-cased, as files on some systems
/// are): `wanted` when it is a safe file name, else `character`, with `_2`, `_3`... until
/// it is free; it is then taken. Scenes name characters without a `name` key this way,
/// from their file's name, and so do worlds built in code.
pub fn unique_character_name(wanted: &str, taken: &mut HashSet<String>) -> String {
    let base = if valid_name(wanted) {
        wanted.to_string()
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

/// Every character table (`[[character]]` tables and the crowds' members, each from
/// `tables`), loaded and checked, in order.
pub(super) fn characters(
    src: &Src,
    raw: &[S<RawCharacter>],
    tables: &[Table],
) -> Result<Vec<SceneCharacter>> {
    characters_within(src, raw, tables, MAX_SCENE_CHARACTER_BYTES)
}

/// [`characters`], holding at most `budget` bytes of character data.
fn characters_within(
    src: &Src,
    raw: &[S<RawCharacter>],
    tables: &[Table],
    budget: u64,
) -> Result<Vec<SceneCharacter>> {
    let dir = src.path.parent().unwrap_or(Path::new(""));
    let mut taken = explicit_names(src, raw, tables)?;
    let mut files = Files::default();
    let mut out = Vec::with_capacity(raw.len());
    let mut held = 0u64;
    for (rc, &table) in raw.iter().zip(tables) {
        let r = rc.get_ref();
        let mut c = Ctx::new(src, table.place());
        let (mut character, input, bytes) = files.character(&c, r, dir)?;
        held += bytes;
        if held > budget {
            let key = if r.file.is_some() {
                "file"
            } else {
                "character"
            };
            return Err(c.err(&rc.span(), key, over_budget(held, budget)));
        }
        let name = match &r.name {
            Some(n) => n.get_ref().clone(),
            None => unique_character_name(&character.name, &mut taken),
        };
        c.place = table.named(&name);
        character.name = name.clone();
        let mut spec = ragdoll(&c, r, rc, &mut character, &mut files, dir)?;
        spec.name = name.clone();
        let position = match &r.position {
            Some(p) => c.point(p, "position")?,
            None => glam::Vec3::ZERO,
        };
        let facing_deg = c.opt_checked(&r.facing_deg, "facing_deg", 0.0, |a| {
            check_within(a, -MAX_FACING_DEG, MAX_FACING_DEG, " degrees")
        })?;
        let activation = activation_of(&c, r, &character, &input)?;
        let motors = match &r.powered {
            Some(p) => Some(powered(&c, p, &character)?),
            None => None,
        };
        let clip_offset_s = clip_offset_of(&c, r, activation, motors.is_some())?;
        let place = table.named(&name);
        out.push(SceneCharacter {
            name,
            input,
            character,
            spec,
            position,
            facing_deg,
            activation,
            clip_offset_s,
            motors,
            line: src.line(rc.span().start),
            place,
        });
    }
    Ok(out)
}

/// Why a scene's characters are refused for the data they would hold.
fn over_budget(held: u64, budget: u64) -> String {
    format!(
        "the scene's characters would hold {} MiB of data, more than the {} MiB a scene may \
         (each character keeps its own copy of its file's meshes, clips and buffers): use \
         fewer or lighter characters",
        held >> 20,
        budget >> 20
    )
}

/// When the character's physics takes over; refused for a clip hand-over where the
/// character (`input`) has no animation to play.
fn activation_of(
    c: &Ctx,
    r: &RawCharacter,
    character: &Character,
    input: &str,
) -> Result<Activation> {
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
                    input
                }
            ),
        ));
    }
    Ok(activation)
}

/// Where in its clip the character starts, seconds; refused where it plays no clip
/// (activated at once and not powered).
fn clip_offset_of(c: &Ctx, r: &RawCharacter, activation: Activation, powered: bool) -> Result<f32> {
    let clip_offset_s = c.time(&r.clip_offset_s, "clip_offset_s", 0.0)?;
    if let Some(v) = &r.clip_offset_s
        && activation == Activation::Immediately
        && !powered
    {
        let message = "needs activate or powered: only then does the character play its clip";
        return Err(c.err(&v.span(), "clip_offset_s", message));
    }
    Ok(clip_offset_s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The copies are counted as they are made: the third humanoid of a budget of two and a
    /// half is refused at its own table.
    #[test]
    fn a_crowd_past_the_data_budget_is_refused_at_the_first_character_too_many() {
        let text = "[[character]]\n[[character]]\n[[character]]\n";
        let src = Src {
            path: Path::new("crowd.toml"),
            text,
        };
        let raw: super::super::raw::RawScene = toml::from_str(text).unwrap();
        let one = character_bytes(&crate::skeleton::humanoid());
        assert!(one > 1000, "{one}");
        let tables: Vec<Table> = (0..3).map(Table::Character).collect();
        assert!(characters_within(&src, &raw.character, &tables, 3 * one).is_ok());
        match characters_within(&src, &raw.character, &tables, 5 * one / 2) {
            Err(Error::Parse { line, message, .. }) => {
                assert_eq!(line, 3, "{message}");
                assert!(message.contains("[[character]] 3") && message.contains("MiB"));
            }
            other => panic!("expected the third character refused, got {other:?}"),
        }
    }
}
