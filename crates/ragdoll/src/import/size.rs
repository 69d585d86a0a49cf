//! A character's size: `height_m` scales it, and a size no character has is pointed out,
//! because a file in the wrong unit (centimetres in glTF's metres) otherwise gives a ragdoll
//! a hundred times too large, a million times too heavy, that falls in slow motion.
//!
//! Two ways to scale, by source, so that exporters writing the file back stay right:
//! - glTF: the scale goes into each root joint's transform (and the static transform above
//!   it), as the `Armature` node of a centimetre rig already does. The joints below keep
//!   their file-unit transforms, so the exporter writes node transforms in the file's own
//!   units and the written file lines up with its meshes and inverse bind matrices.
//! - Everything else (BVH, meshes rigged here, the built-in humanoid): every translation
//!   is scaled; BVH's `metres_per_unit` with it, so its exporter writes the file's units.

use std::ops::RangeInclusive;
use std::path::Path;

use glam::Vec3;

use crate::error::{Error, Result};
use crate::math::Transform;
use crate::skeleton::{Character, MAX_REACH_M, Skeleton, SkinnedMesh, Source};

/// Heights a character plausibly has, metres: 5 cm (an insect) to 50 m (a giant). Outside
/// them the importer warns, stating the height, since a wrong unit is the usual cause.
pub const PLAUSIBLE_HEIGHT_M: RangeInclusive<f32> = 0.05..=50.0;

/// Smallest height `ImportOptions::height_m` may ask for, metres: 1 mm. Below it the
/// physics' fixed tolerances are larger than the character.
pub const MIN_HEIGHT_M: f32 = 0.001;

/// Largest height `ImportOptions::height_m` may ask for, metres: 1 km, well inside
/// [`MAX_REACH_M`].
pub const MAX_HEIGHT_M: f32 = 1000.0;

/// Refuses a requested height outside [`MIN_HEIGHT_M`]..=[`MAX_HEIGHT_M`].
pub(super) fn check_height(height_m: Option<f32>) -> Result<()> {
    match height_m {
        Some(h) if !(MIN_HEIGHT_M..=MAX_HEIGHT_M).contains(&h) => Err(Error::Setting {
            setting: "height".into(),
            message: format!("must be between {MIN_HEIGHT_M} and {MAX_HEIGHT_M} metres, not {h}"),
        }),
        _ => Ok(()),
    }
}

/// How tall a character stands in its rest pose, metres
/// ([`Character::height_along`] the vertical): its meshes' extent (the top of the head,
/// not the head joint), else its joints' scaled as the built-in humanoid's are to its
/// 1.75 m.
pub fn character_height(c: &Character) -> f32 {
    c.height_along(Vec3::Y)
}

/// [`character_height`] of the character standing: measured along the way its roles
/// stand it up ([`crate::spec::Roles::upright`]) when it lies down in its file, else as
/// its file stands it. Measured as the file stands, a figure lying on its back is as tall
/// as it is thick (the Mannequiny lying: 0.35 m).
pub fn standing_height(c: &Character) -> f32 {
    let up = crate::spec::recognise_roles(c)
        .upright
        .map_or(Vec3::Y, |q| q.inverse() * Vec3::Y);
    c.height_along(up)
}

fn extent_along(points: impl Iterator<Item = Vec3>, up: Vec3) -> Option<f32> {
    let (lo, hi) = points.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
        let h = p.dot(up);
        (lo.min(h), hi.max(h))
    });
    (hi >= lo).then_some(hi - lo)
}

fn mesh_height(meshes: &[SkinnedMesh]) -> Option<f32> {
    extent_along(meshes.iter().flat_map(|m| &m.positions).copied(), Vec3::Y)
}

/// A warning when the character's height, standing ([`standing_height`]), lies outside
/// [`PLAUSIBLE_HEIGHT_M`]: a Z-up export in centimetres lies 1.8 m high and 0.3 m thick
/// as its file stands it, a plausible size, while it stands 180 m tall.
pub(super) fn implausible(c: &Character, path: &Path) -> Option<String> {
    let h = standing_height(c);
    if PLAUSIBLE_HEIGHT_M.contains(&h) || !h.is_finite() || h <= 0.0 {
        return None;
    }
    let (lo, hi) = (PLAUSIBLE_HEIGHT_M.start(), PLAUSIBLE_HEIGHT_M.end());
    let size = if h < *lo {
        format!("{:.1} mm", h * 1000.0)
    } else {
        format!("{h:.1} m")
    };
    let (kind, hint) = if h > *hi {
        (
            "large",
            "if the file is in centimetres, say so with --units cm",
        )
    } else {
        (
            "small",
            "if the file is in other units, say so with --units",
        )
    };
    Some(format!(
        "{}: the character is {size} tall, implausibly {kind} (expected {} cm to {hi} m): {hint}, or give its height with --height",
        path.display(),
        lo * 100.0
    ))
}

/// The factor that scales something `measured` metres tall to `height_m`.
fn factor_for(measured: f32, height_m: f32, path: &Path) -> Result<f32> {
    if !(measured.is_finite() && measured > 1e-9) {
        return Err(Error::Format {
            path: path.to_path_buf(),
            place: "rest pose".into(),
            message: format!(
                "is flat ({measured} m tall), so it cannot be scaled to a height of {height_m} m"
            ),
        });
    }
    Ok(height_m / measured)
}

/// Scales meshes not yet rigged to `height_m`, when given.
pub(super) fn scale_meshes_to_height(
    meshes: &mut [SkinnedMesh],
    height_m: Option<f32>,
    path: &Path,
) -> Result<()> {
    let Some(h) = height_m else { return Ok(()) };
    let s = factor_for(mesh_height(meshes).unwrap_or(0.0), h, path)?;
    scale_meshes(meshes, s);
    Ok(())
}

fn scale_meshes(meshes: &mut [SkinnedMesh], s: f32) {
    for p in meshes.iter_mut().flat_map(|m| &mut m.positions) {
        *p *= s;
    }
}

/// The built-in humanoid scaled to `height_m` (as a file's character is with
/// `ImportOptions::height_m`): a crowd's people vary in height.
pub fn humanoid_of_height(height_m: f32) -> Result<Character> {
    check_height(Some(height_m))?;
    let mut c = crate::skeleton::humanoid();
    scale_to_height(&mut c, height_m, Path::new("built-in humanoid"))?;
    Ok(c)
}

/// Scales a character so that [`character_height`] is `height_m`.
pub(super) fn scale_to_height(c: &mut Character, height_m: f32, path: &Path) -> Result<()> {
    let s = factor_for(character_height(c), height_m, path)?;
    scale(c, s, path)
}

/// Scales a character already scaled to `height_m` as its file stands again, when it
/// lies down in its file: its height is then its standing one, measured stood up the way
/// role recognition stands it up ([`crate::spec::Roles::upright`]). Measured as the file
/// stands, a figure lying on its back is as tall as it is thick, and `--height 1.8` made
/// the Mannequiny lying 5.7 times too large.
pub(super) fn stand_to_height(c: &mut Character, height_m: f32, path: &Path) -> Result<()> {
    let s = factor_for(standing_height(c), height_m, path)?;
    if (s - 1.0).abs() < 1e-6 {
        return Ok(());
    }
    scale(c, s, path)
}

/// Scales a character uniformly about the origin by `s`, in the way its source's exporter
/// can write back (module docs). The skeleton and clips are checked again against
/// [`MAX_REACH_M`].
pub(super) fn scale(c: &mut Character, s: f32, path: &Path) -> Result<()> {
    if s == 1.0 {
        return Ok(());
    }
    let mut joints = c.skeleton.joints().to_vec();
    if let Source::Gltf(src) = &mut c.source {
        let src = std::sync::Arc::make_mut(src);
        let by = Transform {
            scale: Vec3::splat(s),
            ..Transform::IDENTITY
        };
        let roots: Vec<usize> = (0..joints.len())
            .filter(|&j| joints[j].parent.is_none())
            .collect();
        for &j in &roots {
            joints[j].rest = by.mul(&joints[j].rest);
            if let Some(o) = src.parent_offsets.get_mut(j) {
                *o = by.mul(o);
            }
            for frame in c.clips.iter_mut().flat_map(|k| &mut k.frames) {
                if let Some(t) = frame.get_mut(j) {
                    *t = by.mul(t);
                }
            }
        }
    } else {
        for j in &mut joints {
            j.rest.translation *= s;
            j.tip = j.tip.map(|t| t * s);
        }
        for t in c
            .clips
            .iter_mut()
            .flat_map(|k| &mut k.frames)
            .flat_map(|f| f.iter_mut())
        {
            t.translation *= s;
        }
        if let Source::Bvh(layout) = &mut c.source {
            layout.metres_per_unit *= s;
        }
    }
    scale_meshes(&mut c.meshes, s);
    c.skeleton = Skeleton::new(joints).map_err(|e| match e {
        Error::Skeleton { joint, message } => Error::Format {
            path: path.to_path_buf(),
            place: format!("joint {joint:?}"),
            message: format!("{message} (scaled by {s})"),
        },
        e => e,
    })?;
    for (k, clip) in c.clips.iter().enumerate() {
        if let Some((f, j, far)) = c.skeleton.clip_out_of_reach(clip) {
            return Err(Error::Format {
                path: path.to_path_buf(),
                place: format!("scaled clip {k}"),
                message: format!(
                    "frame {f} puts joint \"{}\" {far} m from the origin, past the {MAX_REACH_M} m a skeleton may reach (scaled by {s})",
                    c.skeleton.joint_label(j)
                ),
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::{Clip, Joint};

    fn two_joints(source: Source) -> Character {
        let joints = vec![
            Joint {
                name: "root".into(),
                parent: None,
                rest: Transform::from_translation(Vec3::new(0.0, 100.0, 0.0)),
                tip: None,
            },
            Joint {
                name: "tip".into(),
                parent: Some(0),
                rest: Transform::from_translation(Vec3::new(0.0, 80.0, 0.0)),
                tip: Some(Vec3::Y * 20.0),
            },
        ];
        let skeleton = Skeleton::new(joints).unwrap();
        let frame: Vec<Transform> = skeleton.joints().iter().map(|j| j.rest).collect();
        Character {
            name: "c".into(),
            skeleton,
            meshes: Vec::new(),
            clips: vec![Clip {
                name: "a".into(),
                frame_time: 0.1,
                frames: vec![frame],
            }],
            humanoid_bones: Vec::new(),
            warnings: Vec::new(),
            source,
        }
    }

    /// How much taller than its joints' extent a skeleton stands: as the built-in
    /// humanoid's 1.75 m is to its joints' 1.72 m.
    fn stands() -> f32 {
        1.75 / crate::skeleton::humanoid().skeleton.rest_height()
    }

    #[test]
    fn scaling_keeps_the_shape_and_scales_every_position() {
        let mut c = two_joints(Source::BuiltIn);
        assert!((stands() - 1.75 / 1.72).abs() < 1e-6);
        assert!((character_height(&c) - 100.0 * stands()).abs() < 1e-3);
        scale(&mut c, 0.01, Path::new("c.bvh")).unwrap();
        let w = c.skeleton.rest_world();
        assert!((w[1].translation.y - 1.8).abs() < 1e-5);
        assert!((character_height(&c) - stands()).abs() < 1e-5);
        let mut posed = vec![Transform::IDENTITY; 2];
        c.skeleton
            .world_from_local(&c.clips[0].frames[0], &mut posed);
        assert!((posed[1].translation.y - 1.8).abs() < 1e-5);
    }

    #[test]
    fn heights_past_the_limits_are_refused_and_flat_characters_cannot_be_sized() {
        assert!(check_height(Some(0.0)).is_err());
        assert!(check_height(Some(f32::NAN)).is_err());
        assert!(check_height(Some(2.0 * MAX_HEIGHT_M)).is_err());
        assert!(check_height(Some(1.7)).is_ok());
        let e = factor_for(0.0, 1.7, Path::new("flat.glb")).unwrap_err();
        assert!(
            e.to_string().contains("flat.glb: rest pose: is flat"),
            "{e}"
        );
    }

    /// A humanoid lying in its file is scaled to its standing height, not to the
    /// thickness its file's vertical sees; one standing is scaled as before.
    #[test]
    fn a_lying_humanoid_is_scaled_to_its_standing_height() {
        let standing = crate::skeleton::humanoid();
        let tall = character_height(&standing);
        for (how, q) in [
            ("standing", glam::Quat::IDENTITY),
            (
                "on its back",
                glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
            ),
            (
                "on its side",
                glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            ),
        ] {
            let mut c = standing.rotated(q);
            let h = standing_height(&c);
            assert!(
                (h - tall).abs() < 1e-4,
                "{how}: stands {h} m tall, not {tall}"
            );
            scale_to_height(&mut c, 1.8, Path::new("c.glb")).unwrap();
            stand_to_height(&mut c, 1.8, Path::new("c.glb")).unwrap();
            let h = character_height(&c.rotated(q.inverse()));
            assert!((h - 1.8).abs() < 1e-4, "{how}: {h} m tall (was {tall})");
        }
    }

    /// A centimetre file lying down (a Z-up export) is 100 times too tall standing, though
    /// as thick as a tall person as it lies: the warning reads its standing height.
    #[test]
    fn a_lying_giant_is_told_its_standing_height() {
        let lying = crate::skeleton::humanoid()
            .rotated(glam::Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2));
        assert_eq!(implausible(&lying, Path::new("ok.glb")), None);
        let mut giant = lying.clone();
        scale(&mut giant, 100.0, Path::new("cm.glb")).unwrap();
        assert!(character_height(&giant) < PLAUSIBLE_HEIGHT_M.end() / 2.0);
        let w = implausible(&giant, Path::new("cm.glb")).unwrap_or_default();
        assert!(
            w.contains("175.0 m tall") && w.contains("--units cm"),
            "{w}"
        );
    }

    #[test]
    fn implausible_sizes_are_stated() {
        let c = two_joints(Source::BuiltIn);
        let w = implausible(&c, Path::new("big.glb")).unwrap();
        assert!(
            w.contains("101.7 m tall") && w.contains("--units cm"),
            "{w}"
        );
        let mut small = two_joints(Source::BuiltIn);
        scale(&mut small, 1e-4, Path::new("s")).unwrap();
        let w = implausible(&small, Path::new("s")).unwrap();
        assert!(w.contains("10.2 mm tall"), "{w}");
        let mut fine = two_joints(Source::BuiltIn);
        scale(&mut fine, 0.017, Path::new("f")).unwrap();
        assert_eq!(implausible(&fine, Path::new("f")), None);
    }
}
