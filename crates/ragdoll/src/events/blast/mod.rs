//! Air blast physics: how strong the shock from a TNT charge is at a given
//! distance, how its pressure decays in time, and what net force it puts on one body part.
//!
//! Everything here is pure functions on plain data, so that the curves can be tested
//! against published check values without a world or a physics engine. SI units inside
//! (metres, kilograms, seconds, pascals); the Kingery–Bulmash table keeps its published
//! units (kPa, ms, km/s, per kg^(1/3)), which are named where they appear.
//!
//! # The model, in four steps
//!
//! 1. **Peak values at one standoff** ([`surface_burst`], [`air_burst`], [`blast_at`]):
//!    the Kingery–Bulmash fits for a hemispherical surface burst of TNT in Swisdak's
//!    metric form, with documented clamps and continuations outside the fitted ranges,
//!    and a charge high in the air treated as a free-air burst of `W / 1.8`.
//! 2. **Time histories** ([`BlastAt::overpressure_pa`], [`BlastAt::dynamic_pressure_pa`]):
//!    a Friedlander positive phase whose decay coefficient is solved so that its
//!    integral equals the fitted incident impulse; the negative phase is ignored.
//! 3. **Exact impulses over any time interval**
//!    ([`BlastAt::overpressure_impulse_pa_s`], [`BlastAt::dynamic_impulse_pa_s`]): the
//!    simulation applies the load over substeps, so each substep needs the integral of
//!    the load over it, not a sample of it. The integrals are in closed form.
//! 4. **Net load on one body part** ([`part_force`], [`part_impulse`]): reflected
//!    pressure on the face toward the charge, clearing, the incident wave wrapping
//!    round to the back face, and drag.
//!
//! # Example
//!
//! ```
//! use ragdoll::events::blast::{part_impulse, surface_burst};
//!
//! // 10 kg of TNT on the ground, 10 m away.
//! let b = surface_burst(10.0, 10.0);
//! assert!((b.arrival_s - 15.8e-3).abs() < 0.2e-3);
//! assert!((b.incident_pa - 49e3).abs() < 0.5e3);
//! // A standing adult: about 0.5 m² facing the charge, 0.3 m deep, drag coefficient 1.2.
//! let j = part_impulse(&b, 0.0, f64::INFINITY, 0.5, 0.3, 1.2);
//! assert!(j > 50.0 && j < 100.0); // newton-seconds: about 1 m/s for 75 kg
//! ```

use glam::DVec3;

mod kingery;

use kingery::{dynamic_from_overpressure, scaled, scaled_phase};

/// Sea-level ambient pressure, in pascals. The ideal-gas shock relations and the dynamic
/// pressure are written in terms of it.
pub const AMBIENT_PRESSURE_PA: f64 = 101_325.0;

/// Speed of sound in ambient air, in metres per second (a₀ ≈ 340 m/s). Used
/// where the fits end: far from the charge the shock is an acoustic wave.
pub const SOUND_SPEED_M_S: f64 = 340.0;

/// How many kilograms of TNT in free air make the same blast as one kilogram on the
/// ground: the ground reflects the half of the energy that went down, minus
/// what cratering and heating the ground take. A charge well above the ground therefore
/// reads the surface-burst curves with `W / 1.8`.
pub const FREE_AIR_FACTOR: f64 = 1.8;

/// Scaled height of burst (m/kg^(1/3)) at and below which a charge counts as a surface
/// burst. At 0.1 m/kg^(1/3) a 10 kg charge is 22 cm up: the ground is within about two
/// charge radii and reflects the shock before it has left the charge's neighbourhood.
pub const SURFACE_BURST_MAX_SCALED_HEIGHT: f64 = 0.1;

/// Scaled height of burst (m/kg^(1/3)) at and above which a charge counts as a free-air
/// burst (`W / 1.8` on the surface curves). Between this and
/// [`SURFACE_BURST_MAX_SCALED_HEIGHT`] the equivalent charge is blended smoothly; see
/// [`equivalent_surface_charge_kg`].
pub const FREE_AIR_MIN_SCALED_HEIGHT: f64 = 1.0;

/// Smallest Friedlander decay coefficient we return. `b → 0` is the triangular pulse,
/// whose impulse `P·t_d/2` is the largest a Friedlander positive phase can carry; a
/// strictly positive floor keeps `b` meaningful as a "decay" and every formula finite.
pub const MIN_DECAY: f64 = 1e-6;

/// Whether `x` is a usable positive quantity (a mass, an area): rejects zero, negatives,
/// NaN and infinity in one test.
fn positive_finite(x: f64) -> bool {
    x > 0.0 && x.is_finite()
}

// ---------------------------------------------------------------------------------------
// Friedlander pulse
// ---------------------------------------------------------------------------------------

/// `φₙ(x) = ∫₀¹ tⁿ e^(−x·t) dt` for n = 0, 1, 2 and `x ≥ 0`: the building block of every
/// closed-form integral here. A power series below x = 1 (where the closed forms lose
/// digits to cancellation), the closed forms above.
fn phi012(x: f64) -> [f64; 3] {
    if x < 1.0 {
        // Σ_k (−x)^k / (k! (n + k + 1)); |x| < 1 so 25 terms leave < 1e-25.
        let mut out = [0.0; 3];
        let mut term = 1.0; // (−x)^k / k!
        for k in 0..25 {
            let kf = k as f64;
            for (n, o) in out.iter_mut().enumerate() {
                *o += term / (kf + n as f64 + 1.0);
            }
            term *= -x / (kf + 1.0);
        }
        out
    } else {
        let e = (-x).exp();
        [
            (1.0 - e) / x,
            (1.0 - e * (1.0 + x)) / (x * x),
            (2.0 - e * (x * x + 2.0 * x + 2.0)) / (x * x * x),
        ]
    }
}

/// `∫_{s0}^{s0+h} (d₀ + d₁u + d₂u²) e^(−β·s) ds` with `u = s − s0`, `h ≥ 0`, `β ≥ 0`. The
/// polynomial is given in the shifted variable so that short intervals late in the pulse
/// lose no digits.
fn poly_exp_integral(d: [f64; 3], beta: f64, s0: f64, h: f64) -> f64 {
    if h <= 0.0 {
        return 0.0;
    }
    let [f0, f1, f2] = phi012(beta * h);
    (-beta * s0).exp() * h * (d[0] * f0 + h * (d[1] * f1 + h * d[2] * f2))
}

/// The Friedlander decay coefficient `b` whose pulse carries the impulse fraction `ratio =
/// i_s / (P_so·t_d)`.
///
/// The fraction `f(b) = ∫₀¹ (1 − s) e^(−b·s) ds = 1/b − (1 − e^(−b))/b²`, computed as
/// `φ₀(b) − φ₁(b)` which stays accurate as `b → 0`, falls from 1/2 at `b = 0` (triangle)
/// towards `1/b`, and is convex. Newton's method started at `b = 0`, where `f > ratio`, therefore
/// never overshoots (each tangent lies below the curve) and converges monotonically from
/// the left: no bracket, no divergence, about 5 iterations for the ratios the curves
/// produce (0.09…0.46), deterministic. A ratio of 1/2 or more cannot be reached by any
/// Friedlander pulse; it gets [`MIN_DECAY`] (the nearly triangular pulse, which then
/// carries less than the fitted impulse). The curves above never produce such a ratio
/// (the largest is 0.464, at Z ≥ 40), so this is a guard, not a regime.
fn solve_decay(ratio: f64) -> f64 {
    const MAX_DECAY: f64 = 1e6;
    if ratio.is_nan() || ratio >= 0.5 {
        return MIN_DECAY;
    }
    if ratio <= 0.0 {
        // No impulse at all: an infinitely fast decay; keep it finite.
        return MAX_DECAY;
    }
    let mut b = 0.0_f64;
    for _ in 0..200 {
        let [f0, f1, f2] = phi012(b);
        // f(b) − ratio over −f'(b) = ∫ s(1 − s) e^(−bs) ds > 0.
        let step = (f0 - f1 - ratio) / (f1 - f2);
        b += step;
        if b.is_nan() || b >= MAX_DECAY {
            return MAX_DECAY;
        }
        if step.abs() <= 1e-15 * b {
            break;
        }
    }
    b.max(MIN_DECAY)
}

// ---------------------------------------------------------------------------------------
// The blast at one standoff
// ---------------------------------------------------------------------------------------

/// Everything about the blast wave at one point, in SI units: the peak values from the
/// Kingery–Bulmash curves and what is derived from them. Times count from detonation.
///
/// All zero ([`BlastAt::NONE`]) means "no blast" (an invalid charge): every history and
/// load then reads zero, so callers need no special case.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct BlastAt {
    /// The charge read on the surface-burst curves, kg of TNT: the real charge for a
    /// surface burst, less (down to `W / 1.8`) for one in the air. Kept so a report can
    /// say what was used.
    pub tnt_kg: f64,
    /// Distance from the charge's centre, metres.
    pub standoff_m: f64,
    /// Scaled distance `Z = R / W^(1/3)`, m/kg^(1/3), the curves' argument.
    pub scaled_distance: f64,
    /// When the shock front arrives, seconds after detonation.
    pub arrival_s: f64,
    /// Length of the positive phase, seconds. The negative phase that follows is ignored
    /// (it is weaker, about P₀/3 at most, and slower; for throwing bodies it matters little).
    pub duration_s: f64,
    /// Peak incident (side-on) overpressure P_so, pascals: what a surface parallel to
    /// the wave's travel feels.
    pub incident_pa: f64,
    /// Peak normally reflected pressure P_r, pascals: what a surface facing the charge
    /// feels at the instant the shock hits it (2× P_so for weak shocks, far more for
    /// strong ones).
    pub reflected_pa: f64,
    /// Incident positive-phase impulse i_s, pascal-seconds.
    pub incident_impulse_pa_s: f64,
    /// Normally reflected positive-phase impulse i_r, pascal-seconds (from its own fit;
    /// not used by the part load, which models reflection and clearing explicitly).
    pub reflected_impulse_pa_s: f64,
    /// Speed of the shock front, metres per second (sets clearing times).
    pub shock_speed_m_s: f64,
    /// Peak dynamic pressure `q = 5P_so² / (2(P_so + 7P₀))`, pascals: the wind behind
    /// the shock, ½ρu², which drags on every part.
    pub dynamic_pa: f64,
    /// Friedlander decay coefficient b (dimensionless), solved so that the incident
    /// history integrates to `incident_impulse_pa_s`.
    pub decay: f64,
}

impl BlastAt {
    /// No blast: all zero; every history and load is zero.
    pub const NONE: BlastAt = BlastAt {
        tnt_kg: 0.0,
        standoff_m: 0.0,
        scaled_distance: 0.0,
        arrival_s: 0.0,
        duration_s: 0.0,
        incident_pa: 0.0,
        reflected_pa: 0.0,
        incident_impulse_pa_s: 0.0,
        reflected_impulse_pa_s: 0.0,
        shock_speed_m_s: 0.0,
        dynamic_pa: 0.0,
        decay: 0.0,
    };

    /// Whether this describes a real blast (a positive phase of non-zero length).
    pub fn is_blast(&self) -> bool {
        self.duration_s > 0.0
    }

    /// Converts a time since detonation to the fraction of the positive phase elapsed,
    /// `s = (t − t_a)/t_d` (negative before arrival, above 1 after the positive phase).
    fn phase(&self, t: f64) -> f64 {
        (t - self.arrival_s) / self.duration_s
    }

    /// The interval `[t0, t1]` as positive-phase fractions clipped to `[0, 1]`; `None` if
    /// it misses the positive phase or is invalid.
    fn phase_interval(&self, t0: f64, t1: f64) -> Option<(f64, f64)> {
        if !self.is_blast() || t0.is_nan() || t1.is_nan() || t1 <= t0 {
            return None;
        }
        let s0 = self.phase(t0).max(0.0);
        let s1 = self.phase(t1).min(1.0);
        (s1 > s0).then_some((s0, s1))
    }

    /// Incident overpressure at `t` seconds after detonation, pascals: the Friedlander
    /// positive phase `P_so·(1 − τ/t_d)·e^(−b·τ/t_d)`, `τ = t − t_a`; zero before the
    /// shock arrives and after the positive phase (the negative phase is ignored).
    pub fn overpressure_pa(&self, t: f64) -> f64 {
        if !self.is_blast() {
            return 0.0;
        }
        let s = self.phase(t);
        if (0.0..1.0).contains(&s) {
            self.incident_pa * (1.0 - s) * (-self.decay * s).exp()
        } else {
            0.0
        }
    }

    /// Dynamic pressure (the blast wind, ½ρu²) at `t` seconds after detonation, pascals.
    ///
    /// Shape: `q(τ) = q_peak·(1 − τ/t_d)²·e^(−2b·τ/t_d)`, the square of the normalised
    /// incident history. Why: `q = ½ρu²`, and behind a weak shock the particle velocity
    /// is proportional to the overpressure (acoustic impedance), so `q/q_peak ≈ (p/P_so)²`.
    /// The same squared-Friedlander form is the usual engineering idealisation of the
    /// dynamic pressure history (Glasstone & Dolan, "The Effects of Nuclear Weapons",
    /// 1977, ch. III, there with b = 1). Its positive phase is taken equal to the
    /// overpressure's; in reality the wind blows somewhat longer, so late drag is slightly
    /// underestimated.
    pub fn dynamic_pressure_pa(&self, t: f64) -> f64 {
        if !self.is_blast() {
            return 0.0;
        }
        let s = self.phase(t);
        if (0.0..1.0).contains(&s) {
            self.dynamic_pa * (1.0 - s) * (1.0 - s) * (-2.0 * self.decay * s).exp()
        } else {
            0.0
        }
    }

    /// Exact integral of [`overpressure_pa`](Self::overpressure_pa) from `t0` to `t1`
    /// (seconds after detonation), pascal-seconds. Closed form, so a simulation summing
    /// it over substeps gets exactly the fitted impulse. Zero when `t1 ≤ t0`; infinite
    /// bounds are allowed (`(-∞, ∞)` gives `incident_impulse_pa_s`).
    pub fn overpressure_impulse_pa_s(&self, t0: f64, t1: f64) -> f64 {
        let Some((s0, s1)) = self.phase_interval(t0, t1) else {
            return 0.0;
        };
        let c = 1.0 - s0;
        self.incident_pa
            * self.duration_s
            * poly_exp_integral([c, -1.0, 0.0], self.decay, s0, s1 - s0)
    }

    /// Exact integral of [`dynamic_pressure_pa`](Self::dynamic_pressure_pa) from `t0` to
    /// `t1` (seconds after detonation), pascal-seconds; same conventions as
    /// [`overpressure_impulse_pa_s`](Self::overpressure_impulse_pa_s).
    pub fn dynamic_impulse_pa_s(&self, t0: f64, t1: f64) -> f64 {
        let Some((s0, s1)) = self.phase_interval(t0, t1) else {
            return 0.0;
        };
        self.dynamic_pa * self.duration_s * dynamic_shape_integral(self.decay, s0, s1)
    }
}

/// `∫_{s0}^{s1} (1 − s)² e^(−2b·s) ds`, for `0 ≤ s0 ≤ s1 ≤ 1`.
fn dynamic_shape_integral(b: f64, s0: f64, s1: f64) -> f64 {
    let c = 1.0 - s0;
    poly_exp_integral([c * c, -2.0 * c, 1.0], 2.0 * b, s0, s1 - s0)
}

/// The blast of `tnt_kg` kilograms of TNT lying on the ground (hemispherical surface
/// burst), `standoff_m` metres from its centre: the Kingery–Bulmash curves themselves.
///
/// Any standoff from 0 to infinity-exclusive works (see the module's clamping notes; a
/// negative standoff counts as 0). A charge that is not a positive finite mass, or a
/// non-finite standoff, gives [`BlastAt::NONE`]: a blast that does nothing, so that a
/// bad event cannot crash or poison a simulation; validating user input and saying so
/// is the caller's job.
pub fn surface_burst(tnt_kg: f64, standoff_m: f64) -> BlastAt {
    if !(positive_finite(tnt_kg) && standoff_m.is_finite()) {
        return BlastAt::NONE;
    }
    let r = standoff_m.max(0.0);
    let w3 = tnt_kg.cbrt();
    let z = r / w3;
    if !z.is_finite() {
        return BlastAt::NONE;
    }
    let s = scaled(z);
    let incident_pa = s.incident_kpa * 1e3;
    // kPa·ms = Pa·s; times in ms/kg^(1/3).
    let b = BlastAt {
        tnt_kg,
        standoff_m: r,
        scaled_distance: z,
        arrival_s: s.arrival_ms * w3 * 1e-3,
        duration_s: s.duration_ms * w3 * 1e-3,
        incident_pa,
        reflected_pa: s.reflected_kpa * 1e3,
        incident_impulse_pa_s: s.incident_impulse_kpa_ms * w3,
        reflected_impulse_pa_s: s.reflected_impulse_kpa_ms * w3,
        shock_speed_m_s: s.shock_speed_km_s * 1e3,
        dynamic_pa: dynamic_from_overpressure(incident_pa, AMBIENT_PRESSURE_PA),
        // The impulse ratio does not depend on W: take it from the scaled values.
        decay: solve_decay(s.incident_impulse_kpa_ms / (s.incident_kpa * s.duration_ms)),
    };
    if b.duration_s > 0.0 && b.arrival_s.is_finite() && b.incident_impulse_pa_s.is_finite() {
        b
    } else {
        // Only reachable with charges so small or so large that W^(1/3) under- or
        // overflows the times; nothing meaningful to simulate.
        BlastAt::NONE
    }
}

/// The blast of `tnt_kg` kilograms of TNT detonated far from any surface (free air),
/// `standoff_m` metres from its centre: the surface-burst curves read with
/// `W / FREE_AIR_FACTOR`. Same conventions as [`surface_burst`];
/// [`BlastAt::tnt_kg`] holds the reduced charge.
pub fn air_burst(tnt_kg: f64, standoff_m: f64) -> BlastAt {
    surface_burst(tnt_kg / FREE_AIR_FACTOR, standoff_m)
}

/// The surface-burst-equivalent charge (kg) of `tnt_kg` kilograms detonated
/// `height_of_burst_m` metres above the ground.
///
/// Blend: with the scaled height `λ = h / W^(1/3)` (m/kg^(1/3)), the charge is a surface
/// burst (factor 1) for `λ ≤ 0.1`, a free-air burst (factor 1/1.8) for `λ ≥ 1`, and in
/// between the factor is `1.8^(−S(x))`, `x = log₁₀(λ / 0.1)`, `S(x) = 3x² − 2x³`
/// (smoothstep): continuous with a continuous slope, monotonic in height, and geometric
/// in the charge, i.e. linear in the log of the curves' argument. A charge at or below
/// the ground (λ ≤ 0) counts as a surface burst: a buried charge is weaker (energy goes
/// into the crater), so this errs on the strong side.
///
/// Not modelled: the Mach stem and the separate ground-reflected shock of a real air
/// burst, which near the ground can make it stronger than this free-air estimate.
pub fn equivalent_surface_charge_kg(tnt_kg: f64, height_of_burst_m: f64) -> f64 {
    let w3 = tnt_kg.cbrt();
    let lambda = height_of_burst_m / w3;
    if lambda.is_nan() || lambda <= SURFACE_BURST_MAX_SCALED_HEIGHT {
        // Also catches a NaN height: treat as on the ground.
        return tnt_kg;
    }
    let x = ((lambda / SURFACE_BURST_MAX_SCALED_HEIGHT).ln()
        / (FREE_AIR_MIN_SCALED_HEIGHT / SURFACE_BURST_MAX_SCALED_HEIGHT).ln())
    .clamp(0.0, 1.0);
    let smooth = x * x * (3.0 - 2.0 * x);
    tnt_kg * FREE_AIR_FACTOR.powf(-smooth)
}

/// The blast of `tnt_kg` kilograms of TNT at `charge` (world position, metres) as felt
/// at `target`, above a ground plane at height `ground_y` (Y up). The standoff is the
/// straight-line distance; the charge's height above the ground chooses between the
/// surface and free-air curves ([`equivalent_surface_charge_kg`]).
///
/// Any positions work, including the charge at the target itself, directly above it
/// or below the ground; a non-finite position or an invalid charge gives
/// [`BlastAt::NONE`]. (The direction of the push is the caller's: this returns
/// magnitudes only.)
pub fn blast_at(tnt_kg: f64, charge: DVec3, target: DVec3, ground_y: f64) -> BlastAt {
    let valid =
        positive_finite(tnt_kg) && charge.is_finite() && target.is_finite() && ground_y.is_finite();
    if !valid {
        return BlastAt::NONE;
    }
    let w = equivalent_surface_charge_kg(tnt_kg, charge.y - ground_y);
    surface_burst(w, charge.distance(target))
}

/// When the positive phase of [`blast_at`]'s blast reaches `target` and how long it lasts
/// there, seconds: its `arrival_s` and `duration_s` to the bit (0 and 0 for
/// [`BlastAt::NONE`]), from two of the curves instead of all of them and the decay's
/// root. A world asks this of every body part every step, and of most parts the answer
/// is that the wave has not come yet or has passed: a crowd of 300 spent a tenth of its
/// time in [`surface_burst`] before it asked this first.
pub(crate) fn phase_at(tnt_kg: f64, charge: DVec3, target: DVec3, ground_y: f64) -> (f64, f64) {
    let valid =
        positive_finite(tnt_kg) && charge.is_finite() && target.is_finite() && ground_y.is_finite();
    if !valid {
        return (0.0, 0.0);
    }
    let w = equivalent_surface_charge_kg(tnt_kg, charge.y - ground_y);
    let r = charge.distance(target);
    if !(positive_finite(w) && r.is_finite()) {
        return (0.0, 0.0);
    }
    let w3 = w.cbrt();
    let z = r.max(0.0) / w3;
    if !z.is_finite() {
        return (0.0, 0.0);
    }
    let (arrival_ms, duration_ms) = scaled_phase(z);
    let (arrival_s, duration_s) = (arrival_ms * w3 * 1e-3, duration_ms * w3 * 1e-3);
    if duration_s > 0.0 && arrival_s.is_finite() {
        (arrival_s, duration_s)
    } else {
        (0.0, 0.0)
    }
}

// ---------------------------------------------------------------------------------------
// Loading of one body part
// ---------------------------------------------------------------------------------------

/// The geometry of one part's load, in positive-phase fractions `s = τ / t_d`.
struct PartLoad {
    /// Time for the wave to cross the part (front to back), `size / U`, as a fraction.
    s_cross: f64,
    /// Clearing time `3·size / U` as a fraction.
    s_clear: f64,
    /// Reflection excess at the front face at arrival, Pa: `P_r − P_so − C_d·q` (≥ 0).
    excess_pa: f64,
    /// Drag coefficient, clamped to ≥ 0.
    cd: f64,
}

impl PartLoad {
    fn new(b: &BlastAt, size_m: f64, drag_coefficient: f64) -> Self {
        let size = if size_m.is_finite() {
            size_m.max(0.0)
        } else {
            0.0
        };
        let cd = if drag_coefficient.is_finite() {
            drag_coefficient.max(0.0)
        } else {
            0.0
        };
        let cross_s = size / b.shock_speed_m_s;
        Self {
            s_cross: cross_s / b.duration_s,
            s_clear: 3.0 * cross_s / b.duration_s,
            excess_pa: (b.reflected_pa - b.incident_pa - cd * b.dynamic_pa).max(0.0),
            cd,
        }
    }

    /// Share of the incident overpressure not yet balanced by the back face at `s`:
    /// 1 until the wave has crossed the part, then falling linearly to 0 at clearing.
    fn unbalanced(&self, s: f64) -> f64 {
        if s < self.s_cross {
            1.0
        } else if s < self.s_clear {
            (self.s_clear - s) / (self.s_clear - self.s_cross)
        } else {
            0.0
        }
    }
}

/// Net force on one body part, newtons, along the direction away from the charge, at
/// `t_since_detonation` seconds (zero before arrival and after the positive phase).
///
/// `area_m2` is the part's area projected toward the charge, `size_m` its depth along
/// the wave's travel (also used as its clearing distance), `drag_coefficient` the net
/// drag coefficient (front minus back, ≈ 1…1.3 for limbs and torsos).
///
/// Model (after UFC 3-340-02's front/back wall loading, scaled down to a body part; τ is
/// time since arrival, `t_c = 3·size/U` the clearing time):
/// - front face: `P_so(τ) + C_d·q(τ) + E·(1 − τ/t_c)⁺`, with the reflection excess
///   `E = P_r − P_so − C_d·q_peak` so that the face feels exactly P_r at arrival and the
///   stagnation pressure of the flow once the reflection has cleared (linear decay, as
///   in UFC's fictitious front-wall load);
/// - back face: nothing until the wave has crossed the part (`τ_x = size/U`), then the
///   incident pressure wrapping round, rising linearly to the full `P_so(τ)` at `t_c`;
/// - net: `A·(P_front − P_back)`, which is
///   `A·[E(1 − τ/t_c)⁺ + u(τ)·P_so(τ) + C_d·q(τ)]` with `u` the unbalanced share
///   (1 → 0 between `τ_x` and `t_c`). Drag is counted once: the net coefficient (front
///   ≈ 1 minus back ≈ −0.3) is booked on the front face. After `t_c` only drag remains,
///   which is why a small part in a long wave is pushed mostly by the wind, a large one
///   by the diffraction phase.
///
/// The load is never negative. Non-finite or negative sizes, areas and coefficients count
/// as zero.
pub fn part_force(
    b: &BlastAt,
    t_since_detonation: f64,
    area_m2: f64,
    size_m: f64,
    drag_coefficient: f64,
) -> f64 {
    if !(b.is_blast() && positive_finite(area_m2)) {
        return 0.0;
    }
    let s = b.phase(t_since_detonation);
    if !(0.0..1.0).contains(&s) {
        return 0.0;
    }
    let load = PartLoad::new(b, size_m, drag_coefficient);
    let excess = if s < load.s_clear {
        load.excess_pa * (1.0 - s / load.s_clear)
    } else {
        0.0
    };
    let p = b.incident_pa * (1.0 - s) * (-b.decay * s).exp();
    let q = b.dynamic_pa * (1.0 - s) * (1.0 - s) * (-2.0 * b.decay * s).exp();
    area_m2 * (excess + load.unbalanced(s) * p + load.cd * q)
}

/// Exact integral of [`part_force`] from `t0` to `t1` seconds after detonation,
/// newton-seconds: the momentum one simulation substep must give the part. Same
/// arguments and conventions as [`part_force`]; zero when `t1 ≤ t0`; infinite bounds
/// are allowed (`(-∞, ∞)` gives the total).
///
/// Every piece of the load is a polynomial of degree ≤ 2 in τ times an exponential, so
/// each is integrated in closed form between its breakpoints (arrival, wave crossed,
/// clearing, end of the positive phase); summing substeps gives the whole-interval value
/// to rounding.
pub fn part_impulse(
    b: &BlastAt,
    t0: f64,
    t1: f64,
    area_m2: f64,
    size_m: f64,
    drag_coefficient: f64,
) -> f64 {
    if !positive_finite(area_m2) {
        return 0.0;
    }
    let Some((s0, s1)) = b.phase_interval(t0, t1) else {
        return 0.0;
    };
    let load = PartLoad::new(b, size_m, drag_coefficient);
    let bd = b.decay;

    // Reflection excess E(1 − s/s_c) on [0, s_c].
    let (e0, e1) = (s0, s1.min(load.s_clear));
    let excess = if e1 > e0 {
        load.excess_pa * (e1 - e0) * (1.0 - 0.5 * (e0 + e1) / load.s_clear)
    } else {
        0.0
    };

    // Unbalanced incident pressure: (1 − s)e^(−bs) on [0, s_x] ...
    let (a0, a1) = (s0, s1.min(load.s_cross));
    let mut unbalanced = if a1 > a0 {
        poly_exp_integral([1.0 - a0, -1.0, 0.0], bd, a0, a1 - a0)
    } else {
        0.0
    };
    // ... and (1 − s)(s_c − s)/(s_c − s_x) e^(−bs) on [s_x, s_c].
    let (r0, r1) = (s0.max(load.s_cross), s1.min(load.s_clear));
    if r1 > r0 {
        let (c1, c2) = (1.0 - r0, load.s_clear - r0);
        let poly = [c1 * c2, -(c1 + c2), 1.0];
        unbalanced += poly_exp_integral(poly, bd, r0, r1 - r0) / (load.s_clear - load.s_cross);
    }

    let drag = load.cd * b.dynamic_pa * dynamic_shape_integral(bd, s0, s1);

    area_m2 * b.duration_s * (excess + b.incident_pa * unbalanced + drag)
}

#[cfg(test)]
mod tests;
