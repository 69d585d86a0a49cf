//! The checks and measurements [`crate::Preview::new`] makes before it allocates anything: bad
//! input fails here with a message naming the character and frame, and what the camera
//! must frame and how fine the ground grid is are settled once for the whole run.

use std::borrow::Cow;

use glam::Vec3;
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, SkinnedMesh};
use ragdoll::spec::RagdollSpec;
use ragdoll::track::Track;
use ragdoll::{Error, Result};

use crate::markers::fireball_radius;
use crate::{ALBEDO, Actor, ActorView, Marker, MeshView};

/// A ball the camera must keep in the picture: centre and radius, metres.
pub(crate) type Ball = (Vec3, f32);

/// Every input error is reported as a bad `preview` setting, so the caller names it the
/// same way whichever check failed.
fn setting_error(message: String) -> Error {
    Error::Setting {
        setting: "preview".into(),
        message,
    }
}

/// The frame rate every track must share, taken from the first: frame numbers and times
/// only line up across characters when they all agree.
pub(crate) fn shared_fps(actors: &[Actor<'_>]) -> Result<f32> {
    if actors.is_empty() {
        return Err(setting_error("there is no character to draw".into()));
    }
    let fps = actors[0].2.fps;
    if !(fps.is_finite() && fps > 0.0) {
        return Err(setting_error(format!(
            "the frame rate {fps} is not positive"
        )));
    }
    Ok(fps)
}

/// The renderer's buffers for character number `k`, after its track is checked; the
/// balls its motion sweeps are added to `points`.
pub(crate) fn actor_view<'a>(
    k: usize,
    (character, spec, track): Actor<'a>,
    fps: f32,
    points: &mut Vec<Ball>,
) -> Result<ActorView<'a>> {
    check_track(character, track, fps)?;
    let meshes = actor_meshes(character, spec)?;
    let rest = character.skeleton.rest_world();
    let pad = mesh_reach(&meshes, &rest, character);
    let stride = track.frames.len().div_ceil(600).max(1);
    for frame in track.frames.iter().step_by(stride) {
        points.extend(frame.iter().map(|t| (t.translation, pad)));
    }
    Ok(ActorView {
        track,
        rest,
        meshes: meshes
            .into_iter()
            .map(|mesh| MeshView {
                mesh,
                positions: Vec::new(),
                normals: Vec::new(),
            })
            .collect(),
        albedo: ALBEDO[k % ALBEDO.len()],
    })
}

/// Fails on a track that cannot be drawn frame by frame later: empty, at another frame
/// rate than the first, or with a frame that does not fit the skeleton or is not finite.
fn check_track(character: &Character, track: &Track, fps: f32) -> Result<()> {
    let name = &character.name;
    if track.frames.is_empty() {
        return Err(setting_error(format!("{name}: the track has no frames")));
    }
    if (track.fps - fps).abs() > 1e-3 * fps {
        return Err(setting_error(format!(
            "{name}: the track runs at {} fps, the first at {fps}",
            track.fps
        )));
    }
    for (f, frame) in track.frames.iter().enumerate() {
        if frame.len() != character.skeleton.len() {
            return Err(setting_error(format!(
                "{name}: frame {f} has {} joints, the skeleton {}",
                frame.len(),
                character.skeleton.len()
            )));
        }
        if frame.iter().any(|t| !t.is_finite()) {
            return Err(setting_error(format!("{name}: frame {f} is not finite")));
        }
    }
    Ok(())
}

/// The character's own meshes, borrowed; a character without one is drawn as the
/// capsules and boxes of its ragdoll instead.
fn actor_meshes<'a>(
    character: &'a Character,
    spec: &RagdollSpec,
) -> Result<Vec<Cow<'a, SkinnedMesh>>> {
    Ok(if character.meshes.is_empty() {
        vec![Cow::Owned(ragdoll::spec::bodies_mesh(
            &character.skeleton,
            spec,
        )?)]
    } else {
        character.meshes.iter().map(Cow::Borrowed).collect()
    })
}

/// Joints alone underestimate the body: pad by how far the mesh reaches from the joints
/// that carry it (capped at twice the character's height, so a stray vertex cannot pull
/// the camera far back).
fn mesh_reach(meshes: &[Cow<'_, SkinnedMesh>], rest: &[Transform], character: &Character) -> f32 {
    meshes
        .iter()
        .flat_map(|m| m.positions.iter().zip(&m.joints).zip(&m.weights))
        .map(|((p, j), w)| {
            let a = w.to_array();
            let main = (0..4).max_by(|&x, &y| a[x].total_cmp(&a[y])).unwrap_or(0);
            rest.get(j[main] as usize)
                .map_or(0.0, |r| (*p - r.translation).length())
        })
        .fold(0.0f32, f32::max)
        .min(2.0 * character.skeleton.rest_height().max(0.1))
}

/// Adds what each marker needs in the picture to `points`: a blast's whole fireball, a
/// shot's muzzle and (only when it hit) its end. Fails on a non-finite position.
pub(crate) fn marker_balls(markers: &[Marker], points: &mut Vec<Ball>) -> Result<()> {
    for m in markers {
        let marks = match *m {
            Marker::Blast {
                position, tnt_kg, ..
            } => [(position, 1.4 * fireball_radius(tnt_kg)); 2],
            Marker::Shot {
                origin, end, hit, ..
            } => [(origin, 0.05), (if hit { end } else { origin }, 0.05)],
        };
        if marks.iter().any(|(p, _)| !p.is_finite()) {
            return Err(setting_error("a marker's position is not finite".into()));
        }
        points.extend(marks);
    }
    Ok(())
}

/// The box the shadows must cover, corners low and high: around every ball and down to
/// the ground, and at least a small room, whose corners are added to `points` so the
/// camera frames it too.
pub(crate) fn framed_box(points: &mut Vec<Ball>) -> (Vec3, Vec3) {
    let (mut lo, hi) = points.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &(p, r)| (lo.min(p - r), hi.max(p + r)),
    );
    lo.y = lo.y.min(0.0);
    // Never frame less than a small room, so a still character is not blown up.
    let centre = (lo + hi) * 0.5;
    let half = ((hi - lo) * 0.5).max(Vec3::splat(0.4));
    points.push((centre - Vec3::splat(0.4), 0.0));
    points.push((centre + Vec3::splat(0.4), 0.0));
    (centre - half, centre + half)
}

/// The number of frames (the longest track's) and the range drawn, first and last
/// inclusive: `frames` when given, which must end within the track, else all of them.
pub(crate) fn frame_range(
    views: &[ActorView<'_>],
    frames: Option<(usize, usize)>,
) -> Result<(usize, (usize, usize))> {
    let count = views
        .iter()
        .map(|v| v.track.frames.len())
        .max()
        .unwrap_or(1);
    let range = frames.unwrap_or((0, count - 1));
    if range.1 >= count {
        return Err(Error::Setting {
            setting: "frames".into(),
            message: format!(
                "the frame range ends at {} but the last frame is {}",
                range.1,
                count - 1
            ),
        });
    }
    Ok((count, range))
}

/// Ground grid spacing, metres, from the tallest character: 1 m for anything from about
/// half to five times a person's height, a power of ten that suits other sizes.
pub(crate) fn grid_spacing(actors: &[Actor<'_>]) -> f32 {
    let size = actors
        .iter()
        .map(|a| a.0.skeleton.rest_height())
        .fold(0.0f32, f32::max);
    let ratio = size.max(0.01) / ragdoll::skeleton::DEFAULT_HEIGHT_M;
    10f32.powf((ratio.log10() + 0.3).floor())
}
