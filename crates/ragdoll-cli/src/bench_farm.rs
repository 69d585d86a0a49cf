//! `ragdoll bench --farm N`: the farm commands at scale. A wedge of N variants (one
//! built-in humanoid for two seconds, the charge's mass varied) is planned, three of its
//! one-variant tasks are run, and the job is merged, each command as its own process of
//! this binary, as a farm runs them: wall seconds and the child's CPU seconds.
//!
//! Running N real simulations would measure the simulations; the merge is measured on N
//! finished variants made from the first task's: each other variant folder holds hard links
//! to its files (a copy where links are refused) and a manifest naming that variant. The
//! merge reads and hashes every file and parses every report as it would on a real job;
//! the files share their disk blocks, so this measures the merge's own work with the
//! outputs in the page cache, not a farm file server's reads.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use ragdoll::scene::Scene;
use serde_json::{Value, json};

use crate::farm::Plan;
use crate::farm_task::{MANIFEST, Manifest, RemoveOnDrop, variant_dir};

/// Most variants a farm benchmark makes: 100,000 variant folders are about 700,000 small
/// files.
pub const MAX_FARM_VARIANTS: usize = 100_000;

/// Tasks run to measure a task's overhead; the median is reported.
const TASK_RUNS: usize = 3;

/// The benchmark's scene: two seconds of one built-in humanoid and a charge, outputs of a
/// usual size for a simulation a task's time is little more than; `{last}` is the
/// heaviest charge, making N variants.
const SCENE: &str = r#"duration_s = 2.0
fps = 30
backend = "fast"

[[character]]
name = "ann"

[[blast]]
tnt_kg = 1.0
position = [0.0, 0.3, 2.0]

[[wedge.vary]]
key = "blast[0].tnt_kg"
range = { from = 1, to = {last}, step = 1 }
"#;

/// One command's cost.
struct Cost {
    wall_s: f64,
    /// CPU seconds of the child process, all its threads (`None` off Unix).
    cpu_s: Option<f64>,
}

pub fn run(variants: usize, as_json: bool) -> Result<()> {
    if !(1..=MAX_FARM_VARIANTS).contains(&variants) {
        bail!(
            "--farm: the number of variants must be between 1 and {MAX_FARM_VARIANTS}, not {variants}"
        );
    }
    let dir = std::env::temp_dir().join(format!("ragdoll-bench-farm-{}", std::process::id()));
    std::fs::create_dir(&dir).with_context(|| dir.display().to_string())?;
    let _remove = RemoveOnDrop(dir.clone());
    let dir = dir.as_path();
    let scene = SCENE.replace("{last}", &variants.to_string());
    std::fs::write(dir.join("wedge.toml"), &scene)?;
    let tasks = variants.to_string();
    let plan = ragdoll(dir, &["plan", "wedge.toml", "--tasks", &tasks, "-o", "job"])?;
    let simulation_s = simulation_seconds(&scene, dir)?;
    let mut task_runs = Vec::new();
    for task in 0..TASK_RUNS.min(variants) {
        let t = task.to_string();
        task_runs.push(ragdoll(dir, &["run-task", "job/plan.json", "--task", &t])?);
    }
    let made = fill_variants(&dir.join("job"), task_runs.len())?;
    let merge = ragdoll(dir, &["merge", "job", "--no-sheet"])?;
    let sheet = ragdoll(dir, &["merge", "job"])?;
    task_runs.sort_by(|a, b| a.wall_s.total_cmp(&b.wall_s));
    let task = &task_runs[task_runs.len() / 2];
    let overhead_s = (task.wall_s - simulation_s).max(0.0);
    if as_json {
        let report = json!({
            "variants": variants,
            "variants_linked": made,
            "plan": cost_json(&plan),
            "task": cost_json(task),
            "task_simulation_s": simulation_s,
            "task_overhead_s": overhead_s,
            "merge_tables": cost_json(&merge),
            "merge_with_sheet": cost_json(&sheet),
        });
        outln!("{}", serde_json::to_string_pretty(&report)?);
        return Ok(());
    }
    outln!(
        "farm commands, {variants} variants of 2 s of one humanoid ({made} made from the first tasks' outputs)"
    );
    outln!("  {:<22} {:>9} {:>9}", "", "wall s", "CPU s");
    print_cost("plan", &plan);
    print_cost("task (median of runs)", task);
    outln!(
        "    of which simulating {simulation_s:.3} s; overhead {overhead_s:.3} s (start, inputs, preview, outputs, manifest)"
    );
    print_cost("merge --no-sheet", &merge);
    print_cost("merge", &sheet);
    Ok(())
}

/// Runs this binary with `args` in `dir`; an error carries what it printed.
fn ragdoll(dir: &Path, args: &[&str]) -> Result<Cost> {
    let exe = std::env::current_exe().context("this program's path")?;
    let cpu_before = children_cpu_s();
    let started = Instant::now();
    let out = Command::new(exe)
        .current_dir(dir)
        .args(args)
        .output()
        .with_context(|| format!("running ragdoll {}", args.join(" ")))?;
    let wall_s = started.elapsed().as_secs_f64();
    if !out.status.success() {
        bail!(
            "ragdoll {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let cpu_s = cpu_before
        .zip(children_cpu_s())
        .map(|(before, after)| after - before);
    Ok(Cost { wall_s, cpu_s })
}

/// The wall seconds of the variant's simulation alone, in this process: what a task's time
/// beyond it is overhead against.
fn simulation_seconds(scene: &str, dir: &Path) -> Result<f64> {
    let scene = Scene::from_toml(scene, &dir.join("one.toml"))?;
    let started = Instant::now();
    scene.run()?;
    Ok(started.elapsed().as_secs_f64())
}

/// Makes every variant after the first `done` a finished one, from variant 0's files, and
/// returns how many it made.
fn fill_variants(job: &Path, done: usize) -> Result<usize> {
    let plan = Plan::load(&job.join("plan.json"))?;
    let first = &plan.variants[0];
    let source = variant_dir(job, &first.name);
    let manifest = Manifest::check(&source, &plan, first)?;
    for v in &plan.variants[done..] {
        let dir = variant_dir(job, &v.name);
        std::fs::create_dir(&dir).with_context(|| dir.display().to_string())?;
        for f in &manifest.files {
            let (from, to) = (source.join(&f.name), dir.join(&f.name));
            if std::fs::hard_link(&from, &to).is_err() {
                std::fs::copy(&from, &to).with_context(|| to.display().to_string())?;
            }
        }
        let mut value: Value = serde_json::to_value(&manifest)?;
        value["variant"] = json!(v.name);
        value["index"] = json!(v.index);
        value["values"] = Value::Object(v.values.clone());
        std::fs::write(dir.join(MANIFEST), serde_json::to_vec_pretty(&value)?)?;
    }
    Ok(plan.variants.len().saturating_sub(done))
}

fn print_cost(what: &str, c: &Cost) {
    let cpu = c.cpu_s.map_or("?".into(), |s| format!("{s:.3}"));
    outln!("  {what:<22} {:>9.3} {cpu:>9}", c.wall_s);
}

fn cost_json(c: &Cost) -> Value {
    json!({ "wall_s": c.wall_s, "cpu_s": c.cpu_s })
}

/// CPU seconds of the finished children this process has waited for.
#[cfg(unix)]
fn children_cpu_s() -> Option<f64> {
    let mut usage = std::mem::MaybeUninit::<libc::rusage>::zeroed();
    // SAFETY: getrusage fills the struct it is given; RUSAGE_CHILDREN is always valid.
    let ok = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, usage.as_mut_ptr()) } == 0;
    // SAFETY: zero-initialised, and filled by getrusage when it succeeded.
    let u = unsafe { usage.assume_init() };
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    ok.then(|| secs(u.ru_utime) + secs(u.ru_stime))
}

#[cfg(not(unix))]
fn children_cpu_s() -> Option<f64> {
    None
}
