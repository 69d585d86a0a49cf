//! `ragdoll merge JOB/`: gathers a finished job into one table. Every variant's manifest
//! is checked first (present, readable, made from the plan's inputs and values, every
//! output matching its hash); one that fails is refused naming the variant, and nothing is
//! written. The table, `results.csv` and `results.json`, puts each variant's wedge values
//! beside its report's metrics and what it cost to run; the contact sheet
//! (`contact-sheet-001.png`, ...; see `farm_sheet.rs`) shows every variant's preview.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use rayon::prelude::*;
use serde_json::{Map, Value, json};

use crate::farm::{Plan, read_capped};
use crate::farm_task::{MANIFEST, Manifest, variant_dir};
use crate::output::Staging;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The job folder (holding plan.json).
    job: PathBuf,
    /// Write the tables only, not the contact sheet (which decodes every variant's
    /// thumbnail): for a first look at a large job, or a merge run again after a fix.
    #[arg(long)]
    no_sheet: bool,
}

/// One row: a variant, its values, its cost and its report's metrics.
struct Row {
    values: Map<String, Value>,
    fields: Vec<(String, Value)>,
}

pub fn run(a: &MergeArgs) -> Result<()> {
    let plan = Plan::load(&a.job.join("plan.json"))?;
    let rows = check_all(&a.job, &plan)?;
    let mut staging = Staging::new();
    let csv = csv(&plan, &rows);
    staging.write(&a.job.join("results.csv"), csv.as_bytes())?;
    let text = serde_json::to_string_pretty(&results_json(&plan, &rows))?;
    staging.write(&a.job.join("results.json"), text.as_bytes())?;
    let pages = if a.no_sheet {
        Vec::new()
    } else {
        crate::farm_sheet::pages(&a.job, &plan)?
    };
    for (n, png) in pages.iter().enumerate() {
        let name = format!("contact-sheet-{:03}.png", n + 1);
        staging.write(&a.job.join(name), png)?;
    }
    for path in staging.commit()? {
        outln!("{}", path.display());
    }
    errln!("{}: {} variants merged", a.job.display(), rows.len());
    note_leftovers(&a.job);
    Ok(())
}

/// Every variant's row, in plan order; or an error naming the first variant refused (the
/// next 20 printed above it), so nothing is merged from a job with a bad variant.
fn check_all(job: &Path, plan: &Plan) -> Result<Vec<Row>> {
    // Checked in parallel: a check hashes every output, and 10,000 variants are gigabytes.
    let checked: Vec<Result<Row, String>> = plan
        .variants
        .par_iter()
        .map(|v| {
            let dir = variant_dir(job, &v.name);
            let manifest = if dir.join(MANIFEST).exists() {
                Manifest::check(&dir, plan, v)
            } else {
                Err(anyhow::anyhow!(
                    "not run yet (no {}); run task {} again",
                    dir.join(MANIFEST).display(),
                    v.task
                ))
            };
            manifest
                .and_then(|m| row(&dir, &m))
                .map_err(|e| format!("variant {}: {e:#}", v.name))
        })
        .collect();
    let (mut rows, mut refused) = (Vec::new(), Vec::new());
    for c in checked {
        match c {
            Ok(r) => rows.push(r),
            Err(e) => refused.push(e),
        }
    }
    let Some(first) = refused.first() else {
        return Ok(rows);
    };
    for r in refused.iter().skip(1).take(20) {
        errln!("{r}");
    }
    bail!(
        "{}: {first}{}; nothing merged",
        job.display(),
        match refused.len() {
            1 => String::new(),
            n => format!(" (and {} more variants, listed above)", n - 1),
        }
    )
}

/// The table as JSON: one object a variant, its values under `values`.
fn results_json(plan: &Plan, rows: &[Row]) -> Vec<Value> {
    plan.variants
        .iter()
        .zip(rows)
        .map(|(v, r)| {
            let mut o = Map::new();
            o.insert("variant".into(), json!(v.name));
            o.insert("index".into(), json!(v.index));
            o.insert("task".into(), json!(v.task));
            o.insert("values".into(), Value::Object(r.values.clone()));
            o.extend(r.fields.iter().cloned());
            Value::Object(o)
        })
        .collect()
}

/// Says how many temporary folders killed tasks left. Tasks never remove them (another
/// node may still be writing one); once the job is merged they are plainly dead.
fn note_leftovers(job: &Path) {
    let variants = job.join("variants");
    let leftovers = std::fs::read_dir(&variants)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().starts_with(".tmp-"))
                .count()
        })
        .unwrap_or(0);
    if leftovers > 0 {
        errln!(
            "note: {leftovers} temporary folder{} of killed tasks in {} (.tmp-*) can be deleted",
            if leftovers == 1 { "" } else { "s" },
            variants.display()
        );
    }
}

/// A checked variant's row: its cost from the manifest, then the report's numbers.
fn row(dir: &Path, m: &Manifest) -> Result<Row> {
    let mut fields = vec![
        ("wall_s".to_string(), json!(m.wall_s)),
        ("cpu_s".to_string(), json!(m.cpu_s)),
        ("peak_rss_kib".to_string(), json!(m.peak_rss_kib)),
    ];
    if let Some(name) = &m.report {
        let path = dir.join(name);
        let report: Value = serde_json::from_slice(&read_capped(&path, 1 << 30)?)
            .with_context(|| format!("{}: not a scene report", path.display()))?;
        // The report's metrics are its top-level numbers (and the `nan` flag); its
        // lists (characters, blasts) are per-variant detail the report itself keeps.
        if let Some(top) = report.as_object() {
            for (k, v) in top.iter().filter(|(_, v)| v.is_number() || v.is_boolean()) {
                fields.push((k.clone(), v.clone()));
            }
        }
    }
    Ok(Row {
        values: m.values.clone(),
        fields,
    })
}

/// The table as CSV: variant, index, task, each wedge key by label, then the fields of the
/// first row (every row has the same, from the same scene).
fn csv(plan: &Plan, rows: &[Row]) -> String {
    let mut header: Vec<String> = ["variant", "index", "task"].map(String::from).to_vec();
    header.extend(plan.keys.iter().map(|k| k.label.clone()));
    let fields: Vec<&String> = rows
        .first()
        .map(|r| r.fields.iter().map(|(k, _)| k).collect())
        .unwrap_or_default();
    header.extend(fields.iter().map(|k| k.to_string()));
    let mut out = line(&header);
    for (v, r) in plan.variants.iter().zip(rows) {
        let mut cells = vec![v.name.clone(), v.index.to_string(), v.task.to_string()];
        cells.extend(plan.keys.iter().map(|k| cell(r.values.get(&k.key))));
        cells.extend(
            fields
                .iter()
                .map(|k| cell(r.fields.iter().find(|(f, _)| f == *k).map(|(_, v)| v))),
        );
        out.push_str(&line(&cells));
    }
    out
}

/// A value as a CSV cell: strings bare, numbers and lists as JSON writes them.
fn cell(v: Option<&Value>) -> String {
    match v {
        None | Some(Value::Null) => String::new(),
        Some(Value::String(s)) => s.clone(),
        Some(v) => v.to_string(),
    }
}

/// One CSV line (RFC 4180 quoting).
fn line(cells: &[String]) -> String {
    let quoted: Vec<String> = cells
        .iter()
        .map(|c| {
            if c.contains([',', '"', '\n', '\r']) {
                format!("\"{}\"", c.replace('"', "\"\""))
            } else {
                c.clone()
            }
        })
        .collect();
    format!("{}\n", quoted.join(","))
}
