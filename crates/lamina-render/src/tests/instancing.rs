//! Instancing in rendered images: instanced and flattened scenes render alike, and
//! deterministically. (The queries themselves are tested in the acceleration suite,
//! `crate::accel::tests`.)

use super::scenes::*;
use crate::render;
use glam::Affine3A;

/// Rendered images of instanced and flattened geometry agree: each pixel's samples use
/// the same random numbers, so only rounding differences remain (tiny, in a few pixels).
/// With identity transforms the geometry is bit-identical and so is almost every pixel.
#[test]
fn instanced_render_matches_flattened_render() {
    for transforms in [test_transforms(), vec![Affine3A::IDENTITY]] {
        let (inst, flat) = instanced_and_flat(&transforms);
        let a = render(&inst, &opts(8, 2)).unwrap().image;
        let b = render(&flat, &opts(8, 2)).unwrap().image;
        let (ma, mb) = (a.mean(), b.mean());
        assert!(mb.max_element() > 0.01, "not black: {mb}");
        assert!(
            (ma - mb).abs().max_element() < 0.01 * mb.max_element(),
            "{ma} vs {mb}"
        );
        let peak = b.pixels.iter().map(|p| p.max_element()).fold(0.0, f32::max);
        let off = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .filter(|(p, q)| (**p - **q).abs().max_element() > 1e-3 * peak)
            .count();
        assert!(
            off * 50 < a.pixels.len(),
            "{off} of {} pixels differ",
            a.pixels.len()
        );
    }
}

/// Instanced scenes render bit-identically for any thread count.
#[test]
fn instanced_render_is_deterministic() {
    let (inst, _) = instanced_and_flat(&test_transforms());
    let a = render(&inst, &opts(4, 1)).unwrap();
    let b = render(&inst, &opts(4, 2)).unwrap();
    assert_eq!(a.image, b.image);
    assert_eq!(a.stats.rays, b.stats.rays);
    assert!(a.image.mean().max_element() > 0.0);
}
