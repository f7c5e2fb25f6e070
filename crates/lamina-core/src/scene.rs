//! The in-memory scene: what a scene file, a built-in scene or an importer produces, and
//! what the renderers consume. Pure data, validated on construction by the loaders.
//!
//! Units: lengths in metres (leaf thickness, a material parameter, is in millimetres),
//! angles in degrees where a user types them, radiometry in linear Rec.709 RGB:
//! radiance in W m⁻² sr⁻¹, irradiance in W m⁻², intensity in W sr⁻¹.
//! World space is right-handed with `+y` up.

use glam::{Vec2, Vec3, Vec4};
use lamina_leaf::Texture;
use std::sync::Arc;

/// A complete scene ready to render.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The viewpoint.
    pub camera: Camera,
    /// Image size, sampling and tone mapping.
    pub film: Film,
    /// Which light-transport algorithm and its settings.
    pub integrator: Integrator,
    /// Lights other than the sky.
    pub lights: Vec<Light>,
    /// Light arriving from infinitely far away in every direction not blocked by geometry.
    pub sky: Option<Sky>,
    /// Materials, indexed by [`Mesh::material`].
    pub materials: Vec<Material>,
    /// World-space triangle meshes, each placed once.
    pub meshes: Vec<Mesh>,
    /// Geometry placed many times by [`Scene::instances`] (object space).
    pub prototypes: Vec<Prototype>,
    /// Placements of [`Scene::prototypes`].
    pub instances: Vec<Instance>,
    /// The periodic domain, sensors and object provenance (empty for a picture only).
    pub radiometry: crate::Radiometry,
}

impl Scene {
    /// The axis-aligned box (m) around the scene's geometry: every finite vertex of its
    /// meshes, and for each instance the eight corners of its prototype's box, transformed
    /// (a box around the instance). `None` without geometry. Lights are not included.
    pub fn geometry_bounds(&self) -> Option<(Vec3, Vec3)> {
        let grow = |(lo, hi): (Vec3, Vec3), p: Vec3| {
            if p.is_finite() {
                (lo.min(p), hi.max(p))
            } else {
                (lo, hi)
            }
        };
        let empty = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let points = |meshes: &[Mesh]| {
            meshes
                .iter()
                .flat_map(|m| m.positions.iter().copied())
                .fold(empty, grow)
        };
        let mut b = points(&self.meshes);
        let protos: Vec<(Vec3, Vec3)> = self.prototypes.iter().map(|p| points(&p.meshes)).collect();
        for inst in &self.instances {
            let Some(&(l, h)) = protos.get(inst.prototype as usize) else {
                continue;
            };
            if l.cmple(h).all() {
                for k in 0..8 {
                    let c = Vec3::new(
                        if k & 1 == 0 { l.x } else { h.x },
                        if k & 2 == 0 { l.y } else { h.y },
                        if k & 4 == 0 { l.z } else { h.z },
                    );
                    b = grow(b, inst.transform.transform_point3(c));
                }
            }
        }
        b.0.cmple(b.1).all().then_some(b)
    }
}

/// A pinhole or thin-lens perspective camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye position (m).
    pub position: Vec3,
    /// A point the camera looks at (m). Never equal to `position`.
    pub look_at: Vec3,
    /// Approximate up direction; must not be parallel to `look_at - position`.
    pub up: Vec3,
    /// Horizontal field of view (degrees), in `(0, 180)`.
    pub fov_deg: f32,
    /// Lens aperture radius (m); 0 is a pinhole.
    pub aperture_radius: f32,
    /// Distance to the plane in focus (m), used when `aperture_radius > 0`.
    pub focus_distance: f32,
}

/// The reconstruction filter that splats samples into pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFilter {
    /// Each sample counts only in its own pixel (radius 0.5 px).
    Box,
    /// Triangle filter of the given radius (px).
    Tent {
        /// Radius in pixels.
        radius: f32,
    },
    /// Truncated Gaussian (px).
    Gaussian {
        /// Radius in pixels where the filter is cut off.
        radius: f32,
        /// Standard deviation in pixels.
        sigma: f32,
    },
}

/// How linear radiance becomes display values in the PNG (the EXR is never tone-mapped).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ToneMap {
    /// Exposure, then clamp to `[0, 1]`, then the sRGB curve.
    Clamp,
    /// Exposure, then the ACES filmic fit of Narkowicz (2015), then the sRGB curve.
    Aces,
    /// Exposure, then `x / (1 + x)` per channel, then the sRGB curve.
    Reinhard,
}

/// Image size and sampling.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels (> 0).
    pub width: u32,
    /// Height in pixels (> 0).
    pub height: u32,
    /// Samples per pixel (> 0).
    pub spp: u32,
    /// Pixel reconstruction filter.
    pub filter: PixelFilter,
    /// Exposure in stops: the PNG shows radiance times `2^exposure`.
    pub exposure: f32,
    /// Tone map applied to the PNG.
    pub tonemap: ToneMap,
    /// What the image's channels are: linear Rec.709 from an RGB render, or from a render
    /// over visible wavelengths seen through the CIE 1931 observer.
    pub spectral: SpectralMode,
}

/// How the offline renderer makes an RGB image (`[film] spectral`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SpectralMode {
    /// Every value is linear Rec.709 RGB and light is carried in those three channels.
    #[default]
    Rgb,
    /// Light is carried at wavelengths over 360-830 nm (several per path, hero-wavelength
    /// sampling; RGB values upsampled, pigment leaves and physical skies from their
    /// spectra) and the image is what the CIE 1931 observer sees of it, in linear Rec.709.
    Visible,
}

impl Film {
    /// A `width` x `height` film at `spp` samples per pixel with the scene-file defaults:
    /// Gaussian filter (radius 1.5 px, sigma 0.5 px), exposure 0 stops, ACES tone map.
    pub fn new(width: u32, height: u32, spp: u32) -> Film {
        Film {
            width,
            height,
            spp,
            filter: PixelFilter::Gaussian {
                radius: 1.5,
                sigma: 0.5,
            },
            exposure: 0.0,
            tonemap: ToneMap::Aces,
            spectral: SpectralMode::Rgb,
        }
    }
}

/// The light-transport algorithm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    /// Unidirectional path tracing with next-event estimation, MIS and Russian roulette.
    Path {
        /// Longest path, in scattering events (1 = direct light only).
        max_depth: u32,
        /// Depth from which Russian roulette may end paths.
        rr_depth: u32,
        /// Which lights next-event estimation samples at each scattering vertex.
        light_sampling: LightSampling,
        /// Whether next-event estimation samples the sky, or BSDF samples alone reach it.
        sky_sampling: SkySampling,
    },
    /// The paper's renderer: direct light only, per light front/back/through-light shading,
    /// multiple scattering as an ambient term.
    Paper {
        /// Ambient radiance (W m⁻² sr⁻¹) that multiple scattering stands for, times the
        /// material's diffuse albedo. `None`: the sky's mean radiance (zero without a sky).
        ambient: Option<Vec3>,
    },
}

/// How the path tracer's next-event estimation picks lights at a scattering vertex.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSampling {
    /// Every light, one sample each: the least noise per sample; the cost of a vertex grows
    /// with the number of lights (a sun and a sky: two shadow rays).
    #[default]
    All,
    /// One light per vertex, drawn with probability proportional to its estimated power
    /// (emitted flux, with distant lights and skies as seen by the scene's bounding sphere:
    /// pbrt-v4's power light sampler), its contribution divided by that probability: one
    /// shadow ray per vertex, as Mitsuba 3's `path` integrator traces.
    One,
}

/// How the path tracer reaches the sky: by next-event estimation (a shadow ray toward a
/// direction drawn from the sky, combined with BSDF samples by MIS), or by BSDF samples
/// alone (the ray a vertex traces anyway to continue the path, counted in full when it
/// escapes).
///
/// A constant sky is best left to BSDF samples: the sky's own strategy draws directions
/// uniformly over the sphere, which for a diffuse surface is always worse than the BSDF's
/// cosine-weighted samples, so its shadow ray adds little beyond its cost (Cycles, for the
/// same reason, does not light-sample a uniform world). An image sky (`image`, `sunsky`)
/// has bright regions only its own sampling finds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SkySampling {
    /// [`SkySampling::Bsdf`] for a constant sky, [`SkySampling::Light`] for an image sky.
    #[default]
    Auto,
    /// Next-event estimation samples the sky (one shadow ray per vertex with
    /// [`LightSampling::All`], or the sky competes to be the one light with
    /// [`LightSampling::One`]).
    Light,
    /// Only BSDF samples reach the sky; no shadow rays toward it.
    Bsdf,
}

impl SkySampling {
    /// Whether next-event estimation samples `sky` under this setting.
    pub fn light_samples(self, sky: &Sky) -> bool {
        match self {
            SkySampling::Auto => !matches!(sky, Sky::Constant(_)),
            SkySampling::Light => true,
            SkySampling::Bsdf => false,
        }
    }
}

/// A light source.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// A distant disc light such as the sun.
    Sun {
        /// Unit direction from the scene *toward* the sun.
        direction: Vec3,
        /// Irradiance on a surface facing the sun (W m⁻²).
        irradiance: Vec3,
        /// Apparent angular diameter (degrees); 0 is a delta light with hard shadows.
        angular_diameter_deg: f32,
    },
    /// An isotropic point light.
    Point {
        /// Position (m).
        position: Vec3,
        /// Radiant intensity (W sr⁻¹).
        intensity: Vec3,
    },
    /// An emitting parallelogram `corner + s·edge_u + t·edge_v`, `s, t ∈ [0, 1]`, visible to
    /// camera rays. Emits on the side of `edge_u × edge_v`, or both when `two_sided`.
    Quad {
        /// One corner (m).
        corner: Vec3,
        /// First edge (m).
        edge_u: Vec3,
        /// Second edge (m).
        edge_v: Vec3,
        /// Emitted radiance (W m⁻² sr⁻¹).
        radiance: Vec3,
        /// Emit from both faces.
        two_sided: bool,
    },
    /// An emitting sphere, visible to camera rays.
    Sphere {
        /// Centre (m).
        center: Vec3,
        /// Radius (m), > 0.
        radius: f32,
        /// Emitted radiance (W m⁻² sr⁻¹).
        radiance: Vec3,
    },
}

/// Light from infinitely far away.
#[derive(Clone, Debug)]
pub enum Sky {
    /// The same radiance (W m⁻² sr⁻¹) from every direction.
    Constant(Vec3),
    /// An equirectangular (latitude-longitude) linear HDR image, importance-sampled.
    /// Image `u` runs with azimuth `φ = atan2(d.x, -d.z)` from `u = 0` at `φ = -π`, image `v`
    /// from the zenith (`+y`, top row) to the nadir (bottom row).
    Image {
        /// The radiance map (linear, W m⁻² sr⁻¹ after `scale`).
        map: Texture,
        /// Multiplier on the map.
        scale: f32,
        /// Rotation of the map about `+y` (degrees).
        rotation_deg: f32,
        /// The sky's spectral source, when it is known spectrally (a physical sun and sky):
        /// renders in spectral bands make the map from it instead of converting the RGB
        /// map. `None` for an image file.
        spectral: Option<Arc<dyn SpectralSky>>,
    },
}

/// A sky known spectrally (a physical sun and sky, `[sky] type = "sunsky"`), so that renders
/// in spectral bands make its map, and its sun's irradiance, per band instead of
/// converting the RGB ones through the RGB-to-band basis.
pub trait SpectralSky: std::fmt::Debug + Send + Sync {
    /// The map in three bands (channel `i` = `bands[i]`; alpha 1): band-mean spectral
    /// radiance, W m⁻² sr⁻¹ nm⁻¹, oriented as [`Sky::Image`]'s map.
    fn band_map(&self, bands: [&lamina_leaf::spectrum::bands::Band; 3]) -> Texture;
    /// [`Self::band_map`] for each of `groups`, in order: a model may make them together
    /// faster than one by one.
    fn band_maps(&self, groups: &[[&lamina_leaf::spectrum::bands::Band; 3]]) -> Vec<Texture> {
        groups.iter().map(|g| self.band_map(*g)).collect()
    }
    /// The direct normal irradiance of the sun this sky brought (a scene with such a sky
    /// has that sun as its **last** light) in three bands, W m⁻² nm⁻¹; `None` when the sky
    /// brought no sun.
    fn band_sun(&self, bands: [&lamina_leaf::spectrum::bands::Band; 3]) -> Option<Vec3>;
}

/// A colour that is either constant or read from a map.
#[derive(Clone, Debug)]
pub enum ColorInput {
    /// One linear RGB value everywhere.
    Constant(Vec3),
    /// A colour map (already linear) times a linear RGB factor.
    Texture {
        /// The map.
        map: Texture,
        /// Per-channel factor.
        factor: Vec3,
    },
    /// A colour map's linear RGB taken through a matrix: the same map in other channels
    /// (spectral bands: row `i` holds the weights of R, G, B in channel `i`), shared rather
    /// than converted texel by texel. Made by renderers for their band copies of a scene;
    /// loaders never make it.
    Mapped {
        /// The map (linear RGB).
        map: Texture,
        /// Channel `i` = `matrix.row(i) · rgb`.
        matrix: glam::Mat3,
    },
}

impl ColorInput {
    /// The linear RGB value at texture coordinates `uv`.
    #[inline]
    pub fn at(&self, uv: Vec2) -> Vec3 {
        match self {
            ColorInput::Constant(c) => *c,
            ColorInput::Texture { map, factor } => map.rgb(uv) * *factor,
            ColorInput::Mapped { map, matrix } => *matrix * map.rgb(uv),
        }
    }
}

/// A two-state cut-out: the surface exists where the map's value is at least `cutoff`.
#[derive(Clone, Debug)]
pub struct AlphaMask {
    /// The matte; its alpha channel if `use_alpha_channel`, else its first channel.
    pub map: Texture,
    /// Read the alpha channel (RGBA base colours) rather than the first channel (mattes).
    pub use_alpha_channel: bool,
    /// Threshold in `[0, 1]`; the paper's mattes are binary, 0.5 separates them.
    pub cutoff: f32,
}

impl AlphaMask {
    /// Whether the surface is present at `uv`.
    #[inline]
    pub fn opaque(&self, uv: Vec2) -> bool {
        let s = self.map.sample(uv);
        let a = if self.use_alpha_channel { s.w } else { s.x };
        a >= self.cutoff
    }
}

/// A tangent-space normal map (glTF `normalTexture` convention): RGB stored linearly,
/// `n = 2·rgb − 1` with `+x` along increasing texture `u`, `+y` towards the top of the
/// image (increasing lamina `v`), `+z` along the interpolated vertex normal.
#[derive(Clone, Debug)]
pub struct NormalMap {
    /// The map, linear encoding (not sRGB).
    pub map: Texture,
    /// glTF `normalTexture.scale`: multiplies the decoded `x` and `y` before
    /// renormalising (1 = as painted, 0 = no perturbation).
    pub scale: f32,
}

impl NormalMap {
    /// The unit tangent-space normal at `uv` (`+z` up); `+z` where the texel decodes to a
    /// degenerate or non-finite vector.
    #[inline]
    pub fn at(&self, uv: Vec2) -> Vec3 {
        let c = self.map.rgb(uv) * 2.0 - Vec3::ONE;
        let v = Vec3::new(c.x * self.scale, c.y * self.scale, c.z);
        let len2 = v.length_squared();
        if len2 > 1e-8 && len2.is_finite() && v.z > -1.0 {
            v / len2.sqrt()
        } else {
            Vec3::Z
        }
    }
}

/// A glTF-style metallic-roughness material: every factor is multiplied by its map where
/// there is one (glTF semantics).
#[derive(Clone, Debug)]
pub struct PbrMaterial {
    /// Name in the scene file or the imported file (for messages and overrides).
    pub name: String,
    /// Base colour, linear RGB in `[0, 1]` (diffuse albedo of dielectrics, F0 of metals).
    pub base_color: ColorInput,
    /// `metallic` factor in `[0, 1]`.
    pub metallic: f32,
    /// Perceptual `roughness` factor in `[0, 1]` (GGX `alpha = roughness²`).
    pub roughness: f32,
    /// glTF `metallicRoughnessTexture` (linear): roughness in green, metallic in blue,
    /// multiplying the factors.
    pub metallic_roughness: Option<Texture>,
    /// Index of refraction of the dielectric part (1.5: F0 = 0.04).
    pub ior: f32,
    /// Diffuse transmission factor in `[0, 1]` (`KHR_materials_diffuse_transmission`).
    pub transmission: f32,
    /// Map whose alpha channel multiplies `transmission` (`diffuseTransmissionTexture`).
    pub transmission_map: Option<Texture>,
    /// Colour of diffusely transmitted light, linear RGB in `[0, 1]`.
    pub transmission_color: ColorInput,
    /// Tangent-space normal map, if any.
    pub normal_map: Option<NormalMap>,
    /// Optional cut-out.
    pub alpha: Option<AlphaMask>,
}

impl PbrMaterial {
    /// A uniform material: base colour, metallic and roughness, no maps.
    pub fn uniform(name: &str, base_color: Vec3, metallic: f32, roughness: f32) -> Self {
        PbrMaterial {
            name: name.into(),
            base_color: ColorInput::Constant(base_color),
            metallic,
            roughness,
            metallic_roughness: None,
            ior: 1.5,
            transmission: 0.0,
            transmission_map: None,
            transmission_color: ColorInput::Constant(Vec3::ONE),
            normal_map: None,
            alpha: None,
        }
    }

    /// The BSDF at texture coordinates `uv` (factors times maps, clamped to their ranges).
    #[inline]
    pub fn bsdf(&self, uv: Vec2) -> lamina_leaf::PbrBsdf {
        let (mut metallic, mut roughness) = (self.metallic, self.roughness);
        if let Some(mr) = &self.metallic_roughness {
            let s = mr.sample(uv);
            roughness *= s.y;
            metallic *= s.z;
        }
        let mut transmission = self.transmission;
        if transmission > 0.0
            && let Some(t) = &self.transmission_map
        {
            transmission *= t.sample(uv).w;
        }
        lamina_leaf::PbrBsdf {
            base_color: self.base_color.at(uv).clamp(Vec3::ZERO, Vec3::ONE),
            metallic: metallic.clamp(0.0, 1.0),
            roughness: roughness.clamp(0.0, 1.0),
            ior: self.ior,
            transmission: transmission.clamp(0.0, 1.0),
            transmission_color: self.transmission_color.at(uv).clamp(Vec3::ZERO, Vec3::ONE),
        }
    }
}

/// A surface material. All are two-sided.
#[derive(Clone, Debug)]
pub enum Material {
    /// Opaque Lambertian reflector.
    Diffuse {
        /// Name in the scene file (for messages).
        name: String,
        /// Albedo, linear RGB in `[0, 1]`.
        reflectance: ColorInput,
        /// Optional cut-out.
        alpha: Option<AlphaMask>,
    },
    /// Lambertian reflection plus Lambertian transmission (`R + T <= 1`).
    DiffuseTransmission {
        /// Name in the scene file (for messages).
        name: String,
        /// Hemispherical reflectance, linear RGB.
        reflectance: ColorInput,
        /// Hemispherical transmittance, linear RGB.
        transmittance: ColorInput,
        /// Optional cut-out.
        alpha: Option<AlphaMask>,
    },
    /// The glTF 2.0 metallic-roughness surface (pots, stems, bark, ground from glTF, OBJ +
    /// MTL or `type = "pbr"`), with optional diffuse transmission and a tangent-space
    /// normal map. Evaluated as [`lamina_leaf::PbrBsdf`].
    Pbr(Box<PbrMaterial>),
    /// The three-layer leaf model with its seven maps.
    Leaf {
        /// Name in the scene file (for messages).
        name: String,
        /// The leaf's maps and parameters.
        leaf: Arc<lamina_leaf::LeafMaterial>,
    },
}

impl Material {
    /// The material's name (scene file or imported file), for messages and overrides.
    pub fn name(&self) -> &str {
        match self {
            Material::Diffuse { name, .. }
            | Material::DiffuseTransmission { name, .. }
            | Material::Leaf { name, .. } => name,
            Material::Pbr(p) => &p.name,
        }
    }

    /// The cut-out of a non-leaf material (leaves carry theirs in their alpha map).
    pub fn alpha_mask(&self) -> Option<&AlphaMask> {
        match self {
            Material::Diffuse { alpha, .. } | Material::DiffuseTransmission { alpha, .. } => {
                alpha.as_ref()
            }
            Material::Pbr(p) => p.alpha.as_ref(),
            Material::Leaf { .. } => None,
        }
    }

    /// The tangent-space normal map, if the material has one (leaves perturb their normal
    /// inside their BSDF with the bump map instead).
    pub fn normal_map(&self) -> Option<&NormalMap> {
        match self {
            Material::Pbr(p) => p.normal_map.as_ref(),
            _ => None,
        }
    }
}

/// A triangle mesh in world space.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions (m).
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals, or empty for flat shading.
    pub normals: Vec<Vec3>,
    /// Per-vertex tangents for normal maps (glTF `TANGENT`): `xyz` along increasing `u`,
    /// `w = ±1` with the bitangent `w · (normal × tangent)` pointing towards increasing
    /// lamina `v` (the top of the image). Empty: derived per triangle from the UVs.
    pub tangents: Vec<Vec4>,
    /// Per-vertex texture coordinates, or empty (then `uv = (0, 0)` everywhere).
    pub uvs: Vec<Vec2>,
    /// Triangles as indices into the vertex arrays; the front face (for leaves, the
    /// adaxial side) is the one from which the vertices appear counter-clockwise.
    pub indices: Vec<[u32; 3]>,
    /// Index into [`Scene::materials`].
    pub material: u32,
}

impl Mesh {
    /// A parallelogram `corner + s·edge_u + t·edge_v`, `s, t ∈ [0, 1]`, as two triangles with
    /// `uv = (s, t)`. Its front (for a leaf, adaxial) side faces `edge_u × edge_v`.
    pub fn quad(corner: Vec3, edge_u: Vec3, edge_v: Vec3, material: u32) -> Mesh {
        Mesh {
            positions: vec![
                corner,
                corner + edge_u,
                corner + edge_u + edge_v,
                corner + edge_v,
            ],
            normals: Vec::new(),
            tangents: Vec::new(),
            uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            material,
        }
    }
}

/// A group of meshes defined once in its own object space (metres) and placed many times by
/// [`Instance`]s: a leaf shape, a branch, a whole plant. Renderers keep one copy of its
/// geometry (and one BVH) however many instances there are.
#[derive(Clone, Debug, Default)]
pub struct Prototype {
    /// Name, for messages (the glTF mesh name, the plant object's name, ...).
    pub name: String,
    /// Object-space meshes; their `material` indexes [`Scene::materials`].
    pub meshes: Vec<Mesh>,
}

/// One placement of a [`Prototype`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Scene::prototypes`].
    pub prototype: u32,
    /// Object-to-world transform (metres). Must be invertible; one that mirrors (negative
    /// determinant) flips the winding, and renderers keep the adaxial side on the side the
    /// transformed geometric normal points to, as for [`Mesh`] transforms.
    pub transform: glam::Affine3A,
}
