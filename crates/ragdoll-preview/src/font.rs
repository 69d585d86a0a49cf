//! The frame counter's font: 5×7 pixel glyphs for the few characters it needs (digits,
//! `/`, `.`, `s`, space), drawn scaled up with a dark outline so they read on any
//! background. Small enough to keep in the source; no font file, no font crate.

/// Rows top to bottom, bit 4 the leftmost pixel.
fn glyph(c: char) -> Option<[u8; 7]> {
    Some(match c {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1E, 0x01, 0x01, 0x0E, 0x01, 0x01, 0x1E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        '/' => [0x01, 0x02, 0x02, 0x04, 0x08, 0x08, 0x10],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        's' => [0x00, 0x00, 0x0F, 0x10, 0x0E, 0x01, 0x1E],
        ' ' => [0; 7],
        _ => return None,
    })
}

/// Draws `text` into an RGB8 image with its top-left corner at `(x, y)`, each font pixel
/// `scale × scale`, white on a one-pixel dark outline. Characters without a glyph and
/// pixels outside the image are skipped.
pub fn draw_text(
    rgb: &mut [u8],
    width: usize,
    height: usize,
    x: usize,
    y: usize,
    scale: usize,
    text: &str,
) {
    let lit = |cx: i64, cy: i64, rows: &[u8; 7]| {
        (0..5).contains(&cx) && (0..7).contains(&cy) && rows[cy as usize] & (0x10 >> cx) != 0
    };
    for (k, c) in text.chars().enumerate() {
        let Some(rows) = glyph(c) else { continue };
        let gx = x + k * 6 * scale;
        // Outline first (any lit neighbour), then the glyph over it.
        for pass in 0..2 {
            for py in -1..8 * scale as i64 {
                for px in -1..6 * scale as i64 {
                    let (cx, cy) = (px.div_euclid(scale as i64), py.div_euclid(scale as i64));
                    let on = if pass == 0 {
                        (-1..=1).any(|dy| {
                            (-1..=1).any(|dx| {
                                lit(
                                    (px + dx).div_euclid(scale as i64),
                                    (py + dy).div_euclid(scale as i64),
                                    &rows,
                                )
                            })
                        })
                    } else {
                        lit(cx, cy, &rows)
                    };
                    let (ix, iy) = (gx as i64 + px, y as i64 + py);
                    if !on || ix < 0 || iy < 0 || ix >= width as i64 || iy >= height as i64 {
                        continue;
                    }
                    let i = (iy as usize * width + ix as usize) * 3;
                    let v = if pass == 0 { 30 } else { 250 };
                    rgb[i..i + 3].copy_from_slice(&[v, v, v]);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_counter_character_has_a_distinct_glyph() {
        let chars = "0123456789/.s";
        let glyphs: Vec<[u8; 7]> = chars.chars().map(|c| glyph(c).unwrap()).collect();
        for (i, a) in glyphs.iter().enumerate() {
            assert!(a.iter().any(|&r| r != 0));
            assert!(a.iter().all(|&r| r < 0x20), "wider than 5 pixels");
            for b in &glyphs[i + 1..] {
                assert_ne!(a, b);
            }
        }
    }

    #[test]
    fn text_is_drawn_white_where_the_glyph_is() {
        let (w, h) = (40, 20);
        let mut rgb = vec![128u8; w * h * 3];
        draw_text(&mut rgb, w, h, 2, 2, 2, "1");
        // The "1"'s stem: glyph column 2, rows 1..6 → pixels x = 2 + 4..6, y = 2 + 2..12.
        let at = |x: usize, y: usize| rgb[(y * w + x) * 3];
        assert_eq!(at(7, 8), 250);
        // Far from the glyph: untouched.
        assert_eq!(at(35, 15), 128);
    }
}
