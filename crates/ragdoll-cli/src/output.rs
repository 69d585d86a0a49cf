//! Outputs written all or nothing. A command's output paths are checked before any
//! simulation time is spent ([`check_file`], [`check_folder`]); its files are then written
//! under temporary names beside their final ones ([`Staging`]) and renamed into place only
//! when every one of them is written. On any failure (an error, a panic unwinding through
//! the staging) the temporaries and the folders made for them are removed, so the output
//! folder is left as it was.
//!
//! The library's `write_atomic` does this for one file; a run writes several (glTF,
//! report, preview, an OBJ per frame), and a failure in the last must not leave the first.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// Fails unless `path` can become an output file: not an existing folder, and its folder
/// either exists (and is a folder we may write in) or can be made.
pub fn check_file(path: &Path) -> Result<()> {
    if path.as_os_str().is_empty() {
        bail!("the output file name is empty");
    }
    if path.is_dir() {
        bail!("{}: is a folder; expected a file name", path.display());
    }
    check_folder(parent_of(path))
}

/// Fails unless `dir` can be an output folder: an existing folder we may write in, or a
/// path whose nearest existing ancestor is one.
pub fn check_folder(dir: &Path) -> Result<()> {
    let mut existing = dir;
    loop {
        match std::fs::metadata(existing) {
            Ok(meta) if meta.is_dir() => break,
            Ok(_) => bail!("{}: is not a folder", existing.display()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => match existing.parent() {
                Some(p) if !p.as_os_str().is_empty() => existing = p,
                _ => {
                    existing = Path::new(".");
                }
            },
            Err(e) => return Err(e).with_context(|| existing.display().to_string()),
        }
    }
    probe_writable(existing)
}

/// [`check_folder`] for the folder a command writes several files into (`demo`, a scene):
/// also fails when `dir` does not exist yet and is named like one of our output files
/// (`out.glb`), which a user who typed it expects as a file, not a folder holding one.
pub fn check_output_folder(dir: &Path) -> Result<()> {
    const FILE_EXTENSIONS: [&str; 6] = ["glb", "gltf", "bvh", "json", "png", "gif"];
    let ext = dir.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !dir.exists() && FILE_EXTENSIONS.iter().any(|f| f.eq_ignore_ascii_case(ext)) {
        bail!(
            "{}: this command writes its files into a folder; give a folder name (without .{ext})",
            dir.display()
        );
    }
    check_folder(dir)
}

/// Creates and removes an empty file in `dir`: the one test of write permission that
/// holds everywhere (permissions, read-only mounts, ACLs).
fn probe_writable(dir: &Path) -> Result<()> {
    let probe = dir.join(format!(".ragdoll-probe.{}.tmp", std::process::id()));
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(e).with_context(|| format!("{}: cannot write in this folder", dir.display())),
    }
}

/// `a/b.glb` → `a`; `b.glb` → `.`.
fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes one file through a [`Staging`]: like the library's `write_atomic`, but a
/// folder made for it is removed again when the write fails.
pub fn write_one(path: &Path, bytes: &[u8]) -> Result<()> {
    let mut staging = Staging::new();
    staging.write(path, bytes)?;
    staging.commit()?;
    Ok(())
}

/// Files being written under temporary names; see the module documentation.
#[derive(Default)]
pub struct Staging {
    /// Final path and temporary path of each file, in the order staged.
    files: Vec<(PathBuf, PathBuf)>,
    /// Folders this staging created, outermost first.
    made: Vec<PathBuf>,
    done: bool,
}

impl Staging {
    pub fn new() -> Self {
        Self::default()
    }

    /// Stages `bytes` as the file `path`.
    pub fn write(&mut self, path: &Path, bytes: &[u8]) -> Result<()> {
        self.write_with(path, |w| w.write_all(bytes))
    }

    /// Stages the file `path`, its content written by `fill`.
    pub fn write_with(
        &mut self,
        path: &Path,
        fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
    ) -> Result<()> {
        if self.files.iter().any(|(p, _)| p == path) {
            bail!(
                "{}: two outputs of this run would be written to this file",
                path.display()
            );
        }
        if path.is_dir() {
            bail!("{}: is a folder; expected a file name", path.display());
        }
        self.make_folder(parent_of(path))?;
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        let tmp = path.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
        // Recorded before it exists, so a failure below still removes it.
        self.files.push((path.to_path_buf(), tmp.clone()));
        let write = || -> std::io::Result<()> {
            let mut w = BufWriter::new(File::create(&tmp)?);
            fill(&mut w)?;
            w.into_inner().map_err(|e| e.into_error())?.sync_all()
        };
        write().with_context(|| path.display().to_string())
    }

    /// Makes `dir` and its missing ancestors, remembering which it made.
    pub fn make_folder(&mut self, dir: &Path) -> Result<()> {
        let mut missing = Vec::new();
        let mut d = dir;
        loop {
            match std::fs::metadata(d) {
                Ok(meta) if meta.is_dir() => break,
                Ok(_) => bail!("{}: is not a folder", d.display()),
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                    missing.push(d.to_path_buf());
                    match d.parent() {
                        Some(p) if !p.as_os_str().is_empty() => d = p,
                        _ => break,
                    }
                }
                Err(e) => return Err(e).with_context(|| d.display().to_string()),
            }
        }
        for m in missing.into_iter().rev() {
            std::fs::create_dir(&m).with_context(|| m.display().to_string())?;
            self.made.push(m);
        }
        Ok(())
    }

    /// Renames every staged file into place; returns their paths, in the order staged.
    ///
    /// A rename within one folder fails only in the rarest cases (the target turned into a
    /// folder meanwhile); then the files already renamed stay, and the error says which.
    pub fn commit(mut self) -> Result<Vec<PathBuf>> {
        let files = std::mem::take(&mut self.files);
        let mut placed = Vec::with_capacity(files.len());
        for (k, (path, tmp)) in files.iter().enumerate() {
            if let Err(e) = std::fs::rename(tmp, path) {
                // Put the rest back for Drop to remove.
                self.files = files[k..].to_vec();
                let done: Vec<String> = placed
                    .iter()
                    .map(|p: &PathBuf| p.display().to_string())
                    .collect();
                return Err(e).with_context(|| {
                    if done.is_empty() {
                        path.display().to_string()
                    } else {
                        format!("{} (already written: {})", path.display(), done.join(", "))
                    }
                });
            }
            placed.push(path.clone());
        }
        self.done = true;
        Ok(placed)
    }
}

impl Drop for Staging {
    fn drop(&mut self) {
        if self.done {
            return;
        }
        for (_, tmp) in &self.files {
            let _ = std::fs::remove_file(tmp);
        }
        // Innermost first; a folder that is not empty (someone else wrote there) stays.
        for dir in self.made.iter().rev() {
            let _ = std::fs::remove_dir(dir);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listing(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = walk(dir)
            .into_iter()
            .map(|p| p.strip_prefix(dir).unwrap().display().to_string())
            .collect();
        v.sort();
        v
    }

    fn walk(dir: &Path) -> Vec<PathBuf> {
        let mut out = Vec::new();
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                out.extend(walk(&p));
            }
            out.push(p);
        }
        out
    }

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("ragdoll-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn nothing_appears_until_commit_and_everything_after() {
        let dir = scratch("commit");
        let mut s = Staging::new();
        s.write(&dir.join("a/b/one.txt"), b"1").unwrap();
        s.write(&dir.join("two.txt"), b"2").unwrap();
        assert!(!dir.join("two.txt").exists());
        let written = s.commit().unwrap();
        assert_eq!(written, [dir.join("a/b/one.txt"), dir.join("two.txt")]);
        assert_eq!(std::fs::read(dir.join("a/b/one.txt")).unwrap(), b"1");
        assert_eq!(listing(&dir), ["a", "a/b", "a/b/one.txt", "two.txt"]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_dropped_staging_leaves_the_folder_as_it_was() {
        let dir = scratch("drop");
        std::fs::write(dir.join("keep.txt"), b"old").unwrap();
        {
            let mut s = Staging::new();
            s.write(&dir.join("keep.txt"), b"new").unwrap();
            s.write(&dir.join("new/deeper/x.txt"), b"x").unwrap();
            // The same file twice is refused.
            assert!(s.write(&dir.join("keep.txt"), b"again").is_err());
            // A file where a folder must go.
            assert!(s.write(&dir.join("keep.txt/y.txt"), b"y").is_err());
        }
        assert_eq!(listing(&dir), ["keep.txt"]);
        assert_eq!(std::fs::read(dir.join("keep.txt")).unwrap(), b"old");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn checks_refuse_folders_files_in_the_way_and_read_only_places() {
        let dir = scratch("check");
        std::fs::write(dir.join("file"), b"").unwrap();
        assert!(check_file(&dir.join("out.glb")).is_ok());
        assert!(check_file(&dir.join("new/deeper/out.glb")).is_ok());
        assert!(check_file(&dir).is_err(), "a folder is not a file name");
        assert!(check_file(&dir.join("file/out.glb")).is_err());
        assert!(check_folder(&dir.join("file")).is_err());
        assert!(check_folder(&dir.join("new")).is_ok());
        assert!(check_output_folder(&dir.join("out.glb")).is_err());
        assert!(check_output_folder(&dir.join("out")).is_ok());
        std::fs::create_dir(dir.join("existing.glb")).unwrap();
        assert!(check_output_folder(&dir.join("existing.glb")).is_ok());
        std::fs::remove_dir(dir.join("existing.glb")).unwrap();
        assert_eq!(listing(&dir), ["file"], "checks leave nothing behind");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
