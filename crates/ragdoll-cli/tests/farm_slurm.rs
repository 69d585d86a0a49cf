//! The Slurm scripts `ragdoll plan` writes, run on a real (one-node) Slurm cluster:
//! `.ci/slurm_cluster.sh` starts munged, slurmctld and slurmd under a temporary folder,
//! `JOB/slurm/submit.sh` submits the array job and its `afterok` merge, and every
//! variant's outputs must be the bytes that `run-task` on one machine and a single
//! `ragdoll simulate` of its `--variant` scene give. Needs Debian's slurm-wlm and munge
//! and root; `.ci/run` installs them and runs this test in a step of its own. Where the
//! cluster cannot start, the (ignored) test fails with the script's reason.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

mod common;

use common::*;

/// How long the jobs may take, from submission to the merge's end.
const JOBS_TIMEOUT: Duration = Duration::from_secs(300);

fn ok(dir: &Path, args: &[&str]) -> Output {
    let o = ragdoll(dir, args);
    assert!(o.status.success(), "ragdoll {args:?}: {}", stderr(&o));
    o
}

fn script() -> PathBuf {
    repo().join(".ci/slurm_cluster.sh")
}

/// A cluster started by `.ci/slurm_cluster.sh start DIR`; dropping it (a panic included)
/// cancels the jobs left in it and stops its daemons.
struct Cluster {
    dir: PathBuf,
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        let o = Command::new("bash")
            .arg(script())
            .arg("start")
            .arg(dir)
            .output()
            .expect("bash runs .ci/slurm_cluster.sh");
        let cluster = Cluster {
            dir: dir.to_path_buf(),
        };
        assert!(
            o.status.success(),
            "the one-node Slurm cluster did not start (see .ci/slurm_cluster.sh):\n{}{}",
            String::from_utf8_lossy(&o.stdout),
            stderr(&o)
        );
        cluster
    }

    fn conf(&self) -> PathBuf {
        self.dir.join("slurm.conf")
    }

    /// A Slurm client command pointed at this cluster.
    fn client(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", self.conf());
        c
    }

    /// The jobs still in the queue, one `ID STATE REASON` line each.
    fn queue(&self) -> Vec<String> {
        let o = self
            .client("squeue")
            .args(["-h", "-o", "%i %T %r"])
            .output()
            .expect("squeue runs");
        assert!(o.status.success(), "squeue: {}", stderr(&o));
        String::from_utf8_lossy(&o.stdout)
            .lines()
            .map(String::from)
            .collect()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        // Without a slurm.conf (the start failed early), squeue would look for a
        // controller in DNS for a minute.
        if self.conf().is_file() {
            let left: Vec<String> = self
                .client("squeue")
                .args(["-h", "-o", "%i"])
                .output()
                .map(|o| {
                    String::from_utf8_lossy(&o.stdout)
                        .lines()
                        .map(String::from)
                        .collect()
                })
                .unwrap_or_default();
            if !left.is_empty() {
                let _ = self.client("scancel").args(left).status();
            }
        }
        let stopped = Command::new("bash")
            .arg(script())
            .arg("stop")
            .arg(&self.dir)
            .status();
        if !stopped.is_ok_and(|s| s.success()) {
            eprintln!(
                "could not stop the Slurm cluster of {}: run .ci/slurm_cluster.sh stop on it",
                self.dir.display()
            );
        }
    }
}

/// Every `.glb` and `.bvh` in `dir`, sorted.
fn outputs(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".glb") || n.ends_with(".bvh"))
        .collect();
    v.sort();
    v
}

/// The job's Slurm logs, for a failure's message.
fn logs(job: &Path) -> String {
    let mut text = String::new();
    if let Ok(entries) = std::fs::read_dir(job.join("slurm")) {
        let mut paths: Vec<PathBuf> = entries.map(|e| e.unwrap().path()).collect();
        paths.sort();
        for p in paths
            .iter()
            .filter(|p| p.extension().is_some_and(|e| e == "log"))
        {
            let log = std::fs::read_to_string(p).unwrap_or_default();
            text.push_str(&format!("---- {}\n{log}", p.display()));
        }
    }
    text
}

#[test]
#[ignore = "needs a one-node Slurm cluster: .ci/run starts one as root"]
fn slurm_cluster_runs_the_job_to_the_bytes_of_one_machine() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("shot.toml"), SHOT).unwrap();
    ok(d, &["plan", "shot.toml", "--tasks", "2", "-o", "farm"]);
    ok(d, &["plan", "shot.toml", "--tasks", "2", "-o", "local"]);
    let job = d.join("farm");
    let cluster = Cluster::start(&d.join("cluster"));

    let submit = cluster
        .client("sh")
        .arg(job.join("slurm/submit.sh"))
        .env("RAGDOLL", env!("CARGO_BIN_EXE_ragdoll"))
        .output()
        .unwrap();
    assert!(submit.status.success(), "submit.sh: {}", stderr(&submit));
    let merge_id = String::from_utf8_lossy(&submit.stdout).trim().to_string();
    assert!(
        !merge_id.is_empty() && merge_id.split(';').next().unwrap().parse::<u64>().is_ok(),
        "submit.sh printed no merge job id: {merge_id:?}"
    );

    let start = Instant::now();
    loop {
        let queue = cluster.queue();
        if queue.is_empty() {
            break;
        }
        // A failed task leaves the merge waiting forever: say so at once.
        assert!(
            !queue.iter().any(|l| l.contains("DependencyNeverSatisfied")),
            "a task failed, so the merge will never run: {queue:?}\n{}",
            logs(&job)
        );
        assert!(
            start.elapsed() < JOBS_TIMEOUT,
            "the jobs were not done after {JOBS_TIMEOUT:?}: {queue:?}\n{}",
            logs(&job)
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    eprintln!("the farm job took {:.1} s", start.elapsed().as_secs_f64());
    for log in ["task-0.log", "task-1.log", "merge.log"] {
        assert!(
            job.join("slurm").join(log).is_file(),
            "slurm/{log} is missing\n{}",
            logs(&job)
        );
    }
    let csv = std::fs::read_to_string(job.join("results.csv"))
        .unwrap_or_else(|e| panic!("the merge wrote no results.csv ({e})\n{}", logs(&job)));
    let sheet = std::fs::read(job.join("contact-sheet-001.png")).unwrap();
    assert_eq!(&sheet[1..4], b"PNG");
    drop(cluster);

    // The same plan's tasks on this machine, and each variant simulated alone.
    for t in ["0", "1"] {
        ok(d, &["run-task", "local/plan.json", "--task", t]);
    }
    let list = ok(d, &["wedge", "shot.toml", "--list"]);
    let names: Vec<String> = String::from_utf8_lossy(&list.stdout)
        .lines()
        .map(|l| l.split('\t').next().unwrap().to_string())
        .collect();
    assert_eq!(names.len(), 4, "{names:?}");
    assert_eq!(
        csv.lines().count(),
        names.len() + 1,
        "one row a variant:\n{csv}"
    );
    for name in &names {
        assert!(
            csv.lines().any(|l| l.starts_with(&format!("\"{name}\","))),
            "no row for {name}:\n{csv}"
        );
        let scene = format!("alone/{name}/scene.toml");
        let out = format!("alone/{name}/out");
        ok(d, &["wedge", "shot.toml", "--variant", name, "-o", &scene]);
        ok(d, &["simulate", &scene, "-o", &out]);
        let farm = job.join("variants").join(name);
        let local = d.join("local/variants").join(name);
        let alone = d.join(&out);
        let files = outputs(&farm);
        assert_eq!(files, ["ann.bvh", "ben.bvh", "scene.glb"], "{name}");
        assert_eq!(outputs(&local), files, "{name} on one machine");
        assert_eq!(outputs(&alone), files, "{name} simulated alone");
        for f in &files {
            let bytes = std::fs::read(farm.join(f)).unwrap();
            assert!(
                bytes == std::fs::read(local.join(f)).unwrap(),
                "{name}/{f} differs between the farm and run-task on one machine"
            );
            assert!(
                bytes == std::fs::read(alone.join(f)).unwrap(),
                "{name}/{f} differs between the farm and a simulate of its variant scene"
            );
        }
    }
}
