//! The contact sheet `ragdoll merge` draws: every variant's preview picture, shrunk, in a
//! grid, each labelled with its index and its values, so a team picks a take at a
//! glance. Pages of [`PER_PAGE`] keep each picture a size any viewer opens (10,000
//! variants make 209 pages, not one picture of 200 megapixels).

use std::io::Cursor;
use std::path::Path;

use anyhow::{Result, bail};
use rayon::prelude::*;
use serde_json::Value;

use crate::farm::{Plan, PlanVariant};
use crate::farm_task::variant_dir;

/// A shrunk preview, pixels (a quarter of the preview's 640 × 480).
const TILE_W: usize = 160;
const TILE_H: usize = 120;
/// Pictures across a page, and down.
const COLUMNS: usize = 8;
const ROWS: usize = 6;
/// Variants on one page.
pub const PER_PAGE: usize = COLUMNS * ROWS;
/// Space between tiles, pixels.
const GAP: usize = 6;
/// A label line's height: the 7-pixel font, its outline and a pixel between lines.
const LINE_H: usize = 10;
/// The font's advance, pixels a character.
const CHAR_W: usize = 6;
const BACKGROUND: u8 = 36;

/// The sheet's pages as PNG bytes, in variant order.
pub fn pages(job: &Path, plan: &Plan) -> Result<Vec<Vec<u8>>> {
    let lines = 1 + plan.keys.len();
    plan.variants
        .par_chunks(PER_PAGE)
        .map(|chunk| {
            let tiles: Vec<Vec<u8>> = chunk
                .par_iter()
                .map(|v| tile(&variant_dir(job, &v.name).join(THUMB_FILE)))
                .collect();
            page(plan, chunk, &tiles, lines)
        })
        .collect()
}

/// One page: `chunk`'s tiles with their labels under them.
fn page(plan: &Plan, chunk: &[PlanVariant], tiles: &[Vec<u8>], lines: usize) -> Result<Vec<u8>> {
    let cell_h = TILE_H + lines * LINE_H + 2;
    let rows = chunk.len().div_ceil(COLUMNS);
    let width = COLUMNS.min(chunk.len()) * (TILE_W + GAP) + GAP;
    let height = rows * (cell_h + GAP) + GAP;
    let mut rgb = vec![BACKGROUND; width * height * 3];
    for (k, (v, t)) in chunk.iter().zip(tiles).enumerate() {
        let (x0, y0) = (
            GAP + (k % COLUMNS) * (TILE_W + GAP),
            GAP + (k / COLUMNS) * (cell_h + GAP),
        );
        for y in 0..TILE_H {
            let from = &t[y * TILE_W * 3..(y + 1) * TILE_W * 3];
            let at = ((y0 + y) * width + x0) * 3;
            rgb[at..at + TILE_W * 3].copy_from_slice(from);
        }
        for (n, text) in label(plan, v).iter().enumerate() {
            let fits: String = text.chars().take(TILE_W / CHAR_W).collect();
            let y = y0 + TILE_H + 2 + n * LINE_H;
            ragdoll_preview::draw_text(&mut rgb, width, height, x0 + 1, y, 1, &fits);
        }
    }
    encode(width, height, &rgb)
}

/// A variant's label lines: its index, then `label=value` for each varied key.
fn label(plan: &Plan, v: &PlanVariant) -> Vec<String> {
    let mut lines = vec![format!("{}", v.index)];
    for k in &plan.keys {
        let value = v.values.get(&k.key).map_or(String::new(), compact);
        lines.push(format!("{}={value}", k.label));
    }
    lines
}

/// A value in few characters: numbers as JSON writes them, lists by commas, strings bare.
fn compact(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Array(a) => a.iter().map(compact).collect::<Vec<_>>().join(","),
        v => v.to_string(),
    }
}

/// The thumbnail each variant keeps beside its preview, so merging 10,000 variants
/// decodes 10,000 small pictures, not 10,000 full ones (a whole merge of 10,000 took
/// 30 s with full ones, 11 s with thumbnails, on two shared cores).
pub const THUMB_FILE: &str = "thumb.png";

/// A preview picture (PNG bytes) shrunk to a tile, as PNG bytes.
pub fn thumbnail(preview: &[u8]) -> Result<Vec<u8>> {
    let Some((w, h, rgb)) = decode(preview) else {
        bail!("the preview picture could not be read back for its thumbnail");
    };
    encode(TILE_W, TILE_H, &shrink(w, h, &rgb))
}

/// A variant's tile from its thumbnail; a missing or unreadable picture is a grey tile
/// (the manifest vouched for the variant; its picture is only a view of it).
fn tile(path: &Path) -> Vec<u8> {
    let picture = std::fs::read(path).ok().and_then(|b| decode(&b));
    match picture {
        Some((w, h, rgb)) => shrink(w, h, &rgb),
        None => vec![90u8; TILE_W * TILE_H * 3],
    }
}

/// A picture shrunk (or stretched) to a tile, each tile pixel the mean of those it covers.
fn shrink(w: usize, h: usize, rgb: &[u8]) -> Vec<u8> {
    let span = |t: usize, n: usize, tiles: usize| {
        let a = t * n / tiles;
        (a, ((t + 1) * n / tiles).clamp(a + 1, n.max(a + 1)))
    };
    let mut out = Vec::with_capacity(TILE_W * TILE_H * 3);
    for ty in 0..TILE_H {
        let (ya, yb) = span(ty, h, TILE_H);
        for tx in 0..TILE_W {
            let (xa, xb) = span(tx, w, TILE_W);
            let mut sum = [0u32; 3];
            for y in ya..yb.min(h) {
                for x in xa..xb.min(w) {
                    let i = (y * w + x) * 3;
                    for c in 0..3 {
                        sum[c] += rgb[i + c] as u32;
                    }
                }
            }
            let n = ((yb.min(h).saturating_sub(ya)) * (xb.min(w).saturating_sub(xa))).max(1) as u32;
            out.extend(sum.map(|s| (s / n) as u8));
        }
    }
    out
}

/// An 8-bit RGB or RGBA PNG as width, height and RGB bytes.
fn decode(bytes: &[u8]) -> Option<(usize, usize, Vec<u8>)> {
    let mut reader = png::Decoder::new(Cursor::new(bytes)).read_info().ok()?;
    let mut buf = vec![0; reader.output_buffer_size()?];
    let info = reader.next_frame(&mut buf).ok()?;
    if info.bit_depth != png::BitDepth::Eight {
        return None;
    }
    let (w, h) = (info.width as usize, info.height as usize);
    let rgb = match info.color_type {
        png::ColorType::Rgb => buf[..w * h * 3].to_vec(),
        png::ColorType::Rgba => buf[..w * h * 4]
            .chunks(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect(),
        _ => return None,
    };
    Some((w, h, rgb))
}

fn encode(width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, width as u32, height as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    // Fast deflate, and pages drawn in parallel: with both, merging 10,000 variants went
    // from 11 s to 7 s on two cores (a page is 0.8 MB).
    enc.set_compression(png::Compression::Fast);
    let written = enc
        .write_header()
        .and_then(|mut w| w.write_image_data(rgb).and_then(|()| w.finish()));
    if let Err(e) = written {
        bail!("the contact sheet could not be encoded: {e}");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::farm::PlanKey;

    fn plan(n: usize) -> Plan {
        Plan {
            format: crate::farm::PLAN_FORMAT.into(),
            scene: "shot.toml".into(),
            inputs: Vec::new(),
            mode: "cross".into(),
            keys: vec![PlanKey {
                key: "blast[0].tnt_kg".into(),
                label: "tnt_kg".into(),
            }],
            tasks: vec![(0..n).collect()],
            variants: (0..n)
                .map(|i| PlanVariant {
                    index: i,
                    name: format!("{i}_tnt_kg={i}"),
                    task: 0,
                    seeds: Default::default(),
                    values: [("blast[0].tnt_kg".to_string(), Value::from(i))]
                        .into_iter()
                        .collect(),
                })
                .collect(),
        }
    }

    #[test]
    fn many_variants_are_paged_and_labelled() {
        let job = std::env::temp_dir().join(format!("ragdoll-sheet-{}", std::process::id()));
        let pages = pages(&job, &plan(PER_PAGE + 1)).unwrap();
        assert_eq!(pages.len(), 2);
        let (w, h, first) = decode(&pages[0]).unwrap();
        assert_eq!(
            (w, h),
            (
                COLUMNS * (TILE_W + GAP) + GAP,
                ROWS * (TILE_H + 22 + GAP) + GAP
            )
        );
        // A missing preview is a grey tile; its label is drawn under it in white.
        assert_eq!(&first[(GAP * w + GAP) * 3..][..3], &[90, 90, 90]);
        let label_rows = (GAP + TILE_H)..(GAP + TILE_H + 22);
        let white = label_rows
            .flat_map(|y| (GAP..GAP + TILE_W).map(move |x| (y * w + x) * 3))
            .filter(|&i| first[i] == 250)
            .count();
        assert!(white > 20, "{white} white pixels in the label");
        let (w2, _, _) = decode(&pages[1]).unwrap();
        assert_eq!(w2, TILE_W + 2 * GAP, "the last page holds one");
        assert_eq!(label(&plan(3), &plan(3).variants[2]), ["2", "tnt_kg=2"]);
    }
}
