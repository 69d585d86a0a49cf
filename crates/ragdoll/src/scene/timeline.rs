//! The event tables of a scene (`[[blast]]`, `[[projectile]]`, `[[push]]`, `[[field]]`,
//! `[[pin]]`): each value checked against the bounds in [`crate::events`] with the line of
//! its key, then the whole event against its own `validate`, so the scene and the library
//! never disagree about what may be simulated.

use std::ops::Range;

use glam::Vec3;

use super::parse::{Ctx, span_of};
use super::raw::{RawBlast, RawField, RawPin, RawProjectile, RawPush, S};
use super::source::Src;
use super::{Event, SceneCharacter};
use crate::error::Result;
use crate::events::{
    Blast, Field, MAX_BLAST_SCALE, MAX_DRAG_RATE_PER_S, MAX_FORCE_N, MAX_MOMENTUM_NS,
    MAX_PIN_STIFFNESS_HZ, MAX_PROJECTILE_KG, MAX_PROJECTILE_SPEED_MPS, MAX_TNT_KG, MAX_WIND_MPS,
    Pin, Projectile, Push, check_point,
};
use crate::spec::{check_above, check_within, show};
use crate::world::{MAX_COORDINATE_M, MAX_GRAVITY_MPS2, MAX_SECONDS};

/// Most shots in one burst (`count`).
pub const MAX_BURST: u32 = 10_000;

/// Default projectile: a 9 mm pistol bullet, as `ragdoll shoot`.
const DEFAULT_PROJECTILE_KG: f32 = 0.008;
const DEFAULT_PROJECTILE_MPS: f32 = 360.0;
const DEFAULT_BURST_INTERVAL_S: f32 = 0.1;

/// An event for the world from a table at `span`, after its own check: anything the
/// key-by-key checks let through is still reported at the table.
fn event<T>(
    c: &Ctx,
    span: Range<usize>,
    event: T,
    character: Option<usize>,
    valid: impl Fn(&T) -> Result<()>,
) -> Result<Event<T>> {
    c.valid(&span, valid(&event))?;
    Ok(Event {
        event,
        character,
        line: c.src.line(span.start),
    })
}

pub(super) fn blasts(src: &Src, raw: &[S<RawBlast>]) -> Result<Vec<Event<Blast>>> {
    let mut out = Vec::with_capacity(raw.len());
    for (i, b) in raw.iter().enumerate() {
        let c = Ctx::new(src, format!("[[blast]] {}", i + 1));
        let r = b.get_ref();
        let blast = Blast {
            tnt_kg: c.checked(&r.tnt_kg, "tnt_kg", |w| {
                check_above(w, 0.0, MAX_TNT_KG, " kg of TNT")
            })?,
            position: c.point(&r.position, "position")?,
            time_s: c.time(&r.time_s, "time_s", 0.0)?,
            scale: c.opt_checked(&r.scale, "scale", 1.0, |s| {
                check_within(s, 0.0, MAX_BLAST_SCALE, "")
            })?,
        };
        out.push(event(&c, b.span(), blast, None, Blast::validate)?);
    }
    Ok(out)
}

/// Where a projectile flies: its `direction`, or from its origin to its `target`.
fn direction(c: &Ctx, p: &S<RawProjectile>, origin: Vec3) -> Result<Vec3> {
    let r = p.get_ref();
    match (&r.direction, &r.target) {
        (Some(d), None) => {
            let d3 = c.vec3(d, "direction")?;
            if !(d3.length() > 1e-6 && d3.length().is_finite()) {
                return Err(c.err(&d.span(), "direction", "must not be zero"));
            }
            Ok(d3)
        }
        (None, Some(t)) => {
            let d3 = c.point(t, "target")? - origin;
            if d3.length() <= 1e-6 {
                return Err(c.err(&t.span(), "target", "must differ from origin"));
            }
            Ok(d3)
        }
        (Some(_), Some(t)) => Err(c.err(
            &t.span(),
            "target",
            "give either direction or target, not both",
        )),
        (None, None) => Err(c.err(
            &p.span(),
            "direction",
            "missing: give a direction or a target point",
        )),
    }
}

/// Every projectile table, a burst expanded into its shots; at most `budget` shots in all
/// (what the scene's other events leave of [`super::MAX_EVENTS`]), refused before they are
/// made.
pub(super) fn projectiles(
    src: &Src,
    raw: &[S<RawProjectile>],
    budget: usize,
) -> Result<Vec<Event<Projectile>>> {
    let mut out = Vec::new();
    for (i, p) in raw.iter().enumerate() {
        let c = Ctx::new(src, format!("[[projectile]] {}", i + 1));
        let r = p.get_ref();
        let origin = c.point(&r.origin, "origin")?;
        let direction = direction(&c, p, origin)?;
        let mass_kg = c.opt_checked(&r.mass_kg, "mass_kg", DEFAULT_PROJECTILE_KG, |m| {
            check_above(m, 0.0, MAX_PROJECTILE_KG, " kg")
        })?;
        let speed_mps = c.opt_checked(&r.speed_mps, "speed_mps", DEFAULT_PROJECTILE_MPS, |v| {
            check_within(v, 0.0, MAX_PROJECTILE_SPEED_MPS, " m/s")
        })?;
        if mass_kg * speed_mps > MAX_MOMENTUM_NS {
            let (key, span) = match (&r.speed_mps, &r.mass_kg) {
                (Some(v), _) => ("speed_mps", v.span()),
                (None, Some(m)) => ("mass_kg", m.span()),
                (None, None) => ("speed_mps", p.span()),
            };
            return Err(c.err(
                &span,
                key,
                format!(
                    "the momentum mass_kg × speed_mps must be at most {} N·s, not {}",
                    show(MAX_MOMENTUM_NS),
                    show(mass_kg * speed_mps)
                ),
            ));
        }
        let time_s = c.time(&r.time_s, "time_s", 0.0)?;
        let count = match &r.count {
            Some(n) if !(1..=MAX_BURST).contains(n.get_ref()) => {
                return Err(c.err(
                    &n.span(),
                    "count",
                    format!("must be between 1 and {MAX_BURST}, not {}", n.get_ref()),
                ));
            }
            Some(n) => *n.get_ref(),
            None => 1,
        };
        if out.len() + count as usize > budget {
            let span = r.count.as_ref().map_or(p.span(), S::span);
            return Err(c.err(
                &span,
                "count",
                format!(
                    "the scene's events, counting each shot of a burst, would number {}, more \
                     than the {} a scene may hold",
                    out.len() + count as usize + (super::MAX_EVENTS - budget),
                    super::MAX_EVENTS
                ),
            ));
        }
        let interval = c.time(&r.interval_s, "interval_s", DEFAULT_BURST_INTERVAL_S)?;
        let last = time_s + (count - 1) as f32 * interval;
        if last > MAX_SECONDS {
            let (key, span) = match (&r.interval_s, &r.count) {
                (Some(t), _) => ("interval_s", t.span()),
                (None, Some(n)) => ("count", n.span()),
                (None, None) => ("time_s", p.span()),
            };
            return Err(c.err(
                &span,
                key,
                format!(
                    "the burst's last shot would be at {} s, after the {} s a run may last",
                    show(last),
                    show(MAX_SECONDS)
                ),
            ));
        }
        for k in 0..count {
            let shot = Projectile {
                origin,
                direction,
                mass_kg,
                speed_mps,
                time_s: time_s + k as f32 * interval,
            };
            out.push(event(&c, p.span(), shot, None, Projectile::validate)?);
        }
    }
    Ok(out)
}

pub(super) fn pushes(
    src: &Src,
    raw: &[S<RawPush>],
    characters: &[SceneCharacter],
) -> Result<Vec<Event<Push>>> {
    let mut out = Vec::with_capacity(raw.len());
    for (i, p) in raw.iter().enumerate() {
        let c = Ctx::new(src, format!("[[push]] {}", i + 1));
        let r = p.get_ref();
        let who = pick_character(&c, &r.character, characters, p.span())?;
        let target = check_target(&c, &r.target, &characters[who])?;
        let push = match (&r.impulse_ns, &r.force_n) {
            (Some(j), None) => {
                let why = "applies to a force; an impulse takes time_s";
                c.refuse("start_s", span_of(&r.start_s), why)?;
                c.refuse("end_s", span_of(&r.end_s), why)?;
                Push::Impulse {
                    target,
                    impulse_ns: c.vector(j, "impulse_ns", MAX_MOMENTUM_NS, " N·s")?,
                    time_s: c.time(&r.time_s, "time_s", 0.0)?,
                }
            }
            (None, Some(f)) => {
                c.refuse(
                    "time_s",
                    span_of(&r.time_s),
                    "applies to an impulse; a force takes start_s and end_s",
                )?;
                let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
                Push::Force {
                    target,
                    force_n: c.vector(f, "force_n", MAX_FORCE_N, " N")?,
                    start_s,
                    end_s,
                }
            }
            (Some(_), Some(f)) => {
                return Err(c.err(
                    &f.span(),
                    "force_n",
                    "give either impulse_ns or force_n, not both",
                ));
            }
            (None, None) => {
                return Err(c.err(
                    &p.span(),
                    "impulse_ns",
                    "missing: give an impulse_ns (N·s) or a force_n (N)",
                ));
            }
        };
        out.push(event(&c, p.span(), push, Some(who), Push::validate)?);
    }
    Ok(out)
}

pub(super) fn fields(src: &Src, raw: &[S<RawField>]) -> Result<Vec<Event<Field>>> {
    let mut out = Vec::with_capacity(raw.len());
    for (i, f) in raw.iter().enumerate() {
        let c = Ctx::new(src, format!("[[field]] {}", i + 1));
        let field = field(&c, f.get_ref())?;
        out.push(event(&c, f.span(), field, None, Field::validate)?);
    }
    Ok(out)
}

/// Which keys each kind of field takes, checked against those given.
fn field_keys(c: &Ctx, r: &RawField) -> Result<()> {
    let kind = r.kind.get_ref().as_str();
    let given: [(&str, Option<Range<usize>>); 8] = [
        ("keys", span_of(&r.keys)),
        ("center", span_of(&r.center)),
        ("strength_mps2", span_of(&r.strength_mps2)),
        ("radius_m", span_of(&r.radius_m)),
        ("rate_per_s", span_of(&r.rate_per_s)),
        ("velocity_mps", span_of(&r.velocity_mps)),
        ("start_s", span_of(&r.start_s)),
        ("end_s", span_of(&r.end_s)),
    ];
    let takes: &[&str] = match kind {
        "gravity" => &["keys"],
        "radial" => &["center", "strength_mps2", "radius_m", "start_s", "end_s"],
        "drag" => &["rate_per_s", "start_s", "end_s"],
        "wind" => &["velocity_mps", "start_s", "end_s"],
        _ => {
            return Err(c.err(
                &r.kind.span(),
                "kind",
                format!(
                    "\"{kind}\" is not a field; use \"gravity\", \"radial\", \"drag\" or \"wind\""
                ),
            ));
        }
    };
    for (key, span) in &given {
        if !takes.contains(key) {
            c.refuse(
                key,
                span.clone(),
                &format!("does not apply to a {kind} field"),
            )?;
        } else if span.is_none() && !matches!(*key, "start_s" | "end_s") {
            return Err(c.err(
                &r.kind.span(),
                key,
                format!("missing: a {kind} field needs it"),
            ));
        }
    }
    Ok(())
}

fn field(c: &Ctx, r: &RawField) -> Result<Field> {
    field_keys(c, r)?;
    let req = |v: &Option<S<f32>>| v.clone().expect("checked by field_keys");
    let req3 = |v: &Option<S<[f32; 3]>>| v.clone().expect("checked by field_keys");
    Ok(match r.kind.get_ref().as_str() {
        "gravity" => {
            let keys = r.keys.as_ref().expect("checked by field_keys");
            let values: Vec<(f32, Vec3)> = keys
                .get_ref()
                .iter()
                .map(|k| (k.time_s, Vec3::from_array(k.gravity)))
                .collect();
            c.keys(&keys.span(), &values, "gravity", |g| {
                crate::events::check_magnitude(g, MAX_GRAVITY_MPS2, " m/s²")
            })?;
            Field::Gravity { keys: values }
        }
        "radial" => {
            let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
            Field::Radial {
                center: c.point(&req3(&r.center), "center")?,
                strength_mps2: c.checked(&req(&r.strength_mps2), "strength_mps2", |a| {
                    check_within(a, -MAX_GRAVITY_MPS2, MAX_GRAVITY_MPS2, " m/s²")
                })?,
                radius_m: c.checked(&req(&r.radius_m), "radius_m", |x| {
                    check_above(x, 0.0, 2.0 * MAX_COORDINATE_M, " m")
                })?,
                start_s,
                end_s,
            }
        }
        "drag" => {
            let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
            Field::Drag {
                rate_per_s: c.checked(&req(&r.rate_per_s), "rate_per_s", |x| {
                    check_within(x, 0.0, MAX_DRAG_RATE_PER_S, " per second")
                })?,
                start_s,
                end_s,
            }
        }
        _ => {
            let (start_s, end_s) = c.window(&r.start_s, &r.end_s)?;
            Field::Wind {
                velocity_mps: c.vector(
                    &req3(&r.velocity_mps),
                    "velocity_mps",
                    MAX_WIND_MPS,
                    " m/s",
                )?,
                start_s,
                end_s,
            }
        }
    })
}

/// Where a pin holds its part: one `position`, or a path of `keys`.
fn pin_keys(c: &Ctx, p: &S<RawPin>) -> Result<Vec<(f32, Vec3)>> {
    let r = p.get_ref();
    match (&r.position, &r.keys) {
        (Some(pos), None) => Ok(vec![(0.0, c.point(pos, "position")?)]),
        (None, Some(keys)) => {
            let values: Vec<(f32, Vec3)> = keys
                .get_ref()
                .iter()
                .map(|k| (k.time_s, Vec3::from_array(k.position)))
                .collect();
            c.keys(&keys.span(), &values, "position", check_point)?;
            Ok(values)
        }
        (Some(_), Some(k)) => {
            Err(c.err(&k.span(), "keys", "give either position or keys, not both"))
        }
        (None, None) => Err(c.err(
            &p.span(),
            "position",
            "missing: give a position to hold or keys to drag along",
        )),
    }
}

pub(super) fn pins(
    src: &Src,
    raw: &[S<RawPin>],
    characters: &[SceneCharacter],
) -> Result<Vec<Event<Pin>>> {
    let mut out = Vec::with_capacity(raw.len());
    for (i, p) in raw.iter().enumerate() {
        let c = Ctx::new(src, format!("[[pin]] {}", i + 1));
        let r = p.get_ref();
        let who = pick_character(&c, &r.character, characters, p.span())?;
        let target = check_target(&c, &r.target, &characters[who])?;
        let keys = pin_keys(&c, p)?;
        let stiffness_hz = match &r.stiffness_hz {
            Some(k) => Some(c.checked(k, "stiffness_hz", |k| {
                check_above(k, 0.0, MAX_PIN_STIFFNESS_HZ, " Hz")
                    .map_err(|m| format!("{m} (leave it out for a hard pin)"))
            })?),
            None => {
                c.refuse(
                    "damping_ratio",
                    span_of(&r.damping_ratio),
                    "applies to a soft pin: give stiffness_hz too",
                )?;
                None
            }
        };
        let release_s = match &r.release_s {
            Some(t) => Some(c.checked(t, "release_s", crate::events::check_time)?),
            None => None,
        };
        let pin = Pin {
            target,
            keys,
            stiffness_hz,
            damping_ratio: r.damping_ratio.as_ref().map_or(1.0, |d| *d.get_ref()),
            release_s,
        };
        // The damping's bound depends on the stiffness: Pin::validate says which.
        if let Some(d) = &r.damping_ratio {
            c.valid(&d.span(), pin.validate())?;
        }
        out.push(event(&c, p.span(), pin, Some(who), Pin::validate)?);
    }
    Ok(out)
}

/// The character an event names, or the only one.
fn pick_character(
    c: &Ctx,
    name: &Option<S<String>>,
    characters: &[SceneCharacter],
    table: Range<usize>,
) -> Result<usize> {
    let names = || list(characters.iter().map(|c| c.name.as_str()));
    match name {
        Some(n) => characters
            .iter()
            .position(|x| x.name == *n.get_ref())
            .ok_or_else(|| {
                c.err(
                    &n.span(),
                    "character",
                    format!(
                        "no character is named \"{}\" (the scene has: {})",
                        n.get_ref(),
                        names()
                    ),
                )
            }),
        None if characters.len() == 1 => Ok(0),
        None => Err(c.err(
            &table,
            "character",
            format!("missing: the scene has several characters ({})", names()),
        )),
    }
}

/// A body or joint of the character, checked here so a typo fails at load time.
fn check_target(c: &Ctx, target: &S<String>, who: &SceneCharacter) -> Result<String> {
    let t = target.get_ref();
    if who.spec.body_index(t).is_some() || who.character.skeleton.find(t).is_some() {
        return Ok(t.clone());
    }
    Err(c.err(
        &target.span(),
        "target",
        format!(
            "{} has no body or joint named \"{t}\" (its bodies: {})",
            who.name,
            list(who.spec.bodies.iter().map(|b| b.name.as_str()))
        ),
    ))
}

/// Names for a message: the first few, then how many more.
fn list<'a>(names: impl ExactSizeIterator<Item = &'a str>) -> String {
    const SHOWN: usize = 20;
    let n = names.len();
    let mut out: Vec<&str> = names.take(SHOWN).collect();
    let more = format!("and {} more", n.saturating_sub(SHOWN));
    if n > SHOWN {
        out.push(&more);
    }
    out.join(", ")
}
