//! Masses: de Leva's segment fractions for humanoids, volume × density for anything
//! else (the volume its skin encloses where it is closed, shared among the bodies as
//! their shapes' volumes are), then stabilised so no jointed pair is too unequal for an
//! iterative solver.

use super::extras::ExtraPlan;
use super::{Builder, Plan};
use crate::spec::Role;
use crate::spec::anthropometry::*;

/// Largest mass ratio between a jointed parent and child. Strunk ("Stop my Constraints
/// from Blowing Up!", GDC 2013) shows iterative solvers converge badly as linked masses
/// diverge; Jolt's `RagdollSettings::Stabilize` clamps each child/parent ratio to
/// [0.8, 1.2], which flattens anatomy. 5 keeps de Leva's proportions except the lightest
/// links (neck, upper arms against a 12 kg chest), which are raised.
pub(super) const MAX_LINKED_MASS_RATIO: f32 = 5.0;

impl Builder<'_> {
    /// Each body's mass. `enclosed_m3`: the volume the character's skin encloses, where it
    /// is closed ([`super::volume::enclosed_volume_m3`]); `standing_m`: its height
    /// standing ([`crate::skeleton::Character::height_along`] the way it stands), which
    /// weighs a humanoid ([`humanoid_mass_kg`]).
    ///
    /// A creature's share is its shapes' volume, its extra shapes' (`extras`) with its own:
    /// they hold skin the body carries.
    pub(super) fn masses(
        &self,
        plans: &[Plan],
        extras: &[Vec<ExtraPlan>],
        parents: &[usize],
        enclosed_m3: Option<f32>,
        standing_m: f32,
    ) -> Vec<f32> {
        let humanoid_total = || {
            self.opts
                .total_mass_kg
                .unwrap_or_else(|| humanoid_mass_kg(standing_m))
        };
        let mut m: Vec<f32> = if self.roles.humanoid {
            self.humanoid_masses(plans, humanoid_total())
        } else {
            let own: Vec<f32> = plans.iter().map(|p| p.shape.volume()).collect();
            let shares: Vec<f32> = own
                .iter()
                .zip(extras)
                .map(|(v, e)| v + e.iter().map(|x| x.shape.volume()).sum::<f32>())
                .collect();
            // Without a closed skin the bodies' own shapes stand for its volume (extra
            // shapes overlap them and each other).
            let total = match self.opts.total_mass_kg {
                Some(total) => total,
                None => enclosed_m3.unwrap_or(own.iter().sum()) * BODY_DENSITY_KG_M3,
            };
            let v: f32 = shares.iter().sum();
            shares.iter().map(|x| total * x / v).collect()
        };
        let total = match (self.roles.humanoid, self.opts.total_mass_kg) {
            (true, _) => humanoid_total(),
            (false, Some(t)) => t,
            (false, None) => m.iter().sum(),
        };
        stabilize_masses(&mut m, parents, MAX_LINKED_MASS_RATIO);
        keep_total(&mut m, total);
        m
    }

    /// de Leva's fractions of `total`, each segment on the body that carries it; segments
    /// without a body of their own (no spine joint, no hand joint…) go to the neighbour
    /// that spans them, so the total is kept exactly.
    fn humanoid_masses(&self, plans: &[Plan], total: f32) -> Vec<f32> {
        use Role::*;
        let fr = if self.opts.female {
            DE_LEVA_FEMALE
        } else {
            DE_LEVA_MALE
        };
        let kg = |percent: f32| total * percent / fr.total_percent();
        let has = |r: Role| plans.iter().any(|p| p.role == r);
        let mut mass = std::collections::HashMap::<Role, f32>::new();
        let mut give = |r: Role, m: f32| *mass.entry(r).or_insert(0.0) += m;

        // A trunk of one part (a blocky game character's) is all pelvis.
        let chest = if has(Chest) || !has(Pelvis) {
            Chest
        } else {
            Pelvis
        };
        give(Pelvis, kg(fr.trunk_lower));
        give(chest, kg(fr.trunk_upper));
        if has(Spine) {
            give(Spine, kg(fr.trunk_middle));
        } else {
            // The abdomen lies between the pelvis and chest bodies: half to each.
            give(Pelvis, 0.5 * kg(fr.trunk_middle));
            give(chest, 0.5 * kg(fr.trunk_middle));
        }
        let head_neck = kg(fr.head_neck);
        match (has(Neck), has(Head)) {
            (true, true) => {
                give(Neck, NECK_SHARE_OF_HEAD_NECK * head_neck);
                give(Head, (1.0 - NECK_SHARE_OF_HEAD_NECK) * head_neck);
            }
            (true, false) => give(Neck, head_neck),
            (false, true) => give(Head, head_neck),
            (false, false) => give(chest, head_neck),
        }
        for side in [
            [UpperArmL, ForearmL, HandL, ThighL, ShinL, FootL],
            [UpperArmR, ForearmR, HandR, ThighR, ShinR, FootR],
        ] {
            let [ua, fa, hd, th, sh, ft] = side;
            // A limb of one part (no forearm, no shin) carries the whole limb's share.
            let fa = if has(fa) || !has(ua) { fa } else { ua };
            let sh = if has(sh) || !has(th) { sh } else { th };
            give(ua, kg(fr.upper_arm));
            give(fa, kg(fr.forearm));
            give(if has(hd) { hd } else { fa }, kg(fr.hand));
            give(th, kg(fr.thigh));
            give(sh, kg(fr.shank));
            give(if has(ft) { ft } else { sh }, kg(fr.foot));
        }
        plans
            .iter()
            .map(|p| mass.get(&p.role).copied().unwrap_or(0.0))
            .collect()
    }
}

/// Raises the lighter of any jointed pair until no pair's mass ratio exceeds `max_ratio`,
/// and raises a body that carries several others until it weighs at least `1/max_ratio`
/// of what hangs directly from it, then rescales everything so the total is what it was.
///
/// Strunk ("Stop my Constraints from Blowing Up!", GDC 2013) bounds each linked pair's
/// ratio (Jolt's `RagdollSettings::Stabilize` does the same with a tighter ratio), and
/// asks a parent to outweigh the sum of its children too (Jolt does it with inertia): a
/// pair rule alone let a spider's 0.3 kg thorax carry eight legs of 1.4 kg each, and
/// rapier blew the spider apart when its feet touched the floor. Each rule only ever lifts
/// a body; they take turns until the hubs need nothing more (two rounds on the spider), at
/// most [`MAX_STABILIZE_ROUNDS`] times: a hub with more than `max_ratio²` children cannot
/// meet both rules and keeps what the last round gave it.
pub fn stabilize_masses(masses: &mut [f32], parents: &[usize], max_ratio: f32) {
    let total: f32 = masses.iter().sum();
    for _ in 0..MAX_STABILIZE_ROUNDS {
        raise_linked_pairs(masses, parents, max_ratio);
        if !raise_hubs(masses, parents, max_ratio) {
            break;
        }
    }
    let now: f32 = masses.iter().sum();
    if now > 0.0 {
        for m in masses.iter_mut() {
            *m *= total / now;
        }
    }
    keep_total(masses, total);
}

/// The pair rule of [`stabilize_masses`].
fn raise_linked_pairs(masses: &mut [f32], parents: &[usize], max_ratio: f32) {
    for _ in 0..masses.len().max(1) * 4 {
        let mut changed = false;
        for (c, &p) in parents.iter().enumerate() {
            if c == p {
                continue;
            }
            let (mc, mp) = (masses[c], masses[p]);
            if mc * max_ratio < mp * (1.0 - 1e-6) {
                masses[c] = mp / max_ratio;
                changed = true;
            } else if mp * max_ratio < mc * (1.0 - 1e-6) {
                masses[p] = mc / max_ratio;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
}

/// Rounds of [`stabilize_masses`]' two rules at most.
const MAX_STABILIZE_ROUNDS: usize = 8;

/// The hub rule of [`stabilize_masses`], leaves first: `parents` lists every body after
/// its parent (the builder's order), so walking backwards settles each body's children
/// before the body itself is weighed against them. Returns whether it raised any.
fn raise_hubs(masses: &mut [f32], parents: &[usize], max_ratio: f32) -> bool {
    let mut carried = vec![0.0f32; masses.len()];
    let mut changed = false;
    for c in (0..masses.len()).rev() {
        if masses[c] * max_ratio < carried[c] * (1.0 - 1e-6) {
            masses[c] = carried[c] / max_ratio;
            changed = true;
        }
        match parents.get(c) {
            Some(&p) if p != c && p < masses.len() => carried[p] += masses[c],
            _ => {}
        }
    }
    changed
}

/// Puts the rounding residue of a float sum on the first (root, heaviest-ish) body so the
/// masses add up to `total` as closely as f32 allows.
fn keep_total(masses: &mut [f32], total: f32) {
    let now: f32 = masses.iter().sum();
    if let Some(first) = masses.first_mut() {
        *first += total - now;
    }
}
