//! Preview pictures and GIFs of ragdoll results, drawn on the CPU: no GPU, no display, so
//! they work on CI and over SSH.
//!
//! What a picture shows: each character as its skinned mesh deformed by linear blend
//! skinning ([`ragdoll::skeleton::skinning`]), or, without a mesh, as the capsules and boxes
//! of its ragdoll; lit by a sun (Lambert plus a sky term); a ground with a one-metre grid
//! and soft shadows; blasts as a fireball at the charge from its detonation time and a
//! scorch mark after; shots as a tracer from muzzle to hit around their time; a frame
//! counter. The camera frames everything that happens over the whole run and stays put,
//! so the motion reads against a still ground.
//!
//! How: one z-buffer rasteriser (`raster.rs`) draws every triangle and line, so occlusion
//! is right whatever the order; the ground is ray-cast per pixel into the same z-buffer
//! (exact to the horizon, nothing to clip); shadows are the silhouettes projected along
//! the sunlight into a mask over the ground and blurred (`shadow.rs`); the picture is
//! drawn at twice the size and averaged down (anti-aliasing). GIFs share one palette and
//! store only what changed between frames (`encode.rs`).
//!
//! ```
//! use ragdoll::{skeleton, spec, world::{World, WorldSettings}};
//! use ragdoll_preview::{Preview, PreviewOptions};
//!
//! let character = skeleton::humanoid();
//! let spec = spec::build_spec(&character, &spec::BuildOptions::default()).unwrap();
//! let (mut world, _) = World::with_ragdoll(&character, &spec, &WorldSettings::default()).unwrap();
//! world.run(0.2);
//! let track = world.into_track();
//! let options = PreviewOptions { width: 160, height: 120, ..Default::default() };
//! let png = ragdoll_preview::png(&[(&character, &spec, &track)], &[], &options).unwrap();
//! assert_eq!(&png[1..4], b"PNG");
//! let mut preview = Preview::new(&[(&character, &spec, &track)], &[], &options).unwrap();
//! let image = preview.render(0).unwrap();
//! assert_eq!((image.width, image.height), (160, 120));
//! ```
#![deny(missing_docs)]

mod camera;
mod encode;
mod font;
mod raster;
mod shadow;

use std::borrow::Cow;
use std::path::Path;

use glam::{Mat4, Vec3};
use ragdoll::math::Transform;
use ragdoll::skeleton::{Character, SkinnedMesh, skinning};
use ragdoll::spec::RagdollSpec;
use ragdoll::track::Track;
use ragdoll::{Error, Result};

use camera::{Camera, NEAR};
use raster::Target;
use shadow::ShadowMask;

/// What to draw and how big.
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewOptions {
    /// Picture width, pixels (16 to 4096; 640 by default).
    pub width: u32,
    /// Picture height, pixels (16 to 4096; 480 by default).
    pub height: u32,
    /// Each side is drawn this many times larger and averaged down, for smooth edges
    /// (1 to 4; 2 by default; 1 is about four times faster).
    pub supersample: u32,
    /// At most this many GIF frames per second (1 to 50; 15 by default): the GIF shows
    /// every n-th track frame, timed so it plays in real time.
    pub gif_fps: f32,
    /// Track frames to draw, first and last inclusive; all of them when `None`.
    pub frames: Option<(usize, usize)>,
    /// The track frame a PNG shows; the middle of the range when `None` (the action, not
    /// the still start or the settled end).
    pub png_frame: Option<usize>,
    /// Where the camera looks from, as a direction from the scene toward the eye (any
    /// length); by default front-right and a little above, (0.55, 0.38, 1). The distance
    /// is always chosen to frame the action.
    pub view_from: Vec3,
}

impl Default for PreviewOptions {
    fn default() -> Self {
        PreviewOptions {
            width: 640,
            height: 480,
            supersample: 2,
            gif_fps: 15.0,
            frames: None,
            png_frame: None,
            view_from: VIEW_FROM,
        }
    }
}

impl PreviewOptions {
    fn validate(&self) -> Result<()> {
        let bad = |message: String| {
            Err(Error::Setting {
                setting: "preview".into(),
                message,
            })
        };
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(16..=4096).contains(&v) {
                return bad(format!("{name} must be 16 to 4096 pixels, not {v}"));
            }
        }
        if !(1..=4).contains(&self.supersample) {
            return bad(format!(
                "supersample must be 1 to 4, not {}",
                self.supersample
            ));
        }
        let drawn = self.width as u64 * self.height as u64 * (self.supersample as u64).pow(2);
        if drawn > 1 << 24 {
            return bad(format!(
                "{}×{} pixels drawn {} times over would need {drawn} pixels of buffer; at most {} (lower the size or the supersampling)",
                self.width,
                self.height,
                self.supersample * self.supersample,
                1u64 << 24
            ));
        }
        if !(self.gif_fps.is_finite() && (1.0..=50.0).contains(&self.gif_fps)) {
            return bad(format!(
                "the GIF frame rate must be 1 to 50 per second, not {}",
                self.gif_fps
            ));
        }
        if !(self.view_from.is_finite() && self.view_from.length() > 1e-6)
            || self.view_from.normalize().y.abs() > 0.999
        {
            return bad(format!(
                "the view direction {} must be finite, non-zero and not straight up or down",
                self.view_from
            ));
        }
        if let Some((a, b)) = self.frames
            && a > b
        {
            return bad(format!("the frame range {a}..{b} is empty"));
        }
        Ok(())
    }
}

/// Something that happens in the scene, drawn where and when it happens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Marker {
    /// An explosion: a fireball at the charge from the detonation time, then a scorch mark
    /// on the ground below it. Before it goes off the charge shows as a small dark box.
    Blast {
        /// The charge, world space, metres.
        position: Vec3,
        /// Detonation time, seconds.
        time_s: f32,
        /// TNT-equivalent mass, kg (sizes the fireball: radius ∝ ∛mass).
        tnt_kg: f32,
    },
    /// A shot: a tracer from `origin` to `end` shortly before and after `time_s`, and a spark
    /// at `end`.
    Shot {
        /// Where it was fired from, metres.
        origin: Vec3,
        /// Where it hit (or, for a miss, where the tracer should stop), metres.
        end: Vec3,
        /// When it hit, seconds.
        time_s: f32,
    },
}

/// An 8-bit RGB picture, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// `width × height × 3` bytes.
    pub rgb: Vec<u8>,
}

impl Image {
    /// The colour at `(x, y)`.
    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let i = (y * self.width + x) * 3;
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }
}

/// The picture kinds a preview can be written as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// One frame, PNG.
    Png,
    /// The animation, looping GIF.
    Gif,
}

/// The format a preview file's extension asks for (`.png` or `.gif`, any case).
pub fn format_of(path: &Path) -> Result<Format> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("png") => Ok(Format::Png),
        Some("gif") => Ok(Format::Gif),
        _ => Err(Error::Setting {
            setting: "preview".into(),
            message: format!(
                "{}: a preview must be a .png (one frame) or a .gif (the animation)",
                path.display()
            ),
        }),
    }
}

/// A character, its ragdoll and its baked motion: what a preview draws.
pub type Actor<'a> = (&'a Character, &'a RagdollSpec, &'a Track);

/// The preview in the format `path`'s extension names (see [`format_of`]), as bytes for
/// the caller to write (atomically).
pub fn encode(
    path: &Path,
    actors: &[Actor<'_>],
    markers: &[Marker],
    options: &PreviewOptions,
) -> Result<Vec<u8>> {
    match format_of(path)? {
        Format::Png => png(actors, markers, options),
        Format::Gif => gif(actors, markers, options),
    }
}

/// One frame as a PNG: [`PreviewOptions::png_frame`], else the middle of the range.
pub fn png(actors: &[Actor<'_>], markers: &[Marker], options: &PreviewOptions) -> Result<Vec<u8>> {
    let mut preview = Preview::new(actors, markers, options)?;
    let (a, b) = preview.range;
    let frame = options.png_frame.unwrap_or((a + b) / 2);
    if frame >= preview.frame_count() {
        return Err(Error::Setting {
            setting: "preview".into(),
            message: format!(
                "frame {frame} is past the last frame ({})",
                preview.frame_count() - 1
            ),
        });
    }
    encode::png(preview.render(frame)?)
}

/// The animation as a looping GIF, every n-th frame of the range so it shows at most
/// [`PreviewOptions::gif_fps`] frames a second, timed to play in real time.
pub fn gif(actors: &[Actor<'_>], markers: &[Marker], options: &PreviewOptions) -> Result<Vec<u8>> {
    let mut preview = Preview::new(actors, markers, options)?;
    let (a, b) = preview.range;
    let step = ((preview.fps / options.gif_fps) - 1e-3).ceil().max(1.0) as usize;
    let frames: Vec<usize> = (a..=b).step_by(step).collect();
    // Train the palette on frames that between them show every colour: the ends, two in
    // between, and each marker at its brightest.
    let mut samples: Vec<usize> = vec![a, b, a + (b - a) / 3, a + 2 * (b - a) / 3];
    for m in markers {
        let t = match *m {
            Marker::Blast { time_s, .. } => time_s + 0.05,
            Marker::Shot { time_s, .. } => time_s,
        };
        let f = (t * preview.fps).round();
        if f >= a as f32 && f <= b as f32 && samples.len() < 8 {
            samples.push(f as usize);
        }
    }
    let mut sample_images = Vec::with_capacity(samples.len());
    for &f in &samples {
        sample_images.push(preview.render(f)?.clone());
    }
    let refs: Vec<&Image> = sample_images.iter().collect();
    let mut out = encode::Gif::new(preview.width, preview.height, &refs)?;
    drop(sample_images);
    // Delays in hundredths of a second, rounded cumulatively so the total stays exact.
    let fps = preview.fps as f64;
    let cs = |k: usize| (k as f64 * step as f64 * 100.0 / fps).round() as i64;
    for (k, &f) in frames.iter().enumerate() {
        let delay = (cs(k + 1) - cs(k)).clamp(2, u16::MAX as i64) as u16;
        let image = preview.render(f)?;
        out.push(image, delay)?;
    }
    out.finish()
}

/// Sun direction (toward the sun): high, from the front-left, so shadows fall back and to
/// the right of the characters as the camera sees them.
const SUN: Vec3 = Vec3::new(-0.45, 1.0, 0.35);
/// Where the camera looks from, relative to the scene: front-right and a little above.
const VIEW_FROM: Vec3 = Vec3::new(0.55, 0.38, 1.0);
/// Body colours, one per character in turn.
const ALBEDO: [Vec3; 5] = [
    Vec3::new(0.86, 0.52, 0.32),
    Vec3::new(0.33, 0.56, 0.86),
    Vec3::new(0.45, 0.72, 0.38),
    Vec3::new(0.84, 0.72, 0.32),
    Vec3::new(0.68, 0.45, 0.78),
];
const SKY_HORIZON: Vec3 = Vec3::new(0.86, 0.89, 0.93);
const SKY_ZENITH: Vec3 = Vec3::new(0.52, 0.66, 0.85);
const GROUND: Vec3 = Vec3::new(0.80, 0.78, 0.73);
const GRID: Vec3 = Vec3::new(0.48, 0.49, 0.50);

/// One mesh of a character, with buffers reused every frame.
struct MeshView<'a> {
    mesh: Cow<'a, SkinnedMesh>,
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
}

struct ActorView<'a> {
    track: &'a Track,
    rest: Vec<Transform>,
    meshes: Vec<MeshView<'a>>,
    albedo: Vec3,
}

/// A renderer set up for one set of characters and markers: camera, lights and buffers are
/// made once, then [`Preview::render`] draws any frame.
pub struct Preview<'a> {
    actors: Vec<ActorView<'a>>,
    markers: Vec<Marker>,
    fps: f32,
    frames: usize,
    range: (usize, usize),
    width: usize,
    height: usize,
    ss: usize,
    /// The camera for the supersampled buffer.
    camera: Camera,
    light: Vec3,
    shadow: ShadowMask,
    ground: Ground,
    /// Grid spacing, metres: 1 m for people, a power of ten that suits other sizes.
    grid: f32,
    target: Target,
    image: Image,
    matrices: Vec<Mat4>,
    screen: Vec<Vec3>,
    shade: Vec<Vec3>,
    sphere: (Vec<Vec3>, Vec<u32>),
    cube: (Vec<Vec3>, Vec<u32>),
}

impl<'a> Preview<'a> {
    /// Prepares a preview of `actors` (each a character, its spec and its track; the tracks
    /// share a frame rate) with `markers`. Fails on an empty or inconsistent input: no
    /// characters, a track that does not fit its skeleton or holds non-finite values, a
    /// frame range past the end, options out of range.
    pub fn new(
        actors: &[Actor<'a>],
        markers: &[Marker],
        options: &PreviewOptions,
    ) -> Result<Preview<'a>> {
        options.validate()?;
        let err = |message: String| Error::Setting {
            setting: "preview".into(),
            message,
        };
        if actors.is_empty() {
            return Err(err("there is no character to draw".into()));
        }
        let fps = actors[0].2.fps;
        if !(fps.is_finite() && fps > 0.0) {
            return Err(err(format!("the frame rate {fps} is not positive")));
        }
        let mut views = Vec::with_capacity(actors.len());
        // What the camera must keep in the picture: balls around every joint in (a sample
        // of) every frame, and the markers.
        let mut points: Vec<(Vec3, f32)> = Vec::new();
        for (k, &(character, spec, track)) in actors.iter().enumerate() {
            let name = &character.name;
            if track.frames.is_empty() {
                return Err(err(format!("{name}: the track has no frames")));
            }
            if (track.fps - fps).abs() > 1e-3 * fps {
                return Err(err(format!(
                    "{name}: the track runs at {} fps, the first at {fps}",
                    track.fps
                )));
            }
            for (f, frame) in track.frames.iter().enumerate() {
                if frame.len() != character.skeleton.len() {
                    return Err(err(format!(
                        "{name}: frame {f} has {} joints, the skeleton {}",
                        frame.len(),
                        character.skeleton.len()
                    )));
                }
                if frame.iter().any(|t| !t.is_finite()) {
                    return Err(err(format!("{name}: frame {f} is not finite")));
                }
            }
            let meshes: Vec<Cow<'a, SkinnedMesh>> = if character.meshes.is_empty() {
                vec![Cow::Owned(skinning::bodies_mesh(
                    &character.skeleton,
                    spec,
                )?)]
            } else {
                character.meshes.iter().map(Cow::Borrowed).collect()
            };
            let rest = character.skeleton.rest_world();
            // Joints alone underestimate the body: pad by how far the mesh reaches from
            // the joints that carry it.
            let pad = meshes
                .iter()
                .flat_map(|m| m.positions.iter().zip(&m.joints).zip(&m.weights))
                .map(|((p, j), w)| {
                    let a = w.to_array();
                    let main = (0..4).max_by(|&x, &y| a[x].total_cmp(&a[y])).unwrap_or(0);
                    rest.get(j[main] as usize)
                        .map_or(0.0, |r| (*p - r.translation).length())
                })
                .fold(0.0f32, f32::max)
                .min(2.0 * character.skeleton.rest_height().max(0.1));
            let stride = track.frames.len().div_ceil(600).max(1);
            for frame in track.frames.iter().step_by(stride) {
                points.extend(frame.iter().map(|t| (t.translation, pad)));
            }
            views.push(ActorView {
                track,
                rest,
                meshes: meshes
                    .into_iter()
                    .map(|mesh| MeshView {
                        mesh,
                        positions: Vec::new(),
                        normals: Vec::new(),
                    })
                    .collect(),
                albedo: ALBEDO[k % ALBEDO.len()],
            });
        }
        for m in markers {
            let marks = match *m {
                Marker::Blast {
                    position, tnt_kg, ..
                } => [(position, 1.4 * fireball_radius(tnt_kg)); 2],
                Marker::Shot { origin, end, .. } => [(origin, 0.05), (end, 0.05)],
            };
            if marks.iter().any(|(p, _)| !p.is_finite()) {
                return Err(err("a marker's position is not finite".into()));
            }
            points.extend(marks);
        }
        let (mut lo, mut hi) = points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), &(p, r)| (lo.min(p - r), hi.max(p + r)),
        );
        lo.y = lo.y.min(0.0);
        // Never frame less than a small room, so a still character is not blown up.
        let centre = (lo + hi) * 0.5;
        let half = ((hi - lo) * 0.5).max(Vec3::splat(0.4));
        points.push((centre - Vec3::splat(0.4), 0.0));
        points.push((centre + Vec3::splat(0.4), 0.0));
        (lo, hi) = (centre - half, centre + half);

        let frames = views
            .iter()
            .map(|v| v.track.frames.len())
            .max()
            .unwrap_or(1);
        let range = options.frames.unwrap_or((0, frames - 1));
        if range.1 >= frames {
            return Err(err(format!(
                "the frame range ends at {} but the last frame is {}",
                range.1,
                frames - 1
            )));
        }
        let (width, height) = (options.width as usize, options.height as usize);
        let ss = options.supersample as usize;
        let camera = Camera::framing(&points, options.view_from, width as f32, height as f32)
            .scaled(ss as f32);
        let light = SUN.normalize();
        let size = actors
            .iter()
            .map(|a| a.0.skeleton.rest_height())
            .fold(0.0f32, f32::max);
        // 1 m for anything from about half to five times a person's height.
        let ratio = size.max(0.01) / ragdoll::skeleton::DEFAULT_HEIGHT_M;
        let grid = 10f32.powf((ratio.log10() + 0.3).floor());
        let mut preview = Preview {
            actors: views,
            markers: markers.to_vec(),
            fps,
            frames,
            range,
            width,
            height,
            ss,
            camera,
            light,
            shadow: ShadowMask::new(lo, hi, light),
            ground: Ground::empty(),
            grid,
            target: Target::new(width * ss, height * ss),
            image: Image {
                width,
                height,
                rgb: vec![0; width * height * 3],
            },
            matrices: Vec::new(),
            screen: Vec::new(),
            shade: Vec::new(),
            sphere: icosphere(),
            cube: cube(),
        };
        // Skin the first frame now, so a mesh that does not fit its skeleton fails here
        // rather than halfway through a GIF.
        preview.skin_all(range.0)?;
        Ok(preview)
    }

    /// Number of track frames (the longest track's).
    pub fn frame_count(&self) -> usize {
        self.frames
    }

    /// Where world point `p` lands in the picture, pixels from the top-left corner; `None`
    /// when it is behind the camera or outside the picture.
    pub fn project(&self, p: Vec3) -> Option<glam::Vec2> {
        let v = self.camera.view_space(p);
        if v.z < NEAR {
            return None;
        }
        let s = self.camera.screen_point(v) / self.ss as f32;
        (s.x >= 0.0 && s.y >= 0.0 && s.x < self.width as f32 && s.y < self.height as f32)
            .then_some(s)
    }

    /// Draws track frame `frame` (a shorter track holds its last pose).
    pub fn render(&mut self, frame: usize) -> Result<&Image> {
        let t = frame as f32 / self.fps;
        self.skin_all(frame)?;
        self.shadow.clear();
        for actor in &self.actors {
            for m in &actor.meshes {
                self.shadow.cast(&m.positions, &m.mesh.indices);
            }
        }
        self.shadow.soften();
        self.draw_ground(t);
        for k in 0..self.actors.len() {
            for i in 0..self.actors[k].meshes.len() {
                let albedo = self.actors[k].albedo;
                let m = &self.actors[k].meshes[i];
                draw_lit(
                    &mut self.target,
                    &self.camera,
                    self.light,
                    &m.positions,
                    &m.normals,
                    &m.mesh.indices,
                    |_| albedo,
                    &mut self.screen,
                    &mut self.shade,
                );
            }
        }
        self.draw_markers(t);
        self.resolve();
        let text = format!("{frame}/{}  {t:.2}s", self.frames - 1);
        let scale = if self.height >= 360 { 2 } else { 1 };
        font::draw_text(
            &mut self.image.rgb,
            self.width,
            self.height,
            6 * scale,
            6 * scale,
            scale,
            &text,
        );
        Ok(&self.image)
    }

    fn skin_all(&mut self, frame: usize) -> Result<()> {
        for actor in &mut self.actors {
            let f = frame.min(actor.track.frames.len() - 1);
            skinning::skin_matrices(&actor.rest, &actor.track.frames[f], &mut self.matrices)?;
            for m in &mut actor.meshes {
                skinning::skin(&m.mesh, &self.matrices, &mut m.positions, &mut m.normals)?;
                if m.normals.is_empty() {
                    vertex_normals(&m.positions, &m.mesh.indices, &mut m.normals);
                }
            }
        }
        Ok(())
    }

    /// Sky and ground into the z-buffer: the cached picture of the empty scene, darkened
    /// where the shadow mask says.
    fn draw_ground(&mut self, t: f32) {
        let scorches = self.scorches(t);
        if self.ground.scorches != Some(scorches.len()) {
            self.ground = Ground::new(&self.camera, self.light, &scorches, self.grid);
        }
        let g = &self.ground;
        self.target.color.copy_from_slice(&g.color);
        self.target.depth.copy_from_slice(&g.depth);
        let Some((lo, hi)) = self.shadow.bounds() else {
            return;
        };
        for (i, p) in g.xz.iter().enumerate() {
            if p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y {
                let s = self.shadow.at(p.x, p.y);
                self.target.color[i] -= g.shade[i] * s;
            }
        }
    }

    /// The blasts that have gone off by time `t` and sit low enough to scorch the ground:
    /// centre and radius.
    fn scorches(&self, t: f32) -> Vec<(Vec3, f32)> {
        self.markers
            .iter()
            .filter_map(|m| match *m {
                Marker::Blast {
                    position,
                    time_s,
                    tnt_kg,
                } if t >= time_s && position.y < fireball_radius(tnt_kg) => {
                    Some((position, 0.8 * fireball_radius(tnt_kg)))
                }
                _ => None,
            })
            .collect()
    }

    fn draw_markers(&mut self, t: f32) {
        let cam = self.camera;
        let ss = self.ss as f32;
        for m in self.markers.clone() {
            match m {
                Marker::Blast {
                    position,
                    time_s,
                    tnt_kg,
                } => {
                    let tau = t - time_s;
                    let radius = fireball_radius(tnt_kg);
                    if tau < 0.0 {
                        // The charge, waiting.
                        let s = 0.06 * tnt_kg.cbrt().clamp(0.5, 3.0);
                        let pos: Vec<Vec3> =
                            self.cube.0.iter().map(|&v| position + v * s).collect();
                        let nrm = self.cube.0.clone();
                        draw_lit(
                            &mut self.target,
                            &cam,
                            self.light,
                            &pos,
                            &nrm,
                            &self.cube.1,
                            |_| Vec3::new(0.35, 0.12, 0.1),
                            &mut self.screen,
                            &mut self.shade,
                        );
                    } else if tau < 0.45 {
                        // A ragged fireball that swells in 50 ms, then cools and fades.
                        let grow = (tau / 0.05).min(1.0);
                        let r = radius * grow * (1.0 + 0.4 * tau);
                        let heat = (tau / 0.45).clamp(0.0, 1.0);
                        let core = Vec3::new(1.0, 0.96, 0.75)
                            .lerp(Vec3::new(1.0, 0.55, 0.12), (heat * 3.0).min(1.0))
                            .lerp(Vec3::new(0.32, 0.28, 0.26), ((heat - 0.35) / 0.65).max(0.0));
                        let pos: Vec<Vec3> = self
                            .sphere
                            .0
                            .iter()
                            .enumerate()
                            .map(|(k, &v)| position + v * r * (0.8 + 0.4 * hash(k)))
                            .collect();
                        // Mottled: each vertex between the core colour and a deeper orange.
                        let deep = core * Vec3::new(0.95, 0.55, 0.35);
                        let colors: Vec<Vec3> = (0..pos.len())
                            .map(|k| core.lerp(deep, hash(k + 101)))
                            .collect();
                        draw_flat(
                            &mut self.target,
                            &cam,
                            &pos,
                            &self.sphere.1,
                            &colors,
                            &mut self.screen,
                        );
                        if tau < 0.2 {
                            // Sparks flying out of it.
                            let spark = Vec3::new(1.0, 0.85, 0.35);
                            let dirs: Vec<Vec3> =
                                self.sphere.0.iter().step_by(4).copied().collect();
                            for (k, d) in dirs.into_iter().enumerate() {
                                let a = position + d * r * 0.9;
                                let b = position + d * r * (1.4 + 0.8 * hash(k + 7));
                                self.line(a, b, spark, 1.5 * ss);
                            }
                        }
                    }
                }
                Marker::Shot {
                    origin,
                    end,
                    time_s,
                } => {
                    let tau = t - time_s;
                    if (-0.1..=0.25).contains(&tau) {
                        self.line(origin, end, Vec3::new(1.0, 0.9, 0.3), 1.5 * ss);
                    }
                    if (0.0..=0.3).contains(&tau) {
                        let pos: Vec<Vec3> =
                            self.sphere.0.iter().map(|&v| end + v * 0.05).collect();
                        let colors = vec![Vec3::new(1.0, 0.3, 0.15); pos.len()];
                        draw_flat(
                            &mut self.target,
                            &cam,
                            &pos,
                            &self.sphere.1,
                            &colors,
                            &mut self.screen,
                        );
                    }
                }
            }
        }
    }

    fn line(&mut self, a: Vec3, b: Vec3, color: Vec3, width: f32) {
        let (va, vb) = (self.camera.view_space(a), self.camera.view_space(b));
        if va.z < NEAR || vb.z < NEAR {
            return;
        }
        let sa = self.camera.screen_point(va).extend(1.0 / va.z);
        let sb = self.camera.screen_point(vb).extend(1.0 / vb.z);
        self.target.line(sa, sb, color, width);
    }

    /// Averages the supersampled buffer down into the picture.
    fn resolve(&mut self) {
        let ss = self.ss;
        let tw = self.target.width;
        let norm = 255.0 / (ss * ss) as f32;
        for y in 0..self.height {
            for x in 0..self.width {
                let mut sum = Vec3::ZERO;
                for dy in 0..ss {
                    let row = (y * ss + dy) * tw + x * ss;
                    for dx in 0..ss {
                        sum += self.target.color[row + dx];
                    }
                }
                let c = (sum * norm).clamp(Vec3::ZERO, Vec3::splat(255.0));
                let i = (y * self.width + x) * 3;
                self.image.rgb[i] = c.x as u8;
                self.image.rgb[i + 1] = c.y as u8;
                self.image.rgb[i + 2] = c.z as u8;
            }
        }
    }
}

/// The empty scene (sky, ground, grid, scorch marks) ray-cast once per pixel, with what
/// each ground pixel needs to take a shadow: the camera never moves, so only the shadows
/// change from frame to frame (and the scorch marks, when a blast goes off).
struct Ground {
    /// How many scorch marks this picture has (`None`: not drawn yet).
    scorches: Option<usize>,
    color: Vec<Vec3>,
    depth: Vec<f32>,
    /// What full shadow takes away from each pixel (zero for the sky).
    shade: Vec<Vec3>,
    /// The ground point each pixel shows, (x, z); NaN for the sky.
    xz: Vec<glam::Vec2>,
}

impl Ground {
    fn empty() -> Ground {
        Ground {
            scorches: None,
            color: Vec::new(),
            depth: Vec::new(),
            shade: Vec::new(),
            xz: Vec::new(),
        }
    }

    fn new(cam: &Camera, light: Vec3, scorches: &[(Vec3, f32)], grid: f32) -> Ground {
        let (w, h) = (cam.size.x as usize, cam.size.y as usize);
        let n = w * h;
        let mut g = Ground {
            scorches: Some(scorches.len()),
            color: vec![Vec3::ZERO; n],
            depth: vec![0.0; n],
            shade: vec![Vec3::ZERO; n],
            xz: vec![glam::Vec2::NAN; n],
        };
        // World size of one pixel at unit depth, for filtering the grid lines.
        let pixel = 2.0 * cam.tan_half.y / cam.size.y;
        let fog = 1.0 / (6.0 * (cam.eye.y.abs() + 10.0));
        let sun = light.y;
        let step = cam.right * (2.0 * cam.tan_half.x / cam.size.x);
        for y in 0..h {
            let row = cam.ray(0.5, y as f32 + 0.5);
            for x in 0..w {
                let dir = row + step * x as f32;
                let i = y * w + x;
                let len = dir.length();
                if dir.y >= -1e-4 * len || cam.eye.y <= 0.0 {
                    let s = (dir.y / len).max(0.0).sqrt();
                    g.color[i] = SKY_HORIZON.lerp(SKY_ZENITH, s);
                    continue;
                }
                let depth = -cam.eye.y / dir.y;
                let p = cam.eye + dir * depth;
                let dist = depth * len;
                // Ground width of this pixel: wider the further and the more grazing. The
                // grid lines are box-filtered over it (anti-aliased without supersampling)
                // and fade out where they would shimmer.
                let foot = dist * pixel * len / -dir.y;
                let hw = 0.012 * grid;
                let line = |c: f32| {
                    let c = c / grid;
                    let d = (c - c.round()).abs() * grid;
                    ((hw + 0.5 * foot - d) / foot).clamp(0.0, 1.0) * (2.0 * hw / foot).min(1.0)
                };
                let fade = (1.0 - (foot / grid - 0.04) / 0.12).clamp(0.0, 1.0);
                let mut base = GROUND.lerp(GRID, (line(p.x).max(line(p.z)) * fade).min(1.0) * 0.8);
                for &(c, r) in scorches {
                    let d = ((p.x - c.x).powi(2) + (p.z - c.z).powi(2)).sqrt();
                    if d < r {
                        let k = 1.0 - d / r;
                        base *= 1.0 - 0.75 * (k * k * (3.0 - 2.0 * k));
                    }
                }
                let haze = 1.0 - (-dist * fog).exp();
                let lit = base * (0.42 + 0.62 * sun);
                g.color[i] = lit.lerp(SKY_HORIZON, haze);
                g.shade[i] = base * (0.62 * sun * 0.7 * (1.0 - haze));
                g.depth[i] = 1.0 / depth;
                g.xz[i] = glam::Vec2::new(p.x, p.z);
            }
        }
        g
    }
}

/// Fireball radius, metres, for a charge of `tnt_kg`: half a metre per ∛kg (an artistic
/// size, not a physical one; the blast's reach is far larger).
fn fireball_radius(tnt_kg: f32) -> f32 {
    0.5 * tnt_kg.max(0.0).cbrt().clamp(0.2, 20.0)
}

/// A repeatable pseudo-random number in 0..1 for `k`.
fn hash(k: usize) -> f32 {
    let mut x = (k as u32).wrapping_mul(0x9E37_79B9) ^ 0x85EB_CA6B;
    x ^= x >> 15;
    x = x.wrapping_mul(0x2C1B_3C6D);
    x ^= x >> 12;
    (x & 0xFFFF) as f32 / 65535.0
}

/// Projects the vertices, giving each its screen position and `1/depth`; a vertex behind
/// the near plane gets NaN so its triangles are skipped.
fn project(cam: &Camera, positions: &[Vec3], screen: &mut Vec<Vec3>) {
    screen.clear();
    screen.extend(positions.iter().map(|&p| {
        let v = cam.view_space(p);
        if v.z < NEAR {
            Vec3::NAN
        } else {
            cam.screen_point(v).extend(1.0 / v.z)
        }
    }));
}

fn draw_triangles(target: &mut Target, screen: &[Vec3], indices: &[u32], colors: &[Vec3]) {
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        let p = [screen[a], screen[b], screen[c]];
        if p.iter().any(|v| !v.is_finite()) {
            continue;
        }
        target.triangle(p, [colors[a], colors[b], colors[c]]);
    }
}

/// Draws a mesh lit by the sun and the sky, colours computed per vertex (Gouraud).
#[allow(clippy::too_many_arguments)]
fn draw_lit(
    target: &mut Target,
    cam: &Camera,
    light: Vec3,
    positions: &[Vec3],
    normals: &[Vec3],
    indices: &[u32],
    albedo: impl Fn(usize) -> Vec3,
    screen: &mut Vec<Vec3>,
    shade: &mut Vec<Vec3>,
) {
    project(cam, positions, screen);
    shade.clear();
    shade.extend(normals.iter().enumerate().map(|(k, n)| {
        let sky = 0.30 + 0.12 * n.y;
        let sun = 0.68 * n.dot(light).max(0.0);
        albedo(k) * (sky + sun)
    }));
    draw_triangles(target, screen, indices, shade);
}

/// Draws a mesh in its own colours, unlit (fire glows).
fn draw_flat(
    target: &mut Target,
    cam: &Camera,
    positions: &[Vec3],
    indices: &[u32],
    colors: &[Vec3],
    screen: &mut Vec<Vec3>,
) {
    project(cam, positions, screen);
    draw_triangles(target, screen, indices, colors);
}

/// Area-weighted vertex normals, for meshes that come without any.
fn vertex_normals(positions: &[Vec3], indices: &[u32], out: &mut Vec<Vec3>) {
    out.clear();
    out.resize(positions.len(), Vec3::ZERO);
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        for k in [a, b, c] {
            out[k] += n;
        }
    }
    for n in out.iter_mut() {
        *n = n.try_normalize().unwrap_or(Vec3::Y);
    }
}

/// A unit sphere: an icosahedron subdivided twice (320 triangles), vertices on the sphere
/// (so each is also its own normal).
fn icosphere() -> (Vec<Vec3>, Vec<u32>) {
    let p = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, p, 0.0),
        (1.0, p, 0.0),
        (-1.0, -p, 0.0),
        (1.0, -p, 0.0),
        (0.0, -1.0, p),
        (0.0, 1.0, p),
        (0.0, -1.0, -p),
        (0.0, 1.0, -p),
        (p, 0.0, -1.0),
        (p, 0.0, 1.0),
        (-p, 0.0, -1.0),
        (-p, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..2 {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    (v, f.into_iter().flatten().collect())
}

/// A cube of half-size 1 as 8 shared corners (normals along the corners: rounded shading
/// is fine for a marker this small).
fn cube() -> (Vec<Vec3>, Vec<u32>) {
    let v: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let idx = faces
        .iter()
        .flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]])
        .collect();
    (v, idx)
}
