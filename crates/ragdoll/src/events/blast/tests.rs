use super::kingery::*;
use super::*;

const ALL_TABLES: [(&str, &[KbRange]); 7] = [
    ("t_a", &KB_ARRIVAL),
    ("P_so", &KB_INCIDENT),
    ("P_r", &KB_REFLECTED),
    ("t_d", &KB_DURATION),
    ("i_s", &KB_INCIDENT_IMPULSE),
    ("i_r", &KB_REFLECTED_IMPULSE),
    ("U", &KB_SHOCK_SPEED),
];

/// Impulse of a unit-peak, unit-duration Friedlander pulse with decay `b`:
/// `∫₀¹ (1 − s) e^(−b·s) ds = 1/b − (1 − e^(−b))/b²`, computed as `φ₀(b) − φ₁(b)` which
/// stays accurate as `b → 0` (limit 1/2).
fn friedlander_shape_impulse(b: f64) -> f64 {
    let [f0, f1, _] = phi012(b);
    f0 - f1
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

fn assert_rel(name: &str, got: f64, want: f64, tol: f64) {
    let e = rel(got, want);
    println!(
        "{name}: got {got:.6} want {want:.6} ({:+.3} %)",
        100.0 * (got - want) / want
    );
    assert!(
        e <= tol,
        "{name}: got {got}, want {want} (rel error {e:.4} > {tol})"
    );
}

/// All quantities of one BlastAt as a list, for generic checks.
fn fields(b: &BlastAt) -> [(&'static str, f64); 9] {
    [
        ("t_a", b.arrival_s),
        ("t_d", b.duration_s),
        ("P_so", b.incident_pa),
        ("P_r", b.reflected_pa),
        ("i_s", b.incident_impulse_pa_s),
        ("i_r", b.reflected_impulse_pa_s),
        ("U", b.shock_speed_m_s),
        ("q", b.dynamic_pa),
        ("b", b.decay),
    ]
}

fn log_grid(lo: f64, hi: f64, n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |k| (lo.ln() + (hi / lo).ln() * k as f64 / (n - 1) as f64).exp())
}

/// Composite Simpson's rule with `n` (even) panels.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    // Endpoints a hair inside, so that a jump at a breakpoint takes the value of
    // this piece's side.
    let eps = (b - a) * 1e-12;
    let mut sum = f(a + eps) + f(b - eps);
    for k in 1..n {
        sum += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

/// Simpson over `[a, b]` split at the given breakpoints (so that each piece is smooth).
fn simpson_split(f: impl Fn(f64) -> f64, a: f64, b: f64, breaks: &[f64], n: usize) -> f64 {
    let mut pts = vec![a, b];
    pts.extend(breaks.iter().copied().filter(|&x| x > a && x < b));
    pts.sort_by(f64::total_cmp);
    pts.windows(2).map(|w| simpson(&f, w[0], w[1], n)).sum()
}

#[test]
fn blast_check_values_10000kg_at_500m() {
    let b = surface_burst(10_000.0, 500.0);
    assert_rel("t_a ms", b.arrival_s * 1e3, 1276.17, 0.01);
    assert_rel("P_so kPa", b.incident_pa * 1e-3, 5.055, 0.01);
    assert_rel("P_r kPa", b.reflected_pa * 1e-3, 10.245, 0.01);
    assert_rel("t_d ms", b.duration_s * 1e3, 133.23, 0.01);
    assert_rel("i_s kPa·ms", b.incident_impulse_pa_s, 295.88, 0.01);
}

#[test]
fn blast_check_values_1kg_at_z5() {
    let b = surface_burst(1.0, 5.0);
    assert_rel("t_a ms", b.arrival_s * 1e3, 8.24, 0.01);
    assert_rel("P_so kPa", b.incident_pa * 1e-3, 43.2, 0.01);
    assert_rel("P_r kPa", b.reflected_pa * 1e-3, 100.9, 0.01);
    assert_rel("t_d ms", b.duration_s * 1e3, 3.79, 0.01);
    assert_rel("i_s kPa·ms", b.incident_impulse_pa_s, 59.3, 0.01);
    assert_rel("U m/s", b.shock_speed_m_s, 398.0, 0.01);
}

#[test]
fn blast_check_values_10kg_at_10m() {
    let b = surface_burst(10.0, 10.0);
    assert_rel("t_a ms", b.arrival_s * 1e3, 15.8, 0.01);
    assert_rel("P_so kPa", b.incident_pa * 1e-3, 49.0, 0.01);
    assert_rel("t_d ms", b.duration_s * 1e3, 7.9, 0.01);
    assert_rel("i_s kPa·ms", b.incident_impulse_pa_s, 137.0, 0.01);
}

#[test]
fn blast_friedlander_decay_reproduces_incident_impulse() {
    let mut worst = 0.0_f64;
    for w in log_grid(1e-3, 1e6, 19) {
        for r in log_grid(0.01, 1e4, 61) {
            let b = surface_burst(w, r);
            let full = b.incident_pa
                * b.duration_s
                * (1.0 / b.decay - (1.0 - (-b.decay).exp()) / (b.decay * b.decay));
            let closed = b.overpressure_impulse_pa_s(f64::NEG_INFINITY, f64::INFINITY);
            worst = worst.max(rel(full, b.incident_impulse_pa_s));
            worst = worst.max(rel(closed, b.incident_impulse_pa_s));
            assert!(
                b.decay >= MIN_DECAY && b.decay < 20.0,
                "b = {} at W {w} R {r}",
                b.decay
            );
        }
    }
    println!("worst relative impulse error {worst:.2e}");
    assert!(worst < 0.005);
    // The solver on its own, over the whole reachable range.
    for k in 1..500 {
        let ratio = 0.5 * k as f64 / 500.0;
        let b = solve_decay(ratio);
        assert!(
            rel(friedlander_shape_impulse(b), ratio) < 1e-13,
            "ratio {ratio}: b {b}"
        );
    }
    // The guard: a ratio a Friedlander pulse cannot reach gets the floor.
    assert_eq!(solve_decay(0.5), MIN_DECAY);
    assert_eq!(solve_decay(0.7), MIN_DECAY);
    assert!(solve_decay(0.0).is_finite());
    assert!((friedlander_shape_impulse(0.0) - 0.5).abs() < 1e-15);
}

#[test]
fn blast_ideal_gas_relations_match_fits_beyond_z2() {
    let p0 = AMBIENT_PRESSURE_PA;
    let (mut worst_u, mut worst_pr) = ((0.0_f64, 0.0), (0.0_f64, 0.0));
    for z in log_grid(2.0, 40.0, 2000) {
        let b = surface_burst(1.0, z);
        let u = ideal_shock_speed(b.incident_pa, p0, SOUND_SPEED_M_S);
        let pr = b.incident_pa * ideal_reflection_ratio(b.incident_pa, p0);
        let (eu, epr) = (rel(b.shock_speed_m_s, u), rel(b.reflected_pa, pr));
        if eu > worst_u.0 {
            worst_u = (eu, z);
        }
        if epr > worst_pr.0 {
            worst_pr = (epr, z);
        }
    }
    println!("U: worst {:.3} % at Z {:.2}", 100.0 * worst_u.0, worst_u.1);
    println!(
        "P_r: worst {:.3} % at Z {:.2}",
        100.0 * worst_pr.0,
        worst_pr.1
    );
    // U within 0.6 %; P_r within 0.8 % except just above Z = 23.8, where the P_so
    // fit steps up by 0.70 % and the ideal P_r with it (1.5 %).
    assert!(worst_u.0 < 0.01 && worst_pr.0 < 0.02);
    // And the continuations beyond Z = 40 tend to the acoustic limits.
    let far = surface_burst(1.0, 5000.0);
    assert!(rel(far.shock_speed_m_s, SOUND_SPEED_M_S) < 0.001);
    assert!(rel(far.reflected_pa / far.incident_pa, 2.0) < 0.01);
}

#[test]
fn blast_fit_range_boundaries_jump_only_by_fit_mismatch() {
    let mut worst = (0.0_f64, "", 0.0);
    for (name, ranges) in ALL_TABLES {
        for pair in ranges.windows(2) {
            let z = pair[0].z_max;
            assert_eq!(z, pair[1].z_min, "{name}: ranges must be contiguous");
            let (below, above) = (kb_eval(&pair[0], z), kb_eval(&pair[1], z));
            let jump = rel(above, below);
            println!(
                "{name} at Z = {z}: {below:.5} | {above:.5} ({:+.3} %)",
                100.0 * (above / below - 1.0)
            );
            if jump > worst.0 {
                worst = (jump, name, z);
            }
            // The public curves jump by the fits' mismatch there, no more. The decay
            // coefficient b is derived from i_s / (P_so·t_d) and amplifies small
            // steps in its inputs (dr/db is small near the triangle), so it is
            // only reported.
            let lo = fields(&surface_burst(1.0, z * (1.0 - 1e-9)));
            let hi = fields(&surface_burst(1.0, z * (1.0 + 1e-9)));
            for ((field, a), (_, b)) in lo.into_iter().zip(hi) {
                let j = rel(b, a);
                if field == "b" {
                    println!(
                        "  decay b: {a:.4} | {b:.4} ({:+.2} %)",
                        100.0 * (b / a - 1.0)
                    );
                } else {
                    assert!(j < 0.025, "{field} at {name} boundary Z = {z}: jump {j}");
                }
            }
        }
    }
    println!(
        "worst jump: {:.3} % ({} at Z = {})",
        100.0 * worst.0,
        worst.1,
        worst.2
    );
    assert!(worst.0 < 0.025);
}

#[test]
fn blast_clamps_and_continuations_are_continuous() {
    for z in [0.06, 0.2, 40.0, 158.7, 198.5] {
        let lo = surface_burst(1.0, z * (1.0 - 1e-9));
        let hi = surface_burst(1.0, z * (1.0 + 1e-9));
        for ((name, a), (_, b)) in fields(&lo).into_iter().zip(fields(&hi)) {
            assert!(rel(b, a) < 1e-6, "{name} jumps at Z = {z}: {a} -> {b}");
        }
    }
    // Below the lowest ranges pressures are held, the arrival time goes to zero.
    let at0 = surface_burst(1.0, 0.0);
    let at_edge = surface_burst(1.0, 0.06);
    assert_eq!(at0.arrival_s, 0.0);
    assert_eq!(at0.reflected_pa, at_edge.reflected_pa);
    assert_eq!(
        surface_burst(1.0, 0.1).incident_pa,
        surface_burst(1.0, 0.2).incident_pa
    );
}

#[test]
fn blast_monotonic_trends() {
    // Whole span, including clamps and continuations. P_so never rises except at
    // the fits' own +0.70 % step at Z = 23.8; t_a always rises; i_s falls from
    // Z = 0.96 on (below that the fit has a real dip, minimum near Z = 0.5).
    let zs: Vec<f64> = log_grid(1e-3, 1e4, 20_000).collect();
    let bs: Vec<BlastAt> = zs.iter().map(|&z| surface_burst(1.0, z)).collect();
    for k in 1..zs.len() {
        let (z0, z1) = (zs[k - 1], zs[k]);
        let (b0, b1) = (&bs[k - 1], &bs[k]);
        let step_allowed = if z0 < 23.8 && z1 >= 23.8 {
            0.0071
        } else {
            1e-12
        };
        assert!(
            b1.incident_pa <= b0.incident_pa * (1.0 + step_allowed),
            "P_so at {z1}"
        );
        assert!(b1.arrival_s > b0.arrival_s || z0 == 0.0, "t_a at {z1}");
        if z0 >= 0.96 {
            assert!(
                b1.incident_impulse_pa_s < b0.incident_impulse_pa_s,
                "i_s at {z1}"
            );
        }
        // P_r: the fits step up by +0.08 % at Z = 2.
        let step_allowed = if z0 < 2.0 && z1 >= 2.0 { 0.0009 } else { 0.0 };
        if z0 >= 0.06 {
            assert!(
                b1.reflected_pa < b0.reflected_pa * (1.0 + step_allowed),
                "P_r at {z1}"
            );
        }
    }
}

#[test]
fn blast_air_burst_is_weaker_and_smooth_in_height() {
    let w = 10.0;
    let r = 10.0;
    let surface = surface_burst(w, r);
    let air = air_burst(w, r);
    assert!(air.incident_pa < 0.9 * surface.incident_pa);
    assert!(air.incident_impulse_pa_s < surface.incident_impulse_pa_s);
    assert!(air.arrival_s > surface.arrival_s);
    println!(
        "10 kg at 10 m: P_so surface {:.1} kPa, air {:.1} kPa",
        surface.incident_pa * 1e-3,
        air.incident_pa * 1e-3
    );

    // Same standoff, charge raised from below the ground to high up: the
    // target stays level with the charge so only the height changes.
    let at = |h: f64| {
        let charge = DVec3::new(1.0, h, 1.0);
        blast_at(w, charge, charge + DVec3::new(r, 0.0, 0.0), 0.0)
    };
    assert_eq!(at(-1.0), surface);
    assert_eq!(at(0.0), surface);
    assert!(rel(at(0.1 * w.cbrt()).incident_pa, surface.incident_pa) < 1e-12);
    assert!(rel(at(1.0 * w.cbrt()).incident_pa, air.incident_pa) < 1e-12);
    assert!(rel(at(50.0).incident_pa, air.incident_pa) < 1e-12);
    let mut prev = at(0.0).incident_pa;
    let mut worst_step = 0.0_f64;
    for h in log_grid(0.01, 10.0, 2000) {
        let p = at(h).incident_pa;
        assert!(p <= prev, "P_so must not rise with height (h = {h})");
        worst_step = worst_step.max(rel(p, prev));
        prev = p;
    }
    println!(
        "largest step over 2000 heights: {:.4} %",
        100.0 * worst_step
    );
    assert!(worst_step < 0.002);
}

#[test]
fn blast_history_integrals_match_quadrature() {
    for (w, r) in [
        (10.0, 10.0),
        (1.0, 0.3),
        (1000.0, 40.0),
        (0.01, 30.0),
        (5.0, 2000.0),
    ] {
        let b = surface_burst(w, r);
        let (ta, td) = (b.arrival_s, b.duration_s);
        let breaks = [ta, ta + td];
        // Whole phase, and intervals straddling arrival and the end.
        for (t0, t1) in [
            (0.0, ta + 2.0 * td),
            (ta - 0.1 * td, ta + 0.3 * td),
            (ta + 0.25 * td, ta + 0.26 * td),
            (ta + 0.9 * td, ta + 1.5 * td),
        ] {
            let n = 4000;
            let qp = simpson_split(|t| b.overpressure_pa(t), t0, t1, &breaks, n);
            let qd = simpson_split(|t| b.dynamic_pressure_pa(t), t0, t1, &breaks, n);
            let cp = b.overpressure_impulse_pa_s(t0, t1);
            let cd = b.dynamic_impulse_pa_s(t0, t1);
            assert!(
                rel(cp, qp) < 1e-9,
                "p W {w} R {r} [{t0},{t1}]: {cp} vs {qp}"
            );
            assert!(
                rel(cd, qd) < 1e-9,
                "q W {w} R {r} [{t0},{t1}]: {cd} vs {qd}"
            );
        }
        // Substeps of 1/960 s and much smaller ones sum to the whole.
        for dt in [1.0 / 960.0, td / 997.0] {
            let (mut sp, mut sq, mut t) = (0.0, 0.0, 0.0);
            while t < ta + td + dt {
                sp += b.overpressure_impulse_pa_s(t, t + dt);
                sq += b.dynamic_impulse_pa_s(t, t + dt);
                t += dt;
            }
            assert!(rel(sp, b.incident_impulse_pa_s) < 1e-9);
            assert!(rel(sq, b.dynamic_impulse_pa_s(0.0, f64::INFINITY)) < 1e-9);
        }
    }
    assert_eq!(
        surface_burst(1.0, 5.0).overpressure_impulse_pa_s(1.0, 0.5),
        0.0
    );
}

#[test]
fn blast_part_impulse_matches_quadrature_of_part_force() {
    for (w, r, area, size, cd) in [
        (10.0, 10.0, 0.5, 0.3, 1.2),
        (10.0, 3.0, 0.05, 0.1, 1.0),
        (1.0, 0.5, 0.02, 0.08, 1.3),
        (1000.0, 100.0, 0.5, 0.3, 1.2),
        (0.1, 20.0, 0.5, 2.0, 1.2), // clearing longer than the positive phase
        (10.0, 10.0, 0.5, 0.0, 1.2), // no size: drag only
    ] {
        let b = surface_burst(w, r);
        let u = b.shock_speed_m_s;
        let ta = b.arrival_s;
        let breaks = [ta, ta + size / u, ta + 3.0 * size / u, ta + b.duration_s];
        let f = |t: f64| part_force(&b, t, area, size, cd);
        let whole = part_impulse(&b, f64::NEG_INFINITY, f64::INFINITY, area, size, cd);
        let quad = simpson_split(f, 0.0, ta + 2.0 * b.duration_s, &breaks, 4000);
        assert!(rel(whole, quad) < 1e-8, "W {w} R {r}: {whole} vs {quad}");
        let (mut sum, mut t) = (0.0, 0.0);
        let dt = 1.0 / 960.0;
        while t < ta + b.duration_s + dt {
            let piece = part_impulse(&b, t, t + dt, area, size, cd);
            let piece_quad = simpson_split(f, t, t + dt, &breaks, 400);
            assert!((piece - piece_quad).abs() <= 1e-8 * whole, "substep at {t}");
            assert!(piece >= 0.0);
            sum += piece;
            t += dt;
        }
        assert!(rel(sum, whole) < 1e-10);
        // The front face feels exactly P_r at arrival.
        if size > 0.0 {
            let f0 = part_force(&b, ta + 1e-12 * b.duration_s, area, size, cd);
            assert!(rel(f0, area * b.reflected_pa) < 1e-6);
        }
    }
}

#[test]
fn blast_standing_adult_sanity() {
    let (area, size, cd) = (0.5, 0.3, 1.2);
    let total = |r: f64| part_impulse(&surface_burst(10.0, r), 0.0, 1.0, area, size, cd);
    let (j10, j3) = (total(10.0), total(3.0));
    println!(
        "10 kg TNT, standing adult: {j10:.1} N·s at 10 m, {j3:.1} N·s at 3 m (×{:.1})",
        j3 / j10
    );
    // Where it comes from: drag alone (a part of no size) and the peak values.
    for r in [10.0, 3.0] {
        let b = surface_burst(10.0, r);
        let drag = part_impulse(&b, 0.0, 1.0, area, 0.0, cd);
        println!(
            "  R {r} m: drag only {drag:.1} N·s; P_so {:.0} kPa, P_r {:.0} kPa, q {:.1} kPa, \
             t_d {:.2} ms, U {:.0} m/s, b {:.3}, A·i_s {:.1} N·s",
            b.incident_pa * 1e-3,
            b.reflected_pa * 1e-3,
            b.dynamic_pa * 1e-3,
            b.duration_s * 1e3,
            b.shock_speed_m_s,
            b.decay,
            area * b.incident_impulse_pa_s,
        );
    }
    // On the order of 50–100 N·s at 10 m (about 1 m/s for 75 kg). The
    // model gives ~70: ~32 from the reflection excess clearing over 3·0.3/U, ~29 from
    // the incident pressure before the back face is loaded, ~8 from drag.
    assert!((50.0..=100.0).contains(&j10), "{j10}");
    // "At 3 m it is thrown": several times more (≈ 10×, ≈ 9 m/s for 75 kg).
    assert!(j3 > 3.0 * j10, "{j3} vs {j10}");
}

#[test]
fn blast_no_nan_or_panic_anywhere() {
    let cases = [
        (1.0, DVec3::ZERO, DVec3::ZERO), // at the charge
        (10.0, DVec3::new(0.0, 1.0, 0.0), DVec3::new(0.0, 0.0, 0.0)), // equal x and z
        (10.0, DVec3::new(2.0, 1.5, 2.0), DVec3::new(2.0, 1.0, 2.0)),
        (10.0, DVec3::new(0.0, -3.0, 0.0), DVec3::new(5.0, 0.0, 0.0)), // below ground
        (1e-3, DVec3::ZERO, DVec3::new(1e4, 0.0, 0.0)),                // 1 g, 10 km
        (1e6, DVec3::ZERO, DVec3::new(1e4, 0.0, 0.0)),                 // kt at 10 km
        (1e6, DVec3::new(0.0, 5.0, 0.0), DVec3::ZERO),
        (1e-3, DVec3::new(0.0, 100.0, 0.0), DVec3::ZERO),
        (1e-300, DVec3::ZERO, DVec3::new(1e4, 0.0, 0.0)),
        (1e300, DVec3::ZERO, DVec3::new(1.0, 0.0, 0.0)),
    ];
    for (w, c, t) in cases {
        let b = blast_at(w, c, t, 0.0);
        for (name, v) in fields(&b) {
            assert!(
                v.is_finite() && v >= 0.0,
                "{name} = {v} for W {w} at {c} -> {t}"
            );
        }
        for k in 0..200 {
            let time = b.arrival_s + b.duration_s * (k as f64 / 100.0 - 0.5);
            for v in [
                b.overpressure_pa(time),
                b.dynamic_pressure_pa(time),
                part_force(&b, time, 0.1, 0.2, 1.2),
                part_impulse(&b, time, time + 1.0 / 960.0, 0.1, 0.2, 1.2),
                b.overpressure_impulse_pa_s(time, time + 1e-4),
            ] {
                assert!(v.is_finite() && v >= 0.0, "{v} for W {w}");
            }
        }
    }
    // Invalid input: no blast, everything zero.
    for w in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(surface_burst(w, 10.0), BlastAt::NONE);
        assert_eq!(blast_at(w, DVec3::ZERO, DVec3::X, 0.0), BlastAt::NONE);
    }
    assert_eq!(surface_burst(1.0, f64::NAN), BlastAt::NONE);
    assert_eq!(blast_at(1.0, DVec3::NAN, DVec3::X, 0.0), BlastAt::NONE);
    assert_eq!(part_force(&BlastAt::NONE, 0.0, 1.0, 1.0, 1.0), 0.0);
    assert_eq!(part_impulse(&BlastAt::NONE, 0.0, 1.0, 1.0, 1.0, 1.0), 0.0);
    let b = surface_burst(10.0, 10.0);
    assert_eq!(part_impulse(&b, f64::NAN, 1.0, 0.5, 0.3, 1.2), 0.0);
    assert_eq!(part_force(&b, b.arrival_s + 1e-4, f64::NAN, 0.3, 1.2), 0.0);
    // No size and no drag coefficient: nothing left to push.
    assert_eq!(
        part_force(&b, b.arrival_s + 1e-4, 0.5, f64::NAN, f64::NAN),
        0.0
    );
    assert!(part_force(&b, b.arrival_s + 1e-4, 0.5, f64::NAN, 1.2) > 0.0);
}

#[test]
fn blast_phase_alone_is_the_whole_blasts_to_the_bit() {
    // The world decides from `phase_at` alone whether a part is under the positive phase,
    // so it must agree with `blast_at` exactly: over the fits, their clamps and
    // continuations, surface and air bursts, and the inputs that give no blast.
    let charge = DVec3::new(0.3, 0.0, -1.0);
    let mut checked = 0;
    for tnt in [1e-3, 0.2, 1.0, 50.0, 2.0e4] {
        for height in [-1.0, 0.0, 0.4, 3.0, 40.0] {
            let c = charge + DVec3::Y * height;
            for r in log_grid(1e-4, 5e3, 400).chain([0.0]) {
                let target = c + DVec3::new(0.6, -0.8, 0.0) * r;
                let whole = blast_at(tnt, c, target, 0.0);
                let (arrival, duration) = phase_at(tnt, c, target, 0.0);
                assert_eq!(
                    arrival.to_bits(),
                    whole.arrival_s.to_bits(),
                    "t_a {tnt} kg, {r} m"
                );
                assert_eq!(
                    duration.to_bits(),
                    whole.duration_s.to_bits(),
                    "t_d {tnt} kg, {r} m"
                );
                checked += 1;
            }
        }
    }
    assert!(checked > 10_000);
    let nan = DVec3::new(f64::NAN, 0.0, 0.0);
    for (tnt, target) in [
        (0.0, DVec3::ONE),
        (-1.0, DVec3::ONE),
        (f64::NAN, DVec3::ONE),
        (1.0, nan),
    ] {
        let whole = blast_at(tnt, charge, target, 0.0);
        assert_eq!(
            phase_at(tnt, charge, target, 0.0),
            (whole.arrival_s, whole.duration_s)
        );
    }
}
