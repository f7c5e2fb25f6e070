//! Renders split into parts: sample ranges that add up to the whole render, crops equal to
//! the same pixels of the whole image, and their option errors.

use super::scenes::*;
use crate::{Crop, RenderOptions, SampleRange, render};
use glam::DVec3;
use lamina_core::PixelFilter;

/// Distance in units in the last place between two finite non-negative f32s.
fn ulps(a: f32, b: f32) -> u32 {
    (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs() as u32
}

/// Parts `k/n` of the samples, summed in f64 and turned into the mean as the film does,
/// equal the single render: every channel within 1 ulp (the f64 sums can differ only in
/// the order of additions), and bit-identical here (sums of f32 samples of similar size
/// are exact in f64).
#[test]
fn sample_parts_merge_to_the_whole_render() {
    let mut scene = small_canopy_scene();
    // A wide Gaussian filter: samples spread over ±2 px must still stay in their pixel.
    scene.film.filter = PixelFilter::Gaussian {
        radius: 2.0,
        sigma: 0.8,
    };
    let spp = 37;
    let whole = render(&scene, &opts(spp, 2)).unwrap();
    for n in [2u32, 3, 5] {
        let mut sums = vec![DVec3::ZERO; whole.image.pixels.len()];
        let mut covered = 0;
        for k in 0..n {
            let range = SampleRange::part(k, n, spp);
            let out = render(
                &scene,
                &RenderOptions {
                    samples: Some(range),
                    keep_sums: true,
                    ..opts(spp, 2)
                },
            )
            .unwrap();
            assert_eq!(out.stats.sample_range, range);
            assert_eq!(out.stats.spp_done, range.len());
            covered += range.len();
            for (s, p) in sums.iter_mut().zip(out.sums.unwrap()) {
                *s += p;
            }
        }
        assert_eq!(covered, spp);
        let mut identical = 0;
        for (s, w) in sums.iter().zip(&whole.image.pixels) {
            let m = (*s * (1.0 / spp as f64)).as_vec3();
            for c in 0..3 {
                assert!(ulps(m[c], w[c]) <= 1, "{n} parts: {} vs {}", m[c], w[c]);
                identical += (m[c].to_bits() == w[c].to_bits()) as usize;
            }
        }
        assert_eq!(identical, 3 * sums.len(), "{n} parts");
    }
}

/// A crop's pixels are bit-identical to the same pixels of the whole image, for crops
/// that cut through tiles and touch the edges, and crops tile the image with no seam.
#[test]
fn crops_equal_the_whole_image() {
    let mut scene = small_canopy_scene();
    scene.film.filter = PixelFilter::Tent { radius: 1.5 };
    let (w, h) = (scene.film.width, scene.film.height);
    let whole = render(&scene, &opts(6, 2)).unwrap().image;
    let cuts_x = [0, 7, w / 2 + 3, w];
    let cuts_y = [0, h / 3, h];
    let mut stitched = vec![glam::Vec3::splat(-1.0); (w * h) as usize];
    for xs in cuts_x.windows(2) {
        for ys in cuts_y.windows(2) {
            let crop = Crop {
                x0: xs[0],
                y0: ys[0],
                x1: xs[1],
                y1: ys[1],
            };
            let out = render(
                &scene,
                &RenderOptions {
                    crop: Some(crop),
                    ..opts(6, 1)
                },
            )
            .unwrap();
            assert_eq!(
                (out.image.width, out.image.height),
                (crop.width(), crop.height())
            );
            assert_eq!(out.stats.crop, crop);
            for y in 0..crop.height() {
                for x in 0..crop.width() {
                    let at = ((crop.y0 + y) * w + crop.x0 + x) as usize;
                    stitched[at] = out.image.pixels[(y * crop.width() + x) as usize];
                }
            }
        }
    }
    assert_eq!(stitched, whole.pixels);
}

/// A part stopped early holds a prefix of its range; ranges and crops that make no sense
/// are errors.
#[test]
fn bad_ranges_and_crops_are_errors() {
    let scene = small_canopy_scene();
    let (w, h) = (scene.film.width, scene.film.height);
    let bad_ranges = [(3, 3), (5, 2), (0, 9)];
    for (start, end) in bad_ranges {
        let o = RenderOptions {
            samples: Some(SampleRange { start, end }),
            ..opts(8, 1)
        };
        let e = render(&scene, &o).unwrap_err().to_string();
        assert!(e.contains("sample range"), "{e}");
    }
    let bad_crops = [(0, 0, 0, 4), (0, 0, w + 1, h), (2, 2, 1, 5), (0, h, w, h)];
    for (x0, y0, x1, y1) in bad_crops {
        let o = RenderOptions {
            crop: Some(Crop { x0, y0, x1, y1 }),
            ..opts(1, 1)
        };
        let e = render(&scene, &o).unwrap_err().to_string();
        assert!(e.contains("crop"), "{e}");
    }
    assert_eq!(SampleRange::part(0, 3, 2).len(), 0);
    assert_eq!(
        (0..7)
            .map(|k| SampleRange::part(k, 7, 100).len())
            .sum::<u32>(),
        100
    );
}
