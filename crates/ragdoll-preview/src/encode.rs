//! Pictures to bytes: PNG through the `png` crate, GIF through the `gif` crate.
//!
//! GIFs are kept small three ways: one global palette for the whole animation (NeuQuant,
//! trained once on a few sample frames, then a 15-bit lookup table maps every pixel); each
//! frame after the first stores only the rectangle that changed; and inside that rectangle
//! the pixels that did not change are transparent, which LZW compresses to almost nothing.

use ragdoll::{Error, Result};

use crate::Image;

fn encode_err(what: &str, e: impl std::fmt::Display) -> Error {
    Error::Setting {
        setting: "preview".into(),
        message: format!("could not encode the {what}: {e}"),
    }
}

/// One RGB picture as PNG bytes.
pub fn png(image: &Image) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, image.width as u32, image.height as u32);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| encode_err("PNG", e))?;
        w.write_image_data(&image.rgb)
            .map_err(|e| encode_err("PNG", e))?;
        w.finish().map_err(|e| encode_err("PNG", e))?;
    }
    Ok(out)
}

/// Palette index kept for "unchanged since the last frame".
const TRANSPARENT: u8 = 255;

/// A 255-colour palette and the table that maps any 15-bit colour to its nearest entry.
struct Palette {
    rgb: Vec<u8>,
    lut: Vec<u8>,
}

impl Palette {
    /// Trains NeuQuant on the sample pictures (RGB8).
    fn from_samples(samples: &[&Image]) -> Palette {
        let mut rgba = Vec::new();
        for img in samples {
            for px in img.rgb.chunks_exact(3) {
                rgba.extend_from_slice(&[px[0], px[1], px[2], 255]);
            }
        }
        let nq = color_quant::NeuQuant::new(10, TRANSPARENT as usize, &rgba);
        let mut rgb = nq.color_map_rgb();
        rgb.resize(256 * 3, 0);
        let colors: Vec<[i32; 3]> = rgb[..TRANSPARENT as usize * 3]
            .chunks_exact(3)
            .map(|c| [c[0] as i32, c[1] as i32, c[2] as i32])
            .collect();
        let lut = (0..1u32 << 15)
            .map(|k| {
                let c = [
                    ((k >> 10) & 31) as i32 * 255 / 31,
                    ((k >> 5) & 31) as i32 * 255 / 31,
                    (k & 31) as i32 * 255 / 31,
                ];
                let d = |p: &[i32; 3]| {
                    // Weighted for the eye: green counts most, blue least.
                    let (r, g, b) = (p[0] - c[0], p[1] - c[1], p[2] - c[2]);
                    3 * r * r + 4 * g * g + 2 * b * b
                };
                (0..colors.len())
                    .min_by_key(|&i| d(&colors[i]))
                    .unwrap_or(0) as u8
            })
            .collect();
        Palette { rgb, lut }
    }

    #[inline]
    fn index(&self, px: &[u8]) -> u8 {
        let k =
            ((px[0] as usize >> 3) << 10) | ((px[1] as usize >> 3) << 5) | (px[2] as usize >> 3);
        self.lut[k]
    }
}

/// A GIF being written frame by frame.
pub struct Gif {
    encoder: gif::Encoder<Vec<u8>>,
    palette: Palette,
    width: usize,
    height: usize,
    previous: Vec<u8>,
    current: Vec<u8>,
    frames: usize,
}

impl Gif {
    /// Starts a looping GIF whose palette is trained on `samples` (a few frames that show
    /// every colour the animation will use).
    pub fn new(width: usize, height: usize, samples: &[&Image]) -> Result<Gif> {
        let palette = Palette::from_samples(samples);
        let mut encoder = gif::Encoder::new(Vec::new(), width as u16, height as u16, &palette.rgb)
            .map_err(|e| encode_err("GIF", e))?;
        encoder
            .set_repeat(gif::Repeat::Infinite)
            .map_err(|e| encode_err("GIF", e))?;
        Ok(Gif {
            encoder,
            palette,
            width,
            height,
            previous: vec![TRANSPARENT; width * height],
            current: vec![0; width * height],
            frames: 0,
        })
    }

    /// Appends a frame shown for `delay_cs` hundredths of a second.
    pub fn push(&mut self, image: &Image, delay_cs: u16) -> Result<()> {
        let (w, h) = (self.width, self.height);
        for (dst, px) in self.current.iter_mut().zip(image.rgb.chunks_exact(3)) {
            *dst = self.palette.index(px);
        }
        // The rectangle that changed since the last frame (all of the first one).
        let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
        for y in 0..h {
            let row = y * w;
            let (cur, prev) = (&self.current[row..row + w], &self.previous[row..row + w]);
            if let Some(first) = (0..w).find(|&x| cur[x] != prev[x]) {
                let last = (0..w).rev().find(|&x| cur[x] != prev[x]).unwrap_or(first);
                x0 = x0.min(first);
                x1 = x1.max(last);
                y0 = y0.min(y);
                y1 = y1.max(y);
            }
        }
        if x0 > x1 {
            // Nothing changed: a one-pixel transparent frame keeps the timing.
            (x0, y0, x1, y1) = (0, 0, 0, 0);
        }
        let (fw, fh) = (x1 - x0 + 1, y1 - y0 + 1);
        let first = self.frames == 0;
        let mut buffer = Vec::with_capacity(fw * fh);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let i = y * w + x;
                let c = self.current[i];
                buffer.push(if !first && c == self.previous[i] {
                    TRANSPARENT
                } else {
                    c
                });
            }
        }
        let frame = gif::Frame {
            delay: delay_cs,
            dispose: gif::DisposalMethod::Keep,
            transparent: (!first).then_some(TRANSPARENT),
            left: x0 as u16,
            top: y0 as u16,
            width: fw as u16,
            height: fh as u16,
            buffer: std::borrow::Cow::Owned(buffer),
            ..Default::default()
        };
        self.encoder
            .write_frame(&frame)
            .map_err(|e| encode_err("GIF", e))?;
        std::mem::swap(&mut self.previous, &mut self.current);
        self.frames += 1;
        Ok(())
    }

    /// The finished file's bytes.
    pub fn finish(self) -> Result<Vec<u8>> {
        self.encoder.into_inner().map_err(|e| encode_err("GIF", e))
    }
}
