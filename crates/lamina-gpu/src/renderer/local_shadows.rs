//! Shadows of the lights besides the first sun ([`super::lights::MAX_SHADOWED_LIGHTS`] at
//! most), baked once at load (lights and geometry are static; only the first sun moves per
//! frame): for a further sun, one orthographic two-layer map like the first sun's; for a
//! point, sphere or quad light, a cube of them.
//!
//! Each of a cube's six 90° faces ([`CUBE_FACES`]) holds, like the sun's maps, the nearest
//! alpha-tested occluder (layer 1) and the next one behind it (layer 2, depth peeling):
//! depth and transmittance colour with card radius. Depth is the distance from the light's
//! centre over the cube's range, written by the fragment shader (`fs_cube_first`,
//! `fs_cube_peel`), so it is linear and the same on every face: the camera pass compares
//! distances across face seams without a conversion. Layers of the two array textures: a
//! light's first layer (`color.w` of its uniform) plus `2 * face + layer` (a sun: `layer`).
//!
//! The camera pass (`local_transmittance` in scene.wgsl) reads a light's visibility by
//! percentage-closer filtering with 16 taps on a rotated Vogel disc, each tap a direction
//! that finds its own face: one texel wide for a point light; for a sphere (radius `R`) or
//! a quad (the disc of its area, radius `sqrt(A / π)`), percentage-closer soft shadows
//! (Fernando 2005): a blocker search, then a filter as wide as the penumbra
//! `R (d_r - d_b) / (d_r d_b)` (radians, receiver `d_r` and mean blocker `d_b` from the
//! light).

use super::bounds::SceneBounds;
use super::culling::{CullView, Phase};
use super::geometry::Geometry;
use super::layout::{D2_ARRAY, DEPTH_FORMAT, SHADOW_COLOR_FORMAT, texture_2d};
use super::lights::{Globals, ShadowMaps, shadow_range};
use super::pipelines::ScenePipelines;
use super::projection::{CUBE_FACES, cube_face_matrix, light_matrix};
use super::sun::{BakedView, encode_baked_view, layer_view};
use crate::context::GpuContext;
use crate::error::GpuError;
use glam::{Mat4, Vec3};

/// The shadow maps baked at load of the lights besides the first sun.
pub(super) struct LocalShadows {
    /// Depth (distance over range) and transmittance (rgb, card radius in a), one array
    /// layer per light, face and layer.
    textures: [wgpu::Texture; 2],
    /// The same as 2D-array views, for the camera pass.
    pub array_views: [wgpu::TextureView; 2],
    /// Side of each map, texels (0 when no light has one).
    pub size: u32,
}

impl LocalShadows {
    /// Empty maps of side `size` (already clamped to the device) in `layers` array
    /// layers; with none, a 1-texel stand-in that the camera pass never reads.
    pub fn new(device: &wgpu::Device, size: u32, layers: u32) -> Self {
        let empty = layers == 0;
        let (side, layers) = if empty { (1, 2) } else { (size, layers) };
        let mk = |label: &str, format: wgpu::TextureFormat| {
            let usage =
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
            texture_2d(device, label, (side, side, layers), format, usage)
        };
        let textures = [
            mk("local shadow depth", DEPTH_FORMAT),
            mk("local shadow transmittance", SHADOW_COLOR_FORMAT),
        ];
        let array_views = textures.each_ref().map(|t| {
            t.create_view(&wgpu::TextureViewDescriptor {
                dimension: Some(D2_ARRAY),
                ..Default::default()
            })
        });
        LocalShadows {
            textures,
            array_views,
            size: if empty { 0 } else { size },
        }
    }

    /// GPU memory of the maps, bytes.
    pub fn bytes(&self) -> u64 {
        let t = &self.textures[0];
        let texels = t.width() as u64 * t.height() as u64 * t.depth_or_array_layers() as u64;
        // Depth32Float and Rgba16Float.
        texels * (4 + 8)
    }

    /// Renders `maps` (first layer, kind), each light in its own submission (the culling
    /// pass, when the device has one, thins leaves out as seen from the light at the maps'
    /// resolution), with `base` as the globals of every view but its matrix and centre;
    /// waits for validation.
    pub fn bake(
        &self,
        ctx: &GpuContext,
        maps: &[(u32, ShadowMaps)],
        bounds: &SceneBounds,
        base: Globals,
        lod_pixels: f32,
        scene: (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
    ) -> Result<(), GpuError> {
        let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        for &(first, maps) in maps {
            let mut encoder = ctx.device.create_command_encoder(&Default::default());
            let (position, focal_px, ortho) = match maps {
                // A 90° face: the focal length is half its side.
                ShadowMaps::Cube { center } => (center, 0.5 * self.size as f32, None),
                ShadowMaps::Directional { tiles, .. } => {
                    let r = bounds.casters.1.max(1e-6);
                    (
                        Vec3::ZERO,
                        1.0,
                        Some((tiles * self.size) as f32 / (2.0 * r)),
                    )
                }
            };
            if let Some(c) = &scene.1.culling {
                let view = CullView {
                    view_proj: Mat4::IDENTITY,
                    position,
                    focal_px,
                    lod_pixels,
                    frustum: false,
                    ortho_px_per_m: ortho,
                    phase: Phase::All,
                };
                c.encode(&ctx.queue, &mut encoder, &view, None, None);
            }
            match maps {
                ShadowMaps::Cube { center } => {
                    let range = shadow_range(center, bounds);
                    for face in 0..CUBE_FACES.len() {
                        let mut g = base;
                        g.light_view_proj =
                            cube_face_matrix(face, center, range).to_cols_array_2d();
                        g.cube = center.extend(range).to_array();
                        let layer = first + 2 * face as u32;
                        let cube = (&scene.0.cube_first, &scene.0.cube_peel);
                        self.encode_view(&ctx.device, &mut encoder, layer, &g, cube, scene);
                    }
                }
                ShadowMaps::Directional { direction, tiles } => {
                    let (c, r) = bounds.casters;
                    let whole = light_matrix(direction, c, r);
                    let sun = (&scene.0.shadow_first, &scene.0.shadow_peel);
                    for k in 0..tiles * tiles {
                        let mut g = base;
                        g.light_view_proj =
                            (tile_matrix(k % tiles, k / tiles, tiles) * whole).to_cols_array_2d();
                        let layer = first + 2 * k;
                        self.encode_view(&ctx.device, &mut encoder, layer, &g, sun, scene);
                    }
                }
            }
            ctx.queue.submit([encoder.finish()]);
        }
        match pollster::block_on(scope.pop()) {
            None => Ok(()),
            Some(e) => Err(GpuError::Validation {
                what: "baking the shadow maps of the lights besides the first sun".into(),
                message: e.to_string(),
            }),
        }
    }

    /// Records the two layers of one view (array layers `first`, `first + 1`) with `g`,
    /// by `pipelines` (layer 1, layer 2).
    fn encode_view(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        first: u32,
        g: &Globals,
        pipelines: (&wgpu::RenderPipeline, &wgpu::RenderPipeline),
        scene: (&ScenePipelines, &Geometry, &[wgpu::BindGroup]),
    ) {
        let [d, c] = &self.textures;
        let view = BakedView {
            g,
            depth: [layer_view(d, first), layer_view(d, first + 1)],
            color: [layer_view(c, first), layer_view(c, first + 1)],
            pipelines,
        };
        encode_baked_view(device, encoder, &view, scene);
    }
}

/// The clip-space map that makes tile `(i, j)` (column, row from the top left) of a view
/// cut into `n x n` tiles fill the viewport: `x' = n (x + 1) - 2 i - 1`,
/// `y' = n (y - 1) + 2 j + 1`, depth kept.
fn tile_matrix(i: u32, j: u32, n: u32) -> Mat4 {
    let n = n as f32;
    Mat4::from_cols(
        glam::Vec4::new(n, 0.0, 0.0, 0.0),
        glam::Vec4::new(0.0, n, 0.0, 0.0),
        glam::Vec4::Z,
        glam::Vec4::new(
            n - 2.0 * i as f32 - 1.0,
            -n + 2.0 * j as f32 + 1.0,
            0.0,
            1.0,
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tile (i, j) of n maps the corners of its share of the whole view to the viewport's.
    #[test]
    fn tiles_cover_the_view() {
        let n = 4;
        for (i, j) in [(0, 0), (3, 0), (1, 2), (3, 3)] {
            let m = tile_matrix(i, j, n);
            let x0 = -1.0 + 2.0 * i as f32 / n as f32;
            let y0 = 1.0 - 2.0 * j as f32 / n as f32;
            let step = 2.0 / n as f32;
            let tl = m * glam::Vec4::new(x0, y0, 0.3, 1.0);
            let br = m * glam::Vec4::new(x0 + step, y0 - step, 0.3, 1.0);
            assert!(
                (tl - glam::Vec4::new(-1.0, 1.0, 0.3, 1.0)).length() < 1e-5,
                "{tl}"
            );
            assert!(
                (br - glam::Vec4::new(1.0, -1.0, 0.3, 1.0)).length() < 1e-5,
                "{br}"
            );
        }
    }
}
