//! The Kingery–Bulmash curves of a hemispherical TNT surface burst (Swisdak's metric
//! form), with the clamps and continuations that extend them to any scaled distance, and
//! the ideal-gas shock relations the continuations lean on.

use super::{AMBIENT_PRESSURE_PA, SOUND_SPEED_M_S};

/// One fitted range of one Kingery–Bulmash quantity: `Y = exp(Σ cᵢ·Lⁱ)`, `L = ln Z`,
/// valid for `z_min ≤ Z ≤ z_max` (m/kg^(1/3)) and never evaluated outside it.
#[derive(Debug, Clone, Copy)]
pub(super) struct KbRange {
    pub(super) z_min: f64,
    pub(super) z_max: f64,
    pub(super) c: [f64; 7],
}

pub(super) const fn kb(z_min: f64, z_max: f64, c: [f64; 7]) -> KbRange {
    KbRange { z_min, z_max, c }
}

// Kingery–Bulmash fits for a hemispherical surface burst of TNT, metric form, from
// D. Swisdak, "Simplified Kingery Airblast Calculations", Naval Surface Warfare Center,
// Minutes of the 26th DoD Explosives Safety Seminar, 1994 (the basis of UFC 3-340-02 and
// ConWep). Coefficients exactly as published. Units of Y: times in ms/kg^(1/3),
// pressures in kPa, impulses in kPa·ms/kg^(1/3), shock speed in km/s.

/// Arrival time t_a, ms/kg^(1/3).
#[rustfmt::skip]
pub(super) const KB_ARRIVAL: [KbRange; 2] = [
    kb(0.06, 1.50, [-0.7604, 1.8058, 0.1257, -0.0437, -0.0310, -0.00669, 0.0]),
    kb(1.50, 40.0, [-0.7137, 1.5732, 0.5561, -0.4213,  0.1054, -0.00929, 0.0]),
];
/// Incident (side-on) peak overpressure P_so, kPa.
#[rustfmt::skip]
pub(super) const KB_INCIDENT: [KbRange; 3] = [
    kb(0.2,  2.9,   [7.2106, -2.1069, -0.3229,  0.1117,  0.0685,  0.0, 0.0]),
    kb(2.9,  23.8,  [7.5938, -3.0523,  0.40977, 0.0261, -0.01267, 0.0, 0.0]),
    kb(23.8, 198.5, [6.0536, -1.4066,  0.0,     0.0,     0.0,     0.0, 0.0]),
];
/// Normally reflected peak pressure P_r, kPa.
#[rustfmt::skip]
pub(super) const KB_REFLECTED: [KbRange; 2] = [
    kb(0.06, 2.0,  [9.006,  -2.6893, -0.6295, 0.1011,  0.29255, 0.13505,  0.019736]),
    kb(2.0,  40.0, [8.8396, -1.733,  -2.64,   2.293,  -0.8232,  0.14247, -0.0099]),
];
/// Positive phase duration t_d, ms/kg^(1/3).
#[rustfmt::skip]
pub(super) const KB_DURATION: [KbRange; 3] = [
    kb(0.2,  1.02, [ 0.5426, 3.2299, -1.5931, -5.9667, -4.0815,  -0.9149,  0.0]),
    kb(1.02, 2.8,  [ 0.5440, 2.7082, -9.7354, 14.3425, -9.7791,   2.8535,  0.0]),
    kb(2.8,  40.0, [-2.4608, 7.1639, -5.6215,  2.2711, -0.44994,  0.03486, 0.0]),
];
/// Incident positive impulse i_s, kPa·ms/kg^(1/3).
#[rustfmt::skip]
pub(super) const KB_INCIDENT_IMPULSE: [KbRange; 4] = [
    kb(0.2,  0.96,  [5.522,   1.117,   0.6,    -0.292,  -0.087,   0.0, 0.0]),
    kb(0.96, 2.38,  [5.465,  -0.308,  -1.464,   1.362,  -0.432,   0.0, 0.0]),
    kb(2.38, 33.7,  [5.2749, -0.4677, -0.2499,  0.0588, -0.00554, 0.0, 0.0]),
    kb(33.7, 158.7, [5.9825, -1.062,   0.0,     0.0,     0.0,     0.0, 0.0]),
];
/// Normally reflected positive impulse i_r, kPa·ms/kg^(1/3).
#[rustfmt::skip]
pub(super) const KB_REFLECTED_IMPULSE: [KbRange; 1] = [
    kb(0.06, 40.0, [6.7853, -1.3466, 0.101, 0.01123, 0.0, 0.0, 0.0]),
];
/// Shock front speed U, km/s.
#[rustfmt::skip]
pub(super) const KB_SHOCK_SPEED: [KbRange; 2] = [
    kb(0.06, 1.50, [0.1794, -0.956, -0.0866, 0.109,  0.0699, 0.01218, 0.0]),
    kb(1.50, 40.0, [0.2597, -1.326,  0.3767, 0.0396, -0.0351, 0.00432, 0.0]),
];

/// Evaluates one fitted range. Callers guarantee `z` lies inside it.
pub(super) fn kb_eval(r: &KbRange, z: f64) -> f64 {
    debug_assert!(z >= r.z_min * (1.0 - 1e-12) && z <= r.z_max * (1.0 + 1e-12));
    let l = z.ln();
    let mut acc = 0.0;
    for c in r.c.iter().rev() {
        acc = acc * l + c;
    }
    acc.exp()
}

/// Evaluates a quantity at a `z` inside its overall fitted span. A `z` exactly on a
/// boundary between two ranges uses the lower range (the fits differ there by up to
/// 2.4 %, see the tests); anything outside the span is clamped to it, so a polynomial is
/// never evaluated outside its range even if a caller forgets to continue it.
pub(super) fn kb_fit(ranges: &[KbRange], z: f64) -> f64 {
    let lo = ranges[0].z_min;
    let hi = ranges[ranges.len() - 1].z_max;
    let z = z.clamp(lo, hi);
    let r = ranges
        .iter()
        .find(|r| z <= r.z_max)
        .unwrap_or(&ranges[ranges.len() - 1]);
    kb_eval(r, z)
}

pub(super) fn kb_min(ranges: &[KbRange]) -> f64 {
    ranges[0].z_min
}

pub(super) fn kb_max(ranges: &[KbRange]) -> f64 {
    ranges[ranges.len() - 1].z_max
}

/// Peak dynamic pressure behind a shock of overpressure `p` (any pressure unit, with the
/// ambient pressure `p0` in the same unit): `q = 5p² / (2(p + 7p₀))`, the ideal-gas
/// (γ = 1.4) Rankine–Hugoniot result.
pub(super) fn dynamic_from_overpressure(p: f64, p0: f64) -> f64 {
    5.0 * p * p / (2.0 * (p + 7.0 * p0))
}

/// Ideal-gas normal reflection coefficient `P_r / P_so = 2(7p₀ + 4p)/(7p₀ + p)`: 2 for
/// an acoustic wave, 8 for a very strong shock.
pub(super) fn ideal_reflection_ratio(p: f64, p0: f64) -> f64 {
    2.0 * (7.0 * p0 + 4.0 * p) / (7.0 * p0 + p)
}

/// Ideal-gas shock speed `U = a₀·√(1 + 6p/(7p₀))`, in the unit of `a0`.
pub(super) fn ideal_shock_speed(p: f64, p0: f64, a0: f64) -> f64 {
    a0 * (1.0 + 6.0 * p / (7.0 * p0)).sqrt()
}

/// Every Kingery–Bulmash quantity at one scaled distance, in the table's own units per
/// kg^(1/3) (see the table's comment), with the clamps and continuations applied.
#[derive(Debug, Clone, Copy)]
pub(super) struct Scaled {
    pub(super) arrival_ms: f64,
    pub(super) incident_kpa: f64,
    pub(super) reflected_kpa: f64,
    pub(super) duration_ms: f64,
    pub(super) incident_impulse_kpa_ms: f64,
    pub(super) reflected_impulse_kpa_ms: f64,
    pub(super) shock_speed_km_s: f64,
}

/// The surface-burst curves at any scaled distance `z ≥ 0` (m/kg^(1/3)).
///
/// Inside the fitted ranges these are the fits themselves. Outside, the choices are
/// (each is continuous at the edge it starts from):
///
/// - **Below the lowest range** (`Z < 0.06` for t_a, P_r, i_r, U; `Z < 0.2` for P_so,
///   t_d, i_s): the value at the range edge. Pressures and impulses therefore stop
///   growing as the target gets closer than that; Z = 0.06 is about the radius of a cast
///   TNT sphere (0.053 m/kg^(1/3)), i.e. the charge's surface, where the fits' own data
///   end. The exception is the arrival time, which falls linearly to 0 at Z = 0
///   (`t_a(Z) = t_a(0.06)·Z/0.06`) so that the shock starts at the charge.
/// - **Above the highest range**, the far field is acoustic:
///   - t_a: the edge value plus the extra distance at the speed of sound,
///     `t_a(40) + (Z − 40)/a₀`;
///   - P_so (beyond 198.5) and i_s (beyond 158.7): `∝ 1/Z`, spherical acoustic decay
///     (the last fitted ranges already fall as Z^-1.41 and Z^-1.06);
///   - t_d (beyond 40): not held, but derived from the P_so and i_s fits, which remain
///     valid out to ~160–200, keeping the Friedlander shape (decay coefficient b) of
///     Z = 40. Holding t_d instead would push `i_s / (P_so·t_d)` past 1/2 from Z ≈ 50,
///     where no Friedlander pulse can carry the fitted impulse. With this choice t_d
///     grows by ≈ 2.2× between Z = 40 and Z = 200 and is constant beyond.
///   - P_r (beyond 40): P_so times the ideal-gas reflection ratio plus the fit's
///     offset from it at Z = 40, that offset fading in proportion to P_so, so the ratio
///     tends to the acoustic value 2;
///   - U (beyond 40): the ideal-gas shock speed plus the fit's offset at Z = 40, fading
///     the same way, so U tends to a₀;
///   - i_r (beyond 40): keeps its Z = 40 ratio to i_s.
pub(super) fn scaled(z: f64) -> Scaled {
    let z = z.max(0.0);
    let p0_kpa = AMBIENT_PRESSURE_PA * 1e-3;
    let a0_m_per_ms = SOUND_SPEED_M_S * 1e-3; // = km/s
    let arrival_ms = arrival(z);
    let incident_kpa = incident(z);
    let incident_impulse_kpa_ms = incident_impulse(z);
    let duration_ms = duration(z, || (incident_kpa, incident_impulse_kpa_ms));
    let edge = kb_max(&KB_DURATION);
    let p_edge = incident(edge);

    let reflected_kpa = if z > kb_max(&KB_REFLECTED) {
        let fit_ratio = kb_fit(&KB_REFLECTED, edge) / p_edge;
        let offset = fit_ratio - ideal_reflection_ratio(p_edge, p0_kpa);
        incident_kpa
            * (ideal_reflection_ratio(incident_kpa, p0_kpa) + offset * incident_kpa / p_edge)
    } else {
        kb_fit(&KB_REFLECTED, z)
    };

    let reflected_impulse_kpa_ms = if z > kb_max(&KB_REFLECTED_IMPULSE) {
        kb_fit(&KB_REFLECTED_IMPULSE, edge) * incident_impulse_kpa_ms / incident_impulse(edge)
    } else {
        kb_fit(&KB_REFLECTED_IMPULSE, z)
    };

    let shock_speed_km_s = if z > kb_max(&KB_SHOCK_SPEED) {
        let offset = kb_fit(&KB_SHOCK_SPEED, edge) - ideal_shock_speed(p_edge, p0_kpa, a0_m_per_ms);
        ideal_shock_speed(incident_kpa, p0_kpa, a0_m_per_ms) + offset * incident_kpa / p_edge
    } else {
        kb_fit(&KB_SHOCK_SPEED, z)
    };

    Scaled {
        arrival_ms,
        incident_kpa,
        reflected_kpa,
        duration_ms,
        incident_impulse_kpa_ms,
        reflected_impulse_kpa_ms,
        shock_speed_km_s,
    }
}

/// [`scaled`]'s arrival time and positive-phase duration alone (ms/kg^(1/3)), to the bit:
/// all that says whether a target is under the positive phase at a given time, for a
/// fraction of the cost of every curve.
pub(super) fn scaled_phase(z: f64) -> (f64, f64) {
    let z = z.max(0.0);
    (
        arrival(z),
        duration(z, || (incident(z), incident_impulse(z))),
    )
}

/// Arrival time: linear to 0 below the fits, acoustic above.
fn arrival(z: f64) -> f64 {
    let a0_m_per_ms = SOUND_SPEED_M_S * 1e-3; // = km/s
    let (ta_lo, ta_hi) = (kb_min(&KB_ARRIVAL), kb_max(&KB_ARRIVAL));
    if z < ta_lo {
        kb_fit(&KB_ARRIVAL, ta_lo) * z / ta_lo
    } else if z > ta_hi {
        kb_fit(&KB_ARRIVAL, ta_hi) + (z - ta_hi) / a0_m_per_ms
    } else {
        kb_fit(&KB_ARRIVAL, z)
    }
}

/// Incident overpressure: hold below, 1/Z above.
fn incident(z: f64) -> f64 {
    held_then_acoustic(&KB_INCIDENT, z)
}

/// Incident impulse: hold below, 1/Z above.
fn incident_impulse(z: f64) -> f64 {
    held_then_acoustic(&KB_INCIDENT_IMPULSE, z)
}

/// A fit held at its lowest range's edge below it (by [`kb_fit`]'s clamp) and falling
/// as 1/Z, spherical acoustic decay, beyond its highest.
fn held_then_acoustic(ranges: &[KbRange], z: f64) -> f64 {
    let hi = kb_max(ranges);
    if z > hi {
        kb_fit(ranges, hi) * hi / z
    } else {
        kb_fit(ranges, z)
    }
}

/// Positive-phase duration: the fit up to its edge (Z = 40), beyond it derived from the
/// incident pressure and impulse at `z` (`at_z`, asked for only there) with the
/// Friedlander shape of the edge.
fn duration(z: f64, at_z: impl FnOnce() -> (f64, f64)) -> f64 {
    let edge = kb_max(&KB_DURATION);
    if z > edge {
        let shape = incident_impulse(edge) / (incident(edge) * kb_fit(&KB_DURATION, edge));
        let (incident_kpa, impulse_kpa_ms) = at_z();
        impulse_kpa_ms / (shape * incident_kpa)
    } else {
        kb_fit(&KB_DURATION, z)
    }
}
