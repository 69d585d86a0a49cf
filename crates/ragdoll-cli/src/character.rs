//! A character from the command line: the file read with the import flags (or the
//! built-in humanoid), its roles (with a roles file if given), and the ragdoll built from
//! it or read from a spec, with import errors worded for the user. Every command that
//! takes a character goes through here.

use std::path::Path;

use anyhow::{Result, bail};
use ragdoll::import::{self, ClipChoice, ImportOptions, Units, UpAxis};
use ragdoll::skeleton::{self, Character};
use ragdoll::spec::{self, BuildOptions, RagdollSpec, RoleFile, Roles};

use crate::progress::Progress;
use crate::{ImportArgs, RagdollArgs, UnitsArg, UpArg, checks};

pub(crate) fn import_options(a: &ImportArgs) -> ImportOptions {
    ImportOptions {
        units: a.units.map(|u| match u {
            UnitsArg::M => Units::M,
            UnitsArg::Cm => Units::Cm,
            UnitsArg::Mm => Units::Mm,
            UnitsArg::In => Units::In,
        }),
        up: a.up.map(|u| match u {
            UpArg::Y => UpAxis::Y,
            UpArg::Z => UpAxis::Z,
        }),
        height_m: a.height,
        clip: a.clip.as_deref().map(ClipChoice::parse),
    }
}

/// Reads a character file, with a spinner when that takes more than a second.
pub(crate) fn load(file: &Path, a: &ImportArgs) -> Result<Character> {
    checks::import_flags(Some(file), a)?;
    let character = {
        let _progress = Progress::new(0, &format!("reading {}", file.display()));
        import::load(file, &import_options(a))
            .map_err(|e| naming(&file.display().to_string(), e, import_error))?
    };
    for w in &character.warnings {
        eprintln!("warning: {}", crate::printable::shown(w));
    }
    Ok(character)
}

/// The roles the ragdoll is built from: recognised, or with the `--roles` file. Names
/// that promise a humanoid the skeleton denies get a warning on every command that reads
/// a character (recognition is near-linear in joints), since the ragdoll will not be what
/// the user expects; `label` names the character in it.
pub(crate) fn roles(
    character: &Character,
    label: &str,
    a: &RagdollArgs,
) -> Result<(Roles, Option<RoleFile>)> {
    let file = match &a.roles {
        Some(path) => Some(RoleFile::load(path)?),
        None => None,
    };
    let roles = spec::roles_for(character, file.as_ref())?;
    if let Some(w) = &roles.warning {
        eprintln!(
            "warning: {}: {}",
            crate::printable::shown(label),
            crate::printable::shown(w)
        );
    }
    Ok((roles, file))
}

/// An import error, with `--height` or `--clip` named when it is about the flag's value
/// (the library names the setting, or the clip asked for).
pub(crate) fn import_error(e: ragdoll::Error) -> anyhow::Error {
    match e {
        ragdoll::Error::Setting { setting, message } => anyhow::anyhow!("--{setting}: {message}"),
        ragdoll::Error::NoSuchClip { .. } => anyhow::Error::new(e).context("--clip"),
        e => e.into(),
    }
}

/// `e` with the input it is about named in front, unless the error names a file itself:
/// the builder's and the skeleton's checks ("spec: body ...", "skeleton: joint ...") know
/// no file, and a user running a batch needs to know which one failed. `word` turns the
/// library's error into the CLI's (naming the flag it is about).
fn naming(
    input: &str,
    e: ragdoll::Error,
    word: fn(ragdoll::Error) -> anyhow::Error,
) -> anyhow::Error {
    if e.path().is_some() {
        word(e)
    } else {
        word(e).context(input.to_string())
    }
}

/// An error about the file `path`, named once: the library's parse errors already name it,
/// its spec checks do not.
pub(crate) fn in_file(path: &Path, e: ragdoll::Error) -> anyhow::Error {
    naming(&path.display().to_string(), e, anyhow::Error::new)
}

/// The spec from `--spec` (its masses scaled to `--mass` when given), or one built from
/// the character (with `--roles` when given); `label` names the character in warnings.
pub(crate) fn ragdoll_spec(
    character: &Character,
    label: &str,
    a: &RagdollArgs,
) -> Result<RagdollSpec> {
    Ok(ragdoll(character, label, a)?.0)
}

/// [`ragdoll_spec`], with the roles it was built from.
pub(crate) fn ragdoll(
    character: &Character,
    label: &str,
    a: &RagdollArgs,
) -> Result<(RagdollSpec, Roles)> {
    if let Some(m) = a.mass
        && !(m.is_finite() && m > 0.0)
    {
        bail!("--mass: the total mass must be a positive number of kilograms, not {m}");
    }
    let (roles, file) = roles(character, label, a)?;
    let Some(path) = &a.spec else {
        let opts = BuildOptions {
            total_mass_kg: a.mass,
            female: a.female,
        };
        let spec = spec::build_spec_with_roles(character, &opts, file.as_ref())
            .map_err(|e| naming(label, e, anyhow::Error::new))?;
        return Ok((spec, roles));
    };
    let mut spec = RagdollSpec::load(path).map_err(|e| in_file(path, e))?;
    if let Some(m) = a.mass {
        scale_masses(&mut spec, m);
        spec.validate().map_err(|e| in_file(path, e))?;
    }
    Ok((spec, roles))
}

/// Scales every body's mass by one factor so they add up to `total_kg`: the spec's mass
/// distribution (what the user edited) is kept, the total is what `--mass` says.
fn scale_masses(spec: &mut RagdollSpec, total_kg: f32) {
    let now = spec.total_mass_kg();
    if now > 0.0 && now.is_finite() {
        let factor = total_kg / now;
        for b in &mut spec.bodies {
            b.mass_kg *= factor;
        }
    }
}

/// The character from `file`, or the built-in humanoid; and how to name it in the report.
pub(crate) fn load_or_builtin(
    file: Option<&Path>,
    import: &ImportArgs,
) -> Result<(Character, String)> {
    Ok(match file {
        Some(file) => (load(file, import)?, file.display().to_string()),
        None => {
            checks::import_flags(None, import)?;
            (skeleton::humanoid(), "built-in".to_string())
        }
    })
}
