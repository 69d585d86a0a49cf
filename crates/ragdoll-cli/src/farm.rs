//! `ragdoll plan SCENE.toml --tasks N -o JOB/`: a wedge split into a job a render farm
//! runs. The job folder holds `plan.json` (every variant's values, the task that runs it,
//! and the hash of every input file, so a task refuses inputs edited after planning), an
//! Open Job Description template and Slurm scripts. Every path in them is relative to the
//! job folder, so the folder (with the inputs where the plan says) can move between
//! machines: a farm maps the one `JobDir` path, nothing else.
//!
//! `farm_task.rs` runs a task's variants, `farm_merge.rs` gathers them.

use std::fmt::Write as _;
use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use ragdoll::scene::wedge::{Wedge, portable_path, relative_path};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::output::{self, Staging};

/// What `plan.json` says it is, so a future layout is told apart.
pub const PLAN_FORMAT: &str = "ragdoll-plan/1";

/// Largest plan.json read (10,000 variants take about 2 MB).
const MAX_PLAN_BYTES: u64 = 256 << 20;

#[derive(Args, Debug)]
pub struct PlanArgs {
    /// A scene file with a [wedge] table.
    scene: PathBuf,
    /// How many tasks to split the variants into (each runs its variants one after
    /// another; at most one task per variant).
    #[arg(long, value_name = "N")]
    tasks: usize,
    /// The job folder to write (new, or without a plan.json).
    #[arg(short, long, value_name = "JOB")]
    output: PathBuf,
}

/// `plan.json`.
#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct Plan {
    pub format: String,
    /// The scene file, relative to the job folder.
    pub scene: String,
    /// Every file the variants read, the scene first, with its hash when planned.
    pub inputs: Vec<Input>,
    /// `cross` or `zip`.
    pub mode: String,
    /// The varied keys and their labels, in wedge order.
    pub keys: Vec<PlanKey>,
    /// Per task, the indices of the variants it runs.
    pub tasks: Vec<Vec<usize>>,
    pub variants: Vec<PlanVariant>,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct Input {
    /// Relative to the job folder (absolute where there is no common root).
    pub path: String,
    pub sha256: String,
}

#[derive(Serialize, Deserialize, Debug, Clone)]
pub struct PlanKey {
    pub key: String,
    pub label: String,
}

#[derive(Serialize, Deserialize, Debug, Clone, PartialEq)]
pub struct PlanVariant {
    pub index: usize,
    pub name: String,
    pub task: usize,
    /// Each varied key's value, by key.
    pub values: serde_json::Map<String, serde_json::Value>,
    /// The seed of each random generator the variant's scene runs (its crowds').
    #[serde(default)]
    pub seeds: serde_json::Map<String, serde_json::Value>,
}

impl Plan {
    /// Reads a plan, naming the file in every error.
    pub fn load(path: &Path) -> Result<Plan> {
        let bytes = read_capped(path, MAX_PLAN_BYTES)?;
        let plan: Plan = serde_json::from_slice(&bytes)
            .with_context(|| format!("{}: not a plan written by `ragdoll plan`", path.display()))?;
        if plan.format != PLAN_FORMAT {
            bail!(
                "{}: format {:?}, but this ragdoll reads {PLAN_FORMAT:?}; plan the job again",
                path.display(),
                plan.format
            );
        }
        Ok(plan)
    }

    /// One hash over every input's path and hash: what a manifest records, so merge can
    /// tell a variant made from other inputs (a stale one).
    pub fn inputs_digest(&self) -> String {
        let mut h = Sha256::new();
        for i in &self.inputs {
            h.update(format!("{}\t{}\n", i.path, i.sha256).as_bytes());
        }
        hex(&h.finalize())
    }

    /// Refuses to go on when an input is missing or differs from when it was planned,
    /// naming the file.
    pub fn check_inputs(&self, job: &Path) -> Result<()> {
        for input in &self.inputs {
            let path = job.join(&input.path);
            let now = sha256_file(&path).with_context(|| {
                format!("{}: an input of this job cannot be read", path.display())
            })?;
            if now != input.sha256 {
                bail!(
                    "{}: changed since the job was planned (sha256 {} in plan.json, {} now); plan the job again",
                    path.display(),
                    short(&input.sha256),
                    short(&now)
                );
            }
        }
        Ok(())
    }

    /// The scene's wedge, checked to make the variants the plan lists.
    pub fn wedge(&self, job: &Path) -> Result<Wedge> {
        let scene = job.join(&self.scene);
        let wedge = crate::wedge_cmd::load(&scene)?;
        let same = wedge.len() == self.variants.len()
            && self
                .variants
                .iter()
                .all(|v| v.index < wedge.len() && wedge.variant(v.index).name == v.name);
        if !same {
            bail!(
                "{}: its wedge no longer makes the variants in the job's plan.json; plan the job again",
                scene.display()
            );
        }
        Ok(wedge)
    }
}

pub fn plan(a: &PlanArgs) -> Result<()> {
    let wedge = crate::wedge_cmd::load(&a.scene)?;
    if a.tasks == 0 {
        bail!("--tasks: must be at least 1");
    }
    output::check_output_folder(&a.output)?;
    if a.output.join("plan.json").exists() {
        bail!(
            "{}: already holds a plan.json; plan into a new folder (its finished variants belong to that plan)",
            a.output.display()
        );
    }
    check_loads(&wedge)?;
    let tasks = a.tasks.min(wedge.len());
    let mut staging = Staging::new();
    staging.make_folder(&a.output)?;
    let job = a
        .output
        .canonicalize()
        .with_context(|| a.output.display().to_string())?;
    let plan = make_plan(&wedge, tasks, &job)?;
    let name = a
        .scene
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy().into_owned());
    let json = serde_json::to_string_pretty(&plan)?;
    staging.write(&a.output.join("plan.json"), json.as_bytes())?;
    let template = crate::farm_templates::openjd(&name, tasks);
    staging.write(&a.output.join("job.openjd.yaml"), template.as_bytes())?;
    for (file, text) in crate::farm_templates::slurm(&name, tasks) {
        staging.write(&a.output.join("slurm").join(file), text.as_bytes())?;
    }
    for path in staging.commit()? {
        outln!("{}", path.display());
    }
    errln!(
        "{}: {} variants in {tasks} task{}",
        a.scene.display(),
        wedge.len(),
        if tasks == 1 { "" } else { "s" }
    );
    Ok(())
}

/// Variants loaded when planning, at most.
const MAX_CHECKED_VARIANTS: usize = 64;

/// Loads variants holding every value of every key between them (at most
/// [`MAX_CHECKED_VARIANTS`], evenly spread, the first and last always: characters read,
/// ragdolls built), so a value the scene refuses (the far end of a range, one bad entry
/// of a list) is found before a farm spends a task on it. Not every variant: each load
/// reads its character files again, and a wedge may have 100,000.
fn check_loads(wedge: &Wedge) -> Result<()> {
    let dir = match wedge.path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    for i in wedge.covering_variants(MAX_CHECKED_VARIANTS) {
        let v = wedge.variant(i);
        let text = wedge.scene_text(&v, dir)?;
        ragdoll::scene::Scene::from_toml(&text, &dir.join(format!("{}.toml", v.name)))
            .with_context(|| {
                format!(
                    "{}: variant {} would not run (`ragdoll wedge --variant {} -o FILE` writes its scene)",
                    wedge.path.display(),
                    v.name,
                    v.index
                )
            })?;
    }
    Ok(())
}

/// The plan of `wedge` in `tasks` tasks (contiguous runs of variants, sizes differing by
/// at most one), its paths relative to the absolute job folder `job`.
fn make_plan(wedge: &Wedge, tasks: usize, job: &Path) -> Result<Plan> {
    let mut inputs = Vec::new();
    for file in wedge.input_files() {
        let abs = file.canonicalize().with_context(|| {
            format!(
                "{}: an input of {} is missing",
                file.display(),
                wedge.path.display()
            )
        })?;
        inputs.push(Input {
            path: portable_path(&relative_path(&abs, job)),
            sha256: sha256_file(&abs)?,
        });
    }
    let n = wedge.len();
    let task_of = |i: usize| i * tasks / n;
    let mut task_lists = vec![Vec::new(); tasks];
    let variants: Vec<PlanVariant> = wedge
        .variants()
        .map(|v| {
            task_lists[task_of(v.index)].push(v.index);
            PlanVariant {
                seeds: wedge
                    .seeds(&v)
                    .into_iter()
                    .map(|(k, s)| (k, s.into()))
                    .collect(),
                index: v.index,
                name: v.name,
                task: task_of(v.index),
                values: v
                    .values
                    .iter()
                    .map(|(k, x)| (k.clone(), serde_json::to_value(x).unwrap_or_default()))
                    .collect(),
            }
        })
        .collect();
    Ok(Plan {
        format: PLAN_FORMAT.into(),
        scene: inputs[0].path.clone(),
        inputs,
        mode: wedge.mode.as_str().into(),
        keys: wedge
            .keys
            .iter()
            .map(|k| PlanKey {
                key: k.key.clone(),
                label: k.label.clone(),
            })
            .collect(),
        tasks: task_lists,
        variants,
    })
}

/// At most `limit` bytes of a regular file, else an error naming it.
pub fn read_capped(path: &Path, limit: u64) -> Result<Vec<u8>> {
    let meta = std::fs::metadata(path).with_context(|| path.display().to_string())?;
    if !meta.is_file() {
        bail!("{}: is not a regular file", path.display());
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(limit + 1).read_to_end(&mut bytes))
        .with_context(|| path.display().to_string())?;
    if bytes.len() as u64 > limit {
        bail!("{}: larger than {limit} bytes", path.display());
    }
    Ok(bytes)
}

/// The SHA-256 of a file, read in blocks (character files can be large).
pub fn sha256_file(path: &Path) -> Result<String> {
    let mut f = std::fs::File::open(path).with_context(|| path.display().to_string())?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = f
            .read(&mut buf)
            .with_context(|| path.display().to_string())?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Ok(hex(&h.finalize()))
}

/// The SHA-256 of bytes in hand.
pub fn sha256(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// A hash shortened for a message.
fn short(h: &str) -> &str {
    h.get(..12).unwrap_or(h)
}
