//! Light hubs: what acts at a body that many joints share and that is much lighter than
//! what they hold is relaxed, so one Gauss-Seidel pass per substep (`fast`'s joints,
//! `particle`'s distances) does not overshoot around it.

/// Most a hub (a body with three joints or more) may be outweighed by the bodies jointed
/// to it before what acts at it is relaxed (see [`hub_relaxation`]). Measured on a light
/// hub with 8 and 16 arms of 1 kg in zero gravity (a ball joint each, 32 substeps): hubs
/// outweighed 4 times held still, 5 times (16 arms) and 8 times (8 arms) blew up.
const HUB_MAX_OUTWEIGHED: f32 = 4.0;

/// For each body of one ragdoll (`masses`, with its joints `links` as (parent, child)
/// indices into it), the share of a correction that acts on it a pass applies: 1, except
/// at a light hub, where it is the hub's mass times [`HUB_MAX_OUTWEIGHED`] over the mass
/// jointed to it.
///
/// One Gauss-Seidel pass per substep converges along a chain, but not around a body that
/// several joints share and that is much lighter than what they hold: each joint's
/// correction throws the hub, and with it the others, past where they meet, so the pass
/// overshoots back and forth, and the substeps' velocities, read from those moves, grow
/// from rounding noise alone: eight 1 kg arms ball-jointed to a 1 kg hub in zero gravity
/// flew about at 19 m/s within two seconds on `fast` and 10 m/s on `particle`, and a
/// spider with a 1 kg thorax and eight legs blew apart in free fall
/// (`tests/light_hub.rs`, `tests/creature_drops.rs`). Relaxing what ties the hub to its
/// limbs (successive under-relaxation: `fast`'s joint anchors and alignments, `particle`'s
/// distances within the hub) damps that. A humanoid's most loaded hub, its pelvis, is
/// outweighed 3.996 times by its spine and thighs (de Leva's fractions) and keeps the
/// full correction.
pub(crate) fn hub_relaxation(masses: &[f32], links: &[(usize, usize)]) -> Vec<f32> {
    let mut count = vec![0usize; masses.len()];
    let mut held = vec![0.0f32; masses.len()];
    for &(a, b) in links {
        count[a] += 1;
        count[b] += 1;
        held[a] += masses[b];
        held[b] += masses[a];
    }
    (0..masses.len())
        .map(|i| {
            if count[i] < 3 || held[i] <= HUB_MAX_OUTWEIGHED * masses[i] {
                1.0
            } else {
                HUB_MAX_OUTWEIGHED * masses[i] / held[i]
            }
        })
        .collect()
}
