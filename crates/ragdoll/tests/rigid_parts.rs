//! Characters made of rigid mesh parts under a node hierarchy, without a skin: the
//! hierarchy is the skeleton and each part rides on one body. The files are
//! made here: a box robot with humanoid names, a four-link arm, VRM 0.x and 1.0 bare
//! hierarchies, and a single unskinned mesh that still goes to the automatic rig.
//!
//! The baked robot is read back with the `gltf` crate and posed here, node by node, from
//! its own animation (not through our importer), so a defect shared by our writer and our
//! reader cannot cancel out.

use std::path::PathBuf;

use glam::{Mat4, Quat, Vec3};
use ragdoll::import::{self, ImportOptions};
use ragdoll::skeleton::Source;
use ragdoll::spec::{self, Role};
use ragdoll::world::{World, WorldSettings};
use serde_json::{Value, json};

mod rigid_parts_files;

use rigid_parts_files::{Doc, ROBOT, bare, glb, load_as, robot};

/// A fresh folder of this test process.
fn scratch() -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let k = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("ragdoll-rigid-{}-{k}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Each node's world matrix at every key of the baked file's `ragdoll` animation, and each
/// mesh node's vertices (in the node's space), read with the `gltf` crate alone.
struct Baked {
    /// Per frame, per node.
    worlds: Vec<Vec<Mat4>>,
    /// (node, vertices) of every mesh node.
    parts: Vec<(usize, Vec<Vec3>)>,
}

fn read_baked(bytes: &[u8]) -> Baked {
    let g = gltf::Gltf::from_slice(bytes).unwrap();
    let blob = g.blob.clone().unwrap();
    let get = |_: gltf::Buffer| Some(blob.as_slice());
    let n = g.nodes().len();
    let mut parent = vec![None; n];
    let mut trs = Vec::new();
    for node in g.nodes() {
        for c in node.children() {
            parent[c.index()] = Some(node.index());
        }
        let (t, r, s) = node.transform().decomposed();
        trs.push((Vec3::from(t), Quat::from_array(r), Vec3::from(s)));
    }
    let anim = g
        .animations()
        .find(|a| a.name() == Some("ragdoll"))
        .unwrap();
    let mut keys = Vec::new();
    let mut frames = 0;
    for ch in anim.channels() {
        let r = ch.reader(get);
        let times: Vec<f32> = r.read_inputs().unwrap().collect();
        frames = times.len();
        use gltf::animation::util::ReadOutputs;
        let vals: Vec<[f32; 4]> = match r.read_outputs().unwrap() {
            ReadOutputs::Translations(t) => t.map(|v| [v[0], v[1], v[2], 0.0]).collect(),
            ReadOutputs::Scales(t) => t.map(|v| [v[0], v[1], v[2], 0.0]).collect(),
            ReadOutputs::Rotations(q) => q.into_f32().collect(),
            ReadOutputs::MorphTargetWeights(_) => continue,
        };
        keys.push((ch.target().node().index(), ch.target().property(), vals));
    }
    let order: Vec<usize> = {
        let mut o: Vec<usize> = (0..n).filter(|&i| parent[i].is_none()).collect();
        let mut k = 0;
        while k < o.len() {
            let i = o[k];
            o.extend(g.nodes().nth(i).unwrap().children().map(|c| c.index()));
            k += 1;
        }
        o
    };
    let mut worlds = Vec::new();
    for f in 0..frames {
        let mut local = trs.clone();
        for (node, prop, vals) in &keys {
            let v = vals[f];
            use gltf::animation::Property as P;
            match prop {
                P::Translation => local[*node].0 = Vec3::new(v[0], v[1], v[2]),
                P::Rotation => local[*node].1 = Quat::from_array(v),
                P::Scale => local[*node].2 = Vec3::new(v[0], v[1], v[2]),
                P::MorphTargetWeights => {}
            }
        }
        let mut w = vec![Mat4::IDENTITY; n];
        for &i in &order {
            let (t, r, s) = local[i];
            let m = Mat4::from_scale_rotation_translation(s, r, t);
            w[i] = parent[i].map_or(m, |p| w[p] * m);
        }
        worlds.push(w);
    }
    let mut parts = Vec::new();
    for node in g.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        let mut verts = Vec::new();
        for p in mesh.primitives() {
            verts.extend(p.reader(get).read_positions().unwrap().map(Vec3::from));
        }
        parts.push((node.index(), verts));
    }
    Baked { worlds, parts }
}

/// (a) The box robot is a humanoid with one body per part; dropped for 3 s, every part
/// keeps its shape (no distance between two of its vertices changes by 1e-3 of the height)
/// and nothing goes more than 4 % of the height below the floor.
#[test]
fn a_box_robot_of_rigid_parts_is_a_humanoid_whose_parts_stay_rigid() {
    let c = load_as("robot.glb", &robot());
    let names: Vec<&str> = c
        .skeleton
        .joints()
        .iter()
        .map(|j| j.name.as_str())
        .collect();
    let parts: Vec<&str> = ROBOT.iter().map(|p| p.0).collect();
    assert_eq!(
        names, parts,
        "the parts, without Armature or the HeadTop marker"
    );
    assert!(matches!(c.source, Source::Gltf(_)));
    assert_eq!(
        c.meshes.len(),
        14,
        "one mesh per part, the shared arm mesh twice"
    );
    // Every vertex on its own part's joint, with weight 1, where the file puts it.
    let rest = c.skeleton.rest_world();
    for (m, (name, ..)) in c.meshes.iter().zip(ROBOT) {
        let j = c.skeleton.find(name).unwrap();
        assert!(m.joints.iter().all(|js| js[0] as usize == j), "{name}");
        assert!(m.weights.iter().all(|w| *w == glam::Vec4::X), "{name}");
        let centre = m.positions.iter().sum::<Vec3>() / m.positions.len() as f32;
        let local = rest[j].inverse().transform_point(centre);
        let want = Vec3::from(ROBOT.iter().find(|p| p.0 == name).unwrap().4);
        assert!((local - want).length() < 1e-5, "{name}: {local} vs {want}");
    }
    let lowest = c
        .meshes
        .iter()
        .flat_map(|m| &m.positions)
        .map(|p| p.y)
        .fold(f32::INFINITY, f32::min);
    assert!(
        lowest.abs() < 1e-5,
        "the soles stand on y = 0, not {lowest}"
    );

    let roles = spec::recognise_roles(&c);
    assert!(roles.humanoid, "{}", roles.why);
    for (role, name) in [
        (Role::Pelvis, "Hips"),
        (Role::Chest, "Chest"),
        (Role::Head, "Head"),
        (Role::UpperArmL, "UpperArm.L"),
        (Role::ForearmR, "LowerArm.R"),
        (Role::ThighL, "UpperLeg.L"),
        (Role::ShinR, "LowerLeg.R"),
        (Role::FootL, "Foot.L"),
    ] {
        let j = roles.joint(role).unwrap_or_else(|| panic!("no {role:?}"));
        assert_eq!(c.skeleton.joints()[j].name, name, "{role:?}");
    }
    let spec = spec::build_spec(&c, &Default::default()).unwrap();
    let mut bones: Vec<&str> = spec.bodies.iter().map(|b| b.bone.as_str()).collect();
    bones.sort();
    let mut want = parts.clone();
    want.sort();
    assert_eq!(bones, want, "one body per part");

    let (mut world, _) = World::with_ragdoll(&c, &spec, &WorldSettings::default()).unwrap();
    world.run(3.0);
    let track = world.into_track();
    let out = ragdoll::export::gltf::to_glb(&c, &spec, &track).unwrap();
    // Read back, the baked file is the same rigid-part robot playing the fall.
    let back = load_as("baked.glb", &out);
    assert_eq!(back.skeleton, c.skeleton);
    assert_eq!(back.clips[0].name, "ragdoll");
    assert_eq!(back.clips[0].frames.len(), track.frames.len());
    let baked = read_baked(&out);
    assert_eq!(baked.parts.len(), 14);
    assert!(baked.worlds.len() > 60, "{} frames", baked.worlds.len());
    let height = 1.85;
    let mut lowest = f32::INFINITY;
    let mut worst = 0.0f32;
    let mut moved = 0.0f32;
    for w in &baked.worlds {
        for (node, verts) in &baked.parts {
            let posed: Vec<Vec3> = verts
                .iter()
                .map(|v| w[*node].transform_point3(*v))
                .collect();
            let at_rest: Vec<Vec3> = verts
                .iter()
                .map(|v| baked.worlds[0][*node].transform_point3(*v))
                .collect();
            for a in 0..posed.len() {
                lowest = lowest.min(posed[a].y);
                moved = moved.max(posed[a].distance(at_rest[a]));
                for b in a + 1..posed.len() {
                    let d = posed[a].distance(posed[b]) - at_rest[a].distance(at_rest[b]);
                    worst = worst.max(d.abs());
                }
            }
        }
    }
    eprintln!(
        "robot: moved {moved} m, worst {worst} m, lowest {lowest} m, {} frames",
        baked.worlds.len()
    );
    assert!(moved > 0.3, "the robot only moved {moved} m: not a fall");
    assert!(worst < 1e-3 * height, "a part changed shape by {worst} m");
    assert!(
        lowest > -0.04 * height,
        "a vertex went {} m below the floor",
        -lowest
    );
}

/// (b) Four nested links that no name calls a humanoid: a chain, one body per link.
#[test]
fn a_four_link_arm_is_a_chain_of_its_links() {
    let mut d = Doc::default();
    let mut parent = None;
    for k in 0..4 {
        let mesh = d.cuboid(
            &format!("link{k}"),
            Vec3::new(0.1, 0.4, 0.1),
            Vec3::new(0.0, 0.2, 0.0),
        );
        let at = if k == 0 {
            Vec3::new(0.0, 0.05, 0.0)
        } else {
            Vec3::new(0.0, 0.4, 0.0)
        };
        let n = d.node(&format!("Link{k}"), at, Some(mesh));
        if let Some(p) = parent {
            d.child(p, n);
        }
        parent = Some(n);
    }
    let c = load_as("arm.glb", &d.glb(&[0], json!({})));
    assert_eq!(c.skeleton.len(), 4);
    for (k, j) in c.skeleton.joints().iter().enumerate() {
        assert_eq!(j.name, format!("Link{k}"));
        assert_eq!(j.parent, k.checked_sub(1));
    }
    let roles = spec::recognise_roles(&c);
    assert!(!roles.humanoid);
    assert_eq!(roles.per_joint, vec![Some(Role::Chain); 4], "{}", roles.why);
    let spec = spec::build_spec(&c, &Default::default()).unwrap();
    assert_eq!(spec.bodies.len(), 4);
    assert_eq!(spec.joints.len(), 3);
}

/// (c) VRM 0.x and 1.0 bare hierarchies, with no mesh or with rigid meshes on two bones,
/// are humanoids from their tables: every table bone a joint, `HairJoint` dropped.
#[test]
fn vrm_bare_hierarchies_are_humanoids_from_their_tables() {
    for ext in ["VRM", "VRMC_vrm"] {
        for meshes in [false, true] {
            let what = format!("{ext}, meshes: {meshes}");
            let c = load_as("bare.vrm", &bare(ext, meshes));
            assert_eq!(c.skeleton.len(), 17, "{what}");
            assert!(c.skeleton.find("HairJoint").is_none(), "{what}");
            assert!(c.skeleton.find("Root").is_none(), "{what}");
            assert_eq!(c.humanoid_bones.len(), 17, "{what}");
            assert_eq!(c.meshes.len(), if meshes { 2 } else { 0 }, "{what}");
            assert!(c.warnings.is_empty(), "{what}: {:?}", c.warnings);
            let roles = spec::recognise_roles(&c);
            assert!(roles.humanoid, "{what}: {}", roles.why);
            assert!(
                roles.why.contains("humanoid bone table"),
                "{what}: {}",
                roles.why
            );
            for (role, name) in [
                (Role::Pelvis, "J_Bip_C_Hips"),
                (Role::Head, "J_Bip_C_Head"),
                (Role::HandL, "J_Bip_L_Hand"),
                (Role::FootR, "J_Bip_R_Foot"),
            ] {
                let j = roles.joint(role).unwrap();
                assert_eq!(c.skeleton.joints()[j].name, name, "{what}: {role:?}");
            }
            let spec = spec::build_spec(&c, &Default::default()).unwrap();
            let (mut world, _) = World::with_ragdoll(&c, &spec, &WorldSettings::default()).unwrap();
            world.run(0.5);
            let track = world.into_track();
            ragdoll::export::gltf::to_glb(&c, &spec, &track).unwrap();
        }
    }
}

/// (d) One unskinned mesh on one node (a statue) is rigged automatically, as before; so are
/// parts that are all siblings, which say nothing about joints.
#[test]
fn one_mesh_or_sibling_parts_are_still_rigged_automatically() {
    let mut d = Doc::default();
    let mesh = d.cuboid("statue", Vec3::new(0.4, 1.6, 0.3), Vec3::new(0.0, 0.8, 0.0));
    d.node("Statue", Vec3::ZERO, Some(mesh));
    let c = load_as("statue.glb", &d.glb(&[0], json!({})));
    assert!(matches!(c.source, Source::Mesh(_)));
    assert!(c.skeleton.len() > 1, "the automatic rig has several joints");

    let mut d = Doc::default();
    let group = d.node("Group", Vec3::ZERO, None);
    for k in 0..3 {
        let m = d.cuboid("piece", Vec3::new(0.3, 0.5, 0.3), Vec3::new(0.0, 0.25, 0.0));
        let n = d.node(
            &format!("Piece{k}"),
            Vec3::new(0.0, 0.5 * k as f32, 0.0),
            Some(m),
        );
        d.child(group, n);
    }
    let c = load_as("pieces.glb", &d.glb(&[group], json!({})));
    assert!(matches!(c.source, Source::Mesh(_)));
}

/// A rigid-part file with its own animation of the part nodes reads it as a clip.
#[test]
fn animated_part_nodes_are_the_clip() {
    let mut d = Doc::default();
    let a = d.cuboid("a", Vec3::splat(0.2), Vec3::ZERO);
    let b = d.cuboid("b", Vec3::splat(0.2), Vec3::ZERO);
    let base = d.node("Base", Vec3::new(0.0, 0.5, 0.0), Some(a));
    let tip = d.node("Tip", Vec3::new(0.0, 0.4, 0.0), Some(b));
    d.child(base, tip);
    let times: Vec<u8> = [0.0f32, 1.0].iter().flat_map(|x| x.to_le_bytes()).collect();
    let rots: Vec<u8> = [Quat::IDENTITY, Quat::from_rotation_z(1.0)]
        .iter()
        .flat_map(|q| q.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let tv = d.view(&times);
    let rv = d.view(&rots);
    let ta = d.accessor(json!({"bufferView": tv, "componentType": 5126, "count": 2,
        "type": "SCALAR", "min": [0.0], "max": [1.0]}));
    let ra =
        d.accessor(json!({"bufferView": rv, "componentType": 5126, "count": 2, "type": "VEC4"}));
    let mut doc_bytes = d.glb(&[base], json!({}));
    // Add the animation to the JSON chunk.
    let json_len = u32::from_le_bytes(doc_bytes[12..16].try_into().unwrap()) as usize;
    let mut doc: Value = serde_json::from_slice(&doc_bytes[20..20 + json_len]).unwrap();
    doc["animations"] = json!([{"name": "Wag", "samplers": [{"input": ta, "output": ra}],
        "channels": [{"sampler": 0, "target": {"node": tip, "path": "rotation"}}]}]);
    let bin_start = 20 + json_len + 8;
    doc_bytes = glb(&doc, &doc_bytes[bin_start..]);
    let c = load_as("wag.glb", &doc_bytes);
    assert_eq!(c.clips.len(), 1);
    assert_eq!(c.clips[0].name, "Wag");
    let tip_j = c.skeleton.find("Tip").unwrap();
    let last = c.clips[0].frames.last().unwrap();
    assert!(
        last[tip_j]
            .rotation
            .abs_diff_eq(Quat::from_rotation_z(1.0), 1e-5)
    );
}

/// More nested parts than a skeleton may have joints: one sentence, no crash, no hang
/// (70,000 nodes nested in one chain, every one an instance of one small mesh).
#[test]
fn too_many_parts_are_refused_in_one_sentence() {
    let mut d = Doc::default();
    let mesh = d.cuboid("link", Vec3::splat(0.01), Vec3::ZERO);
    let n = 70_000;
    for k in 0..n {
        d.node("", Vec3::new(0.0, 0.0001, 0.0), Some(mesh));
        if k > 0 {
            d.child(k - 1, k);
        }
    }
    let dir = scratch();
    let path = dir.join("deep.glb");
    std::fs::write(&path, d.glb(&[0], json!({}))).unwrap();
    let t = std::time::Instant::now();
    let e = import::load(&path, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(e.contains("65536") || e.contains("65,536"), "{e}");
    assert!(t.elapsed().as_secs_f32() < 10.0, "took {:?}", t.elapsed());
}
