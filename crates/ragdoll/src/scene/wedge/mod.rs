//! Wedges: one scene file that stands for many variations of itself. A team rarely needs
//! one simulation of a shot; it asks for the charge moved, resized and delayed, the crowd
//! reseeded, each character tried, and picks the take that reads best. Writing each
//! variation by hand drifts; a `[wedge]` table names the keys to vary and how, and every
//! variant is the base scene with those values put in.
//!
//! ```toml
//! [wedge]
//! mode = "cross"                    # every combination; "zip" pairs the lists instead
//!
//! [[wedge.vary]]
//! key = "blast[0].tnt_kg"           # a key of the scene, tables indexed from 0
//! values = [0.5, 1.0, 2.0]
//!
//! [[wedge.vary]]
//! key = "blast[0].time_s"
//! range = { from = 0.2, to = 0.6, step = 0.2 }   # both ends included
//!
//! [[wedge.vary]]
//! key = "crowd[0].seed"
//! label = "seed"                    # its name in variant names (default: the last key)
//! random = { count = 4, min = 1, max = 1000, seed = 7 }   # integers when min and max are
//! ```
//!
//! The wedge acts on the TOML document before the scene is read, so any scalar or vector
//! key can vary, and each variant's scene is an ordinary scene file: running it with
//! `ragdoll simulate` gives what a farm gives. Random draws come from a seeded ChaCha8
//! generator (as crowds do), so a wedge gives the same variants on every machine. Names
//! are the variant's index, zero-padded so they sort, then `label=value` pairs, cleaned
//! to characters every file system takes: `07_tnt_kg=2_time_s=0.4`.
//!
//! ```no_run
//! use ragdoll::scene::{Scene, wedge::Wedge};
//! let wedge = Wedge::load("examples/wedge_crowd.toml".as_ref())?.expect("a [wedge] table");
//! for variant in wedge.variants() {
//!     // Written beside where it will run, its relative files rewritten for that folder.
//!     let dir = std::path::Path::new("out").join(&variant.name);
//!     std::fs::create_dir_all(&dir).map_err(|e| ragdoll::Error::io(&dir, e))?;
//!     let text = wedge.scene_text(&variant, &dir)?;
//!     let scene = Scene::from_toml(&text, &dir.join("scene.toml"))?;
//!     scene.write(&scene.run()?, &dir)?;
//! }
//! # Ok::<(), ragdoll::Error>(())
//! ```

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::{Spanned, Table, Value};

use crate::error::{Error, Result};
use files::{for_each_file, is_file_key, strings};
pub use files::{portable_path, relative_path};
use values::{RawRandom, RawRange, name_value, random, range};

mod files;
mod values;

/// Most variants one wedge makes: each is a simulation, and a plan lists them all.
pub const MAX_VARIANTS: usize = 100_000;

/// Most keys one wedge varies.
pub const MAX_WEDGE_KEYS: usize = 32;

/// Longest a value may be in a variant name, bytes; the index keeps shortened names unique.
const MAX_NAME_VALUE_BYTES: usize = 40;

/// How the lists of values combine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WedgeMode {
    /// Every combination: the product of the lists' lengths; the first key varies slowest.
    Cross,
    /// The lists side by side, which must be equally long: the n-th variant takes the n-th
    /// value of each.
    Zip,
}

impl WedgeMode {
    /// Its name in scene files: `cross` or `zip`.
    pub fn as_str(self) -> &'static str {
        match self {
            WedgeMode::Cross => "cross",
            WedgeMode::Zip => "zip",
        }
    }
}

/// One varied key.
#[derive(Clone, Debug)]
pub struct WedgeKey {
    /// The key as written, e.g. `blast[0].tnt_kg`.
    pub key: String,
    /// Its name in variant names and table columns.
    pub label: String,
    /// Its values, in order.
    pub values: Vec<Value>,
    path: Vec<Segment>,
}

/// A scene file's `[wedge]` table, expanded, with the base scene it varies.
#[derive(Clone, Debug)]
pub struct Wedge {
    /// The scene file (relative files in it are relative to its folder).
    pub path: PathBuf,
    /// How the keys' values combine.
    pub mode: WedgeMode,
    /// The varied keys, in file order.
    pub keys: Vec<WedgeKey>,
    base: Table,
    count: usize,
}

/// One variant: its place in the wedge, its name and the value of each varied key.
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// From 0, in wedge order.
    pub index: usize,
    /// Unique within the wedge, and a valid file name.
    pub name: String,
    /// `(key, value)` for each varied key, in the wedge's key order.
    pub values: Vec<(String, Value)>,
}

#[derive(Deserialize)]
struct RawDoc {
    wedge: Option<Spanned<RawWedge>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWedge {
    mode: Option<Spanned<WedgeMode>>,
    #[serde(default)]
    vary: Vec<Spanned<RawVary>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawVary {
    key: String,
    label: Option<String>,
    values: Option<Vec<Value>>,
    range: Option<RawRange>,
    random: Option<RawRandom>,
}

/// One step of a key path: a table key, then optionally an index into its array.
#[derive(Clone, Debug, PartialEq)]
struct Segment {
    name: String,
    index: Option<usize>,
}

impl Wedge {
    /// Reads a scene file's wedge; `None` when it has no `[wedge]` table.
    pub fn load(path: &Path) -> Result<Option<Wedge>> {
        let text = crate::files::read_text_capped(path, crate::files::MAX_SETTINGS_BYTES)?;
        Wedge::from_toml(&text, path)
    }

    /// Reads the wedge of a scene's TOML text; `path` names it in errors and anchors its
    /// relative files. Every key path must reach a table of the base scene (the last key
    /// may be missing from it), and a value must have the type of the one it replaces.
    ///
    /// ```
    /// use ragdoll::scene::wedge::Wedge;
    /// let text = r#"
    /// [[blast]]
    /// tnt_kg = 1.0
    /// position = [0.0, 0.5, 0.0]
    /// [[wedge.vary]]
    /// key = "blast[0].tnt_kg"
    /// values = [1.0, 2.0]
    /// [[wedge.vary]]
    /// key = "blast[0].time_s"
    /// range = { from = 0.0, to = 0.5, step = 0.25 }
    /// "#;
    /// let wedge = Wedge::from_toml(text, "shot.toml".as_ref())?.unwrap();
    /// assert_eq!(wedge.len(), 6);
    /// assert_eq!(wedge.variant(5).name, "5_tnt_kg=2_time_s=0.5");
    /// # Ok::<(), ragdoll::Error>(())
    /// ```
    pub fn from_toml(text: &str, path: &Path) -> Result<Option<Wedge>> {
        let at = |pos: usize, message: String| Error::Parse {
            path: path.to_path_buf(),
            line: crate::spec::line_at(text, pos),
            message,
        };
        // TOML syntax first, so a mistake anywhere in the file is not blamed on the wedge.
        let mut base: Table = text.parse().map_err(|e: toml::de::Error| {
            at(e.span().map_or(0, |s| s.start), e.message().trim().into())
        })?;
        let doc: RawDoc = toml::from_str(text).map_err(|e| {
            let pos = e.span().map_or(0, |s| s.start);
            at(pos, format!("[wedge]: {}", e.message().trim()))
        })?;
        let Some(raw) = doc.wedge else {
            return Ok(None);
        };
        base.remove("wedge");
        let wedge_pos = raw.span().start;
        let raw = raw.into_inner();
        let mode = raw.mode.map_or(WedgeMode::Cross, |m| m.into_inner());
        if raw.vary.is_empty() {
            return Err(at(
                wedge_pos,
                "[wedge]: has no [[wedge.vary]] tables".into(),
            ));
        }
        if raw.vary.len() > MAX_WEDGE_KEYS {
            return Err(at(
                wedge_pos,
                format!("[wedge]: varies more than {MAX_WEDGE_KEYS} keys"),
            ));
        }
        let mut keys: Vec<WedgeKey> = Vec::with_capacity(raw.vary.len());
        for (n, v) in raw.vary.into_iter().enumerate() {
            let pos = v.span().start;
            let place = format!("[[wedge.vary]] {}", n + 1);
            let key = vary_key(&base, v.into_inner(), &keys)
                .map_err(|m| at(pos, format!("{place}: {m}")))?;
            keys.push(key);
        }
        let count =
            variant_count(mode, &keys).map_err(|m| at(wedge_pos, format!("[wedge]: {m}")))?;
        Ok(Some(Wedge {
            path: path.to_path_buf(),
            mode,
            keys,
            base,
            count,
        }))
    }

    /// How many variants the wedge makes (at least one).
    pub fn len(&self) -> usize {
        self.count
    }

    /// Always false: a wedge with no variant is refused when read.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Variant `index` (below [`Wedge::len`]).
    pub fn variant(&self, index: usize) -> Variant {
        let mut rest = index;
        let mut picks = vec![0; self.keys.len()];
        match self.mode {
            WedgeMode::Zip => picks.iter_mut().for_each(|p| *p = index),
            WedgeMode::Cross => {
                for (p, k) in picks.iter_mut().zip(&self.keys).rev() {
                    *p = rest % k.values.len();
                    rest /= k.values.len();
                }
            }
        }
        let values: Vec<(String, Value)> = self
            .keys
            .iter()
            .zip(picks)
            .map(|(k, p)| (k.key.clone(), k.values[p].clone()))
            .collect();
        let width = (self.count.max(1) - 1).to_string().len();
        let mut name = format!("{index:0width$}");
        for (k, (_, v)) in self.keys.iter().zip(&values) {
            name.push_str(&format!("_{}={}", k.label, name_value(v)));
        }
        Variant {
            index,
            name,
            values,
        }
    }

    /// Variants that between them hold every value of every key, at most `cap` of them
    /// (evenly spread, the first and the last always among them), in order: what a tool
    /// loads to find a value the scene refuses without loading every combination. In a
    /// cross wedge variant `j` of the diagonal takes each key's `j`-th value (its last
    /// once a shorter key runs out), so the longest key's count of variants covers all.
    pub fn covering_variants(&self, cap: usize) -> Vec<usize> {
        let longest = self.keys.iter().map(|k| k.values.len()).max().unwrap_or(1);
        let diagonal = |j: usize| match self.mode {
            WedgeMode::Zip => j,
            WedgeMode::Cross => self.keys.iter().fold(0, |index, k| {
                index * k.values.len() + j.min(k.values.len() - 1)
            }),
        };
        let picks = cap.clamp(2, longest.max(2)).min(longest);
        let mut out: Vec<usize> = (0..picks)
            .map(|i| {
                diagonal(if picks > 1 {
                    i * (longest - 1) / (picks - 1)
                } else {
                    0
                })
            })
            .collect();
        out.dedup();
        out
    }

    /// Every variant, in order.
    pub fn variants(&self) -> impl Iterator<Item = Variant> + '_ {
        (0..self.count).map(|i| self.variant(i))
    }

    /// The variant called `name`, or its index given as a number.
    pub fn find(&self, name: &str) -> Option<Variant> {
        if let Ok(i) = name.parse::<usize>()
            && i < self.count
        {
            return Some(self.variant(i));
        }
        self.variants().find(|v| v.name == name)
    }

    /// The variant's scene as a TOML document: the base scene, the wedge's values put in,
    /// without the `[wedge]` table.
    pub fn scene_table(&self, variant: &Variant) -> Table {
        let mut table = self.base.clone();
        for (k, (_, v)) in self.keys.iter().zip(&variant.values) {
            // Every path was resolved against this same base when the wedge was read.
            let _ = set(&mut table, &k.path, v.clone());
        }
        table
    }

    /// The seeds of the variant's random generators: each crowd's `seed` (0 where the
    /// file leaves it out, as crowds do), by key. With the values, they pin down
    /// everything drawn at random in the variant.
    pub fn seeds(&self, variant: &Variant) -> Vec<(String, i64)> {
        let changed = self.keys.iter().any(|k| k.path[0].name == "crowd");
        let table = if changed {
            Cow::Owned(self.scene_table(variant))
        } else {
            Cow::Borrowed(&self.base)
        };
        let crowds = table.get("crowd").and_then(Value::as_array);
        crowds
            .into_iter()
            .flatten()
            .enumerate()
            .map(|(i, c)| {
                let seed = c.get("seed").and_then(Value::as_integer).unwrap_or(0);
                (format!("crowd[{i}].seed"), seed)
            })
            .collect()
    }

    /// The variant's scene as a file to be written into `dir`: [`Wedge::scene_table`]
    /// with every relative character, spec and roles file rewritten relative to `dir`, so
    /// the file reads the same files wherever it is written. Both folders must exist.
    pub fn scene_text(&self, variant: &Variant, dir: &Path) -> Result<String> {
        let mut table = self.scene_table(variant);
        let from = self.folder()?;
        let to = dir.canonicalize().map_err(|e| Error::io(dir, e))?;
        for_each_file(&mut table, |s| {
            let p = Path::new(s.as_str());
            if p.is_relative() {
                *s = portable_path(&relative_path(&from.join(p), &to));
            }
        });
        toml::to_string(&table).map_err(|e| Error::Refused {
            path: self.path.clone(),
            message: format!("variant {}: cannot be written as TOML: {e}", variant.name),
        })
    }

    /// Every file the scene and its variants read: the scene file itself, then each
    /// character, spec and roles file the base scene or a wedge value names, resolved
    /// against the scene's folder, each once, in first-named order.
    pub fn input_files(&self) -> Vec<PathBuf> {
        let dir = self.path.parent().unwrap_or(Path::new(""));
        let mut files = vec![self.path.clone()];
        let mut add = |s: &str| {
            let p = dir.join(s);
            if !files.contains(&p) {
                files.push(p);
            }
        };
        let mut base = self.base.clone();
        for_each_file(&mut base, |s| add(s));
        for k in &self.keys {
            if is_file_key(&k.path) {
                for v in &k.values {
                    for s in strings(v) {
                        add(s);
                    }
                }
            }
        }
        files
    }

    /// The scene file's folder, absolute.
    fn folder(&self) -> Result<PathBuf> {
        let dir = match self.path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        dir.canonicalize().map_err(|e| Error::io(dir, e))
    }
}

/// One `[[wedge.vary]]` table checked against the base scene.
fn vary_key(
    base: &Table,
    raw: RawVary,
    earlier: &[WedgeKey],
) -> std::result::Result<WedgeKey, String> {
    let path = parse_path(&raw.key)?;
    if path[0].name == "wedge" {
        return Err(format!("key: {}: the wedge cannot vary itself", raw.key));
    }
    let current = get(base, &path).map_err(|m| format!("key: {}: {m}", raw.key))?;
    let values = match (raw.values, raw.range, raw.random) {
        (Some(v), None, None) => v,
        (None, Some(r), None) => range(&r)?,
        (None, None, Some(r)) => random(&r)?,
        _ => return Err("give one of values, range or random".into()),
    };
    if values.is_empty() {
        return Err(format!("{}: has no values", raw.key));
    }
    if values.len() > MAX_VARIANTS {
        return Err(format!("{}: more than {MAX_VARIANTS} values", raw.key));
    }
    if let Some(cur) = current {
        for v in &values {
            same_kind(cur, v).map_err(|m| format!("{}: {m}", raw.key))?;
        }
    }
    let label = raw
        .label
        .unwrap_or_else(|| path.last().map(|s| s.name.clone()).unwrap_or_default());
    if label.is_empty()
        || !label
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    {
        return Err(format!(
            "label: {label:?} must be letters, digits, _ and - only"
        ));
    }
    if let Some(k) = earlier.iter().find(|k| k.label == label) {
        return Err(format!(
            "{}: its label {label:?} is also {}'s; give one of them another label = \"...\"",
            raw.key, k.key
        ));
    }
    Ok(WedgeKey {
        key: raw.key,
        label,
        values,
        path,
    })
}

/// The variant count of `keys` combined by `mode`, within [`MAX_VARIANTS`].
fn variant_count(mode: WedgeMode, keys: &[WedgeKey]) -> std::result::Result<usize, String> {
    match mode {
        WedgeMode::Zip => {
            let n = keys[0].values.len();
            match keys.iter().find(|k| k.values.len() != n) {
                Some(k) => Err(format!(
                    "mode = \"zip\" pairs lists of one length, but {} has {} values and {} has {n}",
                    k.key,
                    k.values.len(),
                    keys[0].key
                )),
                None => Ok(n),
            }
        }
        WedgeMode::Cross => keys.iter().try_fold(1usize, |n, k| {
            n.checked_mul(k.values.len())
                .filter(|&n| n <= MAX_VARIANTS)
                .ok_or_else(|| format!("every combination makes more than {MAX_VARIANTS} variants"))
        }),
    }
}

/// `blast[0].position[1]` into its segments.
fn parse_path(key: &str) -> std::result::Result<Vec<Segment>, String> {
    let bad = || {
        format!(
            "key: {key:?} is not a key path (table keys joined by '.', arrays indexed from 0 as in blast[0].tnt_kg)"
        )
    };
    let mut path = Vec::new();
    for part in key.split('.') {
        let (name, index) = match part.split_once('[') {
            Some((n, rest)) => {
                let i = rest.strip_suffix(']').and_then(|i| i.parse::<usize>().ok());
                (n, Some(i.ok_or_else(bad)?))
            }
            None => (part, None),
        };
        if name.is_empty()
            || !name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
        {
            return Err(bad());
        }
        path.push(Segment {
            name: name.to_string(),
            index,
        });
    }
    Ok(path)
}

/// The value at `path` in `table`: `Ok(None)` when only the last key is missing from a
/// table that exists.
fn get<'a>(table: &'a Table, path: &[Segment]) -> std::result::Result<Option<&'a Value>, String> {
    let mut t = table;
    for (n, seg) in path.iter().enumerate() {
        let last = n + 1 == path.len();
        let Some(v) = t.get(&seg.name) else {
            return if last && seg.index.is_none() {
                Ok(None)
            } else {
                Err(format!("the scene has no {}", seg.name))
            };
        };
        let v = match seg.index {
            None => v,
            Some(i) => {
                let arr = v
                    .as_array()
                    .ok_or_else(|| format!("{} is not a list", seg.name))?;
                arr.get(i).ok_or_else(|| {
                    format!(
                        "{}[{i}]: the scene has {} of them (indexed from 0)",
                        seg.name,
                        arr.len()
                    )
                })?
            }
        };
        if last {
            return Ok(Some(v));
        }
        t = v
            .as_table()
            .ok_or_else(|| format!("{} is not a table", seg.name))?;
    }
    Ok(None)
}

/// Puts `value` at `path`, which [`get`] resolved.
fn set(table: &mut Table, path: &[Segment], value: Value) -> Option<()> {
    let (last, parents) = path.split_last()?;
    let mut t = table;
    for seg in parents {
        let v = t.get_mut(&seg.name)?;
        let v = match seg.index {
            None => v,
            Some(i) => v.as_array_mut()?.get_mut(i)?,
        };
        t = v.as_table_mut()?;
    }
    match last.index {
        None => {
            t.insert(last.name.clone(), value);
        }
        Some(i) => *t.get_mut(&last.name)?.as_array_mut()?.get_mut(i)? = value,
    }
    Some(())
}

/// Whether `new` may replace `old`: numbers for numbers, lists of the same length.
fn same_kind(old: &Value, new: &Value) -> std::result::Result<(), String> {
    let number = |v: &Value| matches!(v, Value::Integer(_) | Value::Float(_));
    match (old, new) {
        (a, b) if number(a) && number(b) => Ok(()),
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => {
            a.iter().zip(b).try_for_each(|(a, b)| same_kind(a, b))
        }
        (a, b) if std::mem::discriminant(a) == std::mem::discriminant(b) && !a.is_array() => Ok(()),
        (a, b) => Err(format!(
            "the value {b} does not fit where the scene has {a} (a {} there)",
            a.type_str()
        )),
    }
}

#[cfg(test)]
mod tests;
