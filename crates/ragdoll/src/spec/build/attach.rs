//! Deform bones the hierarchy detaches from their limb. Creature rigs with IK parent the
//! feet or hooves to the root (or to a control bone) so an animator can plant them; the
//! foot still deforms skin where the leg ends. Joined where the hierarchy puts it, the foot
//! hung from whatever body came first, half a metre away: a spider's eight feet joined to
//! one front leg tore apart on landing. Humanoids are joined by anatomy instead
//! (`order.rs`); this is the same for any skeleton, found from where things are.

use glam::Vec3;

use crate::spec::roles::{Rig, Roles};

/// A detached bone joins the body whose bone or skin passes within this share of the
/// character's extent of its joint (5 cm on a spider 1 m across): the foot's joint lies on
/// the shin's skin at the ankle, while its hierarchy parent is far away.
const ATTACH_FRACTION_OF_EXTENT: f32 = 0.05;

/// For each skeleton joint of a non-humanoid, the joint whose body its body joins instead
/// of the one the hierarchy gives it, where the hierarchy detaches it: its nearest
/// ancestor with a body (if any) is not where it sits, and another body is. `None` for
/// every other joint, and for every joint of a humanoid.
pub(super) fn detached_parents(rig: &Rig, roles: &Roles, joints: &[usize]) -> Vec<Option<usize>> {
    let n = rig.len();
    let mut out = vec![None; n];
    if roles.humanoid {
        return out;
    }
    let mut has_body = vec![false; n];
    joints.iter().for_each(|&j| has_body[j] = true);
    // The skin each joint carries most of.
    let mut skin: Vec<Vec<Vec3>> = vec![Vec::new(); n];
    for (p, js, ws) in &rig.verts {
        let c = (0..4).max_by(|&a, &b| ws[a].total_cmp(&ws[b])).unwrap_or(0);
        if ws[c] > 0.0
            && let Some(s) = skin.get_mut(js[c] as usize)
        {
            s.push(*p);
        }
    }
    let tol = ATTACH_FRACTION_OF_EXTENT * rig.extent;
    // How near body `c`'s bone or skin comes to joint `j`.
    let near = |j: usize, c: usize| -> f32 {
        let at = rig.pos[j];
        let bone = rig.chain_bone_end(c).map_or(at.distance(rig.pos[c]), |e| {
            segment_distance(at, rig.pos[c], e)
        });
        skin[c].iter().map(|v| v.distance(at)).fold(bone, f32::min)
    };
    for &j in joints {
        let Some(p) = rig.parent(j) else { continue };
        if has_body[p] {
            continue;
        }
        let mut above = Some(p);
        while let Some(a) = above.filter(|&a| !has_body[a]) {
            above = rig.parent(a);
        }
        if above.is_some_and(|o| near(j, o) <= tol) {
            continue;
        }
        let mut below = vec![false; n];
        rig.subtree(j).into_iter().for_each(|k| below[k] = true);
        out[j] = joints
            .iter()
            .copied()
            .filter(|&c| !below[c])
            .map(|c| (c, near(j, c)))
            .filter(|&(_, d)| d <= tol)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(c, _)| c);
    }
    out
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let t = if ab.length_squared() > 0.0 {
        ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
    } else {
        0.0
    };
    p.distance(a + ab * t)
}
