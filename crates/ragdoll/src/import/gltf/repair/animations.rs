//! The input's own animations, which the exporter writes back after the new `ragdoll`
//! one: keyframe times that do not rise (or start below zero), and rotation keys that are
//! not unit quaternions, both errors to the validator and undefined motion to a viewer.
//!
//! Times that do not rise cannot be mended without guessing which key is wrong, so the
//! channels they drive are left out (and an animation left with none goes); rotation keys
//! are scaled to unit length in the buffer where they are stored, as every viewer that
//! plays them does anyway, so the animation keeps its motion.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::Path;

use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};
use serde_json::{Value, json};

use super::{UNIT_TOLERANCE, listed};
use crate::error::Result;
use crate::import::gltf::{AccessorReader, MAX_ACCESSOR_COMPONENTS, format_err};

/// What was found in one animation: samplers to leave out, each with why.
type Faults = BTreeMap<usize, String>;

/// Rotation keys to write back: accessor → its keys at unit length.
type Rewrites = BTreeMap<usize, Vec<f32>>;

/// Reads the keys of every animation and mends them: rotation keys normalised in
/// `buffers`, channels whose times do not rise removed from `json`. One warning for each
/// kind of repair made. Times that are not single numbers and rotation keys that are not
/// quaternions are refused, as the importer refuses them on a joint: such a sampler is
/// not one a file could mean.
pub(super) fn repair_keys(
    json: &mut Value,
    doc: &gltf::Document,
    buffers: &mut [Vec<u8>],
    path: &Path,
) -> Result<Vec<String>> {
    let reader = AccessorReader {
        buffers: &*buffers,
        path,
    };
    let mut budget = MAX_ACCESSOR_COMPONENTS;
    let mut times_ok: HashMap<usize, Option<String>> = HashMap::new();
    let mut faults: BTreeMap<usize, Faults> = BTreeMap::new();
    let mut rewrites = Rewrites::new();
    let mut rotation_notes = Vec::new();
    for anim in doc.animations() {
        let found = faults.entry(anim.index()).or_default();
        for sampler in anim.samplers() {
            let input = sampler.input();
            let why = match times_ok.get(&input.index()) {
                Some(why) => why.clone(),
                None => {
                    reader.expect_dims(&input, &[Dimensions::Scalar], "animation input")?;
                    let (times, _) = read(&reader, &input, &mut budget)?;
                    let why = times_fault(&times);
                    times_ok.insert(input.index(), why.clone());
                    why
                }
            };
            if let Some(why) = why {
                let text = format!("the keyframe times of accessor {} {why}", input.index());
                found.insert(sampler.index(), text);
            }
        }
        for ch in anim.channels() {
            let sampler = ch.sampler();
            if ch.target().property() != Property::Rotation || found.contains_key(&sampler.index())
            {
                continue;
            }
            let output = sampler.output();
            let cubic = sampler.interpolation() == Interpolation::CubicSpline;
            let a = output.index();
            if rewrites.contains_key(&a) {
                continue;
            }
            reader.expect_dims(&output, &[Dimensions::Vec4], "rotation keys")?;
            let (keys, _) = read(&reader, &output, &mut budget)?;
            let (unit, off, all) = unit_keys(keys, cubic);
            if off == 0 {
                continue;
            }
            if !writable(&output) {
                let text = format!(
                    "its rotation keys (accessor {a}) are not unit quaternions and are stored where they cannot be mended"
                );
                found.insert(sampler.index(), text);
                continue;
            }
            rotation_notes.push(format!(
                "{}: {off} of {all} rotation keys of accessor {a}",
                label(&anim)
            ));
            rewrites.insert(a, unit);
        }
    }
    for (a, unit) in &rewrites {
        if let Some(acc) = doc.accessors().nth(*a) {
            write_keys(&acc, buffers, unit);
        }
    }
    let mut warnings = Vec::new();
    if !rotation_notes.is_empty() {
        warnings.push(format!(
            "{}: not unit quaternions, normalised (a zero one set to the identity)",
            listed(&rotation_notes)
        ));
    }
    warnings.extend(drop_faulty(json, doc, &faults));
    Ok(warnings)
}

/// `animation 0 ("wave")`, or `animation 0` for one without a name.
fn label(anim: &gltf::Animation) -> String {
    match anim.name() {
        Some(n) => format!("animation {} ({n:?})", anim.index()),
        None => format!("animation {}", anim.index()),
    }
}

/// An accessor's components as floats, charged to what one import may read here.
fn read(
    reader: &AccessorReader,
    a: &gltf::Accessor,
    budget: &mut usize,
) -> Result<(Vec<f32>, usize)> {
    let want = a.count().saturating_mul(a.dimensions().multiplicity());
    *budget = budget.checked_sub(want).ok_or_else(|| {
        format_err(
            reader.path,
            format!("accessor {}", a.index()),
            format!("its animation keys would pass the {MAX_ACCESSOR_COMPONENTS} components that one import checks"),
        )
    })?;
    reader.floats_as_stored(a)
}

/// Why keyframe times are not valid (they must be finite, not below zero and strictly
/// rising), or `None` when they are.
fn times_fault(times: &[f32]) -> Option<String> {
    if let Some(k) = times.iter().position(|t| !t.is_finite()) {
        return Some(format!("are not all numbers (key {k})"));
    }
    if let Some(&t) = times.first().filter(|&&t| t < 0.0) {
        return Some(format!("start below zero ({t} s)"));
    }
    let k = times.windows(2).position(|w| w[1] <= w[0])?;
    Some(format!(
        "do not rise (key {}, {} s, is not after {} s)",
        k + 1,
        times[k + 1],
        times[k]
    ))
}

/// Rotation keys scaled to unit length (a zero or non-finite one the identity), with how
/// many were off by more than [`UNIT_TOLERANCE`] and how many there are; only a cubic
/// spline's values are rotations, its tangents are not.
fn unit_keys(mut keys: Vec<f32>, cubic: bool) -> (Vec<f32>, usize, usize) {
    let (mut off, mut all) = (0, 0);
    for (k, q) in keys.chunks_exact_mut(4).enumerate() {
        if cubic && k % 3 != 1 {
            continue;
        }
        all += 1;
        let len = q.iter().map(|&x| x as f64 * x as f64).sum::<f64>().sqrt();
        if (len - 1.0).abs() <= UNIT_TOLERANCE {
            continue;
        }
        off += 1;
        if len.is_finite() && len > 1e-12 {
            q.iter_mut().for_each(|x| *x = (*x as f64 / len) as f32);
        } else {
            q.copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
        }
    }
    (keys, off, all)
}

/// Whether an accessor's keys can be written back where they are: a plain buffer view (no
/// sparse substitution) of floats or normalised signed integers, the types glTF allows
/// for rotations.
fn writable(a: &gltf::Accessor) -> bool {
    a.view().is_some()
        && a.sparse().is_none()
        && (a.data_type() == DataType::F32
            || (a.normalized() && matches!(a.data_type(), DataType::I8 | DataType::I16)))
}

/// Writes `values` over accessor `a`'s components in `buffers`, in its own type. The
/// reader has checked that they fit its view; a range that still falls outside the buffer
/// writes nothing.
fn write_keys(a: &gltf::Accessor, buffers: &mut [Vec<u8>], values: &[f32]) {
    let Some(view) = a.view() else {
        return;
    };
    let size = a.data_type().size();
    let elem = 4 * size;
    let stride = view.stride().unwrap_or(elem);
    let Some(buffer) = buffers.get_mut(view.buffer().index()) else {
        return;
    };
    let base = view.offset().checked_add(a.offset());
    let end = a
        .count()
        .checked_sub(1)
        .and_then(|last| last.checked_mul(stride))
        .and_then(|n| n.checked_add(base?))
        .and_then(|n| n.checked_add(elem));
    let (Some(base), Some(end)) = (base, end) else {
        return;
    };
    if end > buffer.len() || values.len() / 4 != a.count() || stride < elem {
        return;
    }
    for (i, v) in values.iter().enumerate() {
        let at = base + (i / 4) * stride + (i % 4) * size;
        let bytes = &mut buffer[at..at + size];
        match a.data_type() {
            DataType::F32 => bytes.copy_from_slice(&v.to_le_bytes()),
            DataType::I16 => {
                bytes.copy_from_slice(&((v * 32767.0).round() as i16).to_le_bytes());
            }
            _ => bytes[0] = (v * 127.0).round() as i8 as u8,
        }
    }
}

/// Removes the faulty samplers and every channel they drive, renumbering the samplers that
/// stay; an animation left with no channel is removed.
fn drop_faulty(
    json: &mut Value,
    doc: &gltf::Document,
    faults: &BTreeMap<usize, Faults>,
) -> Option<String> {
    let anims = json.get_mut("animations")?.as_array_mut()?;
    let mut said = Vec::new();
    let mut empty = BTreeSet::new();
    for (&a, found) in faults.iter().filter(|(_, f)| !f.is_empty()) {
        let Some(anim) = anims.get_mut(a) else {
            continue;
        };
        let mut new_index = Vec::new();
        let mut next = 0;
        for s in 0..anim["samplers"].as_array().map_or(0, Vec::len) {
            new_index.push((!found.contains_key(&s)).then(|| {
                next += 1;
                next - 1
            }));
        }
        if let Some(Value::Array(samplers)) = anim.get_mut("samplers") {
            let mut s = 0;
            samplers.retain(|_| {
                s += 1;
                !found.contains_key(&(s - 1))
            });
        }
        let mut lost: BTreeMap<usize, usize> = BTreeMap::new();
        if let Some(Value::Array(channels)) = anim.get_mut("channels") {
            channels.retain_mut(|c| {
                let s = c["sampler"].as_u64().unwrap_or(u64::MAX) as usize;
                match new_index.get(s).copied().flatten() {
                    Some(n) => {
                        c["sampler"] = json!(n);
                        true
                    }
                    None => {
                        *lost.entry(s).or_default() += 1;
                        false
                    }
                }
            });
            if channels.is_empty() {
                empty.insert(a);
            }
        }
        let name = doc
            .animations()
            .nth(a)
            .map_or(format!("animation {a}"), |x| label(&x));
        for (s, why) in found {
            let n = lost.get(s).copied().unwrap_or(0);
            let channels = if n == 1 {
                "channel was"
            } else {
                "channels were"
            };
            said.push(format!("{name}: {why}, so its {n} {channels} left out"));
        }
        if empty.contains(&a) {
            said.push(format!("{name}, left with no channel, was removed"));
        }
    }
    let mut a = 0;
    anims.retain(|_| {
        a += 1;
        !empty.contains(&(a - 1))
    });
    if anims.is_empty() {
        json.as_object_mut()?.remove("animations");
    }
    (!said.is_empty()).then(|| said.join("; "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_must_be_numbers_that_rise_from_zero() {
        assert_eq!(times_fault(&[0.0, 0.5, 1.0]), None);
        assert_eq!(times_fault(&[0.2]), None);
        let said = times_fault(&[0.0, 0.5, 0.5]).unwrap();
        assert_eq!(said, "do not rise (key 2, 0.5 s, is not after 0.5 s)");
        assert!(times_fault(&[-0.1, 0.5]).unwrap().contains("below zero"));
        assert!(times_fault(&[0.0, f32::NAN]).unwrap().contains("key 1"));
    }

    #[test]
    fn rotation_keys_become_unit_but_cubic_tangents_are_left_alone() {
        let keys = vec![0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0];
        let (unit, off, all) = unit_keys(keys, false);
        assert_eq!((off, all), (2, 3));
        assert_eq!(
            unit,
            [0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
        );
        // In-tangent, value, out-tangent: only the value is a rotation.
        let cubic = vec![5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 3.0, 0.0, 0.0];
        let (unit, off, all) = unit_keys(cubic, true);
        assert_eq!((off, all), (1, 1));
        assert_eq!(
            unit,
            [5.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 3.0, 0.0, 0.0]
        );
    }
}
