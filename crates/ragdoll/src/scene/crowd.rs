//! `[[crowd]]` tables: many characters from one description, placed on a grid or
//! scattered, each with its own facing, height, mass and sex drawn from a seeded generator,
//! so the same table gives the same crowd on every machine. A crowd becomes ordinary
//! `[[character]]` tables, checked and built as those are.

use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};

use super::parse::{Ctx, Src};
use super::raw::{Formation, RawCharacter, RawCrowd, S};
use crate::error::Result;
use crate::spec::check_within;

/// Closest spacing between neighbours of a crowd, metres: a person's footprint. Closer,
/// characters start inside each other (which the world refuses anyway, naming the two).
pub const MIN_CROWD_SPACING_M: f32 = 0.3;

/// Widest spacing, metres.
pub const MAX_CROWD_SPACING_M: f32 = 100.0;

/// Largest share by which heights and masses may vary either way: ±50 %.
pub const MAX_CROWD_SPREAD: f32 = 0.5;

/// Default spacing between neighbours, metres (issue 12's crowd: 2 m).
const DEFAULT_SPACING_M: f32 = 2.0;

/// Darts thrown per scattered character before it takes the best one seen: enough that a
/// crowd at the density scattering allows rarely needs the fallback.
const SCATTER_TRIES: usize = 30;

/// The characters the crowd tables stand for, in order, each with the index of its crowd
/// and carrying its table's span (errors in a member name the crowd and its line).
pub(super) fn expand(src: &Src, crowds: &[S<RawCrowd>]) -> Result<Vec<(usize, S<RawCharacter>)>> {
    let mut out = Vec::new();
    for (i, table) in crowds.iter().enumerate() {
        let c = Ctx::new(src, format!("[[crowd]] {}", i + 1));
        out.extend(members(&c, table, i)?.into_iter().map(|m| (i, m)));
    }
    Ok(out)
}

/// The characters of crowd `index` (from 0), named `{name}-{n}` from 1 (`name` defaults to
/// `crowd{index + 1}`, so two unnamed crowds do not clash).
fn members(c: &Ctx, table: &S<RawCrowd>, index: usize) -> Result<Vec<S<RawCharacter>>> {
    let r = table.get_ref();
    let span = table.span();
    let s = spread(c, table)?;
    let seed = r.seed.as_ref().map_or(0, |v| *v.get_ref());
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let formation = r
        .formation
        .as_ref()
        .map_or(Formation::Grid, |f| *f.get_ref());
    let spots = match formation {
        Formation::Grid => grid(s.count, s.spacing),
        Formation::Scatter => scatter(s.count, s.spacing, &mut rng),
    };
    let name = r
        .name
        .as_ref()
        .map_or(format!("crowd{}", index + 1), |n| n.get_ref().clone());
    let mut out = Vec::with_capacity(s.count);
    for (k, (x, z)) in spots.into_iter().enumerate() {
        let mut u = || unit(&mut rng);
        // Kept within a turn either way, as a character's facing must be.
        let turned = s.facing + s.facing_spread * (2.0 * u() - 1.0);
        let facing_deg = (turned + 180.0).rem_euclid(360.0) - 180.0;
        // A member's value carries the span of the crowd's key it comes from.
        let height = r.height.as_ref().map(|h| {
            at(
                &h.span(),
                *h.get_ref() * (1.0 + s.height_spread * (2.0 * u() - 1.0)),
            )
        });
        let mass_kg = r.mass_kg.as_ref().map(|m| {
            at(
                &m.span(),
                *m.get_ref() * (1.0 + s.mass_spread * (2.0 * u() - 1.0)),
            )
        });
        let female = u() < s.female_share;
        out.push(at(
            &span,
            RawCharacter {
                name: Some(at(&span, format!("{name}-{}", k + 1))),
                file: r.file.clone(),
                position: Some(at(
                    &span,
                    (s.center + glam::Vec3::new(x, 0.0, z)).to_array(),
                )),
                facing_deg: Some(at(&span, facing_deg)),
                mass_kg,
                female: Some(at(&span, female)),
                spec: None,
                activate: r.activate.clone(),
                powered: None,
                units: r.units.clone(),
                up: r.up.clone(),
                height,
                clip: r.clip.clone(),
                roles: None,
            },
        ));
    }
    Ok(out)
}

/// A crowd's checked numbers: how many, where, and how much they vary.
struct Spread {
    count: usize,
    spacing: f32,
    center: glam::Vec3,
    facing: f32,
    facing_spread: f32,
    height_spread: f32,
    mass_spread: f32,
    female_share: f32,
}

/// Checks a crowd table's numbers, each error naming its key and line.
fn spread(c: &Ctx, table: &S<RawCrowd>) -> Result<Spread> {
    let r = table.get_ref();
    let count = *r.count.get_ref() as usize;
    if count == 0 || count > super::MAX_CHARACTERS {
        let max = super::MAX_CHARACTERS;
        let message = format!("must be between 1 and {max} (a scene's characters), not {count}");
        return Err(c.err(&r.count.span(), "count", message));
    }
    let spacing = c.opt_checked(&r.spacing_m, "spacing_m", DEFAULT_SPACING_M, |x| {
        check_within(x, MIN_CROWD_SPACING_M, MAX_CROWD_SPACING_M, " m")
    })?;
    let center = match &r.center {
        Some(p) => c.point(p, "center")?,
        None => glam::Vec3::ZERO,
    };
    let facing = c.opt_checked(&r.facing_deg, "facing_deg", 0.0, |a| {
        check_within(a, -360.0, 360.0, " degrees")
    })?;
    let facing_spread = c.opt_checked(&r.facing_spread_deg, "facing_spread_deg", 0.0, |a| {
        check_within(a, 0.0, 180.0, " degrees")
    })?;
    let share = |v: &Option<S<f32>>, key: &str| {
        c.opt_checked(v, key, 0.0, |x| check_within(x, 0.0, MAX_CROWD_SPREAD, ""))
    };
    let height_spread = share(&r.height_spread, "height_spread")?;
    let mass_spread = share(&r.mass_spread, "mass_spread")?;
    for (amount, value, key, base) in [
        (height_spread, r.height.is_some(), "height_spread", "height"),
        (mass_spread, r.mass_kg.is_some(), "mass_spread", "mass_kg"),
    ] {
        if amount > 0.0 && !value {
            let message = format!("needs {base}, the value it varies about");
            return Err(c.err(&table.span(), key, message));
        }
    }
    let female_share = c.opt_checked(&r.female_share, "female_share", 0.0, |x| {
        check_within(x, 0.0, 1.0, "")
    })?;
    Ok(Spread {
        count,
        spacing,
        center,
        facing,
        facing_spread,
        height_spread,
        mass_spread,
        female_share,
    })
}

/// `v` marked as written at `span` (its crowd table).
fn at<T>(span: &std::ops::Range<usize>, v: T) -> S<T> {
    S::new(span.clone(), v)
}

/// A uniform number in [0, 1) from the generator's next 24 bits.
fn unit(rng: &mut ChaCha8Rng) -> f32 {
    (rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32
}

/// `count` spots `spacing` apart in rows and columns, as square as the count allows,
/// centred on the origin (x, z).
fn grid(count: usize, spacing: f32) -> Vec<(f32, f32)> {
    let cols = (count as f64).sqrt().ceil() as usize;
    let rows = count.div_ceil(cols);
    let mid = |n: usize| 0.5 * (n as f32 - 1.0);
    (0..count)
        .map(|k| {
            let (i, j) = (k % cols, k / cols);
            (
                (i as f32 - mid(cols)) * spacing,
                (j as f32 - mid(rows)) * spacing,
            )
        })
        .collect()
}

/// `count` spots at random in a square centred on the origin, each at least `spacing`
/// from those before it. The square starts with twice the area the spots would take on a
/// grid (dart throwing fills about half a plane before it runs out of room); where
/// [`SCATTER_TRIES`] darts find no place, it grows by 5 % and the darts fly again.
fn scatter(count: usize, spacing: f32, rng: &mut ChaCha8Rng) -> Vec<(f32, f32)> {
    let mut side = spacing * (2.0 * count as f32).sqrt();
    let mut spots: Vec<(f32, f32)> = Vec::with_capacity(count);
    while spots.len() < count {
        let free = (0..SCATTER_TRIES).find_map(|_| {
            let p = (side * (unit(rng) - 0.5), side * (unit(rng) - 0.5));
            let clear = spots
                .iter()
                .all(|q| (p.0 - q.0).hypot(p.1 - q.1) >= spacing);
            clear.then_some(p)
        });
        match free {
            Some(p) => spots.push(p),
            None => side *= 1.05,
        }
    }
    spots
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_grid_is_centred_and_spaced() {
        let g = grid(9, 2.0);
        assert_eq!(g[0], (-2.0, -2.0));
        assert_eq!(g[4], (0.0, 0.0));
        assert_eq!(g[8], (2.0, 2.0));
        let g = grid(5, 1.0);
        assert_eq!(g.len(), 5);
        assert_eq!(g[0], (-1.0, -0.5));
    }

    #[test]
    fn scattered_spots_keep_their_distance_and_repeat_with_the_seed() {
        let spots = |seed| scatter(200, 1.5, &mut ChaCha8Rng::seed_from_u64(seed));
        let a = spots(7);
        for (i, p) in a.iter().enumerate() {
            for q in &a[..i] {
                assert!((p.0 - q.0).hypot(p.1 - q.1) >= 1.5, "{p:?} {q:?}");
            }
        }
        assert_eq!(a, spots(7));
        assert_ne!(a, spots(8));
    }
}
