//! The commands that read a character without simulating it: inspect (print its joint
//! tree and ragdoll) and build (write its ragdoll spec for editing).

use anyhow::{Context, Result};
use ragdoll::skeleton::Character;
use ragdoll::spec::{self, RagdollSpec, Roles};

use crate::character::{load, ragdoll, ragdoll_spec};
use crate::printable::shown;
use crate::{BuildArgs, ImportArgs, InspectArgs, clip_list, output};

pub fn build(a: &BuildArgs) -> Result<()> {
    output::check_file(&a.output)?;
    let character = load(&a.file, &a.import)?;
    let spec = ragdoll_spec(&character, &a.file.display().to_string(), &a.ragdoll)?;
    let text = format!(
        "# Ragdoll spec for {} (built by ragdoll {} from {}).\n# Edit any number and pass it back with --spec. Lengths in metres, masses in kg,\n# angles in degrees; centres and rotations are in each bone's rest frame.\n\n{}",
        spec.name,
        env!("CARGO_PKG_VERSION"),
        a.file.display(),
        spec.to_toml()
    );
    output::write_one(&a.output, text.as_bytes())?;
    errln!(
        "{}: {} bodies, {} joints, {:.1} kg",
        spec.name,
        spec.bodies.len(),
        spec.joints.len(),
        spec.total_mass_kg()
    );
    outln!("{}", a.output.display());
    Ok(())
}

pub fn inspect(a: &InspectArgs) -> Result<()> {
    // Every clip is read so all are listed; the chosen one is kept after.
    let import = ImportArgs {
        clip: None,
        ..a.import.clone()
    };
    let mut character = load(&a.file, &import)?;
    let clips = clip_list::list_and_choose(&mut character, a.import.clip.as_deref(), &a.file)?;
    let label = a.file.display().to_string();
    let (spec, roles) = ragdoll(&character, &label, &a.ragdoll)
        .with_context(|| format!("{label}: building the ragdoll"))?;
    let out = if a.json {
        as_json(&character, &roles, &spec, &clips)?
    } else {
        as_text(&character, &roles, &spec, &clips)?
    };
    use std::io::Write;
    std::io::stdout().write_all(out.as_bytes())?;
    Ok(())
}

/// `inspect --json`: the joints with their roles, the bodies and constraints as the spec
/// has them, the clips.
fn as_json(
    character: &Character,
    roles: &Roles,
    spec: &RagdollSpec,
    clips: &clip_list::Clips,
) -> Result<String> {
    let s = &character.skeleton;
    let joints: Vec<serde_json::Value> = (0..s.len())
        .map(|i| {
            serde_json::json!({
                "index": i,
                "name": s.joint_label(i),
                "parent": s.parent(i).map(|p| s.joint_label(p)),
                "role": roles.per_joint[i].map(|r| r.as_str()),
                "role_from_file": roles.from_file.get(i).copied().unwrap_or(false),
            })
        })
        .collect();
    let value = serde_json::json!({
        "character": character.name,
        "humanoid": roles.humanoid,
        // Where it faces in the file: a character lying there was measured stood up.
        "forward": roles
            .upright
            .map_or(roles.forward, |q| q.inverse() * roles.forward)
            .to_array(),
        "roles_why": roles.why,
        "roles_missing": roles.missing().iter().map(|(r, why)| serde_json::json!({
            "role": r.as_str(), "why": why,
        })).collect::<Vec<_>>(),
        "joints": joints,
        "bodies": spec.bodies,
        "constraints": spec.joints,
        "total_mass_kg": spec.total_mass_kg(),
        "clips": clips.json(),
    });
    let mut out = serde_json::to_string_pretty(&value)?;
    out.push('\n');
    Ok(out)
}

/// `inspect`: the joint tree with each joint's role, then the bodies, the joints, the
/// total mass and the clips.
fn as_text(
    character: &Character,
    roles: &Roles,
    spec: &RagdollSpec,
    clips: &clip_list::Clips,
) -> Result<String> {
    use std::fmt::Write;
    let s = &character.skeleton;
    let mut out = String::new();
    let kind = if roles.humanoid {
        "humanoid"
    } else {
        "not humanoid: generic chain bodies"
    };
    writeln!(
        out,
        "{} ({kind}), {} joints, {} meshes, {} clips",
        shown(&character.name),
        s.len(),
        character.meshes.len(),
        clips.count()
    )?;
    for line in role_summary(roles).lines() {
        writeln!(out, "{}", shown(line))?;
    }
    let mut depth = vec![0usize; s.len()];
    for i in 0..s.len() {
        if let Some(p) = s.parent(i) {
            depth[i] = depth[p] + 1;
        }
        let role = roles.per_joint[i].map_or("-".to_string(), |r| r.as_str().to_string());
        let given = if roles.from_file.get(i).copied().unwrap_or(false) {
            " (roles file)"
        } else {
            ""
        };
        writeln!(
            out,
            "{}{}  [{role}]{given}",
            indent(depth[i]),
            shown(&s.joint_label(i))
        )?;
    }
    writeln!(out, "\nbodies:")?;
    for b in &spec.bodies {
        // Skin its own shape does not reach, held by shapes of its own (a creature's).
        let extras = match b.extra_shapes.len() {
            0 => String::new(),
            1 => ", 1 extra shape".to_string(),
            n => format!(", {n} extra shapes"),
        };
        writeln!(
            out,
            "  {:<16} on {:<16} {}, {:.2} kg{extras}",
            shown(&b.name),
            shown(&b.bone),
            shape_words(&b.shape),
            b.mass_kg
        )?;
    }
    writeln!(out, "\njoints:")?;
    for j in &spec.joints {
        let kind = joint_words(&j.kind);
        writeln!(
            out,
            "  {:<16} {} -> {}: {kind}",
            shown(&j.name),
            shown(&j.parent),
            shown(&j.child)
        )?;
    }
    writeln!(out, "\ntotal mass: {:.2} kg", spec.total_mass_kg())?;
    clips.write(&mut out)?;
    Ok(out)
}

/// A body's shape as `inspect` prints it.
fn shape_words(shape: &spec::Shape) -> String {
    match *shape {
        spec::Shape::Capsule { radius_m, length_m } => {
            format!("capsule r={radius_m:.3} m, l={length_m:.3} m")
        }
        spec::Shape::Box { size_m } => format!(
            "box {:.3} x {:.3} x {:.3} m",
            size_m[0], size_m[1], size_m[2]
        ),
    }
}

/// A joint's kind and limits as `inspect` prints them.
fn joint_words(kind: &spec::JointKind) -> String {
    match *kind {
        spec::JointKind::Hinge { min_deg, max_deg } => {
            // Rounded first, so -0.3 reads 0, not -0.
            let (lo, hi) = (min_deg.round() + 0.0, max_deg.round() + 0.0);
            format!("hinge {lo:.0}..{hi:.0}°")
        }
        spec::JointKind::SwingTwist {
            swing_deg,
            twist_deg,
            ..
        } => format!(
            "swing-twist cone {swing_deg:.0}°, twist {:.0}..{:.0}°",
            twist_deg[0], twist_deg[1]
        ),
        spec::JointKind::Ball => "ball".into(),
        spec::JointKind::Fixed => "fixed".into(),
    }
}

/// Deepest joint level drawn by indentation; deeper ones (a 60,000-joint chain would
/// otherwise print gigabytes of spaces) say their depth instead.
const MAX_INDENT: usize = 32;

/// The indentation of a joint `depth` levels below its root.
fn indent(depth: usize) -> String {
    if depth <= MAX_INDENT {
        "  ".repeat(depth)
    } else {
        format!("{}(depth {depth}) ", "  ".repeat(MAX_INDENT))
    }
}

/// What role recognition found and what it did not, in sentences: a user whose rig is
/// not taken for a humanoid, or lacks a hand, learns why.
fn role_summary(roles: &spec::Roles) -> String {
    let mut s = format!("{}\n", roles.why);
    let found: Vec<&str> = roles.found().iter().map(|r| r.as_str()).collect();
    if !found.is_empty() {
        s += &format!("roles found: {}\n", found.join(", "));
    }
    let given: Vec<&str> = roles
        .found()
        .into_iter()
        .filter(|&r| {
            roles
                .joint(r)
                .is_some_and(|j| roles.from_file.get(j).copied().unwrap_or(false))
        })
        .map(|r| r.as_str())
        .collect();
    if !given.is_empty() {
        s += &format!("roles from the roles file: {}\n", given.join(", "));
    }
    for (r, why) in roles.missing() {
        s += &format!("role not found: {}: {why}.\n", r.as_str());
    }
    s
}
