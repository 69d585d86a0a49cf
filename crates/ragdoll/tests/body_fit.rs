//! Body fit: each body's shape encloses the skin it carries in the rest pose,
//! so a character lying on its bodies does not push its mesh into the floor.
//!
//! The skin a body carries is worked out here independently of the builder: a vertex
//! belongs to the body of the joint holding at least half its weight, a joint without a
//! body counting as its nearest ancestor's body.
//!
//! The data test prints each file's fit:
//! `RAGDOLL_DATA=../shared/data cargo test --release -p ragdoll --test body_fit -- --ignored --nocapture`.

mod common;

use glam::{Quat, Vec3, Vec4};
use ragdoll::import::{ImportOptions, load};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, Joint, Skeleton, SkinnedMesh, Source, humanoid};
use ragdoll::spec::{BuildOptions, RagdollSpec, Shape, build_spec, recognise_roles};

/// A body's world shape in the rest pose.
struct Solid {
    shape: Shape,
    centre: Vec3,
    rotation: Quat,
}

impl Solid {
    /// How far `p` lies outside the shape (0 inside), metres.
    fn outside(&self, p: Vec3) -> f32 {
        let q = self.rotation.conjugate() * (p - self.centre);
        match self.shape {
            Shape::Capsule { radius_m, length_m } => {
                let y = q.y.clamp(-0.5 * length_m, 0.5 * length_m);
                ((q - Vec3::new(0.0, y, 0.0)).length() - radius_m).max(0.0)
            }
            Shape::Box { size_m } => (q.abs() - 0.5 * Vec3::from_array(size_m))
                .max(Vec3::ZERO)
                .length(),
        }
    }
}

/// Each skin vertex (rest pose, world) with the bodies that carry it: those whose joints
/// hold at least half its weight (two on an even split, which the builder may give to
/// either).
fn carried(c: &Character, spec: &RagdollSpec) -> Vec<(Vec3, Vec<usize>)> {
    let s = &c.skeleton;
    let mut owner: Vec<Option<usize>> = vec![None; s.len()];
    for (b, body) in spec.bodies.iter().enumerate() {
        let j = (0..s.len())
            .find(|&j| s.joint_label(j) == body.bone)
            .unwrap();
        owner[j] = Some(b);
    }
    for j in 0..s.len() {
        if owner[j].is_none() {
            owner[j] = Some(s.parent(j).and_then(|p| owner[p]).unwrap_or(0));
        }
    }
    let mut out = Vec::new();
    for m in &c.meshes {
        for (k, p) in m.positions.iter().enumerate() {
            let (js, ws): ([u16; 4], Vec4) = (m.joints[k], m.weights[k]);
            let mut share = vec![0.0f32; spec.bodies.len()];
            for i in 0..4 {
                if let Some(Some(o)) = owner.get(js[i] as usize) {
                    share[*o] += ws[i].max(0.0);
                }
            }
            let bodies: Vec<usize> = (0..share.len()).filter(|&b| share[b] >= 0.5).collect();
            if !bodies.is_empty() {
                out.push((*p, bodies));
            }
        }
    }
    out
}

fn solids(c: &Character, spec: &RagdollSpec) -> Vec<Solid> {
    let world = c.skeleton.rest_world();
    spec.bodies
        .iter()
        .map(|b| {
            let j = (0..c.skeleton.len())
                .find(|&j| c.skeleton.joint_label(j) == b.bone)
                .unwrap();
            let (r, t) = (world[j].rotation, world[j].translation);
            Solid {
                shape: b.shape,
                centre: t + r * Vec3::from_array(b.center_m),
                rotation: r * Quat::from_array(b.rotation),
            }
        })
        .collect()
}

/// How far each carried vertex lies outside the body (of those carrying it) that holds
/// it best, metres, with that body.
fn misfits(c: &Character, spec: &RagdollSpec) -> Vec<(f32, usize, Vec3)> {
    let solids = solids(c, spec);
    carried(c, spec)
        .into_iter()
        .map(|(p, bodies)| {
            let (d, b) = bodies
                .iter()
                .map(|&b| (solids[b].outside(p), b))
                .min_by(|x, y| x.0.total_cmp(&y.0))
                .unwrap();
            (d, b, p)
        })
        .collect()
}

/// Vertical extent of the skin, metres.
fn skin_height(c: &Character) -> f32 {
    let ys = c
        .meshes
        .iter()
        .flat_map(|m| m.positions.iter().map(|p| p.y));
    let (lo, hi) = ys.fold((f32::MAX, f32::MIN), |(l, h), y| (l.min(y), h.max(y)));
    hi - lo
}

/// Farthest point of the shape along unit `dir`, as a distance along it.
fn support(s: &Solid, dir: Vec3) -> f32 {
    let d = s.rotation.conjugate() * dir;
    let local = match s.shape {
        Shape::Capsule { radius_m, length_m } => 0.5 * length_m * d.y.abs() + radius_m,
        Shape::Box { size_m } => 0.5 * Vec3::from_array(size_m).dot(d.abs()),
    };
    s.centre.dot(dir) + local
}

/// Ring vertices around `a → b` (semi-axes `rx` along `x`, `rz` across), from `t0` to
/// `t1` of the bone's length, weighted wholly to `joint`; `round` narrows the rings to an
/// ellipsoid's.
#[allow(clippy::too_many_arguments)]
fn tube(
    mesh: &mut SkinnedMesh,
    joint: usize,
    a: Vec3,
    b: Vec3,
    x: Vec3,
    (rx, rz): (f32, f32),
    (t0, t1): (f32, f32),
    round: bool,
) {
    let u = (b - a).normalize();
    let x = (x - u * x.dot(u)).normalize();
    let z = x.cross(u);
    for i in 0..=8 {
        let t = t0 + (t1 - t0) * i as f32 / 8.0;
        let s = 2.0 * i as f32 / 8.0 - 1.0;
        let w = if round { (1.0 - s * s).sqrt() } else { 1.0 };
        let (rx, rz) = (rx * w, rz * w);
        for k in 0..12 {
            let th = k as f32 / 12.0 * std::f32::consts::TAU;
            let p = a.lerp(b, t) + x * (rx * th.cos()) + z * (rz * th.sin());
            mesh.positions.push(p);
            mesh.joints.push([joint as u16, 0, 0, 0]);
            mesh.weights.push(Vec4::new(1.0, 0.0, 0.0, 0.0));
        }
    }
}

/// The built-in humanoid with a skin: elliptic tubes around each bone, as thick as a
/// person's limbs and trunk, reaching a little past the joints; flat hands and feet; a
/// round head whose crown lies past the head bone's end.
fn skinned_humanoid() -> Character {
    let mut c = humanoid();
    let s = &c.skeleton;
    let world = s.rest_world();
    let ends = s.rest_bone_ends();
    let mut mesh = SkinnedMesh {
        name: "skin".into(),
        positions: Vec::new(),
        normals: Vec::new(),
        indices: Vec::new(),
        joints: Vec::new(),
        weights: Vec::new(),
    };
    for j in 0..s.len() {
        let (a, Some(b)) = (world[j].translation, ends[j]) else {
            continue;
        };
        let name = s.joints()[j].name.as_str();
        let (r, t) = match name.trim_end_matches("_l").trim_end_matches("_r") {
            "pelvis" | "spine" | "chest" => ((0.15, 0.10), (-0.1, 1.1)),
            "neck" => ((0.05, 0.05), (0.0, 1.0)),
            "head" => ((0.09, 0.10), (-0.2, 1.1)),
            "upper_arm" => ((0.05, 0.05), (-0.1, 1.1)),
            "forearm" => ((0.04, 0.035), (-0.1, 1.1)),
            "hand" => ((0.045, 0.015), (0.0, 1.1)),
            "thigh" => ((0.08, 0.08), (-0.1, 1.1)),
            "shin" => ((0.055, 0.055), (-0.1, 1.1)),
            "foot" => ((0.045, 0.03), (-0.3, 1.1)),
            other => panic!("unexpected joint {other}"),
        };
        tube(&mut mesh, j, a, b, Vec3::X, r, t, name == "head");
    }
    c.meshes.push(mesh);
    c
}

#[test]
fn body_fit_every_vertex_of_a_skinned_humanoid_lies_inside_its_body() {
    let c = skinned_humanoid();
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    let fits = misfits(&c, &spec);
    assert!(fits.len() > 1000, "{} vertices carried", fits.len());
    for (d, b, p) in &fits {
        assert!(
            *d < 1e-3,
            "a vertex at {p} lies {d} m outside {} ({:?})",
            spec.bodies[*b].name,
            spec.bodies[*b].shape
        );
    }
}

#[test]
fn body_fit_bodies_reach_as_far_as_the_skin_and_not_much_farther() {
    // Lying on any side, the character rests on its bodies: in every direction (the six
    // axes and the eight diagonals) they reach the skin's farthest point, so no vertex
    // goes through the floor, and not more than 5 % of its height past it (bodies much
    // bigger than the skin would float it off the floor).
    let c = skinned_humanoid();
    let spec = build_spec(&c, &BuildOptions::default()).unwrap();
    let h = skin_height(&c);
    let (past, short) = reach_past_skin(&c, &spec);
    assert!(short <= 1e-3, "the bodies stop {short} m short of the skin");
    assert!(past <= 0.05 * h, "the bodies reach {past} m past the skin");
}

/// How far past the skin the bodies reach at worst, over the six axes and the eight
/// diagonals, and how far short of it (both metres, positive when past).
fn reach_past_skin(c: &Character, spec: &RagdollSpec) -> (f32, f32) {
    let solids = solids(c, spec);
    let skin: Vec<Vec3> = c.meshes.iter().flat_map(|m| m.positions.clone()).collect();
    let mut dirs = vec![Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                dirs.push(Vec3::new(sx, sy, sz).normalize());
            }
        }
    }
    let (mut past, mut short) = (f32::MIN, f32::MIN);
    for dir in dirs {
        let skin_far = skin.iter().map(|p| p.dot(dir)).fold(f32::MIN, f32::max);
        let body_far = solids
            .iter()
            .map(|s| support(s, dir))
            .fold(f32::MIN, f32::max);
        past = past.max(body_far - skin_far);
        short = short.max(skin_far - body_far);
    }
    (past, short)
}

/// Two joints in a chain `turn`ed in the world, the bone between them `length` metres
/// long, with an empty skin.
fn two_bones(turn: Quat, length: f32) -> Character {
    let joints = vec![
        Joint {
            name: "root".into(),
            parent: None,
            rest: Transform::new(Vec3::ZERO, turn),
            tip: None,
        },
        Joint {
            name: "tip".into(),
            parent: Some(0),
            rest: Transform::new(Vec3::Y * length, Quat::IDENTITY),
            tip: Some(Vec3::Y * length),
        },
    ];
    let mesh = SkinnedMesh {
        name: "skin".into(),
        positions: Vec::new(),
        normals: Vec::new(),
        indices: Vec::new(),
        joints: Vec::new(),
        weights: Vec::new(),
    };
    Character {
        name: "two bones".into(),
        skeleton: Skeleton::new(joints).unwrap(),
        meshes: vec![mesh],
        clips: Vec::new(),
        humanoid_bones: Vec::new(),
        warnings: Vec::new(),
        source: Source::BuiltIn,
    }
}

/// A low-polygon strip: [`two_bones`] 1 m apart and a flat strip of `rows` pairs of
/// vertices beside the bones (not around them), blended from the first joint to the
/// second along it, as Khronos' skinning sample is.
fn strip(turn: Quat, rows: usize) -> Character {
    let mut c = two_bones(turn, 1.0);
    let mesh = &mut c.meshes[0];
    for r in 0..rows {
        let t = r as f32 / (rows - 1) as f32;
        for x in [0.0, 1.0] {
            mesh.positions.push(turn * Vec3::new(x, 2.0 * t, 0.0));
            mesh.joints.push([0, 1, 0, 0]);
            mesh.weights.push(Vec4::new(1.0 - t, t, 0.0, 0.0));
        }
    }
    c
}

#[test]
fn body_fit_a_strip_of_a_few_vertices_rests_on_bodies_as_thin_as_it() {
    // Too few vertices per body for a percentile, but enough to say where the skin is:
    // the bodies hold the whole strip and reach no farther than 5 % of its length past
    // it on any side, so it neither sinks nor stands on bodies wider than it is. Upright,
    // lying, and turned off every axis.
    for turn in [
        Quat::IDENTITY,
        Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        Quat::from_euler(glam::EulerRot::YXZ, 0.7, 0.4, -0.3),
    ] {
        for rows in [4, 5, 7] {
            let c = strip(turn, rows);
            let spec = build_spec(&c, &BuildOptions::default()).unwrap();
            for (d, b, p) in misfits(&c, &spec) {
                assert!(
                    d < 1e-3,
                    "{rows} rows turned {turn}: {p} lies {d} m outside {:?}",
                    spec.bodies[b].shape
                );
            }
            let (past, short) = reach_past_skin(&c, &spec);
            assert!(short < 1e-3, "{rows} rows turned {turn}: {short} m short");
            assert!(
                past < 0.05 * 2.0,
                "{rows} rows turned {turn}: bodies reach {past} m past the strip: {:?}",
                spec.bodies.iter().map(|b| &b.shape).collect::<Vec<_>>()
            );
        }
    }
}

#[test]
fn body_fit_a_few_vertices_bunched_off_the_bone_keep_a_body_as_thick_as_a_limb() {
    // A handful of vertices in a centimetre, 12 cm beside a 30 cm bone (a stray patch of
    // skin weighted to it, farther out than the bone's proportional radius): too few to
    // measure, and no strip or plate, so the body keeps its proportional thickness rather
    // than shrinking to a box round the patch (a 14 mm box on a fox's leg blew it apart
    // on the particle engine).
    for turn in [
        Quat::IDENTITY,
        Quat::from_euler(glam::EulerRot::YXZ, 0.7, 0.4, -0.3),
    ] {
        let mut c = two_bones(turn, 0.3);
        let mesh = &mut c.meshes[0];
        for k in 0..5 {
            let p = Vec3::new(
                0.12 + 0.002 * k as f32,
                0.15 + 0.002 * (k % 2) as f32,
                0.003,
            );
            mesh.positions.push(turn * p);
            mesh.joints.push([0, 1, 0, 0]);
            mesh.weights.push(Vec4::new(1.0, 0.0, 0.0, 0.0));
        }
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        let root = &spec.bodies[0];
        let thinnest = match root.shape {
            Shape::Capsule { radius_m, .. } => 2.0 * radius_m,
            Shape::Box { size_m } => size_m[0].min(size_m[2]),
        };
        assert!(thinnest > 0.03, "{:?}", root.shape);
    }
}

#[test]
#[ignore = "needs ../shared/data"]
fn body_fit_every_data_rig_holds_its_skin() {
    // Every skinned humanoid of the data folder (glTF and VRM): each body holds the skin
    // it carries, within 1 % of the character's height. (Creatures' bodies are fitted the
    // same way: see `Builder::chain_plan` in spec/build/shapes.rs.)
    let data = common::shared_data();
    let mut files = Vec::new();
    for folder in ["gltf", "rigs"] {
        for e in std::fs::read_dir(data.join(folder)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|e| e != "bvh") {
                files.push(p);
            }
        }
    }
    files.sort();
    assert!(files.len() >= 8, "{files:?}");
    let mut bad = Vec::new();
    for f in files {
        let c = load(&f, &ImportOptions::default()).unwrap();
        if !recognise_roles(&c).humanoid {
            continue;
        }
        let spec = build_spec(&c, &BuildOptions::default()).unwrap();
        let h = skin_height(&c);
        let fits = misfits(&c, &spec);
        let out = fits.iter().filter(|(d, ..)| *d > 0.01 * h).count();
        let worst = fits.iter().max_by(|a, b| a.0.total_cmp(&b.0));
        println!(
            "{:<40} {:>6} vertices, {out:>4} outside by > 1 % H, worst {:.1} % H",
            f.file_name().unwrap().to_string_lossy(),
            fits.len(),
            100.0 * worst.map_or(0.0, |w| w.0) / h
        );
        if let Some((d, b, p)) = worst
            && *d > 0.01 * h
        {
            bad.push(format!(
                "{}: {p} lies {:.1} % of the height outside {}",
                f.display(),
                100.0 * d / h,
                spec.bodies[*b].name
            ));
        }
    }
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}
