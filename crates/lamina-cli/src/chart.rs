//! A small line chart as a PNG: spectra against wavelength (`lamina leaf fit`'s `fit.png`).
//! Axes with ticks and labels in a built-in 3x5 pixel font, solid or dotted series, a legend.

use image::{Rgb, RgbImage};

/// One series: points `(x, y)`, its colour, dotted or solid, its legend label.
pub struct Series<'a> {
    /// Points in data coordinates, in x order.
    pub points: Vec<(f64, f64)>,
    /// Line colour.
    pub colour: [u8; 3],
    /// Dotted (measured) or solid (model).
    pub dotted: bool,
    /// Legend text (upper case letters, digits, `.`, `-`, `:` and spaces).
    pub label: &'a str,
    /// Error bars: per point the half-length (data units) of a vertical bar; empty: none.
    pub errors: Vec<f64>,
}

/// The chart's frame: data ranges, tick spacing and the axis titles.
pub struct Chart<'a> {
    /// x range (data units).
    pub x: (f64, f64),
    /// y range (data units).
    pub y: (f64, f64),
    /// Tick spacing on x and y.
    pub ticks: (f64, f64),
    /// Axis titles.
    pub x_title: &'a str,
    /// Title above the plot.
    pub title: &'a str,
}

const W: u32 = 960;
const H: u32 = 540;
const LEFT: i32 = 70;
const RIGHT: i32 = 20;
const TOP: i32 = 40;
const BOTTOM: i32 = 60;

/// Draws `series` on `chart`.
pub fn draw(chart: &Chart, series: &[Series]) -> RgbImage {
    let mut img = RgbImage::from_pixel(W, H, Rgb([255, 255, 255]));
    let pw = W as i32 - LEFT - RIGHT;
    let ph = H as i32 - TOP - BOTTOM;
    let px = |x: f64, y: f64| -> (f64, f64) {
        (
            LEFT as f64 + (x - chart.x.0) / (chart.x.1 - chart.x.0) * pw as f64,
            (TOP + ph) as f64 - (y - chart.y.0) / (chart.y.1 - chart.y.0) * ph as f64,
        )
    };
    let grid = Rgb([228, 228, 228]);
    let black = Rgb([0, 0, 0]);
    // Grid and ticks.
    let mut x = (chart.x.0 / chart.ticks.0).ceil() * chart.ticks.0;
    while x <= chart.x.1 + 1e-9 {
        let (sx, _) = px(x, chart.y.0);
        for y in TOP..=TOP + ph {
            put(&mut img, sx as i32, y, grid);
        }
        let label = format!("{}", x as i64);
        text(
            &mut img,
            sx as i32 - 6 * label.len() as i32 / 2,
            TOP + ph + 8,
            &label,
            2,
            black,
        );
        x += chart.ticks.0;
    }
    let mut y = (chart.y.0 / chart.ticks.1).ceil() * chart.ticks.1;
    while y <= chart.y.1 + 1e-9 {
        let (_, sy) = px(chart.x.0, y);
        for x in LEFT..=LEFT + pw {
            put(&mut img, x, sy as i32, grid);
        }
        let decimals = (-chart.ticks.1.log10()).ceil().max(1.0) as usize;
        text(
            &mut img,
            8,
            sy as i32 - 5,
            &format!("{y:.decimals$}"),
            2,
            black,
        );
        y += chart.ticks.1;
    }
    for x in LEFT..=LEFT + pw {
        put(&mut img, x, TOP + ph, black);
        put(&mut img, x, TOP, black);
    }
    for y in TOP..=TOP + ph {
        put(&mut img, LEFT, y, black);
        put(&mut img, LEFT + pw, y, black);
    }
    text(
        &mut img,
        LEFT + pw / 2 - 4 * chart.x_title.len() as i32,
        TOP + ph + 32,
        chart.x_title,
        2,
        black,
    );
    text(&mut img, LEFT, 12, chart.title, 2, black);
    // Series.
    for s in series {
        let c = Rgb(s.colour);
        let mut run = 0usize;
        for w in s.points.windows(2) {
            let (a, b) = (px(w[0].0, w[0].1), px(w[1].0, w[1].1));
            let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
            for k in 0..=steps {
                run += 1;
                if s.dotted && (run / 3) % 2 == 1 {
                    continue;
                }
                let f = k as f64 / steps as f64;
                let (x, y) = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    put(&mut img, x as i32 + dx, y as i32 + dy, c);
                }
            }
        }
    }
    // Error bars, with caps.
    for s in series {
        let c = Rgb(s.colour);
        for (&(x, y), &e) in s.points.iter().zip(&s.errors) {
            let (sx, lo) = px(x, y - e);
            let (_, hi) = px(x, y + e);
            for yy in hi.round() as i32..=lo.round() as i32 {
                put(&mut img, sx as i32, yy, c);
            }
            for dx in -3..=3 {
                put(&mut img, sx as i32 + dx, hi.round() as i32, c);
                put(&mut img, sx as i32 + dx, lo.round() as i32, c);
            }
        }
    }
    // Legend, top right.
    for (k, s) in series.iter().enumerate() {
        let y = TOP + 10 + 16 * k as i32;
        let x = LEFT + pw - 230;
        for dx in 0..24 {
            if !(s.dotted && (dx / 3) % 2 == 1) {
                put(&mut img, x + dx, y + 4, Rgb(s.colour));
                put(&mut img, x + dx, y + 5, Rgb(s.colour));
            }
        }
        text(&mut img, x + 32, y, s.label, 2, black);
    }
    img
}

fn put(img: &mut RgbImage, x: i32, y: i32, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// Writes `s` at `(x, y)` (top left), each glyph pixel `scale` pixels square.
pub fn text(img: &mut RgbImage, x: i32, y: i32, s: &str, scale: i32, c: Rgb<u8>) {
    let mut cx = x;
    for ch in s.chars() {
        if let Some(g) = lamina_io::font::glyph(ch) {
            for (row, bits) in g.iter().enumerate() {
                for col in 0..3 {
                    if bits & (4 >> col) != 0 {
                        for dy in 0..scale {
                            for dx in 0..scale {
                                put(img, cx + col * scale + dx, y + row as i32 * scale + dy, c);
                            }
                        }
                    }
                }
            }
        }
        cx += 4 * scale;
    }
}
