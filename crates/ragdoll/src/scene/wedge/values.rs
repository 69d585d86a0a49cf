//! The values of one `[[wedge.vary]]` table: a range stepped through, seeded random draws,
//! and how a value is written in a variant's name.

use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};
use serde::Deserialize;
use toml::Value;

use super::{MAX_NAME_VALUE_BYTES, MAX_VARIANTS};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRange {
    from: Value,
    to: Value,
    step: Value,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRandom {
    count: u32,
    min: Value,
    max: Value,
    #[serde(default)]
    seed: u64,
}

/// A number of a range or a draw: an integer or a finite float.
fn number(v: &Value, what: &str) -> std::result::Result<f64, String> {
    match v {
        Value::Integer(i) => Ok(*i as f64),
        Value::Float(f) if f.is_finite() => Ok(*f),
        _ => Err(format!("{what}: must be a number, not {v}")),
    }
}

/// `range = { from, to, step }`: from `from` toward `to` by `step`, both ends included
/// (`to` where a step lands on it within rounding); integers when all three are.
pub(super) fn range(r: &RawRange) -> std::result::Result<Vec<Value>, String> {
    let (from, to, step) = (
        number(&r.from, "range.from")?,
        number(&r.to, "range.to")?,
        number(&r.step, "range.step")?,
    );
    if step == 0.0 || (to - from) * step < 0.0 {
        return Err(format!(
            "range: a step of {step} never goes from {from} to {to}"
        ));
    }
    let steps = ((to - from) / step + 1e-9).floor();
    if steps >= MAX_VARIANTS as f64 {
        return Err(format!("range: makes more than {MAX_VARIANTS} values"));
    }
    let ints = [&r.from, &r.to, &r.step].iter().all(|v| v.is_integer());
    Ok((0..=steps as usize)
        .map(|i| {
            let x = from + i as f64 * step;
            if ints {
                Value::Integer(x.round() as i64)
            } else {
                Value::Float(round_sig(x, 12))
            }
        })
        .collect())
}

/// `random = { count, min, max, seed }`: `count` draws between `min` and `max`
/// (integers when both are, else floats to 6 significant digits; lists draw each
/// component between theirs).
pub(super) fn random(r: &RawRandom) -> std::result::Result<Vec<Value>, String> {
    if r.count == 0 || r.count as usize > MAX_VARIANTS {
        return Err(format!("random.count: must be 1 to {MAX_VARIANTS}"));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(r.seed);
    let (mins, maxs) = match (&r.min, &r.max) {
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() && !a.is_empty() => {
            (a.clone(), b.clone())
        }
        (Value::Array(_), _) | (_, Value::Array(_)) => {
            return Err("random: min and max must both be numbers, or lists of one length".into());
        }
        (a, b) => (vec![a.clone()], vec![b.clone()]),
    };
    let mut bounds = Vec::with_capacity(mins.len());
    for (a, b) in mins.iter().zip(&maxs) {
        let (lo, hi) = (number(a, "random.min")?, number(b, "random.max")?);
        if lo > hi {
            return Err(format!("random: min {lo} is above max {hi}"));
        }
        bounds.push((lo, hi, a.is_integer() && b.is_integer()));
    }
    let mut draw = |(lo, hi, int): (f64, f64, bool)| {
        let u = rng.next_u64();
        if int {
            let span = (hi - lo) as u128 + 1;
            Value::Integer(lo as i64 + ((u as u128 * span) >> 64) as i64)
        } else {
            let unit = (u >> 11) as f64 / (1u64 << 53) as f64;
            Value::Float(round_sig(lo + unit * (hi - lo), 6))
        }
    };
    Ok((0..r.count)
        .map(|_| {
            let parts: Vec<Value> = bounds.iter().map(|&b| draw(b)).collect();
            if r.min.is_array() {
                Value::Array(parts)
            } else {
                parts.into_iter().next().unwrap_or(Value::Integer(0))
            }
        })
        .collect())
}

/// `x` to `digits` significant digits: 0.30000000000000004 → 0.3, and drawn numbers short
/// enough to read in a name.
fn round_sig(x: f64, digits: usize) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    format!("{x:.*e}", digits - 1).parse().unwrap_or(x)
}

/// A value as it appears in a variant name: numbers shortest, lists joined by commas,
/// anything but letters, digits and `.,+-` turned into `-`, shortened.
pub(super) fn name_value(v: &Value) -> String {
    let text = match v {
        Value::Float(f) if f.fract() == 0.0 && f.abs() < 1e15 => format!("{}", *f as i64),
        Value::Float(f) => format!("{f}"),
        Value::Integer(i) => i.to_string(),
        Value::String(s) => s.clone(),
        Value::Boolean(b) => b.to_string(),
        Value::Array(a) => a.iter().map(name_value).collect::<Vec<_>>().join(","),
        other => other.to_string(),
    };
    let mut clean: String = text
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || ".,+-".contains(c) {
                c
            } else {
                '-'
            }
        })
        .collect();
    clean.truncate(MAX_NAME_VALUE_BYTES);
    clean
}
