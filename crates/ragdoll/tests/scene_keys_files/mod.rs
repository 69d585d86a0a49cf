//! Character files for the scene-key tests, built in code: shared by `scene_keys.rs` and
//! the CLI's `scene_keys_cli.rs` and `roles_warning.rs` (which include this file by path).

#![allow(dead_code)] // each test binary uses its own subset

/// A BVH person (Mixamo-like names, metres, one frame) with each offset given as
/// (sideways, up); `folded` raises its legs above its hips instead (knees and feet higher
/// than the hips, the trunk upright), as no figure standing or lying has them: its names
/// then promise a humanoid its skeleton denies. (A person merely lying down, as an
/// exporter with the wrong up axis leaves one, is stood up and recognised.)
pub fn person(folded: bool) -> String {
    let off = |x: f32, up: f32| format!("OFFSET {x} {up} 0");
    let leg_up = if folded { -1.0 } else { 1.0 };
    let chain = |names: &[String], offsets: &[(f32, f32)], end: (f32, f32)| -> String {
        let mut s = String::new();
        for (n, &(x, up)) in names.iter().zip(offsets) {
            s += &format!(
                "JOINT {n}\n{{\n{}\nCHANNELS 3 Zrotation Xrotation Yrotation\n",
                off(x, up)
            );
        }
        s += &format!("End Site\n{{\n{}\n}}\n", off(end.0, end.1));
        s + &"}\n".repeat(names.len())
    };
    let names = |side: &str, parts: [&str; 3]| parts.map(|p| format!("{side}{p}"));
    let leg = |side: &str, x: f32| {
        chain(
            &names(side, ["UpLeg", "Leg", "Foot"]),
            &[(x, 0.0), (0.0, -0.45 * leg_up), (0.0, -0.42 * leg_up)],
            (0.0, -0.08 * leg_up),
        )
    };
    let arm = |side: &str, x: f32| {
        let s = x.signum();
        chain(
            &names(side, ["Arm", "ForeArm", "Hand"]),
            &[(x, 0.45), (s * 0.3, 0.0), (s * 0.25, 0.0)],
            (s * 0.1, 0.0),
        )
    };
    let spine = format!(
        "JOINT Spine\n{{\n{}\nCHANNELS 3 Zrotation Xrotation Yrotation\n{}{}{}}}\n",
        off(0.0, 0.1),
        chain(
            &["Neck".to_string(), "Head".to_string()],
            &[(0.0, 0.5), (0.0, 0.1)],
            (0.0, 0.2)
        ),
        arm("Left", 0.2),
        arm("Right", -0.2),
    );
    let channels = 6 + 3 * 15;
    format!(
        "HIERARCHY\nROOT Hips\n{{\nOFFSET 0 0 0\nCHANNELS 6 Xposition Yposition Zposition \
         Zrotation Xrotation Yrotation\n{spine}{}{}}}\nMOTION\nFrames: 1\nFrame Time: 0.0333333\n{}\n",
        leg("Left", 0.1),
        leg("Right", -0.1),
        vec!["0"; channels].join(" ")
    )
}
