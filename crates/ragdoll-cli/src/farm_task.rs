//! `ragdoll run-task JOB/plan.json --task I`: runs one task's variants of a planned job.
//!
//! A farm kills tasks (preemption, time limits, a node lost), and reruns them. Each
//! variant is therefore made in a temporary folder beside the others
//! (`variants/.tmp-NAME-PID-TIME`), every file synced, its manifest written last, and the
//! folder renamed to `variants/NAME` in one step: a variant folder is complete or absent,
//! whenever the task is killed. A rerun skips variants whose manifest checks out and makes
//! the rest; a killed run's temporary folder is left alone (it may be another node's live
//! one on a shared file system) and never read. Two runs of one variant at once both make
//! it; the first rename wins and the other, finding a valid variant in place, discards its
//! own.
//!
//! The manifest records each output's hash, the wall and CPU seconds of the variant, and
//! the process's peak resident memory so far (`getrusage`, on Unix; `null` elsewhere).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use ragdoll::scene::Scene;
use ragdoll::scene::wedge::Wedge;
use serde::{Deserialize, Serialize};

use crate::farm::{Plan, PlanVariant, read_capped, sha256, sha256_file};

/// What a manifest says it is.
pub const MANIFEST_FORMAT: &str = "ragdoll-variant/1";

/// The manifest's file name inside a variant's folder.
pub const MANIFEST: &str = "manifest.json";

/// The variant's scene, written beside its outputs so it can be run again alone.
const SCENE_FILE: &str = "scene.toml";

/// The variant's preview picture (its thumbnail makes its tile of the contact sheet).
const PREVIEW_FILE: &str = "preview.png";

#[derive(Args, Debug)]
pub struct RunTaskArgs {
    /// The job's plan.json, written by `ragdoll plan`.
    plan: PathBuf,
    /// Which task to run, from 0.
    #[arg(long, value_name = "I")]
    task: usize,
}

/// `manifest.json`: what makes a variant folder complete and valid.
#[derive(Serialize, Deserialize, Debug)]
pub struct Manifest {
    pub format: String,
    pub variant: String,
    pub index: usize,
    /// The plan's digest of its inputs: a variant made from other inputs is stale.
    pub inputs: String,
    pub values: serde_json::Map<String, serde_json::Value>,
    /// Every file of the folder but the manifest, with its size and hash.
    pub files: Vec<OutputFile>,
    /// The file holding the scene report, if the scene writes one.
    pub report: Option<String>,
    pub wall_s: f64,
    pub cpu_s: f64,
    /// Peak resident memory of the task's process up to the end of this variant, KiB.
    pub peak_rss_kib: Option<u64>,
}

#[derive(Serialize, Deserialize, Debug, PartialEq)]
pub struct OutputFile {
    pub name: String,
    pub bytes: u64,
    pub sha256: String,
}

impl Manifest {
    /// Reads `dir`'s manifest and checks it against the plan and the files beside it; the
    /// error says what is wrong, for a sentence that names the variant.
    pub fn check(dir: &Path, plan: &Plan, v: &PlanVariant) -> Result<Manifest> {
        let path = dir.join(MANIFEST);
        let bytes = read_capped(&path, 16 << 20)?;
        let m: Manifest = serde_json::from_slice(&bytes)
            .with_context(|| format!("{}: corrupt manifest", path.display()))?;
        if m.format != MANIFEST_FORMAT || m.variant != v.name || m.index != v.index {
            bail!("{}: is another variant's manifest", path.display());
        }
        if m.inputs != plan.inputs_digest() || m.values != v.values {
            bail!(
                "{}: stale: made from other inputs or values than the job's plan",
                path.display()
            );
        }
        for f in &m.files {
            let file = dir.join(&f.name);
            if sha256_file(&file)? != f.sha256 {
                bail!("{}: differs from the hash in its manifest", file.display());
            }
        }
        Ok(m)
    }
}

/// The folder of a finished variant.
pub fn variant_dir(job: &Path, name: &str) -> PathBuf {
    job.join("variants").join(name)
}

/// The folder `plan.json` is in.
pub fn job_of(plan: &Path) -> PathBuf {
    match plan.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

pub fn run(a: &RunTaskArgs) -> Result<()> {
    let plan = Plan::load(&a.plan)?;
    let job = job_of(&a.plan);
    let Some(indices) = plan.tasks.get(a.task) else {
        bail!(
            "{}: --task {}: the plan has tasks 0 to {}",
            a.plan.display(),
            a.task,
            plan.tasks.len().saturating_sub(1)
        );
    };
    plan.check_inputs(&job)?;
    let wedge = plan.wedge(&job)?;
    std::fs::create_dir_all(job.join("variants"))
        .with_context(|| job.join("variants").display().to_string())?;
    for &i in indices {
        let Some(v) = plan.variants.get(i).filter(|v| v.index == i) else {
            bail!(
                "{}: task {} lists variant {i}, which it does not hold",
                a.plan.display(),
                a.task
            );
        };
        let dir = variant_dir(&job, &v.name);
        if dir.exists() {
            match Manifest::check(&dir, &plan, v) {
                Ok(_) => {
                    outln!("{}: already complete", v.name);
                    continue;
                }
                Err(e) => {
                    errln!("warning: {}: remade: {e:#}", v.name);
                    std::fs::remove_dir_all(&dir).with_context(|| dir.display().to_string())?;
                }
            }
        }
        let seconds = make_variant(&job, &plan, &wedge, v)?;
        outln!("{}: done in {seconds:.2} s", v.name);
    }
    Ok(())
}

/// Makes one variant in a temporary folder and renames it into place; returns its wall
/// seconds. Losing the rename to a concurrent run of the same variant is success when the
/// winner's folder checks out.
fn make_variant(job: &Path, plan: &Plan, wedge: &Wedge, v: &PlanVariant) -> Result<f64> {
    let started = Instant::now();
    let cpu = cpu_time::ProcessTime::now();
    // The process id alone could repeat on another node of a shared file system; the
    // clock's nanoseconds make two runs' folders differ, and create_dir refuses a clash.
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos());
    let tmp =
        job.join("variants")
            .join(format!(".tmp-{}-{}-{nanos:x}", v.name, std::process::id()));
    std::fs::create_dir(&tmp).with_context(|| tmp.display().to_string())?;
    let guard = RemoveOnDrop(tmp.clone());
    let variant = wedge.variant(v.index);
    let text = wedge.scene_text(&variant, &tmp)?;
    let mut files = vec![(SCENE_FILE.to_string(), text.clone().into_bytes())];
    let mut scene = Scene::from_toml(&text, &tmp.join(SCENE_FILE))?;
    // The report names its scene: the variant's place in the job, the same on every run
    // (not the temporary folder's).
    scene.path = Path::new("variants").join(&v.name).join(SCENE_FILE);
    let result = scene.run()?;
    files.extend(scene.encode(&result)?);
    let picture = preview(&scene, &result)?;
    let thumb = crate::farm_sheet::thumbnail(&picture)?;
    files.push((PREVIEW_FILE.into(), picture));
    files.push((crate::farm_sheet::THUMB_FILE.into(), thumb));
    crate::fatal::debug_panic_point("variant-staged");
    let mut listed = Vec::with_capacity(files.len());
    for (name, bytes) in &files {
        write_synced(&tmp.join(name), bytes)?;
        listed.push(OutputFile {
            name: name.clone(),
            bytes: bytes.len() as u64,
            sha256: sha256(bytes),
        });
    }
    debug_stall_point("variant-written");
    let wall_s = started.elapsed().as_secs_f64();
    let manifest = Manifest {
        format: MANIFEST_FORMAT.into(),
        variant: v.name.clone(),
        index: v.index,
        inputs: plan.inputs_digest(),
        values: v.values.clone(),
        files: listed,
        report: scene.outputs.report.clone(),
        wall_s,
        cpu_s: cpu.elapsed().as_secs_f64(),
        peak_rss_kib: peak_rss_kib(),
    };
    write_synced(&tmp.join(MANIFEST), &serde_json::to_vec_pretty(&manifest)?)?;
    sync_dir(&tmp);
    let dir = variant_dir(job, &v.name);
    match std::fs::rename(&tmp, &dir) {
        Ok(()) => {
            std::mem::forget(guard);
            sync_dir(&job.join("variants"));
        }
        Err(e) => {
            // Another run of this variant renamed its folder first.
            Manifest::check(&dir, plan, v)
                .map_err(|_| e)
                .with_context(|| dir.display().to_string())?;
        }
    }
    Ok(wall_s)
}

/// The variant's preview picture: the middle frame, as `simulate --preview x.png` draws.
fn preview(scene: &Scene, result: &ragdoll::scene::SceneResult) -> Result<Vec<u8>> {
    let (actors, markers) = crate::scene_cmd::drawn(scene, result);
    Ok(ragdoll_preview::png(
        &actors,
        &markers,
        &ragdoll_preview::PreviewOptions::default(),
    )?)
}

/// Writes and syncs a file, so a rename after it never publishes unwritten data.
fn write_synced(path: &Path, bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    let mut f = std::fs::File::create(path).with_context(|| path.display().to_string())?;
    f.write_all(bytes)
        .and_then(|()| f.sync_all())
        .with_context(|| path.display().to_string())
}

/// Syncs a folder's entries where the platform allows it (not on Windows, where a folder
/// cannot be opened so; its renames are journaled by NTFS).
fn sync_dir(dir: &Path) {
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Peak resident memory of this process so far, KiB (`ru_maxrss`: KiB on Linux, bytes on
/// macOS).
#[cfg(unix)]
fn peak_rss_kib() -> Option<u64> {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage fills the struct it is given; RUSAGE_SELF is always valid.
    let ok = unsafe { libc::getrusage(libc::RUSAGE_SELF, usage.as_mut_ptr()) } == 0;
    // SAFETY: zero-initialised, and filled by getrusage when it succeeded.
    let max = unsafe { usage.assume_init() }.ru_maxrss as u64;
    let kib = if cfg!(target_os = "macos") {
        max / 1024
    } else {
        max
    };
    ok.then_some(kib)
}

#[cfg(not(unix))]
fn peak_rss_kib() -> Option<u64> {
    None
}

/// Stops here for good when `RAGDOLL_DEBUG_STALL` names `point`: how the tests kill a
/// task (SIGKILL) at a known moment, its outputs written and its manifest not yet.
fn debug_stall_point(point: &str) {
    if std::env::var_os("RAGDOLL_DEBUG_STALL").is_some_and(|v| v == point) {
        loop {
            std::thread::sleep(std::time::Duration::from_secs(60));
        }
    }
}

/// Removes a temporary folder on an error or a panic unwinding through.
pub struct RemoveOnDrop(pub PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
