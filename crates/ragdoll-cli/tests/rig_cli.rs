//! `ragdoll rig`: a mesh without a skeleton in, a skinned glTF out, that the
//! importer reads back and `ragdoll simulate` runs.

mod common;

use std::path::Path;

use common::{data_dir, ragdoll, stderr};

/// A closed box 2 m long along X, 0.4 m tall, 0.3 m deep, standing 0.5 m up, with each long
/// face split in ten so the mesh has some surface to sample.
fn write_bar(path: &Path) {
    let mut text = String::from("# a bar\n");
    let n = 10;
    for i in 0..=n {
        let x = -1.0 + 2.0 * i as f32 / n as f32;
        for (y, z) in [(0.5, -0.15), (0.9, -0.15), (0.9, 0.15), (0.5, 0.15)] {
            text += &format!("v {x} {y} {z}\n");
        }
    }
    let v = |i: usize, k: usize| i * 4 + k + 1;
    for i in 0..n {
        for k in 0..4 {
            let k1 = (k + 1) % 4;
            text += &format!(
                "f {} {} {} {}\n",
                v(i, k),
                v(i + 1, k),
                v(i + 1, k1),
                v(i, k1)
            );
        }
    }
    text += &format!("f {} {} {} {}\n", v(0, 0), v(0, 1), v(0, 2), v(0, 3));
    text += &format!("f {} {} {} {}\n", v(n, 3), v(n, 2), v(n, 1), v(n, 0));
    std::fs::write(path, text).unwrap();
}

#[test]
fn rig_writes_a_skinned_glb_that_reads_back_and_simulates() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    write_bar(&dir.join("bar.obj"));
    let out = ragdoll(
        dir,
        &[
            "rig",
            "bar.obj",
            "--joints",
            "7",
            "--head",
            "1,0.7,0",
            "--branch",
            "leg=0.5,0.55,-0.1/0.6,0.2,-0.2/0.6,0,-0.2",
            "-o",
            "rigged.glb",
        ],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let c = ragdoll::import::load(&dir.join("rigged.glb"), &Default::default()).unwrap();
    // 7 spine joints, and two legs of a joint on the spine plus two along the landmarks.
    assert_eq!(c.skeleton.len(), 7 + 2 * 3);
    assert!(matches!(c.source, ragdoll::skeleton::Source::Gltf(_)));
    let head = c.skeleton.find("head").expect("a joint named head");
    let p = c.skeleton.rest_world()[head].translation;
    assert!(p.x > 0.5, "the head is the +X end as asked, got {p:?}");
    for name in ["leg_l00", "leg_r00", "leg_l02", "leg_r02"] {
        assert!(c.skeleton.find(name).is_some(), "{name}");
    }
    assert_eq!(c.meshes.len(), 1);
    let m = &c.meshes[0];
    assert_eq!(m.weights.len(), m.positions.len());
    assert!(
        m.weights
            .iter()
            .all(|w| (w.element_sum() - 1.0).abs() < 1e-5)
    );
    assert!(
        c.clips.is_empty(),
        "a rig in the rest pose carries no animation"
    );

    // The rigged file and the OBJ itself both simulate.
    for input in ["rigged.glb", "bar.obj"] {
        let o = ragdoll(dir, &["simulate", input, "--seconds", "1", "-o", "sim.glb"]);
        assert!(o.status.success(), "{input}: {}", stderr(&o));
        let report = common::read_json(&dir.join("sim.report.json"));
        assert_eq!(report["nan"], false, "{input}");
    }
}

/// The report's `height_m` is the character's size: its skin's height where it has a
/// skin. The bar's spine runs level along it, so its skeleton alone read 0.1 m; the bar
/// is 0.4 m.
#[test]
fn the_report_gives_the_height_of_the_skin() {
    let dir = tempfile::tempdir().unwrap();
    write_bar(&dir.path().join("bar.obj"));
    for args in [
        &["rig", "bar.obj", "-o", "bar.glb"][..],
        &["simulate", "bar.glb", "--seconds", "0.2", "-o", "out.glb"][..],
    ] {
        let o = ragdoll(dir.path(), args);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    }
    let report = common::read_json(&dir.path().join("out.report.json"));
    let height = report["characters"][0]["height_m"].as_f64().unwrap();
    assert!((height - 0.4).abs() < 0.01, "height_m {height}");
}

/// A mesh standing on end is rigged as it lies (a spine along it), but the user is told
/// that a standing figure gets a spine only; the bar lying down, as a creature lies, is not
/// warned about.
#[test]
fn rigging_an_upright_mesh_warns_that_it_gets_a_spine_only() {
    let dir = tempfile::tempdir().unwrap();
    write_bar(&dir.path().join("bar.obj"));
    // The same bar stood on its end: x and y swapped (and z flipped, to keep the faces
    // turned outward), 2 m tall.
    let text = std::fs::read_to_string(dir.path().join("bar.obj")).unwrap();
    let stood: String = text
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => {
                let c: Vec<f32> = v.split(' ').map(|x| x.parse().unwrap()).collect();
                format!("v {} {} {}\n", c[1], c[0] + 1.0, -c[2])
            }
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(dir.path().join("post.obj"), stood).unwrap();
    let o = ragdoll(dir.path(), &["rig", "post.obj", "-o", "post.glb"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("stands upright"), "{}", stderr(&o));
    assert!(stderr(&o).contains("--humanoid"), "{}", stderr(&o));
    // A post has no arms to fit a person's skeleton to: refused, nothing written.
    let o = ragdoll(
        dir.path(),
        &["rig", "post.obj", "--humanoid", "-o", "person.glb"],
    );
    assert!(!o.status.success());
    assert!(stderr(&o).contains("T-pose or an A-pose"), "{}", stderr(&o));
    assert!(!dir.path().join("person.glb").exists());
    let o = ragdoll(dir.path(), &["rig", "bar.obj", "-o", "bar.glb"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
}

#[test]
fn rig_refuses_bad_input_with_a_clear_message_and_no_output() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n").unwrap();
    let out = ragdoll(dir, &["rig", "bad.obj", "-o", "rigged.glb"]);
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("bad.obj") && err.contains("line 4"), "{err}");
    assert!(!dir.join("rigged.glb").exists());

    write_bar(&dir.join("bar.obj"));
    let cases: [&[&str]; 5] = [
        &["rig", "bar.obj", "-o", "rigged.gltf"],
        &["rig", "bar.obj", "--joints", "0", "-o", "rigged.glb"],
        &["rig", "bar.obj", "--branch", "leg=1,2", "-o", "rigged.glb"],
        &["rig", "bar.obj", "--head", "v100000", "-o", "rigged.glb"],
        // On the symmetry plane: its mirror image would coincide with it.
        &[
            "rig",
            "bar.obj",
            "--branch",
            "fin=0,0.9,0/0,1.2,0",
            "-o",
            "rigged.glb",
        ],
    ];
    for args in cases {
        let out = ragdoll(dir, args);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(!stderr(&out).is_empty());
        assert!(!dir.join("rigged.glb").exists(), "{args:?} left a file");
        assert!(!dir.join("rigged.gltf").exists(), "{args:?} left a file");
    }
    let out = ragdoll(
        dir,
        &["rig", "bar.obj", "--joints", "0", "-o", "rigged.glb"],
    );
    assert!(stderr(&out).contains("--joints"), "{}", stderr(&out));
}

#[test]
#[ignore = "needs ../shared/data"]
fn rig_refuses_a_file_that_already_has_a_skeleton() {
    let data = data_dir();
    let tmp = tempfile::tempdir().unwrap();
    let fox = data.join("gltf/Fox.glb");
    let out = ragdoll(tmp.path(), &["rig", fox.to_str().unwrap(), "-o", "fox.glb"]);
    assert!(!out.status.success());
    assert!(
        stderr(&out).contains("already has a skeleton"),
        "{}",
        stderr(&out)
    );
    assert!(!tmp.path().join("fox.glb").exists());
}

#[test]
#[ignore = "needs ../shared/data"]
fn rig_the_stanford_dragons() {
    let data = data_dir();
    let tmp = tempfile::tempdir().unwrap();
    for name in ["stanford_dragon_1k7", "stanford_dragon_13k"] {
        let obj = data.join("mesh").join(format!("{name}.obj"));
        let out_name = format!("{name}.glb");
        let out = ragdoll(tmp.path(), &["rig", obj.to_str().unwrap(), "-o", &out_name]);
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        let c = ragdoll::import::load(&tmp.path().join(&out_name), &Default::default()).unwrap();
        assert_eq!(c.skeleton.len(), ragdoll::rig::DEFAULT_JOINTS, "{name}");
        let vertices = std::fs::read_to_string(&obj)
            .unwrap()
            .lines()
            .filter(|l| l.starts_with("v "))
            .count();
        assert_eq!(c.meshes[0].positions.len(), vertices, "{name}");
    }
}
