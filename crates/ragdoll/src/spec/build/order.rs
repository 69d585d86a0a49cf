//! The order bodies hang in: by anatomy for humanoids (a detached IK foot still hangs from
//! its shin), where a detached bone sits for anything else (`attach.rs`), by the hierarchy
//! otherwise.

use crate::spec::Role;
use crate::spec::roles::Roles;

/// The roles a humanoid body hangs from, nearest first: where the hierarchy detaches a
/// deform bone from its anatomy (IK feet under the root, hands under a control bone), the
/// body still joins its anatomical neighbour, the foot the shin at the ankle, so the
/// character is one articulated body.
fn anatomical_parents(role: Role) -> &'static [Role] {
    use Role::*;
    match role {
        Spine => &[Pelvis],
        Chest => &[Spine, Pelvis],
        Neck => &[Chest, Spine, Pelvis],
        Head => &[Neck, Chest, Spine, Pelvis],
        ThighL | ThighR => &[Pelvis],
        ShinL => &[ThighL],
        ShinR => &[ThighR],
        FootL => &[ShinL],
        FootR => &[ShinR],
        UpperArmL | UpperArmR => &[Chest, Spine, Pelvis],
        ForearmL => &[UpperArmL],
        ForearmR => &[UpperArmR],
        HandL => &[ForearmL],
        HandR => &[ForearmR],
        Pelvis | Chain => &[],
    }
}

/// The body (by `body_of`) that joint `j`'s body hangs from by anatomy, for humanoids, or
/// where a detached bone sits (`attach`, from `attach.rs`) for anything else; `None`
/// leaves it to the hierarchy.
pub(super) fn parent_body(
    roles: &Roles,
    attach: &[Option<usize>],
    j: usize,
    body_of: impl Fn(usize) -> Option<usize>,
) -> Option<usize> {
    if !roles.humanoid {
        return attach
            .get(j)
            .copied()
            .flatten()
            .and_then(|k| body_of(k).filter(|_| k != j));
    }
    let role = roles.per_joint.get(j).copied().flatten()?;
    anatomical_parents(role)
        .iter()
        .filter_map(|&r| roles.joint(r))
        .find_map(|k| body_of(k).filter(|_| k != j))
}

/// The bodies' joints reordered so each comes after the body it hangs from (a detached
/// IK foot comes before its shin in the file), otherwise in file order, root first.
pub(super) fn parent_first(
    roles: &Roles,
    attach: &[Option<usize>],
    joints: Vec<usize>,
) -> Vec<usize> {
    let index = |j: usize| joints.iter().position(|&k| k == j);
    let mut out: Vec<usize> = Vec::with_capacity(joints.len());
    let mut placed = vec![false; joints.len()];
    for start in 0..joints.len() {
        // Walk up to the first unplaced ancestor body, then place downward.
        let mut stack = vec![start];
        while let Some(&b) = stack.last() {
            let up = parent_body(roles, attach, joints[b], index)
                .filter(|&p| !placed[p] && !stack.contains(&p));
            match up {
                Some(p) if b != 0 => stack.push(p),
                _ => {
                    stack.pop();
                    if !placed[b] {
                        placed[b] = true;
                        out.push(joints[b]);
                    }
                }
            }
        }
    }
    out
}
