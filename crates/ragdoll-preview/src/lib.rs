//! Preview pictures and GIFs of ragdoll results, drawn on the CPU: no GPU, no display, so
//! they work on CI and over SSH.
//!
//! What a picture shows: each character as its skinned mesh deformed by linear blend
//! skinning ([`ragdoll::skeleton::skinning`]), or, without a mesh, as the capsules and boxes
//! of its ragdoll; lit by a sun (Lambert plus a sky term); a ground with a grid (1 m for
//! people) and soft shadows; blasts as a fireball at the charge from its detonation time, a
//! scorch mark after; shots as a tracer from muzzle to hit around their time; a frame
//! counter. The camera frames everything that happens over the whole run and stays put,
//! so the motion reads against a still ground.
//!
//! How, one file each: a single z-buffer rasteriser (`raster.rs`) draws every triangle and
//! line, so occlusion is right whatever the order; the ground is ray-cast per pixel into
//! the same z-buffer, once, since the camera never moves (`ground.rs`; exact to the
//! horizon, nothing to clip); shadows are the silhouettes projected along the sunlight into
//! a mask over the ground and blurred (`shadow.rs`); markers are in `markers.rs`, lighting
//! and marker shapes in `mesh.rs`, the counter's font in `font.rs`. The picture is drawn at
//! twice the size and averaged down (anti-aliasing). GIFs share one palette and store only
//! what changed between frames (`encode.rs`).
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
mod ground;
mod markers;
mod mesh;
mod raster;
mod setup;
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
/// Text on a picture (a contact sheet's labels), in the frame counter's font.
pub use font::draw_text;
use ground::Ground;
use mesh::{cube, draw_lit, icosphere, vertex_normals};
use raster::Target;
use setup::{Ball, actor_view, frame_range, framed_box, grid_spacing, marker_balls, shared_fps};
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
        // Each error's setting is the option's field name ("size" for the pixel budget of
        // width, height and supersampling together), so a caller can say which of its own
        // flags set it.
        let bad = |setting: &str, message: String| {
            Err(Error::Setting {
                setting: setting.into(),
                message,
            })
        };
        for (name, v) in [("width", self.width), ("height", self.height)] {
            if !(16..=4096).contains(&v) {
                return bad(name, format!("{name} must be 16 to 4096 pixels, not {v}"));
            }
        }
        if !(1..=4).contains(&self.supersample) {
            return bad(
                "supersample",
                format!("supersample must be 1 to 4, not {}", self.supersample),
            );
        }
        let drawn = self.width as u64 * self.height as u64 * (self.supersample as u64).pow(2);
        if drawn > 1 << 24 {
            return bad(
                "size",
                format!(
                    "{}×{} pixels drawn {} times over would need {drawn} pixels of buffer; at most {} (lower the size or the supersampling)",
                    self.width,
                    self.height,
                    self.supersample * self.supersample,
                    1u64 << 24
                ),
            );
        }
        if !(self.gif_fps.is_finite() && (1.0..=50.0).contains(&self.gif_fps)) {
            return bad(
                "gif_fps",
                format!(
                    "the GIF frame rate must be 1 to 50 per second, not {}",
                    self.gif_fps
                ),
            );
        }
        if !(self.view_from.is_finite() && self.view_from.length() > 1e-6)
            || self.view_from.normalize().y.abs() > 0.999
        {
            return bad(
                "view_from",
                format!(
                    "the view direction {} must be finite, non-zero and not straight up or down",
                    self.view_from
                ),
            );
        }
        if let Some((a, b)) = self.frames
            && a > b
        {
            return bad("frames", format!("the frame range {a}..{b} is empty"));
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
    /// at `end` when it hit something.
    Shot {
        /// Where it was fired from, metres.
        origin: Vec3,
        /// Where it hit (or, for a miss, where the tracer should stop), metres.
        end: Vec3,
        /// When it hit, seconds.
        time_s: f32,
        /// Whether it hit a body. The camera frames the end of a hit, not of a miss.
        hit: bool,
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
            setting: "png_frame".into(),
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
pub(crate) const SKY_HORIZON: Vec3 = Vec3::new(0.86, 0.89, 0.93);
pub(crate) const SKY_ZENITH: Vec3 = Vec3::new(0.52, 0.66, 0.85);
pub(crate) const GROUND: Vec3 = Vec3::new(0.80, 0.78, 0.73);
pub(crate) const GRID: Vec3 = Vec3::new(0.48, 0.49, 0.50);

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
        let fps = shared_fps(actors)?;
        let mut views = Vec::with_capacity(actors.len());
        // What the camera must keep in the picture: balls around every joint in (a sample
        // of) every frame, and the markers.
        let mut points: Vec<Ball> = Vec::new();
        for (k, &actor) in actors.iter().enumerate() {
            views.push(actor_view(k, actor, fps, &mut points)?);
        }
        marker_balls(markers, &mut points)?;
        let (lo, hi) = framed_box(&mut points);
        let (frames, range) = frame_range(&views, options.frames)?;
        let (width, height) = (options.width as usize, options.height as usize);
        let ss = options.supersample as usize;
        let camera = Camera::framing(&points, options.view_from, width as f32, height as f32)
            .scaled(ss as f32);
        let light = SUN.normalize();
        let grid = grid_spacing(actors);
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
