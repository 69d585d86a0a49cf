//! Wedges and farm jobs end to end, on the real binary: `wedge --list` and `--variant`,
//! `plan`, `run-task` and `merge`, with the faults a farm deals in (a task killed mid
//! variant, two runs of one task at once, an input edited after planning, a truncated
//! manifest). Scenes are two built-in humanoids for 0.3 s at 10 fps, so each variant takes
//! a fraction of a second. The Open Job Description checks need `openjd` (openjd-cli from
//! PyPI, which `.ci/run` installs) and are ignored tests.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

mod common;

use common::*;

/// A temporary folder holding `shot.toml`, with `tail` added at its end.
fn shot(tail: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("shot.toml"), format!("{SHOT}{tail}")).unwrap();
    dir
}

fn ok(dir: &Path, args: &[&str]) -> Output {
    let o = ragdoll(dir, args);
    assert!(o.status.success(), "ragdoll {args:?}: {}", stderr(&o));
    o
}

fn fails(dir: &Path, args: &[&str]) -> String {
    let o = ragdoll(dir, args);
    assert_eq!(o.status.code(), Some(1), "ragdoll {args:?}: {}", stderr(&o));
    stderr(&o)
}

fn stdout_lines(o: &Output) -> Vec<String> {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(String::from)
        .collect()
}

/// The names of the variants, from `wedge --list`.
fn names(dir: &Path) -> Vec<String> {
    let o = ok(dir, &["wedge", "shot.toml", "--list"]);
    stdout_lines(&o)
        .iter()
        .map(|l| l.split('\t').next().unwrap().to_string())
        .collect()
}

/// Plans `shot.toml` into `job` and runs every task.
fn plan_and_run(dir: &Path, tasks: usize) {
    ok(
        dir,
        &[
            "plan",
            "shot.toml",
            "--tasks",
            &tasks.to_string(),
            "-o",
            "job",
        ],
    );
    for t in 0..tasks {
        ok(
            dir,
            &["run-task", "job/plan.json", "--task", &t.to_string()],
        );
    }
}

/// The entries of `job/variants`, sorted (none before the first task makes it).
fn variants(dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(dir.join("job/variants")) else {
        return Vec::new();
    };
    let mut v: Vec<String> = entries
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn cross_and_zip_list_their_variants_with_unique_names() {
    let cross = shot("");
    let n = names(cross.path());
    assert_eq!(n.len(), 4, "{n:?}");
    assert_eq!(n[1], "1_tnt_kg=0.5_at=0.5,0.3,0.5");
    let zip = shot("[wedge]\nmode = \"zip\"\n");
    let z = names(zip.path());
    assert_eq!(z, ["0_tnt_kg=0.5_at=0,0.3,0", "1_tnt_kg=2_at=0.5,0.3,0.5"]);
    let json = ok(zip.path(), &["wedge", "shot.toml", "--list", "--json"]);
    let list: Value = serde_json::from_slice(&json.stdout).unwrap();
    assert_eq!(list[1]["values"]["blast[0].tnt_kg"], 2.0);
    let err = fails(
        zip.path(),
        &["wedge", "shot.toml", "--variant", "7", "-o", "v.toml"],
    );
    assert!(err.contains("no variant is called \"7\""), "{err}");
    assert!(!zip.path().join("v.toml").exists());
}

#[test]
fn a_variant_run_alone_gives_the_bytes_the_job_gave() {
    let dir = shot("");
    let d = dir.path();
    plan_and_run(d, 3);
    let name = "3_tnt_kg=2_at=0.5,0.3,0.5";
    ok(
        d,
        &[
            "wedge",
            "shot.toml",
            "--variant",
            name,
            "-o",
            "alone/scene.toml",
        ],
    );
    ok(d, &["simulate", "alone/scene.toml", "-o", "alone/out"]);
    let job = d.join("job/variants").join(name);
    for f in ["scene.glb", "ann.bvh", "ben.bvh"] {
        let (a, b) = (
            std::fs::read(job.join(f)).unwrap(),
            std::fs::read(d.join("alone/out").join(f)).unwrap(),
        );
        assert!(a == b, "{f} differs between the job and a run alone");
    }
    assert_eq!(
        std::fs::read(job.join("scene.toml")).unwrap(),
        std::fs::read(d.join("alone/scene.toml")).unwrap()
    );
    // The report differs only in what says where and how long it ran.
    let strip = |p: PathBuf| {
        let mut r = read_json(&p);
        for key in ["scene", "wall_seconds"] {
            r.as_object_mut().unwrap().remove(key);
        }
        r
    };
    assert_eq!(
        strip(job.join("report.json")),
        strip(d.join("alone/out/report.json"))
    );
}

#[test]
fn merge_writes_one_row_per_variant_with_its_values() {
    let dir = shot("");
    let d = dir.path();
    plan_and_run(d, 2);
    ok(d, &["merge", "job", "--no-sheet"]);
    assert!(d.join("job/results.json").exists());
    assert!(!d.join("job/contact-sheet-001.png").exists(), "--no-sheet");
    ok(d, &["merge", "job"]);
    let csv = std::fs::read_to_string(d.join("job/results.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines.len(), 5, "{csv}");
    assert!(
        lines[0].starts_with("variant,index,task,tnt_kg,at,wall_s,cpu_s,peak_rss_kib,"),
        "{}",
        lines[0]
    );
    assert!(lines[0].contains("max_penetration_m"), "{}", lines[0]);
    assert!(
        lines[4].starts_with("\"3_tnt_kg=2_at=0.5,0.3,0.5\",3,1,2.0,\"[0.5,0.3,0.5]\","),
        "{}",
        lines[4]
    );
    let json = read_json(&d.join("job/results.json"));
    assert_eq!(json.as_array().unwrap().len(), 4);
    assert_eq!(json[2]["values"]["blast[0].tnt_kg"], 2.0);
    assert!(json[2]["max_penetration_m"].is_number());
    let sheet = std::fs::read(d.join("job/contact-sheet-001.png")).unwrap();
    assert_eq!(&sheet[1..4], b"PNG");
    assert!(
        !d.join("job/contact-sheet-002.png").exists(),
        "4 variants fit one page"
    );
}

/// The farm benchmark runs the real commands (its numbers are for `docs/src/farm.md`, not
/// asserted here): every cost measured, every variant but the tasks' made from theirs.
#[test]
fn bench_farm_plans_runs_and_merges_a_wedge() {
    let dir = tempfile::tempdir().unwrap();
    let o = ok(dir.path(), &["bench", "--farm", "5", "--json"]);
    let r: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(r["variants"], 5);
    assert_eq!(r["variants_linked"], 2, "three tasks run for real");
    for step in ["plan", "task", "merge_tables", "merge_with_sheet"] {
        assert!(r[step]["wall_s"].as_f64().unwrap() > 0.0, "{step}: {r}");
    }
    assert!(r["task_simulation_s"].as_f64().unwrap() > 0.0, "{r}");
    let refused = fails(dir.path(), &["bench", "--farm", "0"]);
    assert!(refused.contains("--farm"), "{refused}");
}

#[test]
fn an_input_edited_after_planning_is_refused_by_name() {
    let dir = shot("");
    let d = dir.path();
    ok(d, &["plan", "shot.toml", "--tasks", "2", "-o", "job"]);
    let mut text = std::fs::read_to_string(d.join("shot.toml")).unwrap();
    text.push_str("# edited\n");
    std::fs::write(d.join("shot.toml"), text).unwrap();
    let err = fails(d, &["run-task", "job/plan.json", "--task", "0"]);
    assert!(
        err.contains("shot.toml: changed since the job was planned"),
        "{err}"
    );
    assert!(!d.join("job/variants").exists(), "nothing ran");
    let again = fails(d, &["plan", "shot.toml", "--tasks", "2", "-o", "job"]);
    assert!(again.contains("already holds a plan.json"), "{again}");
}

#[test]
fn merge_refuses_a_truncated_or_missing_manifest_naming_the_variant() {
    let dir = shot("");
    let d = dir.path();
    plan_and_run(d, 1);
    let name = "2_tnt_kg=2_at=0,0.3,0";
    let manifest = d.join("job/variants").join(name).join("manifest.json");
    let bytes = std::fs::read(&manifest).unwrap();
    std::fs::write(&manifest, &bytes[..bytes.len() / 2]).unwrap();
    let err = fails(d, &["merge", "job"]);
    assert!(
        err.contains(&format!("variant {name}: ")) && err.contains("corrupt manifest"),
        "{err}"
    );
    assert!(!d.join("job/results.csv").exists(), "nothing merged");
    // An output changed after its manifest was written is refused too.
    std::fs::write(&manifest, &bytes).unwrap();
    std::fs::write(manifest.with_file_name("ann.bvh"), "HIERARCHY\n").unwrap();
    let err = fails(d, &["merge", "job"]);
    assert!(
        err.contains("ann.bvh: differs from the hash in its manifest"),
        "{err}"
    );
    // A rerun remakes the bad variant; then the job merges.
    ok(d, &["run-task", "job/plan.json", "--task", "0"]);
    std::fs::remove_dir_all(d.join("job/variants/0_tnt_kg=0.5_at=0,0.3,0")).unwrap();
    let err = fails(d, &["merge", "job"]);
    assert!(
        err.contains("variant 0_tnt_kg=0.5_at=0,0.3,0: not run yet"),
        "{err}"
    );
}

#[test]
fn a_task_killed_mid_variant_leaves_nothing_half_written_and_a_rerun_finishes() {
    let dir = shot("");
    let d = dir.path();
    ok(d, &["plan", "shot.toml", "--tasks", "1", "-o", "job"]);
    let mut child = Command::new(env!("CARGO_BIN_EXE_ragdoll"))
        .current_dir(d)
        .args(["run-task", "job/plan.json", "--task", "0"])
        .env("RAGDOLL_DEBUG_STALL", "variant-written")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let written = |v: &str| d.join("job/variants").join(v).join("scene.glb").exists();
    loop {
        let tmp = variants(d).into_iter().find(|v| v.starts_with(".tmp-"));
        if tmp.as_deref().is_some_and(written) {
            break;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the task never stalled"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let left = variants(d);
    assert_eq!(
        left.len(),
        1,
        "only the killed task's temporary folder: {left:?}"
    );
    assert!(left[0].starts_with(".tmp-0_"), "{left:?}");
    let err = fails(d, &["merge", "job"]);
    assert!(
        err.contains("variant 0_tnt_kg=0.5_at=0,0.3,0: not run yet"),
        "{err}"
    );
    ok(d, &["run-task", "job/plan.json", "--task", "0"]);
    let merged = ok(d, &["merge", "job"]);
    let note = stderr(&merged);
    assert!(
        note.contains("note: 1 temporary folder of killed tasks"),
        "{note}"
    );
    assert_eq!(
        variants(d).iter().filter(|v| !v.starts_with('.')).count(),
        4
    );
}

#[test]
fn two_runs_of_one_task_at_once_both_end_well() {
    let dir = shot("");
    let d = dir.path();
    ok(d, &["plan", "shot.toml", "--tasks", "1", "-o", "job"]);
    let spawn = || {
        Command::new(env!("CARGO_BIN_EXE_ragdoll"))
            .current_dir(d)
            .args(["run-task", "job/plan.json", "--task", "0"])
            .output()
    };
    let (a, b) = std::thread::scope(|s| {
        let a = s.spawn(spawn);
        let b = s.spawn(spawn);
        (a.join().unwrap().unwrap(), b.join().unwrap().unwrap())
    });
    assert!(a.status.success(), "{}", stderr(&a));
    assert!(b.status.success(), "{}", stderr(&b));
    ok(d, &["merge", "job"]);
    assert_eq!(
        variants(d).len(),
        4,
        "no temporary folder is left: {:?}",
        variants(d)
    );
}

/// `openjd`: `$OPENJD`, else on the PATH; a missing one fails the (ignored) test, naming
/// how to get it.
fn openjd() -> PathBuf {
    let bin = std::env::var_os("OPENJD").map_or_else(|| PathBuf::from("openjd"), PathBuf::from);
    let found = Command::new(&bin).arg("--version").output();
    assert!(
        found.is_ok_and(|o| o.status.success()),
        "{} is missing: pip install openjd-cli (into a venv; .ci/run does), or set OPENJD",
        bin.display()
    );
    bin
}

#[test]
#[ignore = "needs openjd (pip install openjd-cli; .ci/run installs it)"]
fn the_openjd_template_checks_and_runs_the_whole_job() {
    let openjd = openjd();
    let dir = shot("");
    let d = dir.path();
    ok(d, &["plan", "shot.toml", "--tasks", "3", "-o", "job"]);
    let check = Command::new(&openjd)
        .args(["check", "job/job.openjd.yaml"])
        .current_dir(d)
        .output()
        .unwrap();
    assert!(
        check.status.success(),
        "{}",
        String::from_utf8_lossy(&check.stdout)
    );
    let job = d.join("job").canonicalize().unwrap();
    let run = Command::new(&openjd)
        .args([
            "run",
            "job/job.openjd.yaml",
            "--step",
            "Merge",
            "--run-dependencies",
        ])
        .arg("-p")
        .arg(format!("JobDir={}", job.display()))
        .arg("-p")
        .arg(format!("Ragdoll={}", env!("CARGO_BIN_EXE_ragdoll")))
        .current_dir(d)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{log}");
    let csv = std::fs::read_to_string(job.join("results.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
}

#[test]
fn the_slurm_scripts_chain_the_merge_after_the_array() {
    let dir = shot("");
    let d = dir.path();
    ok(d, &["plan", "shot.toml", "--tasks", "3", "-o", "job"]);
    let run = std::fs::read_to_string(d.join("job/slurm/run.sbatch")).unwrap();
    assert!(run.contains("#SBATCH --array=0-2\n"), "{run}");
    assert!(
        run.contains("run-task plan.json --task \"$SLURM_ARRAY_TASK_ID\""),
        "{run}"
    );
    let submit = std::fs::read_to_string(d.join("job/slurm/submit.sh")).unwrap();
    assert!(submit.contains("--dependency=afterok:"), "{submit}");
    let plan = read_json(&d.join("job/plan.json"));
    assert_eq!(plan["tasks"].as_array().unwrap().len(), 3);
    assert_eq!(plan["inputs"][0]["path"], "../shot.toml");
    for sh in ["run.sbatch", "merge.sbatch", "submit.sh"] {
        let o = Command::new("sh")
            .arg("-n")
            .arg(d.join("job/slurm").join(sh))
            .output()
            .unwrap();
        assert!(o.status.success(), "{sh}: {}", stderr(&o));
    }
}

/// The example and the guide's wedge (its Wedges and farm jobs page) stay in step with
/// the parser.
#[test]
fn the_example_and_the_guide_wedge_list_their_variants() {
    let example = repo().join("examples/wedge_crowd.toml");
    let o = ok(&repo(), &["wedge", example.to_str().unwrap(), "--list"]);
    assert_eq!(stdout_lines(&o).len(), 6);
    let section = std::fs::read_to_string(repo().join("docs/src/wedges.md")).unwrap();
    let start = section.find("```toml\n").unwrap() + 8;
    let block = &section[start..start + section[start..].find("```").unwrap()];
    let dir = tempfile::tempdir().unwrap();
    let base = "[[blast]]\ntnt_kg = 1.0\nposition = [0.0, 0.3, 0.0]\n";
    std::fs::write(dir.path().join("shot.toml"), format!("{base}{block}")).unwrap();
    assert_eq!(names(dir.path())[4], "4_at=1.5,0.3,0_tnt_kg=1");
}

/// Character files a wedge names are hashed into the plan, found from the job folder and
/// from a variant written anywhere else, and an edited one is refused by name.
#[test]
fn character_files_are_hashed_and_found_from_anywhere() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    ok(d, &["demo", "-o", "made", "--seconds", "0.3"]);
    std::fs::create_dir_all(d.join("scenes/chars")).unwrap();
    std::fs::copy(d.join("made/demo.bvh"), d.join("scenes/chars/a.bvh")).unwrap();
    std::fs::copy(d.join("made/demo.bvh"), d.join("scenes/chars/b.bvh")).unwrap();
    let scene = "duration_s = 0.3\nfps = 10\nbackend = \"fast\"\n\
        [[character]]\nname = \"cat\"\nfile = \"chars/a.bvh\"\n\
        [[wedge.vary]]\nkey = \"character[0].file\"\nlabel = \"who\"\nvalues = [\"chars/a.bvh\", \"chars/b.bvh\"]\n";
    std::fs::write(d.join("scenes/shot.toml"), scene).unwrap();
    ok(
        d,
        &["plan", "scenes/shot.toml", "--tasks", "1", "-o", "jobs/one"],
    );
    let plan = read_json(&d.join("jobs/one/plan.json"));
    let inputs: Vec<&str> = plan["inputs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| i["path"].as_str().unwrap())
        .collect();
    assert_eq!(
        inputs,
        [
            "../../scenes/shot.toml",
            "../../scenes/chars/a.bvh",
            "../../scenes/chars/b.bvh"
        ]
    );
    ok(d, &["run-task", "jobs/one/plan.json", "--task", "0"]);
    let name = "1_who=chars-b.bvh";
    let job = d.join("jobs/one/variants").join(name);
    let written = std::fs::read_to_string(job.join("scene.toml")).unwrap();
    assert!(
        written.contains("file = \"../../../../scenes/chars/b.bvh\""),
        "{written}"
    );
    ok(
        d,
        &[
            "wedge",
            "scenes/shot.toml",
            "--variant",
            name,
            "-o",
            "x/y/v.toml",
        ],
    );
    ok(d, &["simulate", "x/y/v.toml", "-o", "x/out"]);
    for f in ["scene.glb", "cat.bvh"] {
        let same =
            std::fs::read(job.join(f)).unwrap() == std::fs::read(d.join("x/out").join(f)).unwrap();
        assert!(same, "{f} differs between the job and a run alone");
    }
    let mut edited = std::fs::read(d.join("scenes/chars/b.bvh")).unwrap();
    edited.extend_from_slice(b"\n");
    std::fs::write(d.join("scenes/chars/b.bvh"), edited).unwrap();
    let err = fails(d, &["run-task", "jobs/one/plan.json", "--task", "0"]);
    assert!(
        err.contains("chars/b.bvh: changed since the job was planned"),
        "{err}"
    );
}

#[test]
fn misuse_is_one_clear_line() {
    let dir = shot("");
    let d = dir.path();
    std::fs::write(d.join("plain.toml"), "duration_s = 0.3\n[[character]]\n").unwrap();
    let err = fails(d, &["wedge", "plain.toml", "--list"]);
    assert!(err.contains("plain.toml: has no [wedge] table"), "{err}");
    std::fs::write(
        d.join("far.toml"),
        SHOT.replace("values = [0.5, 2.0]", "values = [0.5, -2.0]"),
    )
    .unwrap();
    let err = fails(d, &["plan", "far.toml", "--tasks", "1", "-o", "job"]);
    assert!(
        err.contains("far.toml: variant 3_tnt_kg=-2_at=0.5,0.3,0.5 would not run"),
        "{err}"
    );
    assert!(err.contains("tnt_kg"), "{err}");
    // A bad value in the middle of a list is found too, not only at its ends.
    std::fs::write(
        d.join("mid.toml"),
        SHOT.replace("values = [0.5, 2.0]", "values = [0.5, -2.0, 2.0]"),
    )
    .unwrap();
    let err = fails(d, &["plan", "mid.toml", "--tasks", "1", "-o", "job"]);
    assert!(
        err.contains("variant 3_tnt_kg=-2_at=0.5,0.3,0.5 would not run"),
        "{err}"
    );
    let err = fails(d, &["plan", "shot.toml", "--tasks", "0", "-o", "job"]);
    assert!(err.contains("--tasks: must be at least 1"), "{err}");
    assert!(!d.join("job").exists());
    ok(d, &["plan", "shot.toml", "--tasks", "9", "-o", "job"]);
    let plan = read_json(&d.join("job/plan.json"));
    assert_eq!(
        plan["tasks"].as_array().unwrap().len(),
        4,
        "one task per variant at most"
    );
    let err = fails(d, &["run-task", "job/plan.json", "--task", "4"]);
    assert!(err.contains("--task 4: the plan has tasks 0 to 3"), "{err}");
    std::fs::write(d.join("job/plan.json"), "{\"format\": ").unwrap();
    let err = fails(d, &["run-task", "job/plan.json", "--task", "0"]);
    assert!(
        err.contains("job/plan.json: not a plan written by `ragdoll plan`"),
        "{err}"
    );
}

/// Variants made from other inputs than the plan's (the job planned again after an edit)
/// are stale: merge refuses them by name, and a task remakes them.
#[test]
fn a_stale_variant_is_refused_then_remade() {
    let dir = shot("");
    let d = dir.path();
    plan_and_run(d, 1);
    let mut text = std::fs::read_to_string(d.join("shot.toml")).unwrap();
    text.push_str("# edited\n");
    std::fs::write(d.join("shot.toml"), text).unwrap();
    std::fs::remove_file(d.join("job/plan.json")).unwrap();
    ok(d, &["plan", "shot.toml", "--tasks", "1", "-o", "job"]);
    let err = fails(d, &["merge", "job"]);
    assert!(
        err.contains("variant 0_tnt_kg=0.5_at=0,0.3,0: ") && err.contains("stale"),
        "{err}"
    );
    let rerun = ok(d, &["run-task", "job/plan.json", "--task", "0"]);
    assert!(stderr(&rerun).contains("remade"), "{}", stderr(&rerun));
    ok(d, &["merge", "job"]);
}

/// The README shows the example job's contact sheet and the commands that made it; the
/// picture keeps the size a fresh merge of the example gives (remake it with those
/// commands when the sheet's layout changes).
#[test]
fn the_readme_contact_sheet_is_the_example_jobs() {
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    for line in [
        "ragdoll plan examples/wedge_crowd.toml --tasks 3 -o out/wedge_job",
        "cp out/wedge_job/contact-sheet-001.png docs/wedge_contact_sheet.png",
        "(docs/wedge_contact_sheet.png)",
    ] {
        assert!(readme.contains(line), "the README lacks {line:?}");
    }
    let shown = std::fs::read(repo().join("docs/wedge_contact_sheet.png")).unwrap();
    assert!(shown.len() < 300_000, "{} bytes", shown.len());
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let example = repo().join("examples/wedge_crowd.toml");
    let example = example.to_str().unwrap();
    ok(d, &["plan", example, "--tasks", "1", "-o", "job"]);
    ok(d, &["run-task", "job/plan.json", "--task", "0"]);
    ok(d, &["merge", "job"]);
    let made = std::fs::read(d.join("job/contact-sheet-001.png")).unwrap();
    // A PNG's IHDR: width and height, big-endian, at bytes 16..24.
    assert_eq!(&shown[..24], &made[..24], "docs/wedge_contact_sheet.png");
}
