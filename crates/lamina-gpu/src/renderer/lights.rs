//! Lights and sky as the shader sees them: the per-frame uniform block (camera and light
//! matrices, the shadowed sun, up to [`MAX_LIGHTS`] point, quad, sphere and directional
//! lights, the sky's SH irradiance) and how scene lights become those.
//!
//! The first sun is the shadowed one (its direction may be overridden per frame); further
//! suns become unshadowed directional lights. A quad light is shaded by its exact
//! unshadowed irradiance (the vector form factor of the polygon, Lambert 1760 / Arvo 1994:
//! `E = L/2 Σ Θ_k Γ_k` over its edges), one-sided as on the CPU unless `two_sided`; a sphere
//! light is a point light of intensity `L π R²`, which is exact outside the sphere when all
//! of it is above the receiver's horizon. The first [`MAX_SHADOWED_LIGHTS`] of those cast
//! shadows through two-layer translucent maps baked at load ([`super::local_shadows`]):
//! further suns through one orthographic map each like the first sun's; point, sphere and
//! quad lights through a cube of them, hard for a point light, soft for a sphere (its
//! radius) and a quad (the disc of its area) by percentage-closer soft shadows.
//! [`Lighting::warnings`] names the lights that cast no shadows, the quads whose shadow
//! stands in for a long one, and the lights past [`MAX_LIGHTS`], which are left out.

use super::FrameView;
use super::bounds::SceneBounds;
use super::projection::{camera_matrix, light_matrix};
use crate::sky;
use glam::{Mat4, Vec3};
use lamina_scene::{Light, Scene, Sky};

/// Most lights besides the shadowed sun in the uniform block (`MAX_LIGHTS` in scene.wgsl).
pub(super) const MAX_LIGHTS: usize = 32;

/// Most lights besides the first sun with shadow maps baked at load (a cube of 12 array
/// layers for a point, sphere or quad light, 2 layers for a sun).
pub const MAX_SHADOWED_LIGHTS: usize = 8;

/// The shadow maps of one light besides the first sun, baked at load.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum ShadowMaps {
    /// Six 90° faces around `center` (m), two layers each.
    Cube { center: Vec3 },
    /// One orthographic view along `-direction` (`direction` toward the sun) of the
    /// casters' bounding sphere, two layers, as the first sun's, cut into `tiles x tiles`
    /// maps (one array layer pair each, row by row from the top left) so that it is as
    /// sharp as the first sun's.
    Directional { direction: Vec3, tiles: u32 },
}

impl ShadowMaps {
    /// Array layers they take.
    pub fn layers(&self) -> u32 {
        match self {
            ShadowMaps::Cube { .. } => 12,
            ShadowMaps::Directional { tiles, .. } => 2 * tiles * tiles,
        }
    }
}

/// A quad light longer than this many times its width is named in a warning: its soft
/// shadow is drawn as from the disc of its area at its centre.
const LONG_QUAD: f32 = 3.0;

/// One light in the uniform block (see `Light` in scene.wgsl for the kinds).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuLight {
    pos: [f32; 4],
    color: [f32; 4],
    u: [f32; 4],
    v: [f32; 4],
}

/// Per-frame uniforms (see `Globals` in scene.wgsl for the meaning and units).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct Globals {
    /// World-to-clip of the camera.
    pub view_proj: [[f32; 4]; 4],
    /// World-to-clip of the light view being rendered or sampled.
    pub light_view_proj: [[f32; 4]; 4],
    camera_pos: [f32; 4],
    /// Direction toward the sun, `w` = 1 when there is a sun.
    pub sun_dir: [f32; 4],
    sun_irr: [f32; 4],
    /// Sun map side (texels), world size of one of its texels (m), its depth range (m),
    /// side of each cube face of the local lights' maps (texels).
    pub shadow: [f32; 4],
    /// For a cube face's light-view pass: the light's centre (m) and the maps' range (m),
    /// depth being distance over range.
    pub cube: [f32; 4],
    /// The casters' bounding sphere (centre, radius in m) the suns' maps frame.
    casters: [f32; 4],
    sky: [[f32; 4]; 9],
    lights: [GpuLight; MAX_LIGHTS],
    counts: [u32; 4],
}

/// The scene's lights and sky, kept for building every frame's [`Globals`].
#[derive(Clone, Debug)]
pub(super) struct Lighting {
    /// The scene's lights, in order.
    pub lights: Vec<Light>,
    /// Sky irradiance as 9 SH coefficients (W m⁻², [`sky::sky_irradiance_sh`]).
    sky_sh: [Vec3; 9],
    /// Radiance seen where no geometry is (the clear colour), linear RGB W m⁻² sr⁻¹.
    pub background: Vec3,
    /// Per scene light, its shadow maps baked at load (first array layer, kind), if any.
    pub maps: Vec<Option<(u32, ShadowMaps)>>,
    /// What the GPU path does differently from the offline renderer with these lights.
    pub warnings: Vec<String>,
}

impl Lighting {
    /// The lights and sky of `scene`, with shadow maps for at most `shadowed` of its lights
    /// besides the first sun (the first ones shaded), in at most `layers` array layers, a
    /// sun's cut into `sun_tiles x sun_tiles` maps.
    pub fn of(scene: &Scene, shadowed: usize, layers: u32, sun_tiles: u32) -> Self {
        let sky_sh = sky::sky_irradiance_sh(scene.sky.as_ref());
        let background = match &scene.sky {
            None => Vec3::ZERO,
            Some(Sky::Constant(c)) => *c,
            // The mean radiance: SH band 0 is E = pi * mean.
            Some(Sky::Image { .. }) => sky_sh[0] * 0.282_095 / std::f32::consts::PI,
        };
        let maps = shadow_maps(&scene.lights, shadowed, layers, sun_tiles);
        Lighting {
            lights: scene.lights.clone(),
            sky_sh,
            background,
            warnings: light_warnings(&scene.lights, &maps, shadowed),
            maps,
        }
    }

    /// Every light's shadow maps baked at load: (first array layer, kind), in layer order.
    pub fn shadow_maps(&self) -> Vec<(u32, ShadowMaps)> {
        self.maps.iter().flatten().copied().collect()
    }

    /// Array layers the baked shadow maps take.
    pub fn shadow_layers(&self) -> u32 {
        self.maps.iter().flatten().map(|(_, m)| m.layers()).sum()
    }

    /// The uniforms of a frame seen by `view`: depth range from the scene's `bounds`, the
    /// sun's light matrix around the casters, its maps of side `shadow_size` texels, the
    /// local lights' cube faces of side `cube_size`.
    pub fn globals(
        &self,
        view: &FrameView,
        bounds: &SceneBounds,
        shadow_size: u32,
        cube_size: u32,
    ) -> Globals {
        let (c, r) = bounds.all;
        let dist = (view.camera.position - c).length();
        let far = (dist + r) * 1.01;
        let near = (dist - r).max(far * 1e-4).max(1e-4);
        let view_proj = camera_matrix(&view.camera, view.width, view.height, near, far);
        let (lights, n, sun) = self.gpu_lights(view.sun_dir, bounds);
        let (sc, sr) = bounds.casters;
        let (sun_dir, sun_irr, light_view_proj) = match sun {
            Some((d, e)) => (d.extend(1.0), e.extend(0.0), light_matrix(d, sc, sr)),
            None => (Vec3::Y.extend(0.0), Vec3::ZERO.extend(0.0), Mat4::IDENTITY),
        };
        let mut sky = [[0.0; 4]; 9];
        for (s, v) in sky.iter_mut().zip(self.sky_sh) {
            *s = v.extend(0.0).to_array();
        }
        let size = shadow_size;
        Globals {
            view_proj: view_proj.to_cols_array_2d(),
            light_view_proj: light_view_proj.to_cols_array_2d(),
            camera_pos: view.camera.position.extend(1.0).to_array(),
            sun_dir: sun_dir.to_array(),
            sun_irr: sun_irr.to_array(),
            shadow: [
                size as f32,
                2.0 * sr / size as f32,
                2.0 * sr,
                cube_size as f32,
            ],
            cube: [0.0; 4],
            casters: sc.extend(sr).to_array(),
            sky,
            lights,
            counts: [n as u32, 0, 0, 0],
        }
    }

    /// The lights besides the sun (the first [`MAX_LIGHTS`], with their shadow maps' first
    /// layers and cubes' ranges in `bounds`), their count, and the shadowed sun (unit direction toward it,
    /// `sun_dir` if given, and irradiance W m⁻²).
    fn gpu_lights(
        &self,
        sun_dir: Option<Vec3>,
        bounds: &SceneBounds,
    ) -> ([GpuLight; MAX_LIGHTS], usize, Option<(Vec3, Vec3)>) {
        let mut lights = [GpuLight::default(); MAX_LIGHTS];
        let mut n = 0usize;
        let mut sun: Option<(Vec3, Vec3)> = None;
        for (i, l) in self.lights.iter().enumerate() {
            if let Light::Sun {
                direction,
                irradiance,
                ..
            } = l
                && sun.is_none()
            {
                let d = sun_dir.unwrap_or(*direction).normalize_or(Vec3::Y);
                sun = Some((d, *irradiance));
                continue;
            }
            if n < MAX_LIGHTS {
                lights[n] = gpu_light(l);
                lights[n].color[3] = -1.0;
                if let Some((layer, maps)) = self.maps[i] {
                    lights[n].color[3] = layer as f32;
                    match maps {
                        ShadowMaps::Cube { center } => {
                            lights[n].u[3] = shadow_range(center, bounds)
                        }
                        ShadowMaps::Directional { tiles, .. } => lights[n].v[3] = tiles as f32,
                    }
                }
                n += 1;
            }
        }
        (lights, n, sun)
    }
}

/// Where a light's cube of shadow maps is centred: a point or sphere light's centre, a
/// quad's middle; `None` for suns (they have no cube).
fn shadow_center(l: &Light) -> Option<Vec3> {
    match l {
        Light::Sun { .. } => None,
        Light::Point { position, .. } => Some(*position),
        Light::Sphere { center, .. } => Some(*center),
        Light::Quad {
            corner,
            edge_u,
            edge_v,
            ..
        } => Some(*corner + 0.5 * (*edge_u + *edge_v)),
    }
}

/// The range (m) of a cube of shadow maps centred at `center`: the farthest any geometry
/// of `bounds` can be from it, with 1 % to spare.
pub(super) fn shadow_range(center: Vec3, bounds: &SceneBounds) -> f32 {
    let (c, r) = bounds.all;
    ((center - c).length() + r).max(1e-4) * 1.01
}

/// Which lights get shadow maps baked at load: the first `shadowed` among those shaded
/// (the first [`MAX_LIGHTS`] besides the first sun) whose maps fit in `layers` array
/// layers (a sun's cut into `sun_tiles x sun_tiles` maps), with their first layers in order.
fn shadow_maps(
    lights: &[Light],
    shadowed: usize,
    layers: u32,
    sun_tiles: u32,
) -> Vec<Option<(u32, ShadowMaps)>> {
    let first_sun = lights.iter().position(|l| matches!(l, Light::Sun { .. }));
    let mut shaded = 0usize;
    let mut count = 0usize;
    let mut next = 0u32;
    lights
        .iter()
        .enumerate()
        .map(|(i, l)| {
            if Some(i) == first_sun {
                return None;
            }
            shaded += 1;
            let maps = match (l, shadow_center(l)) {
                (Light::Sun { direction, .. }, _) => ShadowMaps::Directional {
                    direction: direction.normalize_or(Vec3::Y),
                    tiles: sun_tiles,
                },
                (_, Some(center)) => ShadowMaps::Cube { center },
                _ => return None,
            };
            if shaded > MAX_LIGHTS || count >= shadowed || next + maps.layers() > layers {
                return None;
            }
            count += 1;
            next += maps.layers();
            Some((next - maps.layers(), maps))
        })
        .collect()
}

/// A scene light as a uniform-block light: `pos.w` 0 = directional (toward the light,
/// irradiance W m⁻²), 1 = point (position m, intensity W sr⁻¹, `u.x` the radius of a
/// sphere light, inside which the distance is clamped), 2 = one-sided quad and 3 =
/// two-sided quad (`pos` a corner, `u`, `v` its edges in m, emitting toward `u × v`,
/// radiance W m⁻² sr⁻¹). [`Lighting::gpu_lights`] adds the first array layer of its
/// shadow maps (`color.w`, -1 for none), a cube's range (`u.w`, m) and a sun's tiles per
/// side (`v.w`).
fn gpu_light(l: &Light) -> GpuLight {
    let v4 = |v: Vec3, w: f32| v.extend(w).to_array();
    match l {
        Light::Sun {
            direction,
            irradiance,
            ..
        } => GpuLight {
            pos: v4(*direction, 0.0),
            color: v4(*irradiance, 0.0),
            ..Default::default()
        },
        Light::Point {
            position,
            intensity,
        } => GpuLight {
            pos: v4(*position, 1.0),
            color: v4(*intensity, 0.0),
            ..Default::default()
        },
        Light::Quad {
            corner,
            edge_u,
            edge_v,
            radiance,
            two_sided,
        } => GpuLight {
            pos: v4(*corner, if *two_sided { 3.0 } else { 2.0 }),
            color: v4(*radiance, 0.0),
            u: v4(*edge_u, 0.0),
            v: v4(*edge_v, 0.0),
        },
        // A sphere of radius R and radiance L has intensity L pi R^2 in every
        // direction.
        Light::Sphere {
            center,
            radius,
            radiance,
        } => GpuLight {
            pos: v4(*center, 1.0),
            color: v4(*radiance * std::f32::consts::PI * radius * radius, 0.0),
            u: [*radius, 0.0, 0.0, 0.0],
            ..Default::default()
        },
    }
}

/// A light's name in messages: its kind and 1-based place in the scene's list.
fn light_name(i: usize, l: &Light) -> String {
    let kind = match l {
        Light::Sun { .. } => "sun",
        Light::Point { .. } => "point",
        Light::Quad { .. } => "quad",
        Light::Sphere { .. } => "sphere",
    };
    format!("light {} ({kind})", i + 1)
}

/// The warnings for `lights` on the GPU path, given their shadow `maps` and the number of
/// lights allowed them (`shadowed`): which cast no shadows there (past those), which long
/// quads cast the shadow of a disc, and which are left out (past the first sun and
/// [`MAX_LIGHTS`] others).
fn light_warnings(
    lights: &[Light],
    maps: &[Option<(u32, ShadowMaps)>],
    shadowed: usize,
) -> Vec<String> {
    let first_sun = lights.iter().position(|l| matches!(l, Light::Sun { .. }));
    let others: Vec<(usize, &Light)> = lights
        .iter()
        .enumerate()
        .filter(|(i, _)| Some(*i) != first_sun)
        .collect();
    let names = |ls: &[(usize, &Light)]| {
        ls.iter()
            .map(|(i, l)| light_name(*i, l))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let shaded = &others[..others.len().min(MAX_LIGHTS)];
    let unshadowed: Vec<(usize, &Light)> = shaded
        .iter()
        .filter(|(i, _)| maps[*i].is_none())
        .copied()
        .collect();
    let mut out = Vec::new();
    if !unshadowed.is_empty() {
        let one = unshadowed.len() == 1;
        let why = if shadowed == 0 {
            "shadows of lights besides the first sun are off".to_string()
        } else {
            format!("it shadows the first sun and {shadowed} other lights")
        };
        out.push(format!(
            "{} cast{} no shadows on the GPU path ({why}): what the offline renderer shows in \
             {} shadow is lit here",
            names(&unshadowed),
            if one { "s" } else { "" },
            if one { "its" } else { "their" }
        ));
    }
    for (i, l) in shaded {
        if let (Some(_), Light::Quad { edge_u, edge_v, .. }) = (maps[*i], l) {
            let (a, b) = (edge_u.length(), edge_v.length());
            let ratio = a.max(b) / a.min(b).max(1e-12);
            if ratio > LONG_QUAD {
                out.push(format!(
                    "{} is {ratio:.1} times longer than wide: its soft shadow on the GPU \
                     path is drawn as from a disc of its area at its centre",
                    light_name(*i, l)
                ));
            }
        }
    }
    if others.len() > MAX_LIGHTS {
        out.push(format!(
            "{} left out: the GPU path shades the first sun and {MAX_LIGHTS} other lights",
            names(&others[MAX_LIGHTS..])
        ));
    }
    out
}
