//! Procedural leaves: the seven maps from a species preset and a seed.
//!
//! # Method
//! * **Outline**: an implicit shape in *design space* (main lobe length 1, petiole junction at
//!   the origin, tip toward `+y`). Every lobe is a region along an axis whose half-width
//!   follows a profile `t^a (1-t)^b` ([`Profile`](crate::species::Profile)); palmate leaves (maple, ivy) are a smooth
//!   union of several lobes fanned out from the petiole, pinnately lobed ones (oak) modulate
//!   the half-width with rounded lobes and sinuses, and the margin carries serrate, doubly
//!   serrate or crenate teeth as a periodic perturbation of the half-width along the axis (so
//!   the teeth point toward the apex, as in real serrate leaves). The seed jitters lobe angles,
//!   lengths and widths, left/right asymmetry, tooth phase and a slight bend of the midrib.
//! * **Venation**: a primary vein along each lobe axis (the midrib, or the five primaries of
//!   a palmate leaf); secondaries leave it at a species angle that flattens toward the tip
//!   and are *grown* step by step, bending toward the tip with a species curvature, until
//!   they reach the margin (craspedodromous: beech, birch, oak, maple) or arch along it
//!   (brochidodromous: ivy, willow); oak secondaries aim at the lobe tips. Some species get
//!   side branches running to the teeth. The higher orders (tertiary and quaternary veins)
//!   form a reticulate net of closed loops, the *areoles*; instead of growing them too
//!   (space colonisation after Runions et al. 2005 would), we take the edges of two
//!   domain-warped Voronoi diagrams at the species' areole size and a third of it: Voronoi
//!   edges are exactly closed polygonal loops around seed points, which is what areoles look
//!   like, at a constant cost per pixel and independent of resolution. The major veins are
//!   rasterised as tapered capsules with a round cross-section (which gives their relief).
//!   Grass blades get parallel veins instead.
//! * **Colour**: mesophyll albedo from the preset with low-frequency mottling (pigment
//!   variation), a yellowing term and fine grain; veins lighter on the front; the back paler
//!   and less saturated with more visible veins; the through-light colour yellow-green with
//!   veins darker (they are thicker, and absorb more) and the thin rim a little brighter.
//! * **Data maps**: extinction = `1 - Y'(translucency)`, thickness = its blur (as the paper
//!   derives them from a scan, see [`crate::folder`]); bump = veins as grooves seen from the
//!   adaxial side, i.e. raised on the abaxial side, plus a slight bulge of the areoles;
//!   alpha from the outline, anti-aliased over one pixel.
//!
//! # Layout
//! [`generate()`] runs the steps in order: `outline` (the implicit outline and its
//! seeded jitter), `card` (the pixel grid fitted around it), `veins` (major veins grown
//! and rasterised), `pixels` (per-pixel colours, alpha and bump), then the data maps.

mod card;
mod outline;
mod pixels;
mod veins;

use crate::folder::{MapPlanes, extinction_from_translucency, thickness_from_extinction};
use crate::noise::Rng;
use crate::plane::{Gray, Plane, Rgb};
use crate::species::{Preset, Species};
use crate::{FolderWrite, LeafMapsError, write_leaf_folder};
use card::fit_card;
use lamina_leaf::{LeafMaps, LeafParams};
use outline::build_outline;
use pixels::{PixelInputs, Px, shade_pixels};
use std::path::{Path, PathBuf};
use veins::{build_veins, raster_veins};

/// What to generate: a preset, a seed and the resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct LeafSpec {
    /// The species preset (built in via [`Species::preset`], or custom).
    pub preset: Preset,
    /// Seed of every random choice: the same spec gives a bit-identical leaf.
    pub seed: u64,
    /// Pixels along the longer side of the card (clamped to `[16, 16384]`); the shorter side
    /// follows from the outline's aspect ratio.
    pub resolution: u32,
}

impl LeafSpec {
    /// A spec for a built-in species.
    pub fn new(species: Species, seed: u64, resolution: u32) -> Self {
        LeafSpec {
            preset: species.preset(),
            seed,
            resolution,
        }
    }
}

/// A generated leaf: the seven maps, its parameters and the size of its card.
#[derive(Clone, Debug)]
pub struct GeneratedLeaf {
    /// The maps as textures (linear values, clamped addressing), ready for
    /// [`lamina_leaf::LeafMaterial::new`].
    pub maps: LeafMaps,
    /// The preset's parameters, with [`LeafParams::bump_scale`] set to match the bump map.
    pub params: LeafParams,
    /// Card width and height in metres (`u` across the width, `v` along the height; the leaf
    /// tip is at the top, `v = 1`, the petiole at the bottom).
    pub size_m: (f32, f32),
    /// The same maps as planes (what [`GeneratedLeaf::write_folder`] writes).
    pub planes: MapPlanes,
    /// Preset name.
    pub species: String,
    /// The seed.
    pub seed: u64,
}

impl GeneratedLeaf {
    /// Writes the leaf folder (seven PNG maps and `leaf.toml`), replacing only a leaf folder
    /// lamina wrote; see [`write_leaf_folder`]. Returns the folder.
    pub fn write_folder(&self, dir: &Path) -> Result<PathBuf, LeafMapsError> {
        self.write_folder_with(dir, &FolderWrite::default())
    }

    /// [`GeneratedLeaf::write_folder`] with an explicit rule for an existing folder
    /// (e.g. [`crate::Replace::Force`]).
    pub fn write_folder_with(
        &self,
        dir: &Path,
        how: &FolderWrite,
    ) -> Result<PathBuf, LeafMapsError> {
        let (w, h) = self.planes.size();
        let comments = vec![
            format!(
                "Procedural {} leaf, seed {}, {w}x{h} px, generated by lamina-leafmaps.",
                self.species, self.seed
            ),
            format!(
                "Card size: {:.4} m wide x {:.4} m high (tip at the top, petiole at the bottom).",
                self.size_m.0, self.size_m.1
            ),
            "All seven maps are procedural: outline, venation and colour from the species preset;"
                .into(),
            "extinction = 1 - luma(translucency), thickness = its blur re-centred on 0.5.".into(),
        ];
        write_leaf_folder(dir, &self.planes, &self.params, &comments, how)
    }
}

/// Generates a leaf (see the module docs for the method). Deterministic in the spec.
pub fn generate(spec: &LeafSpec) -> GeneratedLeaf {
    let p = &spec.preset;
    let res = spec.resolution.clamp(16, 16384) as usize;
    let mut rng = Rng::new(spec.seed, 1);
    let seed32 = (spec.seed ^ (spec.seed >> 32)) as u32;

    // Design units -> mm: the card height (leaf length incl. petiole stub) is height_m.
    // The outline is built first with a provisional scale, then the card is fitted around it.
    let provisional_mm_per_unit = p.height_m * 1000.0 / (1.0 + p.outline.petiole + 0.06);
    let midrib_r0 = 0.5 * p.venation.midrib_mm / provisional_mm_per_unit;
    let outline = build_outline(p, &mut rng, midrib_r0 * 1.1);
    let grid = fit_card(&outline, res);
    let (w, h, ppu) = (grid.w, grid.h, grid.ppu);
    let (card_w, card_h) = grid.card_size();
    let mm_per_unit = p.height_m * 1000.0 / card_h;
    let px_per_mm = ppu / mm_per_unit;
    let midrib_r = 0.5 * p.venation.midrib_mm / mm_per_unit;

    let mut timer = crate::PhaseTimer::new();
    let segs = build_veins(&outline, p, midrib_r, &mut rng);
    timer.lap("veins grown");
    let (vein_cover, vein_height) =
        raster_veins(&segs, &outline, &grid, p.vein_relief_mm, midrib_r);
    timer.lap("veins rasterised");
    // Outline function on the grid (for alpha and the distance to the margin).
    let field = Plane::from_fn(w, h, |x, y| {
        outline.field(outline.to_design(grid.card(x, y))) * ppu
    });
    timer.lap("outline");
    let range_mm = p.vein_relief_mm * 1.1 + 0.06;
    let pixels = shade_pixels(&PixelInputs {
        preset: p,
        outline: &outline,
        grid: &grid,
        field: &field,
        vein_cover: &vein_cover,
        vein_height: &vein_height,
        mm_per_unit,
        px_per_mm,
        range_mm,
        seed32,
    });
    timer.lap("pixels");

    let planes = data_maps(pixels, px_per_mm);
    timer.lap("extinction+thickness");
    let size_m = (card_w * mm_per_unit / 1000.0, p.height_m);
    let mut params = p.params;
    // One unit of bump map value spans 2 * range_mm; express it in texture-space units,
    // taking the geometric mean of the card sides as the texture-space unit length.
    params.bump_scale = (2.0 * range_mm / 1000.0 / (size_m.0 * size_m.1).sqrt()).clamp(0.0, 1.0);
    let maps = planes.to_leaf_maps();
    timer.lap("textures");
    GeneratedLeaf {
        maps,
        params,
        size_m,
        planes,
        species: p.name.clone(),
        seed: spec.seed,
    }
}

/// The seven map planes from the per-pixel maps: the colour maps, alpha and bump as they
/// are, extinction from the translucency and thickness its blur (`px_per_mm` sets the
/// blur radius).
fn data_maps(pixels: Plane<Px>, px_per_mm: f32) -> MapPlanes {
    let front: Rgb = pixels.map(|p| p.0);
    let back: Rgb = pixels.map(|p| p.1);
    let translucency: Rgb = pixels.map(|p| p.2);
    let alpha: Gray = pixels.map(|p| p.3);
    let bump: Gray = pixels.map(|p| p.4);
    drop(pixels);
    let extinction = extinction_from_translucency(&translucency);
    let thickness = thickness_from_extinction(&extinction, &alpha, 0.3 * px_per_mm, 1.5);
    MapPlanes {
        front,
        back,
        translucency,
        alpha,
        thickness,
        extinction,
        bump,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn every_preset_generates_a_sane_leaf() {
        for s in Species::ALL {
            let leaf = generate(&LeafSpec::new(s, 7, 160));
            let (w, h) = leaf.planes.size();
            assert!(w.max(h) == 160, "{s}: {w}x{h}");
            let a = &leaf.planes.alpha.data;
            let cover = a.iter().filter(|v| **v >= 0.5).count() as f32 / a.len() as f32;
            assert!((0.04..0.9).contains(&cover), "{s}: alpha cover {cover}");
            // Border is transparent except the petiole at the bottom.
            for x in 0..w {
                assert!(leaf.planes.alpha.get(x, 0) < 0.5, "{s}: top row opaque");
            }
            // Back paler than front, translucency yellow-green, inside the leaf.
            let mean = |p: &Rgb| {
                let mut acc = Vec3::ZERO;
                let mut n = 0.0;
                for (c, a) in p.data.iter().zip(a) {
                    if *a >= 0.5 {
                        acc += Vec3::from_array(*c);
                        n += 1.0;
                    }
                }
                acc / n
            };
            let (f, b, t) = (
                mean(&leaf.planes.front),
                mean(&leaf.planes.back),
                mean(&leaf.planes.translucency),
            );
            assert!(
                b.dot(Vec3::ONE) > f.dot(Vec3::ONE),
                "{s}: back {b} not paler than front {f}"
            );
            assert!(t.y > t.x && t.y > t.z, "{s}: translucency {t} not green");
            assert!(f.y < 0.3 && f.y > 0.02, "{s}: front {f} not a leaf albedo");
            leaf.params.validate().unwrap();
            let (e0, e1) = leaf.planes.extinction.min_max();
            assert!(e0 >= 0.0 && e1 <= 1.0);
            assert!(leaf.size_m.0 > 0.0 && leaf.size_m.1 > leaf.size_m.0 * 0.5);
        }
    }

    #[test]
    fn deterministic_and_seed_dependent() {
        let a = generate(&LeafSpec::new(Species::Beech, 3, 96));
        let b = generate(&LeafSpec::new(Species::Beech, 3, 96));
        let c = generate(&LeafSpec::new(Species::Beech, 4, 96));
        assert_eq!(a.planes.front.data, b.planes.front.data);
        assert_ne!(a.planes.front.data, c.planes.front.data);
    }
}
