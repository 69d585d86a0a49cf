//! Non-humanoids: every long enough, skinned bone becomes a chain link.

use glam::Vec3;

use super::rig::{Rig, centroid, horizontal};
use super::*;

/// Every bone long enough (and skinned, when there is a skin) that its name does not call
/// a helper becomes a chain link; so does a bone of any length that carries a good share
/// of the skin ([`HUB_SKIN_SHARE`]): a spider's `Body`, from whose joint all eight legs
/// start, has no length of its own, and without a body its skin hung from a leg
/// ([`HUB_MIN_CHILDREN`]).
pub(super) fn chain_roles(rig: &Rig, hints: &[NameHint]) -> Vec<Option<Role>> {
    let n = rig.len();
    let lengths: Vec<f32> = (0..n)
        .map(|i| {
            rig.chain_bone_end(i)
                .map_or(0.0, |e| e.distance(rig.pos[i]))
        })
        .collect();
    let mut sorted: Vec<f32> = lengths.iter().copied().filter(|l| *l > 1e-6).collect();
    sorted.sort_by(f32::total_cmp);
    let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
    let min_len = (CHAIN_MIN_EXTENT_FRACTION * rig.extent).min(CHAIN_MIN_MEDIAN_FRACTION * median);
    let skinned = |i: usize| !rig.has_skin() || rig.skin_weight[i] >= MIN_SKIN_WEIGHT;
    let total_skin: f32 = rig.skin_weight.iter().sum();
    // How far each joint's own skin (the vertices it carries most of) reaches from it.
    let mut reach = vec![0.0f32; n];
    for (p, js, ws) in &rig.verts {
        let c = (0..4).max_by(|&a, &b| ws[a].total_cmp(&ws[b])).unwrap_or(0);
        if let Some(r) = reach.get_mut(js[c] as usize) {
            *r = r.max(p.distance(rig.pos[js[c] as usize]));
        }
    }
    let hub = |i: usize| {
        rig.has_skin()
            && (rig.skin_weight[i] >= HUB_SKIN_SHARE * total_skin
                || (rig.children[i].len() >= HUB_MIN_CHILDREN && reach[i] > min_len))
    };
    let mut roles: Vec<Option<Role>> = (0..n)
        .map(|i| {
            ((lengths[i] > min_len.max(1e-6) || hub(i)) && skinned(i) && !hints[i].helper)
                .then_some(Role::Chain)
        })
        .collect();
    if roles.iter().all(Option::is_none) {
        // Something must carry the character: the most skinned joint, else the root.
        let pick = (0..n)
            .max_by(|&a, &b| {
                rig.skin_weight[a]
                    .total_cmp(&rig.skin_weight[b])
                    .then(b.cmp(&a))
            })
            .unwrap_or(0);
        roles[pick] = Some(Role::Chain);
    }
    roles
}

/// A bone carrying at least this share of the skin's weight gets a body however short it
/// is: it is a hub (a spider's body, a crab's shell) whose skin is too much to ride on a
/// neighbour.
const HUB_SKIN_SHARE: f32 = 0.1;
/// So does a bone this many limbs start from whose own skin reaches as far as a link's
/// bone must be long: the hub of a mesh whose vertices are few where its surface is plain.
const HUB_MIN_CHILDREN: usize = 3;

/// A creature faces where its spine goes from the hips (a quadruped's head end); else +Z.
pub(super) fn creature_forward(rig: &Rig) -> Vec3 {
    let root = 0;
    let far = rig
        .subtree_points(root)
        .into_iter()
        .max_by(|a, b| a.y.total_cmp(&b.y))
        .unwrap_or(Vec3::Z);
    // The highest point of a quadruped is its head; of anything upright, straight above.
    let d = horizontal(far - centroid(&rig.pos));
    if d.length() > FORWARD_CUE_MIN_H * rig.extent {
        d.normalize()
    } else {
        Vec3::Z
    }
}
