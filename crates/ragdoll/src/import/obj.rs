//! Wavefront OBJ import: an unrigged triangle mesh, rigged on the way in by [`crate::rig`].
//!
//! Read: `v` (positions; a fourth coordinate or vertex colours after them are ignored),
//! `vn` (normals) and `f` (faces: `v`, `v/vt`, `v//vn` and `v/vt/vn` corners, negative
//! indices counting back from the latest element, polygons fan-triangulated). Everything
//! else (`vt`, `o`, `g`, `s`, `usemtl`, `mtllib`, lines, points, curves) is skipped: a
//! ragdoll needs only the shape.
//!
//! Choices, and why:
//! - **Hand-written**, not `tobj`: errors must name the file *and the line* (a broken face
//!   in a 27 000-face scan is otherwise impossible to find), which `tobj` does not report.
//! - **One vertex per `v` line**, in order, so a vertex's index is its OBJ number minus
//!   one and rig landmarks can name vertices as the user sees them in a modeller. Corners
//!   that pair one position with different normals (hard edges) are not split: their
//!   normals are averaged, which is enough to light a ragdoll. Positions no face uses are
//!   kept (their indices must not shift).
//! - **Normals**: the file's, averaged per position; where a position has none, the
//!   area-weighted normal of the faces around it.
//! - **Units and up axis**: OBJ says neither; metres and Y up unless the caller's
//!   [`ImportOptions`] say otherwise.
//! - **Limits**: coordinates within ±[`MAX_COORDINATE`], at most [`MAX_VERTICES`] vertices
//!   (and as many normals) and [`MAX_TRIANGLES`] triangles, each refused with its line; the
//!   file itself is read with [`crate::files::read_capped`].

use std::path::Path;

use glam::{Quat, Vec3};

use super::{ImportOptions, UpAxis};
use crate::error::{Error, Result};
use crate::rig::{RigOptions, rig_reporting};
use crate::skeleton::{Character, SkinnedMesh, Source};

/// Largest absolute coordinate a `v` or `vn` line may have, in file units: one million
/// (1,000 km in metres, 1 km in millimetres). A larger value is a broken file, and would
/// only blow up later, in the rig or the physics.
pub const MAX_COORDINATE: f32 = 1e6;

/// Most vertices (`v` lines), and most normals (`vn` lines), an OBJ may have: 8 million.
/// With its normals, triangles and the automatic skin, such a mesh takes about 1 GB; a
/// 27,000-face scan is small next to it. Decimate larger scans first.
pub const MAX_VERTICES: usize = 8_000_000;

/// Most triangles an OBJ may have once its polygons are fanned: 16 million.
pub const MAX_TRIANGLES: usize = 16_000_000;

/// Loads an OBJ file and rigs it with `rig_opts` (see [`crate::rig`]).
pub fn load(path: &Path, opts: &ImportOptions, rig_opts: &RigOptions) -> Result<Character> {
    let bytes = crate::files::read_capped(path, crate::files::MAX_INPUT_BYTES)?;
    let text = String::from_utf8_lossy(&bytes);
    let mesh = parse(&text, path, opts)?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    rigged_character(name, vec![mesh], rig_opts, path)
}

/// A character from meshes without a skeleton: rigged by [`crate::rig::rig`], its source
/// the file `path` (which also names it in errors).
pub(crate) fn rigged_character(
    name: String,
    mut meshes: Vec<SkinnedMesh>,
    rig_opts: &RigOptions,
    path: &Path,
) -> Result<Character> {
    let (skeleton, fallback) = rig_reporting(&mut meshes, rig_opts).map_err(|e| match e {
        Error::Skeleton { message, .. } => Error::Format {
            path: path.to_path_buf(),
            place: "mesh".into(),
            message,
        },
        other => other,
    })?;
    let fallback = fallback.map(|why| {
        format!(
            "{}: skin weights follow straight-line distance, not the body (bone heat): {why}",
            path.display()
        )
    });
    let spine_only = rig_opts.branches.is_empty() && !rig_opts.humanoid;
    let upright = (spine_only && stands_upright(&skeleton)).then(|| {
        format!(
            "{}: the mesh stands upright, and the automatic rig gives it a spine only: a \
             standing figure (a person) becomes a pole that folds; `ragdoll rig --humanoid` \
             fits a person's skeleton to one standing in a T- or A-pose, and `--branch` \
             adds limbs to anything else",
            path.display()
        )
    });
    let warnings = fallback.into_iter().chain(upright).collect();
    Ok(Character {
        humanoid_bones: Vec::new(),
        warnings,
        name,
        skeleton,
        meshes,
        clips: Vec::new(),
        source: Source::Mesh(path.to_path_buf()),
    })
}

/// Whether a rigged spine runs from its tail to its head within [`UPRIGHT_COS`] of
/// vertical: a figure standing on its own axis, which a spine alone cannot hold up.
fn stands_upright(skeleton: &crate::skeleton::Skeleton) -> bool {
    let world = skeleton.rest_world();
    let (Some(first), Some(last)) = (world.first(), world.last()) else {
        return false;
    };
    let axis = (last.translation - first.translation).normalize_or_zero();
    axis.y.abs() >= UPRIGHT_COS
}

/// A spine whose axis is this close to vertical (|cos|) belongs to a figure standing up.
const UPRIGHT_COS: f32 = 0.9;

fn parse_err(path: &Path, line: usize, message: impl Into<String>) -> Error {
    Error::Parse {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

/// Parses OBJ text into one triangle mesh (no skin yet), converted to metres and Y up.
///
/// This is the entry point for fuzzing (through `String::from_utf8_lossy` of the bytes):
/// any text gives a mesh or an [`Error`] naming a line, never a panic.
pub fn parse(text: &str, path: &Path, opts: &ImportOptions) -> Result<SkinnedMesh> {
    let mut obj = Reader::default();
    for (n, raw) in text.lines().enumerate() {
        obj.read_line(raw, n + 1, path)?;
    }
    if obj.indices.is_empty() {
        return Err(Error::Format {
            path: path.to_path_buf(),
            place: "faces".into(),
            message: format!(
                "the file has {} vertices but no faces (`f` lines): nothing to rig",
                obj.positions.len()
            ),
        });
    }
    let normals = vertex_normals(&obj.positions, &obj.indices, &obj.normal_sum);
    let (positions, normals) = to_metres_y_up(&obj.positions, &normals, opts);
    Ok(SkinnedMesh {
        name: path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default(),
        positions,
        normals,
        indices: obj.indices,
        joints: Vec::new(),
        weights: Vec::new(),
    })
}

/// What [`parse`] has read so far, in file units and axes: faces refer back to it, and
/// negative indices count from its current end.
#[derive(Default)]
struct Reader {
    positions: Vec<Vec3>,
    file_normals: Vec<Vec3>,
    indices: Vec<u32>,
    /// Per position: sum of the file normals its corners name.
    normal_sum: Vec<Vec3>,
    /// The current face's positions; kept between faces to reuse its allocation.
    corners: Vec<u32>,
}

impl Reader {
    /// One line, numbered from 1 for errors. Comments are cut first, so `#` after a
    /// statement is ignored too; unknown keywords are skipped, as the module says.
    fn read_line(&mut self, raw: &str, line_no: usize, path: &Path) -> Result<()> {
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            return Ok(());
        };
        match keyword {
            "v" | "vn" => {
                let xyz = read_xyz(keyword, &mut words, path, line_no)?;
                self.push_vector(keyword, xyz, path, line_no)
            }
            "f" => self.read_face(words, path, line_no),
            _ => Ok(()),
        }
    }

    /// Stores a `v` or `vn` once its coordinates are known good; the count is checked
    /// before the push so that no file grows the lists past [`MAX_VERTICES`].
    fn push_vector(&mut self, keyword: &str, xyz: Vec3, path: &Path, line_no: usize) -> Result<()> {
        let count = if keyword == "v" {
            self.positions.len()
        } else {
            self.file_normals.len()
        };
        if count >= MAX_VERTICES {
            return Err(parse_err(
                path,
                line_no,
                format!("`{keyword}`: more than the {MAX_VERTICES} an OBJ may have"),
            ));
        }
        if keyword == "v" {
            self.positions.push(xyz);
            self.normal_sum.push(Vec3::ZERO);
        } else {
            self.file_normals.push(xyz);
        }
        Ok(())
    }

    /// An `f` line: every corner is resolved (and its file normal added to its position)
    /// before the face is judged, so a bad index is reported ahead of a short face.
    fn read_face<'a>(
        &mut self,
        words: impl Iterator<Item = &'a str>,
        path: &Path,
        line_no: usize,
    ) -> Result<()> {
        self.corners.clear();
        for w in words {
            let vi = self.read_corner(w, path, line_no)?;
            self.corners.push(vi as u32);
        }
        if self.corners.len() < 3 {
            return Err(parse_err(
                path,
                line_no,
                format!(
                    "a face needs at least 3 corners, found {}",
                    self.corners.len()
                ),
            ));
        }
        self.fan_triangulate(path, line_no)
    }

    /// One `v`, `v/vt`, `v//vn` or `v/vt/vn` corner, as its 0-based position. The texture
    /// index is not even parsed: the mesh has no use for it.
    fn read_corner(&mut self, word: &str, path: &Path, line_no: usize) -> Result<usize> {
        let mut parts = word.split('/');
        let v = parts.next().unwrap_or("");
        let vi = resolve(v, self.positions.len(), "vertex", path, line_no)?;
        let _texture = parts.next();
        if let Some(vn) = parts.next().filter(|s| !s.is_empty()) {
            let ni = resolve(vn, self.file_normals.len(), "normal", path, line_no)?;
            self.normal_sum[vi] += self.file_normals[ni];
        }
        Ok(vi)
    }

    /// Fans the current face from its first corner; the triangle count is checked before
    /// the indices grow, so that no file makes more than [`MAX_TRIANGLES`].
    fn fan_triangulate(&mut self, path: &Path, line_no: usize) -> Result<()> {
        let corners = &self.corners;
        if self.indices.len() / 3 + (corners.len() - 2) > MAX_TRIANGLES {
            return Err(parse_err(
                path,
                line_no,
                format!(
                    "the faces so far make more than the {MAX_TRIANGLES} triangles an OBJ may have"
                ),
            ));
        }
        for k in 1..corners.len() - 1 {
            self.indices
                .extend([corners[0], corners[k], corners[k + 1]]);
        }
        Ok(())
    }
}

/// The three numbers after `v` or `vn`, each checked as it is read so the error names the
/// first bad one; numbers after the third (a `w`, vertex colours) are ignored.
fn read_xyz<'a>(
    keyword: &str,
    words: &mut impl Iterator<Item = &'a str>,
    path: &Path,
    line_no: usize,
) -> Result<Vec3> {
    let mut xyz = [0.0f32; 3];
    for (k, c) in xyz.iter_mut().enumerate() {
        let w = words.next().ok_or_else(|| {
            parse_err(
                path,
                line_no,
                format!("`{keyword}` needs three numbers, found {k}"),
            )
        })?;
        *c = read_coordinate(keyword, w, path, line_no)?;
    }
    Ok(Vec3::from_array(xyz))
}

/// One coordinate: finite and within ±[`MAX_COORDINATE`], since a larger one would only
/// blow up later, in the rig or the physics.
fn read_coordinate(keyword: &str, w: &str, path: &Path, line_no: usize) -> Result<f32> {
    let c = w
        .parse::<f32>()
        .ok()
        .filter(|x| x.is_finite())
        .ok_or_else(|| {
            parse_err(
                path,
                line_no,
                format!("`{keyword}`: {w:?} is not a finite number"),
            )
        })?;
    if c.abs() > MAX_COORDINATE {
        return Err(parse_err(
            path,
            line_no,
            format!("`{keyword}`: {w} is beyond the ±{MAX_COORDINATE} a coordinate may be"),
        ));
    }
    Ok(c)
}

/// One unit normal per position: the file's normals averaged, else the area-weighted
/// normal of the faces around it (so scans without `vn` still light), else +Y for a
/// position no face uses or whose faces are degenerate.
fn vertex_normals(positions: &[Vec3], indices: &[u32], normal_sum: &[Vec3]) -> Vec<Vec3> {
    // Area-weighted face normals for positions the file gave none.
    let mut face_sum = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let (a, b, c) = (
            positions[t[0] as usize],
            positions[t[1] as usize],
            positions[t[2] as usize],
        );
        let n = (b - a).cross(c - a);
        for &i in t {
            face_sum[i as usize] += n;
        }
    }
    normal_sum
        .iter()
        .zip(&face_sum)
        .map(|(f, a)| f.try_normalize().or(a.try_normalize()).unwrap_or(Vec3::Y))
        .collect()
}

/// Positions and normals in metres with Y up: OBJ states neither its unit nor its up
/// axis, so the caller's [`ImportOptions`] decide, metres and Y up by default.
fn to_metres_y_up(
    positions: &[Vec3],
    normals: &[Vec3],
    opts: &ImportOptions,
) -> (Vec<Vec3>, Vec<Vec3>) {
    let scale = opts.units.map_or(1.0, |u| u.to_metres());
    let turn = match opts.up {
        Some(UpAxis::Z) => Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
        _ => Quat::IDENTITY,
    };
    (
        positions.iter().map(|p| turn * (*p * scale)).collect(),
        normals.iter().map(|n| turn * *n).collect(),
    )
}

/// A 1-based or negative (relative) OBJ index into a list of `count` elements read so far,
/// as a 0-based index.
fn resolve(word: &str, count: usize, what: &str, path: &Path, line: usize) -> Result<usize> {
    let i: i64 = word.parse().map_err(|_| {
        parse_err(
            path,
            line,
            format!("face corner: {what} index {word:?} is not a whole number"),
        )
    })?;
    let idx = match i {
        0 => None,
        i if i > 0 => Some(i as u64 - 1),
        i => (count as u64).checked_sub(i.unsigned_abs()),
    };
    match idx {
        Some(k) if k < count as u64 => Ok(k as usize),
        _ => Err(parse_err(
            path,
            line,
            format!("face corner: {what} index {i} does not exist (only {count} so far)"),
        )),
    }
}
