//! The frame-time overlay: a built-in 3x5 bitmap font (digits, upper-case letters and a
//! little punctuation) rasterised on the CPU into the R8 overlay texture
//! ([`crate::renderer::OVERLAY_SIZE`]) that the tone-map pass blends over the image.

use crate::renderer::OVERLAY_SIZE;

/// 3x5 glyphs, one row per `u8` (bit 2 = left column), top row first.
fn glyph(c: char) -> [u8; 5] {
    match c.to_ascii_uppercase() {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 2, 2],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'C' => [7, 4, 4, 4, 7],
        'D' => [6, 5, 5, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'F' => [7, 4, 6, 4, 4],
        'G' => [7, 4, 5, 5, 7],
        'H' => [5, 5, 7, 5, 5],
        'I' => [7, 2, 2, 2, 7],
        'J' => [1, 1, 1, 5, 7],
        'K' => [5, 5, 6, 5, 5],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [6, 5, 5, 5, 5],
        'O' => [7, 5, 5, 5, 7],
        'P' => [7, 5, 7, 4, 4],
        'Q' => [7, 5, 5, 7, 1],
        'R' => [7, 5, 6, 5, 5],
        'S' => [7, 4, 7, 1, 7],
        'T' => [7, 2, 2, 2, 2],
        'U' => [5, 5, 5, 5, 7],
        'V' => [5, 5, 5, 5, 2],
        'W' => [5, 5, 7, 7, 5],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        'Z' => [7, 1, 2, 4, 7],
        '.' => [0, 0, 0, 0, 2],
        ',' => [0, 0, 0, 2, 4],
        ':' => [0, 2, 0, 2, 0],
        '-' => [0, 0, 7, 0, 0],
        '/' => [1, 1, 2, 4, 4],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        '=' => [0, 7, 0, 7, 0],
        _ => [0; 5],
    }
}

/// Pixel scale of the font (each glyph cell is 4x6 font pixels including spacing).
const SCALE: usize = 2;

/// Rasterises `text` (one line, clipped) into an R8 image of [`OVERLAY_SIZE`]: 255 on
/// glyph pixels, 0 elsewhere.
pub fn render_text(text: &str) -> Vec<u8> {
    let (w, h) = (OVERLAY_SIZE.0 as usize, OVERLAY_SIZE.1 as usize);
    let mut img = vec![0u8; w * h];
    let (x0, y0) = (SCALE, (h - 5 * SCALE) / 2);
    for (k, c) in text.chars().enumerate() {
        let g = glyph(c);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) == 0 {
                    continue;
                }
                for dy in 0..SCALE {
                    for dx in 0..SCALE {
                        let x = x0 + (k * 4 + col) * SCALE + dx;
                        let y = y0 + row * SCALE + dy;
                        if x < w && y < h {
                            img[y * w + x] = 255;
                        }
                    }
                }
            }
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_lights_pixels_and_blank_does_not() {
        assert!(render_text("   ").iter().all(|&p| p == 0));
        let t = render_text("16.7 MS");
        let lit = t.iter().filter(|&&p| p == 255).count();
        // '1' has 9 pixels of the 3x5 grid... at least 30 font pixels over 6 glyphs.
        assert!(lit >= 30 * SCALE * SCALE, "{lit}");
    }
}
