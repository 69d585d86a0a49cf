//! A `[[character]]` table's files: the character file with its import keys (`units`,
//! `up`, `height`, `clip`) and its roles file, each path relative to the scene's folder.
//! A crowd of one file is read once, and so is a roles file many characters share.

use std::path::{Path, PathBuf};

use super::characters::character_bytes;
use super::parse::{Ctx, span_of};
use super::raw::{RawCharacter, S};
use crate::error::{Error, Result};
use crate::import::{self, ImportOptions};
use crate::skeleton::{self, Character};
use crate::spec::RoleFile;

/// The files already read for one scene.
#[derive(Default)]
pub(super) struct Files {
    /// Characters by path and options, with their size in bytes.
    characters: Vec<((PathBuf, ImportOptions), Character, u64)>,
    /// Roles files by path.
    roles: Vec<(PathBuf, RoleFile)>,
}

/// The import keys of a table, refused where they cannot apply: only `height` to the
/// built-in humanoid, which is no file; `up` not to glTF or VRM, which are Y up by
/// definition.
fn import_options(c: &Ctx, r: &RawCharacter) -> Result<ImportOptions> {
    let keys = [
        ("units", span_of(&r.units)),
        ("up", span_of(&r.up)),
        ("height", span_of(&r.height)),
        ("clip", span_of(&r.clip)),
    ];
    match &r.file {
        None => {
            for (key, span) in keys.into_iter().filter(|(key, _)| *key != "height") {
                c.refuse(
                    key,
                    span,
                    "the built-in humanoid is not a file; this key applies to character files (BVH, glTF, VRM, OBJ)",
                )?;
            }
        }
        Some(f) if import::is_gltf(Path::new(f.get_ref())) => c.refuse(
            "up",
            span_of(&r.up),
            "glTF is Y up by definition; up applies to BVH and OBJ files",
        )?,
        Some(_) => {}
    }
    Ok(ImportOptions {
        units: r.units.as_ref().map(|u| *u.get_ref()),
        up: r.up.as_ref().map(|u| *u.get_ref()),
        height_m: r.height.as_ref().map(|h| *h.get_ref()),
        clip: r.clip.as_ref().map(|k| k.get_ref().0.clone()),
    })
}

impl Files {
    /// The character a table names (its file, relative to the scene's folder, or the
    /// built-in humanoid), how to name its input in the report, and its size in bytes.
    pub(super) fn character(
        &mut self,
        c: &Ctx,
        r: &RawCharacter,
        dir: &Path,
    ) -> Result<(Character, String, u64)> {
        let opts = import_options(c, r)?;
        let Some(f) = &r.file else {
            let ch = match (&r.height, opts.height_m) {
                (Some(given), Some(h)) => {
                    let mut scaled = None;
                    let made = import::humanoid_of_height(h).map(|ch| scaled = Some(ch));
                    c.valid(&given.span(), made)?;
                    scaled.unwrap_or_else(skeleton::humanoid)
                }
                _ => skeleton::humanoid(),
            };
            let bytes = character_bytes(&ch);
            return Ok((ch, "built-in".to_string(), bytes));
        };
        let path = regular_file(c, f, dir, r.file_key)?;
        let key = (path, opts);
        if let Some((_, ch, bytes)) = self.characters.iter().find(|(k, _, _)| *k == key) {
            return Ok((ch.clone(), f.get_ref().clone(), *bytes));
        }
        let ch = import::load(&key.0, &key.1).map_err(|e| import_error(c, r, f, e))?;
        let bytes = character_bytes(&ch);
        self.characters.push((key, ch.clone(), bytes));
        Ok((ch, f.get_ref().clone(), bytes))
    }

    /// The roles file a table names, if any.
    pub(super) fn roles(
        &mut self,
        c: &Ctx,
        r: &RawCharacter,
        dir: &Path,
    ) -> Result<Option<RoleFile>> {
        let Some(name) = &r.roles else {
            return Ok(None);
        };
        let path = regular_file(c, name, dir, "roles")?;
        if let Some((_, file)) = self.roles.iter().find(|(p, _)| *p == path) {
            return Ok(Some(file.clone()));
        }
        let file = RoleFile::load(&path).map_err(|e| c.err(&name.span(), "roles", e))?;
        self.roles.push((path, file.clone()));
        Ok(Some(file))
    }
}

/// An import error at the key it is about: `height` and `clip` name their own values (the
/// library names the setting, or the clip asked for), anything else is the file's.
fn import_error(c: &Ctx, r: &RawCharacter, f: &S<String>, e: Error) -> Error {
    match (e, &r.height, &r.clip) {
        (Error::Setting { setting, message }, Some(h), _) if setting == "height" => {
            c.err(&h.span(), "height", message)
        }
        (Error::NoSuchClip { asked, message, .. }, _, Some(k)) => c.err(
            &k.span(),
            "clip",
            format!("{}: {asked}: {message}", f.get_ref()),
        ),
        (e, _, _) => c.err(&f.span(), r.file_key, e),
    }
}

/// A file a table names, relative to the scene's folder (an absolute path as it is),
/// which must be a regular file: a FIFO would block the reader forever and a device such
/// as `/dev/zero` never ends.
pub(super) fn regular_file(c: &Ctx, name: &S<String>, dir: &Path, key: &str) -> Result<PathBuf> {
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
