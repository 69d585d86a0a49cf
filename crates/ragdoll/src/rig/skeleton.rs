//! The skeleton of an unrigged mesh: its principal frame, a spine along its centre line
//! (found, or through the user's landmarks) from tail to head, and the branches (limbs,
//! fins) hung from the spine with their mirrored twins.

use super::*;

/// The skeleton [`rig`] would bind `meshes` to, without touching them.
pub fn build_skeleton(meshes: &[SkinnedMesh], opts: &RigOptions) -> Result<Skeleton> {
    check_options(opts)?;
    if opts.humanoid {
        return super::humanoid::humanoid_skeleton(meshes);
    }
    let body = Body::new(meshes)?;
    // 1–2. Centre line, tail first.
    let line = centre_line(&body, opts)?;
    let (forward, left) = facing(&body.frame, &line, opts.centre_line.is_empty());
    // 3. Spine.
    let (spine, tip) = resample(&line, opts.joints);
    let mut layout = Layout::spine(&spine, tip);
    // 4. Branches.
    for b in &opts.branches {
        add_branch(&mut layout, b, &spine, tip, &body, left)?;
    }
    check_unique_names(&layout.names)?;
    // 5. Rest frames: Y along the bone, X toward the left.
    let rotations = layout.rest_rotations(forward, left);
    Skeleton::new(layout.into_joints(&rotations))
}

/// The meshes as one body to rig: their vertices, the surface samples the centre line is
/// fitted to, and the samples' principal frame.
struct Body {
    /// Every vertex, in order, so landmarks can name vertices.
    vertices: Vec<Vec3>,
    points: Vec<Vec3>,
    weights: Vec<f32>,
    frame: Frame,
    /// Extent along the principal axis, metres.
    length: f32,
}

impl Body {
    /// Fails when the meshes have no extent to rig.
    fn new(meshes: &[SkinnedMesh]) -> Result<Body> {
        // Every vertex, in order, so landmarks can name vertices; triangle indices shifted.
        let mut vertices = Vec::new();
        let mut indices = Vec::new();
        for m in meshes {
            let base = vertices.len() as u32;
            indices.extend(m.indices.iter().map(|i| i + base));
            vertices.extend_from_slice(&m.positions);
        }
        let (points, weights) = surface_samples(&vertices, &indices);
        let frame = Frame::new(&points, &weights, &vertices);
        let length = frame.span.1 - frame.span.0;
        if points.is_empty() || too_short(length) {
            return Err(Error::Skeleton {
                joint: String::new(),
                message:
                    "cannot rig the mesh: its vertices have no extent (none, or all at one point)"
                        .into(),
            });
        }
        Ok(Body {
            vertices,
            points,
            weights,
            frame,
            length,
        })
    }

    /// Where landmark `l` is; `what` names the setting it came from, for errors.
    fn resolve(&self, l: &Landmark, what: &str) -> Result<Vec3> {
        let vertices = &self.vertices;
        let p = match *l {
            Landmark::Point(p) => p,
            Landmark::Vertex(i) => *vertices.get(i).ok_or_else(|| {
                setting(
                    what,
                    format!(
                        "vertex {i} does not exist: the mesh has {} vertices (numbered from 0)",
                        vertices.len()
                    ),
                )
            })?,
        };
        crate::events::check_point(p)
            .map(|()| p)
            .map_err(|m| setting(what, format!("a landmark: {m}")))
    }

    /// Where each of `landmarks` is, in order; the first that cannot be resolved fails.
    fn resolve_all(&self, landmarks: &[Landmark], what: &str) -> Result<Vec<Vec3>> {
        landmarks.iter().map(|l| self.resolve(l, what)).collect()
    }
}

/// Steps 1–2: the centre line, tail first: found or through the user's landmarks, then
/// turned so the end nearest the user's head point, when given, comes last.
fn centre_line(body: &Body, opts: &RigOptions) -> Result<Vec<Vec3>> {
    let mut line = if opts.centre_line.is_empty() {
        found_centre_line(body, opts.joints)
    } else {
        if opts.centre_line.len() < 2 {
            return Err(setting(
                "rig.centre_line",
                "needs at least two landmarks (tail end, head end)",
            ));
        }
        body.resolve_all(&opts.centre_line, "rig.centre_line")?
    };
    if let Some(h) = &opts.head {
        let h = body.resolve(h, "rig.head")?;
        if line[0].distance(h) < line[line.len() - 1].distance(h) {
            line.reverse();
        }
    }
    if too_short(length(&line)) {
        return Err(setting(
            "rig.centre_line",
            "its landmarks are all at one point",
        ));
    }
    Ok(line)
}

/// The centre line found by principal-component analysis (a slab polyline refined as a
/// principal curve), its higher end last.
fn found_centre_line(body: &Body, joints: usize) -> Vec<Vec3> {
    let (frame, points, weights) = (&body.frame, &body.points, &body.weights);
    let slabs = (SLABS_PER_JOINT * joints).clamp(SLAB_RANGE[0], SLAB_RANGE[1]);
    let slab_line = principal_polyline(frame, points, weights, slabs);
    let line = principal_curve(&slab_line, points, weights, slabs);
    // The higher end is the head unless the user says otherwise.
    let (low, high) = end_heights(frame, points, weights);
    if low > high {
        line.into_iter().rev().collect()
    } else {
        line
    }
}

/// The body's forward (toward the head) and left (facing the head, Y up) directions; left
/// is the normal of its symmetry plane, which runs through the centroid. `found` says the
/// centre line was found rather than run through the user's landmarks.
fn facing(frame: &Frame, line: &[Vec3], found: bool) -> (Vec3, Vec3) {
    // The body's left (facing the head, Y up) and its symmetry plane.
    // Facing: the principal axis toward the head for a found centre line (its ends may sit
    // off the axis), the line's own ends for the user's.
    let chord = line[line.len() - 1] - line[0];
    let forward = if found {
        frame.axes[0] * chord.dot(frame.axes[0]).signum()
    } else {
        chord.normalize_or(frame.axes[0])
    };
    let left = if forward.dot(Vec3::Y).abs() < UPRIGHT_COS {
        Vec3::Y.cross(forward).normalize()
    } else {
        let side = frame.axes[1];
        (side - forward * side.dot(forward)).normalize_or(forward.any_orthonormal_vector())
    };
    (forward, left)
}

/// Step 4: branch `b` and, when mirrored, its twin, each a chain of joints hung from the
/// spine joint (`spine`, the last bone ending at `tip`) nearest its first landmark.
fn add_branch(
    layout: &mut Layout,
    b: &Branch,
    spine: &[Vec3],
    tip: Vec3,
    body: &Body,
    left: Vec3,
) -> Result<()> {
    let what = format!("rig.branch \"{}\"", b.name);
    let pts = body.resolve_all(&b.points, &what)?;
    let sides = branch_sides(b, &pts, body, left, &what)?;
    // Both twins hang from the same spine joint, even where a curled spine passes
    // nearer to one of them.
    let attach = nearest_bone(spine, tip, pts[0]);
    for (pts, side) in sides {
        let stem = branch_stem(b, side);
        let mut path = vec![spine[attach]];
        path.extend_from_slice(&pts);
        let (joints, end) = branch_joints(&path, b.joints);
        if too_short(length(&path)) {
            return Err(setting(what, "its landmarks are all at one point"));
        }
        layout.push_branch(&stem, attach, &joints, end);
    }
    Ok(())
}

/// The branch's landmarks `pts` with their first one's distance off the symmetry plane
/// (normal `left`, positive on the body's left), then, when mirrored, its twin's,
/// reflected across the plane. A mirrored branch starting on the plane is refused.
fn branch_sides(
    b: &Branch,
    pts: &[Vec3],
    body: &Body,
    left: Vec3,
    what: &str,
) -> Result<Vec<(Vec<Vec3>, f32)>> {
    let centroid = body.frame.centroid;
    let mirror = |p: Vec3| p - 2.0 * (p - centroid).dot(left) * left;
    let off_plane = (pts[0] - centroid).dot(left);
    let mut sides = vec![(pts.to_vec(), off_plane)];
    if b.mirror {
        if off_plane.abs() < MIN_OFF_PLANE_OF_LENGTH * body.length {
            return Err(setting(
                what,
                format!(
                    "its first landmark lies on the body's symmetry plane ({:.3} m from it), \
                     so its mirror image would coincide with it: start it to one side, or \
                     do not mirror it",
                    off_plane.abs()
                ),
            ));
        }
        sides.push((pts.iter().map(|&p| mirror(p)).collect(), -off_plane));
    }
    Ok(sides)
}

/// Name stem of one side's joints: the branch's name, with `_l` or `_r` (by the side of
/// the symmetry plane, `side`, it is on) when mirrored.
fn branch_stem(b: &Branch, side: f32) -> String {
    match (b.mirror, side > 0.0) {
        (false, _) => b.name.clone(),
        (true, true) => format!("{}_l", b.name),
        (true, false) => format!("{}_r", b.name),
    }
}

/// A branch's joints along `path` (its spine joint, then its landmarks) and where its last
/// bone ends: one on every point but the last when `count` is 0, else the first and
/// `count` more evenly spaced along the landmarks.
fn branch_joints(path: &[Vec3], count: usize) -> (Vec<Vec3>, Vec3) {
    if count == 0 {
        (path[..path.len() - 1].to_vec(), path[path.len() - 1])
    } else {
        let (mut js, end) = resample(&path[1..], count);
        js.insert(0, path[0]);
        (js, end)
    }
}

/// Joints are found by name: a branch named like the spine's joints would shadow one.
fn check_unique_names(names: &[String]) -> Result<()> {
    let mut seen = std::collections::HashSet::with_capacity(names.len());
    if let Some(dup) = names.iter().find(|n| !seen.insert(n.as_str())) {
        return Err(setting(
            "rig.branch",
            format!("the joint name \"{dup}\" would be used twice: rename the branch"),
        ));
    }
    Ok(())
}

/// The joints placed so far, as parallel lists in skeleton order (the spine, then each
/// branch): world positions, parents, tips (where a joint's bone ends when it has no
/// child to point at) and names.
struct Layout {
    world_pos: Vec<Vec3>,
    parents: Vec<Option<usize>>,
    tips: Vec<Option<Vec3>>,
    names: Vec<String>,
}

impl Layout {
    /// Step 3: the spine's joints from the tail (the root), each the parent of the next,
    /// named `spine00`, `spine01`, …, the last one `head`, tipped at `tip`.
    fn spine(spine: &[Vec3], tip: Vec3) -> Layout {
        let joints = spine.len();
        let mut names: Vec<String> = (0..joints).map(|i| format!("spine{i:02}")).collect();
        if joints > 1 {
            names[joints - 1] = "head".into();
        }
        let mut tips: Vec<Option<Vec3>> = vec![None; joints];
        tips[joints - 1] = Some(tip);
        Layout {
            world_pos: spine.to_vec(),
            parents: (0..joints).map(|i| i.checked_sub(1)).collect(),
            tips,
            names,
        }
    }

    /// Appends one side of a branch: `joints` named `{stem}00`, `{stem}01`, …, the first
    /// hanging from spine joint `attach` and each other from the one before, the last
    /// tipped at `end`.
    fn push_branch(&mut self, stem: &str, attach: usize, joints: &[Vec3], end: Vec3) {
        for (k, p) in joints.iter().enumerate() {
            self.parents.push(Some(if k == 0 {
                attach
            } else {
                self.world_pos.len() - 1
            }));
            self.world_pos.push(*p);
            self.tips.push(None);
            self.names.push(format!("{stem}{k:02}"));
        }
        *self.tips.last_mut().expect("a branch has joints") = Some(end);
    }

    /// Step 5: each joint's world rotation: Y along its bone (to its first child, else to
    /// its tip, else `forward`), X toward `left`.
    fn rest_rotations(&self, forward: Vec3, left: Vec3) -> Vec<Quat> {
        let world_pos = &self.world_pos;
        let n = world_pos.len();
        let mut first_child = vec![None; n];
        for (i, p) in self.parents.iter().enumerate() {
            if let Some(p) = *p {
                // A branch's first joint sits on its spine joint; the spine's own next joint
                // (listed first) is the bone that matters.
                first_child[p].get_or_insert(i);
            }
        }
        (0..n)
            .map(|i| {
                let end = first_child[i]
                    .map(|c| world_pos[c])
                    .filter(|e| e.distance(world_pos[i]) > 1e-6)
                    .or(self.tips[i])
                    .unwrap_or(world_pos[i] + forward);
                bone_frame((end - world_pos[i]).normalize_or(forward), left)
            })
            .collect()
    }

    /// The joints, with their world `rotations` turned into rest transforms relative to
    /// their parents and their tips into their own frames.
    fn into_joints(self, rotations: &[Quat]) -> Vec<Joint> {
        let n = self.world_pos.len();
        let worlds: Vec<Transform> = (0..n)
            .map(|i| Transform::new(self.world_pos[i], rotations[i]))
            .collect();
        (0..n)
            .map(|i| {
                let rest = match self.parents[i] {
                    Some(p) => worlds[p].inverse().mul(&worlds[i]),
                    None => worlds[i],
                };
                Joint {
                    name: self.names[i].clone(),
                    parent: self.parents[i],
                    rest,
                    tip: self.tips[i].map(|t| worlds[i].inverse().transform_point(t)),
                }
            })
            .collect()
    }
}

/// Whether a length (metres) is too small to rig along, or not a number.
fn too_short(len: f32) -> bool {
    len.is_nan() || len <= 1e-6
}

/// The spine joint whose bone (to the next joint, the last one's to `tip`) passes
/// nearest `p`.
fn nearest_bone(spine: &[Vec3], tip: Vec3, p: Vec3) -> usize {
    let end = |i: usize| spine.get(i + 1).copied().unwrap_or(tip);
    (0..spine.len())
        .min_by(|&a, &b| {
            distance_squared_to_segment(p, spine[a], end(a))
                .total_cmp(&distance_squared_to_segment(p, spine[b], end(b)))
        })
        .unwrap_or(0)
}

/// The rotation whose Y axis is `y` and whose X axis is as close to `left` as possible.
pub(super) fn bone_frame(y: Vec3, left: Vec3) -> Quat {
    let mut x = left - y * left.dot(y);
    if x.length_squared() < 1e-8 {
        x = y.any_orthonormal_vector();
    }
    let x = x.normalize();
    let z = x.cross(y);
    Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize()
}
