//! Animations: channels on skin joints, read and checked, sampled at a regular frame time
//! into [`Clip`]s, within [`MAX_CLIP_POSES`] for all of a file's clips together.

use glam::{Quat, Vec3};
use gltf::accessor::Dimensions;
use gltf::animation::{Interpolation, Property};

use super::data::format_err;
use super::mesh::Reads;
use super::skin::Rig;
use crate::error::Result;
use crate::skeleton::{Clip, MAX_CLIP_POSES, MAX_REACH_M, Skeleton};

/// One animation channel on a joint, read and checked.
struct Channel {
    joint: usize,
    property: Property,
    interpolation: Interpolation,
    times: Vec<f32>,
    values: Vec<f32>,
    width: usize,
}

impl Channel {
    fn value(&self, key: usize) -> &[f32] {
        let k = if self.interpolation == Interpolation::CubicSpline {
            3 * key + 1
        } else {
            key
        };
        &self.values[k * self.width..(k + 1) * self.width]
    }

    fn tangent(&self, key: usize, out: bool) -> &[f32] {
        let k = 3 * key + if out { 2 } else { 0 };
        &self.values[k * self.width..(k + 1) * self.width]
    }

    /// The channel's value at time `t`, held constant outside its keys.
    fn sample(&self, t: f32) -> [f32; 4] {
        let mut out = [0.0; 4];
        let last = self.times.len().saturating_sub(1);
        let (k, u) = if t <= self.times[0] || t.is_nan() || last == 0 {
            (0, 0.0)
        } else if t >= self.times[last] {
            (last, 0.0)
        } else {
            let k = self
                .times
                .partition_point(|&x| x <= t)
                .saturating_sub(1)
                .min(last - 1);
            let dt = self.times[k + 1] - self.times[k];
            (
                k,
                if dt > 0.0 {
                    (t - self.times[k]) / dt
                } else {
                    0.0
                },
            )
        };
        let w = self.width;
        if u == 0.0 || self.interpolation == Interpolation::Step {
            out[..w].copy_from_slice(self.value(k));
        } else if self.interpolation == Interpolation::Linear {
            let (a, b) = (self.value(k), self.value(k + 1));
            if self.property == Property::Rotation {
                let q = unit_or_identity(Quat::from_slice(a))
                    .slerp(unit_or_identity(Quat::from_slice(b)), u);
                out = q.to_array();
            } else {
                for c in 0..w {
                    out[c] = a[c] + (b[c] - a[c]) * u;
                }
            }
        } else {
            let dt = self.times[k + 1] - self.times[k];
            let (u2, u3) = (u * u, u * u * u);
            let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
            let h10 = u3 - 2.0 * u2 + u;
            let h01 = -2.0 * u3 + 3.0 * u2;
            let h11 = u3 - u2;
            let (p0, m0) = (self.value(k), self.tangent(k, true));
            let (p1, m1) = (self.value(k + 1), self.tangent(k + 1, false));
            for c in 0..w {
                out[c] = h00 * p0[c] + h10 * dt * m0[c] + h01 * p1[c] + h11 * dt * m1[c];
            }
        }
        if self.property == Property::Rotation {
            out = unit_or_identity(Quat::from_array(out)).to_array();
        }
        out
    }
}

/// `q` scaled to unit length, or the identity for a zero or non-finite quaternion.
fn unit_or_identity(q: Quat) -> Quat {
    let l = q.length();
    if l > 1e-12 && l.is_finite() {
        q / l
    } else {
        Quat::IDENTITY
    }
}

/// Output frame rate when keys are irregular.
const DEFAULT_FPS: f32 = 30.0;
/// Regular keys at least this dense are sampled at their own rate; sparser ones at the
/// smallest multiple of their rate that reaches [`DEFAULT_FPS`], so every key is still hit.
const MIN_KEY_FPS: f32 = 20.0;
/// Denser keys than this are resampled at [`DEFAULT_FPS`].
const MAX_KEY_FPS: f32 = 240.0;

/// The frame time for a clip with these key times: one that lands on every key when keys
/// lie on a regular grid (so nothing is smoothed away and a clip we exported reads back
/// exactly), else 1/30 s.
pub(crate) fn clip_frame_time(times: &[f32]) -> f32 {
    let mut all: Vec<f32> = times.iter().copied().filter(|t| t.is_finite()).collect();
    all.sort_by(f32::total_cmp);
    all.dedup_by(|a, b| (*a - *b).abs() < 1e-6);
    let fallback = 1.0 / DEFAULT_FPS;
    if all.len() < 2 {
        return fallback;
    }
    let gap = all
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f32::INFINITY, f32::min);
    if !(gap * MAX_KEY_FPS >= 0.999 && gap <= 10.0) {
        return fallback;
    }
    let t0 = all[0];
    let on_grid = all.iter().all(|&t| {
        let k = (t - t0) / gap;
        (k - k.round()).abs() < 0.01
    });
    if !on_grid {
        return fallback;
    }
    let mut rate = 1.0 / gap;
    if (rate - rate.round()).abs() < 1e-3 * rate {
        rate = rate.round();
    }
    if rate < MIN_KEY_FPS {
        rate *= (DEFAULT_FPS / rate).ceil();
    }
    1.0 / rate
}

/// One animation's channels that move joints: its index, its name ("" when it has none)
/// and the channels.
type Take = (usize, String, Vec<Channel>);

pub(super) fn read_clips(
    doc: &gltf::Document,
    rig: &Rig,
    skeleton: &Skeleton,
    reader: &Reads,
) -> Result<Vec<Clip>> {
    let mut takes: Vec<Take> = Vec::new();
    for anim in doc.animations() {
        let mut channels = Vec::new();
        for ch in anim.channels() {
            if let Some(channel) = read_channel(&ch, rig, reader)? {
                channels.push(channel);
            }
        }
        if !channels.is_empty() {
            takes.push((
                anim.index(),
                anim.name().unwrap_or("").to_string(),
                channels,
            ));
        }
    }
    let takes = join_split_take(takes);
    let mut poses_left = MAX_CLIP_POSES;
    takes
        .into_iter()
        .map(|(index, name, channels)| {
            let clip = sample_take(rig, reader, index, name, channels, &mut poses_left)?;
            if let Some((f, j, far)) = skeleton.clip_out_of_reach(&clip) {
                return Err(format_err(
                    reader.path(),
                    format!("animation {index}"),
                    format!(
                        "at {} s puts joint \"{}\" {far} m from the origin, past the {MAX_REACH_M} m a skeleton may reach",
                        f as f32 * clip.frame_time,
                        skeleton.joint_label(j)
                    ),
                ));
            }
            Ok(clip)
        })
        .collect()
}

/// One channel of an animation, checked (components per key, values per time, times
/// that do not decrease); `None` for a channel of a node that is not a joint, or of
/// morph weights.
fn read_channel(
    ch: &gltf::animation::Channel,
    rig: &Rig,
    reader: &Reads,
) -> Result<Option<Channel>> {
    let target = ch.target();
    let Some(&joint) = rig.node_to_joint.get(&target.node().index()) else {
        return Ok(None);
    };
    let property = target.property();
    let width = match property {
        Property::Translation | Property::Scale => 3,
        Property::Rotation => 4,
        Property::MorphTargetWeights => return Ok(None),
    };
    let sampler = ch.sampler();
    let interpolation = sampler.interpolation();
    let (input, output) = (sampler.input(), sampler.output());
    reader.expect_dims(&input, &[Dimensions::Scalar], "animation input")?;
    let (times, _) = reader.floats(&input)?;
    let (values, comps) = reader.floats(&output)?;
    let place = || format!("accessor {}", output.index());
    if comps != width {
        return Err(format_err(
            reader.path(),
            place(),
            format!("animates {property:?} with {comps} components per key, expected {width}"),
        ));
    }
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if times.is_empty() || values.len() != times.len() * per_key * width {
        return Err(format_err(
            reader.path(),
            place(),
            format!(
                "has {} values for {} keyframe times ({interpolation:?})",
                values.len() / width,
                times.len()
            ),
        ));
    }
    if times.windows(2).any(|w| w[1] < w[0]) {
        return Err(format_err(
            reader.path(),
            format!("accessor {}", input.index()),
            "keyframe times decrease",
        ));
    }
    Ok(Some(Channel {
        joint,
        property,
        interpolation,
        times,
        values,
        width,
    }))
}

/// Some exporters write one take as one unnamed animation per node (this data's
/// CesiumMan: 19 animations of 3 channels). Played alone, each moves one joint; the
/// unnamed ones are one clip when there are several and no two animate the same joint
/// property. Named animations stay clips of their own.
fn join_split_take(takes: Vec<Take>) -> Vec<Take> {
    let unnamed: Vec<usize> = (0..takes.len())
        .filter(|&k| takes[k].1.is_empty())
        .collect();
    let mut targets = std::collections::HashSet::new();
    let split_take = unnamed.len() > 1
        && unnamed
            .iter()
            .flat_map(|&k| takes[k].2.iter().map(|c| (c.joint, c.property as u8)))
            .all(|t| targets.insert(t));
    if !split_take {
        return takes;
    }
    // One pass (removing each from the list was quadratic in animations): the first
    // unnamed take gets the others' channels, the last take's first. Every take before
    // the first unnamed one is named and kept, so it keeps its index.
    let first = unnamed[0];
    let mut others = Vec::new();
    let mut kept = Vec::with_capacity(takes.len());
    for (k, take) in takes.into_iter().enumerate() {
        if k != first && take.1.is_empty() {
            others.push(take.2);
        } else {
            kept.push(take);
        }
    }
    kept[first].2.extend(others.into_iter().rev().flatten());
    kept
}

/// Samples one animation's channels at a regular frame time into a [`Clip`].
fn sample_take(
    rig: &Rig,
    reader: &Reads,
    index: usize,
    name: String,
    channels: Vec<Channel>,
    poses_left: &mut usize,
) -> Result<Clip> {
    let t0 = channels
        .iter()
        .map(|c| c.times[0])
        .fold(f32::INFINITY, f32::min);
    let t1 = channels
        .iter()
        .map(|c| c.times[c.times.len() - 1])
        .fold(f32::NEG_INFINITY, f32::max);
    let all_times: Vec<f32> = channels
        .iter()
        .flat_map(|c| c.times.iter().copied())
        .collect();
    let frame_time = clip_frame_time(&all_times);
    let steps = ((t1 - t0) / frame_time).round() as f64;
    let max_frames = *poses_left / rig.joints.len().max(1);
    if !(steps.is_finite() && steps < max_frames as f64) {
        return Err(format_err(
            reader.path(),
            format!("animation {index}"),
            format!(
                "runs from {t0} s to {t1} s, too long to sample: the clips of one file hold at most {MAX_CLIP_POSES} joint poses"
            ),
        ));
    }
    let n = steps as usize + 1;
    *poses_left -= n * rig.joints.len();
    let mut frames = Vec::with_capacity(n);
    for f in 0..n {
        let t = if f + 1 == n {
            t1
        } else {
            (t0 as f64 + f as f64 * frame_time as f64) as f32
        };
        let mut trs = rig.node_rest.clone();
        for c in &channels {
            let v = c.sample(t);
            let x = &mut trs[c.joint];
            match c.property {
                Property::Translation => x.translation = Vec3::new(v[0], v[1], v[2]),
                Property::Scale => x.scale = Vec3::new(v[0], v[1], v[2]),
                Property::Rotation => x.rotation = Quat::from_array(v),
                Property::MorphTargetWeights => {}
            }
        }
        frames.push(
            trs.iter()
                .enumerate()
                .map(|(j, t)| rig.local(j, t))
                .collect(),
        );
    }
    Ok(Clip {
        name,
        frame_time,
        frames,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, values: Vec<f32>) -> Channel {
        Channel {
            joint: 0,
            property: Property::Translation,
            interpolation,
            times: vec![0.0, 1.0],
            values,
            width: 3,
        }
    }

    #[test]
    fn samplers_interpolate_as_the_spec_says() {
        let lin = channel(Interpolation::Linear, vec![0.0, 0.0, 0.0, 2.0, 4.0, 6.0]);
        assert_eq!(lin.sample(0.25)[..3], [0.5, 1.0, 1.5]);
        assert_eq!(lin.sample(-1.0)[..3], [0.0, 0.0, 0.0]);
        assert_eq!(lin.sample(9.0)[..3], [2.0, 4.0, 6.0]);
        let step = channel(Interpolation::Step, vec![0.0, 0.0, 0.0, 2.0, 4.0, 6.0]);
        assert_eq!(step.sample(0.99)[..3], [0.0, 0.0, 0.0]);
        // Zero tangents: a smoothstep from 0 to 1, 0.5 at the middle, eased at the ends.
        let mut v = vec![0.0; 18];
        v[9 + 3] = 1.0; // key 1 value x
        let cubic = channel(Interpolation::CubicSpline, v);
        assert!((cubic.sample(0.5)[0] - 0.5).abs() < 1e-6);
        assert!((cubic.sample(0.25)[0] - 0.15625).abs() < 1e-6);
    }

    #[test]
    fn rotations_slerp_and_stay_unit() {
        let c = Channel {
            joint: 0,
            property: Property::Rotation,
            interpolation: Interpolation::Linear,
            times: vec![0.0, 2.0],
            values: [
                Quat::IDENTITY.to_array(),
                Quat::from_rotation_y(1.0).to_array(),
            ]
            .concat(),
            width: 4,
        };
        let q = Quat::from_array(c.sample(1.0));
        assert!((q.length() - 1.0).abs() < 1e-6);
        assert!(q.abs_diff_eq(Quat::from_rotation_y(0.5), 1e-6));
    }

    #[test]
    fn frame_time_follows_regular_keys() {
        let keys: Vec<f32> = (0..10).map(|i| i as f32 / 24.0).collect();
        assert_eq!(clip_frame_time(&keys), 1.0 / 24.0);
        assert_eq!(clip_frame_time(&[0.0, 0.1, 0.35]), 1.0 / 30.0);
        assert_eq!(clip_frame_time(&[0.5]), 1.0 / 30.0);
        let sparse: Vec<f32> = (0..5).map(|i| i as f32 * 0.5).collect();
        assert_eq!(clip_frame_time(&sparse), 1.0 / 30.0);
        let ten: Vec<f32> = (0..5).map(|i| i as f32 * 0.1).collect();
        assert_eq!(clip_frame_time(&ten), 1.0 / 30.0);
        let sixty: Vec<f32> = (0..5).map(|i| i as f32 / 60.0).collect();
        assert_eq!(clip_frame_time(&sixty), 1.0 / 60.0);
    }
}
