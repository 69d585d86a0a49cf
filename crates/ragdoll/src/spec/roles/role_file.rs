//! Reading a roles file (`--roles FILE.toml`, a scene character's `roles = "..."`): each
//! role with the joint it names and the joints to ignore, every one with its line, so
//! what `manual.rs` refuses while applying it names the place. The format:
//!
//! ```toml
//! ignore = ["l-LEGCONTROL", "MASTER"]   # joints that get no body (helpers); optional
//!
//! [roles]                               # role = "joint name", as `ragdoll inspect` prints
//! pelvis = "Hips"
//! thigh_l = "LeftUpLeg"
//! shin_l = "LeftLeg"
//! ```

use std::path::{Path, PathBuf};

use toml::de::{DeTable, DeValue};

use super::{HUMANOID_ROLES, Role};
use crate::error::{Error, Result};

/// Most entries (roles plus ignored joints) a roles file holds: a skeleton rarely has a
/// thousand joints, and each entry is looked up once, so the bound only stops a runaway
/// generated file.
pub const MAX_ROLE_FILE_ENTRIES: usize = 100_000;

/// A roles file as read: each role with its joint name, and the joints to ignore, every
/// one with the line it is written on.
#[derive(Clone, Debug, PartialEq)]
pub struct RoleFile {
    pub(super) path: PathBuf,
    /// The line of the `[roles]` header (or 1), where a missing role is reported.
    pub(super) roles_line: usize,
    pub(super) entries: Vec<Entry>,
}

#[derive(Clone, Debug, PartialEq)]
pub(super) struct Entry {
    /// `None`: listed in `ignore`.
    pub(super) role: Option<Role>,
    pub(super) joint: String,
    pub(super) line: usize,
}

impl Entry {
    pub(super) fn key(&self) -> &'static str {
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
        let mut r = Reader {
            text,
            file: RoleFile {
                path: path.to_path_buf(),
                roles_line: 1,
                entries: Vec::new(),
            },
        };
        let doc = DeTable::parse(text).map_err(|e| {
            let pos = e.span().map_or(0, |s| s.start);
            r.err(pos, parse_message(text, pos, e.message()))
        })?;
        for (k, v) in doc.get_ref() {
            match (k.get_ref().as_ref(), v.get_ref()) {
                ("roles", DeValue::Table(t)) => {
                    r.file.roles_line = crate::spec::line_at(text, k.span().start);
                    r.roles_table(t)?;
                }
                ("roles", other) => {
                    return Err(r.err(
                        k.span().start,
                        format!(
                            "roles: must be a table ([roles]), not a {}",
                            other.type_str()
                        ),
                    ));
                }
                ("ignore", _) => r.ignore_list(v)?,
                (key, _) => {
                    return Err(r.err(
                        k.span().start,
                        format!(
                            "{key}: unknown key; a roles file holds a [roles] table and an ignore list"
                        ),
                    ));
                }
            }
        }
        let mut file = r.file;
        if file.entries.is_empty() {
            return Err(Error::Parse {
                path: file.path,
                line: crate::spec::line_at(text, 0),
                message:
                    "names no role and ignores no joint; write role = \"joint\" lines under [roles]"
                        .into(),
            });
        }
        file.entries.sort_by_key(|e| e.line);
        Ok(file)
    }

    /// The file it was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    pub(super) fn err(&self, line: usize, key: &str, message: impl std::fmt::Display) -> Error {
        Error::Parse {
            path: self.path.clone(),
            line,
            message: format!("{key}: {message}"),
        }
    }
}

/// Reads a roles file's TOML into a [`RoleFile`]; errors name the file and the line.
struct Reader<'t> {
    text: &'t str,
    file: RoleFile,
}

impl Reader<'_> {
    fn err(&self, pos: usize, message: String) -> Error {
        Error::Parse {
            path: self.file.path.clone(),
            line: crate::spec::line_at(self.text, pos),
            message,
        }
    }

    /// Adds an entry that keeps the line of `pos`, where errors about it point.
    fn push(&mut self, role: Option<Role>, joint: String, pos: usize) -> Result<()> {
        if self.file.entries.len() >= MAX_ROLE_FILE_ENTRIES {
            return Err(self.err(
                pos,
                format!("a roles file holds at most {MAX_ROLE_FILE_ENTRIES} entries"),
            ));
        }
        let line = crate::spec::line_at(self.text, pos);
        self.file.entries.push(Entry { role, joint, line });
        Ok(())
    }

    /// An `ignore` list, at the top level or under `[roles]`.
    fn ignore_list(&mut self, v: &toml::Spanned<DeValue>) -> Result<()> {
        for (joint, pos) in joint_list(v, |m| self.err(v.span().start, m))? {
            self.push(None, joint, pos)?;
        }
        Ok(())
    }

    /// The `[roles]` table: `role = "joint"` lines and an `ignore` list.
    fn roles_table(&mut self, t: &DeTable) -> Result<()> {
        for (rk, rv) in t {
            let key = rk.get_ref().as_ref();
            if key == "ignore" {
                self.ignore_list(rv)?;
                continue;
            }
            let role = HUMANOID_ROLES
                .iter()
                .copied()
                .find(|r| r.as_str() == key)
                .ok_or_else(|| {
                    self.err(
                        rk.span().start,
                        format!("{key}: not a role; {}", role_names()),
                    )
                })?;
            let DeValue::String(joint) = rv.get_ref() else {
                return Err(self.err(
                    rv.span().start,
                    format!(
                        "{key}: must be a joint name in quotes, not a {}",
                        rv.get_ref().type_str()
                    ),
                ));
            };
            self.push(Some(role), joint.to_string(), rk.span().start)?;
        }
        Ok(())
    }
}

/// toml's message for a parse error at byte `pos`, on one line; a repeated key is named,
/// with why it matters here (toml names neither).
fn parse_message(text: &str, pos: usize, message: &str) -> String {
    let message = message.trim().replace('\n', " ");
    if message != "duplicate key" {
        return message;
    }
    let before = text.get(..pos).unwrap_or("");
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    let key = text
        .get(start..)
        .unwrap_or("")
        .split(['=', '\n'])
        .next()
        .unwrap_or("")
        .trim();
    format!("{key}: given twice; each role names one joint")
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
