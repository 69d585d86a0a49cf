//! `ragdoll bench`: the pile workload. N built-in humanoids dropped from
//! staggered heights in a grid of piles; reports ragdoll-steps per second (N × steps over
//! the wall seconds of stepping, and over its CPU seconds, which a busy machine disturbs
//! less), whether the run stayed stable, and the limit violation before and after the
//! clamp that turns joints back. Piles are independent, so with
//! several threads each thread steps its own world holding a share of the piles.

use std::time::Instant;

use anyhow::{Result, bail};
use clap::Args;
use cpu_time::ProcessTime;
use ragdoll::skeleton;
use ragdoll::spec::{self, BuildOptions};
use ragdoll::track::Metrics;
use ragdoll::world::{
    BackendKind, DEFAULT_FAST_IMPACT_PASSES, DEFAULT_FAST_SUBSTEPS, MAX_FAST_ITERATIONS,
    MAX_SUBSTEPS, Motors, World, WorldSettings,
};
use rayon::prelude::*;
use serde_json::json;

use crate::bench_piles::{MAX_PILE_HEIGHT, PILE_HEIGHT, Piles, posed, rest_after_s};
use crate::progress::Progress;

/// Most ragdolls in one run. Memory is about 90 KB per humanoid on the rigid backend and
/// 30 KB on the particle one (peak resident size over N, measured at N = 1024 and 4096),
/// so 10,000 stay under a gigabyte; and building a world still grows faster than its size
/// (4,096 humanoids in one world took 4.5 s to build on the rigid backend, 33 s on the
/// particle one).
pub const MAX_RAGDOLLS: usize = 10_000;

/// Most ragdoll-steps (ragdolls × steps) in one run: about 80 minutes on one core at the
/// 2,000 ragdoll-steps a second a rigid pile of 1,024 ran at on a busy 2-core machine
/// (the particle backend is 2-3 times faster).
pub const MAX_RAGDOLL_STEPS: u64 = 10_000_000;

/// Ragdoll-steps a second on one core, rigid backend, as measured for [`MAX_RAGDOLL_STEPS`]:
/// only for the estimate in the refusal.
const RIGID_STEPS_PER_SECOND: f64 = 2000.0;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Numbers of ragdolls to run, comma-separated.
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',', default_values_t = vec![1, 16, 256, 1024])]
    ragdolls: Vec<usize>,
    /// Steps of 1/60 s per run.
    #[arg(long, allow_negative_numbers = true, default_value_t = 600)]
    steps: usize,
    /// Thread counts to run each size with, comma-separated (default: 1 and all cores).
    #[arg(long, allow_negative_numbers = true, value_delimiter = ',')]
    threads: Vec<usize>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
    /// Run each size on the rigid backend (rapier, the reference) too, in the same run,
    /// and print how many times as many ragdoll-steps per CPU-second the chosen backend
    /// does: a ratio taken minutes apart on a shared machine measures the neighbours.
    #[arg(long)]
    compare: bool,
    /// Run the reference workload too, in the same run: the same piles of a plain
    /// 11-capsule ragdoll in rapier3d with rapier's defaults and 4 solver iterations, so
    /// the ratio to a general engine can be reproduced anywhere rapier runs.
    #[arg(long)]
    reference: bool,
    /// Keep every joint of the fast backend active: no joint freezing (its level of detail
    /// below sleep), to measure what freezing saves and costs.
    #[arg(long)]
    no_freeze: bool,
    /// Substeps of the fast backend per 1/60 s step (1 to 100; default 32): fewer trade
    /// penetration, joint gaps and limits for speed (the benchmarks page has the table).
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = DEFAULT_FAST_SUBSTEPS,
        value_name = "N"
    )]
    fast_substeps: usize,
    /// Let the fast backend carry a contact over its substeps while the two shapes move
    /// less than half a millimetre against each other, instead of finding it again (off
    /// by default; the benchmarks page has what it saves and costs).
    #[arg(long)]
    keep_contacts: bool,
    /// Passes of the fast backend's joints and contacts per substep (1 to 8; default 1):
    /// two hold limits and joints tighter for about 1.5 times the time.
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = 1,
        value_name = "N"
    )]
    fast_iterations: usize,
    /// Passes the fast backend adds in a step where a ragdoll strikes something at more
    /// than 2 m/s (0 to 8; default 3): 0 measures the solver without them
    #[arg(
        long,
        allow_negative_numbers = true,
        default_value_t = DEFAULT_FAST_IMPACT_PASSES,
        value_name = "N"
    )]
    impact_passes: usize,
    /// Ragdolls in one pile (1 to 64; default 4): 10 with 160 ragdolls makes sixteen
    /// piles of ten, the size of the ragdoll scene engines publish their speed on.
    #[arg(long, allow_negative_numbers = true, default_value_t = PILE_HEIGHT, value_name = "H")]
    pile_height: usize,
    /// Drive every joint toward the standing pose with motors of this strength (0 to 1),
    /// as a game's ragdolls hold a pose while they fall.
    #[arg(long, allow_negative_numbers = true, value_name = "STRENGTH")]
    motors: Option<f32>,
    /// Measure the farm commands instead, on a wedge of this many variants: `plan`, a
    /// task's overhead beyond its simulation, and `merge` with and without its contact
    /// sheet (see `docs/src/farm.md`).
    #[arg(long, value_name = "VARIANTS")]
    farm: Option<usize>,
    #[command(flatten)]
    backend: crate::BackendArgs,
}

/// How long one run stepped: what every workload, ours or the reference, reports alike.
pub(crate) struct Timing {
    pub ragdolls: usize,
    pub threads: usize,
    /// Wall seconds of stepping.
    pub seconds: f64,
    /// CPU seconds of stepping, all threads together (`None` where the system would not
    /// say): on a shared machine, wall time says as much about the neighbours as about us.
    pub cpu_seconds: Option<f64>,
}

impl Timing {
    fn per_second(&self, steps: usize, seconds: f64) -> f64 {
        (self.ragdolls * steps) as f64 / seconds
    }

    /// The start of a printed row: the workload's label, its size and its speed.
    pub(crate) fn text(&self, label: &str, steps: usize) -> String {
        let cpu = match self.cpu_seconds {
            Some(c) => format!("{:>9.0}/CPU-s ({c:.2} CPU-s)", self.per_second(steps, c)),
            None => "CPU time unknown".into(),
        };
        format!(
            "pile  {label:<8} N={:<5} threads={:<2} {:>9.0} ragdoll-steps/s ({:.2} s wall)  {cpu}",
            self.ragdolls,
            self.threads,
            self.per_second(steps, self.seconds),
            self.seconds,
        )
    }

    /// The fields of a run's JSON that say how fast it went.
    pub(crate) fn json(&self, steps: usize) -> serde_json::Value {
        json!({
            "ragdolls": self.ragdolls,
            "threads": self.threads,
            "steps": steps,
            "wall_seconds": self.seconds,
            "cpu_seconds": self.cpu_seconds,
            "ragdoll_steps_per_second": self.per_second(steps, self.seconds),
            "ragdoll_steps_per_cpu_second": self.cpu_seconds.map(|c| self.per_second(steps, c)),
        })
    }

    /// How many times as many ragdoll-steps per CPU-second this run did as `base` (same
    /// sizes and steps).
    pub(crate) fn cpu_ratio(&self, base: &Timing) -> Option<f64> {
        match (self.cpu_seconds, base.cpu_seconds) {
            (Some(c), Some(b)) if c > 0.0 => Some(b / c),
            _ => None,
        }
    }
}

struct Row {
    timing: Timing,
    metrics: Metrics,
    /// After the last step, when the piles have settled: the deepest overlap in the poses
    /// (bodies in each other or in the ground, measured from the shapes, not the solver's
    /// contacts: [`World::overlap_now`]), metres, and the fastest body's speed, m/s (how
    /// much at rest the piles are).
    end_overlap_m: f32,
    end_fastest_mps: f32,
    /// Seconds until every joint of every ragdoll moves slower than 0.1 m/s for the
    /// rest of the run (read from the recorded frames after the timing); `None` when
    /// something still moves at the end.
    rest_after_s: Option<f32>,
}

pub fn run(a: &BenchArgs) -> Result<()> {
    if let Some(variants) = a.farm {
        return crate::bench_farm::run(variants, a.json);
    }
    let threads = check_args(a)?;
    let piles = Piles {
        height: a.pile_height,
        motors: a.motors,
    };
    let character = posed(skeleton::humanoid(), piles.motors.is_some());
    let spec = spec::build_spec(&character, &BuildOptions::default())?;
    let backend = a.backend.backend;
    if a.compare && backend == BackendKind::Rigid {
        bail!(
            "--compare runs the rigid backend beside another one: choose that one with --backend"
        );
    }
    let mut runs = Vec::new();
    let progress = Progress::new(0, "bench");
    for &n in &a.ragdolls {
        for &t in &threads {
            let mut engine = crate::commands::engine(backend, !a.no_freeze);
            if let Some(f) = engine.fast_mut() {
                f.substeps = a.fast_substeps;
                f.keep_contacts = a.keep_contacts;
                f.iterations = a.fast_iterations;
                f.impact_passes = a.impact_passes;
            }
            let settings = WorldSettings {
                backend: engine,
                ..Default::default()
            };
            let row = run_pile(
                &character,
                &spec,
                &settings,
                piles,
                (n, t, a.steps),
                &progress,
            )?;
            let base = if a.compare {
                let rigid = WorldSettings {
                    backend: BackendKind::Rigid.into(),
                    ..settings
                };
                Some(run_pile(
                    &character,
                    &spec,
                    &rigid,
                    piles,
                    (n, t, a.steps),
                    &progress,
                )?)
            } else {
                None
            };
            let ratio = base.as_ref().and_then(|b| row.timing.cpu_ratio(&b.timing));
            let plain = if a.reference {
                Some(crate::bench_reference::run_plain_pile(
                    piles, n, t, a.steps, &progress,
                )?)
            } else {
                None
            };
            if !a.json {
                progress.suspend(|| {
                    print_row(&row, backend.as_str(), a.steps);
                    if let Some(b) = &base {
                        print_row(b, BackendKind::Rigid.as_str(), a.steps);
                        match ratio {
                            Some(r) => outln!(
                                "      {} / rigid: {r:.2}× the ragdoll-steps per CPU-second",
                                backend.as_str()
                            ),
                            None => outln!("      {} / rigid: CPU time unknown", backend.as_str()),
                        }
                    }
                    if let Some(p) = &plain {
                        crate::bench_reference::print_beside(p, &row.timing, backend, a.steps);
                    }
                });
            }
            let mut run = run_json(&row, backend, a.steps);
            let fast = settings.backend.fast();
            run["freeze_joints"] = json!(fast.is_some_and(|f| f.freeze_joints));
            run["fast_substeps"] = json!(fast.map(|f| f.substeps));
            run["keep_contacts"] = json!(fast.is_some_and(|f| f.keep_contacts));
            run["fast_iterations"] = json!(fast.map(|f| f.iterations));
            run["fast_impact_passes"] = json!(fast.map(|f| f.impact_passes));
            run["pile_height"] = json!(piles.height);
            run["motors"] = json!(piles.motors);
            if let Some(b) = &base {
                run["rigid"] = run_json(b, BackendKind::Rigid, a.steps);
                run["cpu_ratio_to_rigid"] = json!(ratio);
            }
            if let Some(p) = &plain {
                run["plain_rapier"] = p.json(a.steps);
                run["cpu_ratio_to_plain_rapier"] = json!(row.timing.cpu_ratio(&p.timing));
            }
            runs.push(run);
        }
    }
    progress.finish();
    if a.json {
        outln!(
            "{}",
            serde_json::to_string_pretty(&json!({ "runs": runs }))?
        );
    }
    Ok(())
}

/// Refuses flags out of range before any work; returns the thread counts to run.
fn check_args(a: &BenchArgs) -> Result<Vec<usize>> {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut threads = a.threads.clone();
    if threads.is_empty() {
        threads = if cores > 1 { vec![1, cores] } else { vec![1] };
    }
    if threads.iter().any(|&t| t == 0 || t > 1024) {
        bail!("--threads: each count must be between 1 and 1024");
    }
    // Each size runs once per thread count, once more each on the rigid backend with
    // --compare and on plain rapier with --reference.
    check_size(
        &a.ragdolls,
        a.steps,
        threads.len() * (1 + usize::from(a.compare) + usize::from(a.reference)),
    )?;
    if !(1..=MAX_SUBSTEPS).contains(&a.fast_substeps) {
        bail!(
            "--fast-substeps: must be between 1 and {MAX_SUBSTEPS}, not {}",
            a.fast_substeps
        );
    }
    if !(1..=MAX_FAST_ITERATIONS).contains(&a.fast_iterations) {
        bail!(
            "--fast-iterations: must be between 1 and {MAX_FAST_ITERATIONS}, not {}",
            a.fast_iterations
        );
    }
    if a.impact_passes > MAX_FAST_ITERATIONS {
        bail!(
            "--impact-passes: must be between 0 and {MAX_FAST_ITERATIONS}, not {}",
            a.impact_passes
        );
    }
    if !(1..=MAX_PILE_HEIGHT).contains(&a.pile_height) {
        bail!(
            "--pile-height: must be between 1 and {MAX_PILE_HEIGHT}, not {}",
            a.pile_height
        );
    }
    if let Some(m) = a.motors
        && !(0.0..=1.0).contains(&m)
    {
        bail!("--motors: the strength must be between 0 and 1, not {m}");
    }
    if a.motors.is_some() && a.reference {
        bail!("--motors: the plain rapier workload of --reference has no motors; run them apart");
    }
    Ok(threads)
}

/// Refuses sizes that cannot finish in reasonable time or memory, before any work: each
/// count at most [`MAX_RAGDOLLS`], and the whole run (every count, `runs_each` times) at
/// most [`MAX_RAGDOLL_STEPS`]; a long list of counts is as much work as one large count.
fn check_size(ragdolls: &[usize], steps: usize, runs_each: usize) -> Result<()> {
    if ragdolls.is_empty() || ragdolls.iter().any(|&n| n == 0 || n > MAX_RAGDOLLS) {
        bail!(
            "--ragdolls: each count must be between 1 and {MAX_RAGDOLLS} (about 90 KB of memory per ragdoll, and building a world grows faster than its size)"
        );
    }
    if steps == 0 {
        bail!("--steps: must be at least 1");
    }
    let ragdolls_in_all = ragdolls
        .iter()
        .fold(0u64, |sum, &n| sum.saturating_add(n as u64))
        .saturating_mul(runs_each as u64);
    let work = ragdolls_in_all.saturating_mul(steps as u64);
    if work > MAX_RAGDOLL_STEPS {
        let minutes = work as f64 / RIGID_STEPS_PER_SECOND / 60.0;
        bail!(
            "--ragdolls {} run {runs_each} time(s) each (once per thread count, once more each with --compare and --reference) with --steps {steps} is {work} ragdoll-steps in all, about {minutes:.0} minutes on one core at the {RIGID_STEPS_PER_SECOND} ragdoll-steps a second a rigid pile runs at; a run may do at most {MAX_RAGDOLL_STEPS}",
            summary(ragdolls)
        );
    }
    Ok(())
}

/// A list of counts as the message quotes it: the first few, then how many more.
fn summary(ragdolls: &[usize]) -> String {
    let shown: Vec<String> = ragdolls.iter().take(4).map(|n| n.to_string()).collect();
    match ragdolls.len() {
        0..=4 => shown.join(","),
        n => format!("{},... ({n} counts)", shown.join(",")),
    }
}

/// One run as the JSON output lists it.
fn run_json(r: &Row, backend: BackendKind, steps: usize) -> serde_json::Value {
    let mut run = json!({
        "workload": "pile",
        "backend": backend.as_str(),
        "stable": stable(&r.metrics),
        "metrics": r.metrics,
        "end_overlap_m": r.end_overlap_m,
        "end_fastest_body_mps": r.end_fastest_mps,
        "rest_after_s": r.rest_after_s,
    });
    merge(&mut run, r.timing.json(steps));
    run
}

/// Adds the fields of the JSON object `more` to the object `into`.
pub(crate) fn merge(into: &mut serde_json::Value, more: serde_json::Value) {
    if let (Some(into), serde_json::Value::Object(more)) = (into.as_object_mut(), more) {
        into.extend(more);
    }
}

fn stable(m: &Metrics) -> bool {
    !m.nan && m.max_joint_separation_m < 0.05 && m.max_penetration_m < 0.1
}

fn print_row(r: &Row, backend: &str, steps: usize) {
    let m = &r.metrics;
    outln!(
        "{}  stable={}  limit {:.1}° (solver {:.1}°)  penetration {:.1} mm (at the end {:.1} mm, fastest body {:.2} m/s)  separation {:.1} mm  energy gain {:.2} % (most in a frame)  {}",
        r.timing.text(backend, steps),
        stable(m),
        m.max_limit_violation_deg,
        m.max_limit_violation_solver_deg,
        m.max_penetration_m * 1000.0,
        r.end_overlap_m * 1000.0,
        r.end_fastest_mps,
        m.max_joint_separation_m * 1000.0,
        m.energy_drift * 100.0,
        match r.rest_after_s {
            Some(t) => format!("at rest after {t:.2} s"),
            None => "still moving at the end".into(),
        },
    );
}

/// Steps every world `steps` times, each on a thread of a pool of `threads`, and times it:
/// one way of timing for every workload, so that their ratio is of the engines alone.
pub(crate) fn step_timed<W: Send>(
    worlds: &mut [W],
    n: usize,
    threads: usize,
    steps: usize,
    progress: &Progress,
    step: impl Fn(&mut W) + Sync,
) -> Result<Timing> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    progress.stage(
        (worlds.len() * steps) as u64,
        &format!("N={n} threads={threads}: stepping"),
    );
    let started = Instant::now();
    let cpu_started = ProcessTime::try_now().ok();
    pool.install(|| {
        worlds.par_iter_mut().for_each(|w| {
            crate::fatal::debug_panic_point("worker");
            for _ in 0..steps {
                step(w);
                progress.inc(1);
            }
        })
    });
    Ok(Timing {
        ragdolls: n,
        threads,
        seconds: started.elapsed().as_secs_f64(),
        cpu_seconds: cpu_started.map(|t| t.elapsed().as_secs_f64()),
    })
}

fn run_pile(
    character: &skeleton::Character,
    spec: &spec::RagdollSpec,
    settings: &WorldSettings,
    piles: Piles,
    (n, threads, steps): (usize, usize, usize),
    progress: &Progress,
) -> Result<Row> {
    progress.stage(n as u64, &format!("N={n} threads={threads}: building"));
    let mut worlds = Vec::new();
    for share in piles.world_shares(n, threads) {
        let mut world = World::new(settings)?;
        let mut ids = Vec::new();
        for i in share {
            let id = world.add_ragdoll(character, spec, piles.placement(i, n))?;
            if let Some(strength) = piles.motors {
                world.set_motors(id, Motors::constant(strength))?;
            }
            ids.push(id);
            progress.inc(1);
        }
        worlds.push((world, ids));
    }
    let timing = step_timed(&mut worlds, n, threads, steps, progress, |(w, _)| w.step())?;
    let mut metrics = Metrics::default();
    let (mut end_overlap_m, mut end_fastest_mps) = (0.0f32, 0.0f32);
    for (w, ids) in &worlds {
        end_overlap_m = end_overlap_m.max(w.overlap_now());
        for &id in ids {
            for (v, _) in w.body_velocities(id) {
                end_fastest_mps = end_fastest_mps.max(v.length());
            }
        }
        let m = w.metrics();
        metrics.max_limit_violation_deg = metrics
            .max_limit_violation_deg
            .max(m.max_limit_violation_deg);
        metrics.max_limit_violation_solver_deg = metrics
            .max_limit_violation_solver_deg
            .max(m.max_limit_violation_solver_deg);
        metrics.max_penetration_m = metrics.max_penetration_m.max(m.max_penetration_m);
        metrics.max_joint_separation_m =
            metrics.max_joint_separation_m.max(m.max_joint_separation_m);
        metrics.max_joint_separation_solver_m = metrics
            .max_joint_separation_solver_m
            .max(m.max_joint_separation_solver_m);
        metrics.energy_drift = metrics.energy_drift.max(m.energy_drift);
        metrics.max_bone_stretch = metrics.max_bone_stretch.max(m.max_bone_stretch);
        metrics.nan |= m.nan;
    }
    let rest_after_s = worlds
        .iter()
        .flat_map(|(w, ids)| ids.iter().map(move |&id| rest_after_s(w.track(id))))
        .try_fold(0.0f32, |latest, t| t.map(|t| latest.max(t)));
    Ok(Row {
        timing,
        metrics,
        end_overlap_m,
        end_fastest_mps,
        rest_after_s,
    })
}
