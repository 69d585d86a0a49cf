//! `[[crowd]]` tables: many characters from one description, placed on a grid or
//! scattered, each with its own facing, height, mass and sex (and, where asked, file and
//! clip offset) drawn from a seeded generator, so the same table gives the same crowd on
//! every machine. A crowd becomes ordinary `[[character]]` tables, checked and built as
//! those are.

use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};

use super::parse::Ctx;
use super::raw::{Formation, RawCharacter, RawCrowd, S};
use super::source::Src;
use crate::bounds::MAX_SECONDS;
use crate::error::Result;
use crate::spec::check_within;

/// Closest spacing between neighbours of a crowd, metres: a person's footprint. Closer,
/// characters start inside each other (which the world refuses anyway, naming the two).
pub const MIN_CROWD_SPACING_M: f32 = 0.3;

/// Widest spacing, metres.
pub const MAX_CROWD_SPACING_M: f32 = 100.0;

/// Largest share by which heights and masses may vary either way: ±50 %.
pub const MAX_CROWD_SPREAD: f32 = 0.5;

/// Most files one crowd may draw from.
pub const MAX_CROWD_FILES: usize = 64;

/// Default spacing between neighbours, metres (2 m).
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
    // Files and clip offsets come from a stream of their own, so that adding them to a
    // table leaves its members' facings, heights and masses as they were.
    let mut extra = ChaCha8Rng::seed_from_u64(seed);
    extra.set_stream(1);
    let mut out = Vec::with_capacity(s.count);
    for (k, (x, z)) in spots.into_iter().enumerate() {
        let file = match &s.files {
            Some((files, span)) => Some(at(span, pick(files, unit(&mut extra)).clone())),
            None => r.file.clone(),
        };
        let clip_offset_s = s
            .clip_offset
            .as_ref()
            .map(|(base, spread, span)| at(span, base + spread * unit(&mut extra)));
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
                file,
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
                clip_offset_s,
                roles: None,
                file_key: if s.files.is_some() { "files" } else { "file" },
            },
        ));
    }
    Ok(out)
}

/// The files a crowd draws from with their cumulative shares (the last is 1), and the
/// span of its `files` key.
type Draw = (Vec<(String, f32)>, std::ops::Range<usize>);

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
    /// The files to draw from; `None` for `file` (or the built-in humanoid).
    files: Option<Draw>,
    /// Clip offset: the least, how much more it may be, and the span of the key it is
    /// from; `None` when neither key is given.
    clip_offset: Option<(f32, f32, std::ops::Range<usize>)>,
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
        files: files(c, table)?,
        clip_offset: clip_offset(c, table)?,
    })
}

/// `files` and their `weights`, checked: cumulative shares in file order.
fn files(c: &Ctx, table: &S<RawCrowd>) -> Result<Option<Draw>> {
    let r = table.get_ref();
    let Some(files) = &r.files else {
        if let Some(w) = &r.weights {
            return Err(c.err(&w.span(), "weights", "needs files, the files it weighs"));
        }
        return Ok(None);
    };
    if r.file.is_some() {
        let message = "give either file (every member the same) or files, not both";
        return Err(c.err(&files.span(), "files", message));
    }
    let names = files.get_ref();
    if names.is_empty() || names.len() > MAX_CROWD_FILES {
        let message = format!(
            "must list 1 to {MAX_CROWD_FILES} files, not {}",
            names.len()
        );
        return Err(c.err(&files.span(), "files", message));
    }
    let weights = match &r.weights {
        Some(w) => {
            let ws = w.get_ref();
            if ws.len() != names.len() {
                let message = format!(
                    "must give one weight per file: {} files, {} weights",
                    names.len(),
                    ws.len()
                );
                return Err(c.err(&w.span(), "weights", message));
            }
            if let Some(bad) = ws.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
                let message = format!("must be finite and not negative, not {bad}");
                return Err(c.err(&w.span(), "weights", message));
            }
            if ws.iter().sum::<f32>() <= 0.0 {
                return Err(c.err(&w.span(), "weights", "must not all be 0"));
            }
            ws.clone()
        }
        None => vec![1.0; names.len()],
    };
    let total: f32 = weights.iter().sum();
    let mut sum = 0.0;
    let shares = names
        .iter()
        .zip(&weights)
        .map(|(n, w)| {
            sum += w / total;
            (n.clone(), sum)
        })
        .collect();
    Ok(Some((shares, files.span())))
}

/// `clip_offset_s` and `clip_offset_spread_s`, checked.
fn clip_offset(c: &Ctx, table: &S<RawCrowd>) -> Result<Option<(f32, f32, std::ops::Range<usize>)>> {
    let r = table.get_ref();
    let (base, spread) = (&r.clip_offset_s, &r.clip_offset_spread_s);
    let Some(span) = base.as_ref().or(spread.as_ref()).map(|v| v.span()) else {
        return Ok(None);
    };
    let first = c.time(base, "clip_offset_s", 0.0)?;
    let more = c.time(spread, "clip_offset_spread_s", 0.0)?;
    if first + more > MAX_SECONDS {
        let message = format!(
            "clip_offset_s + clip_offset_spread_s must be at most {MAX_SECONDS} s, not {}",
            first + more
        );
        return Err(c.err(&span, "clip_offset_spread_s", message));
    }
    Ok(Some((first, more, span)))
}

/// The file whose cumulative share first reaches `u` (in [0, 1)).
fn pick(files: &[(String, f32)], u: f32) -> &String {
    let k = files.iter().position(|(_, share)| u < *share);
    &files[k.unwrap_or(files.len() - 1)].0
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
