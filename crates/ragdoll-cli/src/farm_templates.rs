//! The farm-side files of a job folder: an Open Job Description template
//! (`jobtemplate-2023-09`) and Slurm batch scripts. Both run the same two commands, so
//! whichever scheduler runs the job, a variant is made by `ragdoll run-task` and the
//! results gathered by `ragdoll merge`, as on one machine.
//!
//! Paths: the template takes the job folder as its `JobDir` parameter, a `PATH`, which is
//! what a farm's path mapping rules rewrite between the submitting machine and the
//! workers; plan.json names every input relative to the job folder, so mapping that one
//! path maps them all. The Slurm scripts run from the job folder (`slurm/submit.sh`
//! changes into it), on a file system every node shares.

/// `ragdoll` on the workers: the `Ragdoll` parameter (OpenJD) or `$RAGDOLL` (Slurm)
/// names another binary.
const DEFAULT_BINARY: &str = "ragdoll";

/// The job's name as the schedulers show it: the scene's, in characters YAML and shell
/// scripts need no quoting for.
fn job_name(scene: &str) -> String {
    let clean: String = scene
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "_.-".contains(c) {
                c
            } else {
                '-'
            }
        })
        .take(64)
        .collect();
    format!("ragdoll-{clean}")
}

/// The Open Job Description template: a `Simulate` step with one task per plan task
/// (its `Task` parameter is the task index), and a `Merge` step that depends on it.
pub fn openjd(scene: &str, tasks: usize) -> String {
    let name = job_name(scene);
    let last = tasks.saturating_sub(1);
    format!(
        r#"# Open Job Description job template written by `ragdoll plan`.
#   openjd check job.openjd.yaml
#   openjd run job.openjd.yaml --step Simulate -p JobDir=$PWD   (then --step Merge)
# JobDir is this folder as the workers see it; a farm's path mapping rewrites it.
specificationVersion: jobtemplate-2023-09
name: {name}
parameterDefinitions:
- name: JobDir
  type: PATH
  objectType: DIRECTORY
  dataFlow: INOUT
  description: The job folder (holding plan.json) as the workers see it.
- name: Ragdoll
  type: STRING
  default: {DEFAULT_BINARY}
  description: The ragdoll command on the workers.
steps:
- name: Simulate
  parameterSpace:
    taskParameterDefinitions:
    - name: Task
      type: INT
      range: "0-{last}"
  script:
    actions:
      onRun:
        command: "{{{{Param.Ragdoll}}}}"
        args:
        - run-task
        - "{{{{Param.JobDir}}}}/plan.json"
        - --task
        - "{{{{Task.Param.Task}}}}"
- name: Merge
  dependencies:
  - dependsOn: Simulate
  script:
    actions:
      onRun:
        command: "{{{{Param.Ragdoll}}}}"
        args:
        - merge
        - "{{{{Param.JobDir}}}}"
"#
    )
}

/// The Slurm scripts, by file name: an array job of the tasks, the merge, and the
/// submission that chains them with `--dependency=afterok`.
pub fn slurm(scene: &str, tasks: usize) -> Vec<(&'static str, String)> {
    let name = job_name(scene);
    let last = tasks.saturating_sub(1);
    let run = format!(
        r#"#!/bin/sh
# One array element per task of plan.json; submitted by submit.sh from the job folder.
#SBATCH --job-name={name}
#SBATCH --array=0-{last}
#SBATCH --output=slurm/task-%a.log
set -eu
exec "${{RAGDOLL:-{DEFAULT_BINARY}}}" run-task plan.json --task "$SLURM_ARRAY_TASK_ID"
"#
    );
    let merge = format!(
        r#"#!/bin/sh
# Gathers every variant once all tasks have succeeded (submit.sh chains it).
#SBATCH --job-name={name}-merge
#SBATCH --output=slurm/merge.log
set -eu
exec "${{RAGDOLL:-{DEFAULT_BINARY}}}" merge .
"#
    );
    let submit = r#"#!/bin/sh
# Submits the tasks as an array job, and the merge to run after all of them succeed.
# RAGDOLL names the ragdoll binary on the nodes (default: ragdoll on the PATH).
set -eu
cd "$(dirname "$0")/.."
tasks=$(sbatch --parsable slurm/run.sbatch)
sbatch --parsable --dependency=afterok:"${tasks%%;*}" slurm/merge.sbatch
"#
    .to_string();
    vec![
        ("run.sbatch", run),
        ("merge.sbatch", merge),
        ("submit.sh", submit),
    ]
}
