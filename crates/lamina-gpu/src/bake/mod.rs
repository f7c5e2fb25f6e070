//! CPU-side baking: every scene material becomes the same three GPU maps plus an angular
//! lookup table, computed **by evaluating lamina-leaf's model**, so the real-time shading is
//! tied to the offline BSDF by construction rather than by copied constants.
//!
//! # What is baked, per material
//! * **Albedo maps** (`front`, `back`, `trans`; 8-bit sRGB-encoded linear Rec.709, filtered
//!   in linear space by the GPU): at every texel centre, [`LeafMaterial::bsdf`] is evaluated
//!   and its white-sky diffuse albedos are stored: adaxial reflectance (`front`, alpha channel
//!   = the alpha matte, 0 or 1), abaxial reflectance (`back`) and diffuse transmittance
//!   (`trans`). These already contain everything the CPU model derives per texel from the
//!   seven maps: the photo colours, the energy bound `lambda`, and the Kubelka-Munk
//!   variation with the **thickness and extinction maps** (thicker or more absorbing texels,
//!   e.g. veins, transmit less). The GPU's through-light therefore follows the thickness
//!   and extinction maps exactly at normal white-sky illumination.
//! * **Angular tables** (`lut`, 32 x 32 per lobe, linear RGB, 1/sr): the physical lobe's
//!   shape `g_X(mu_o, mu_i) = <f_X(wo, wi)>_phi / a_X`, i.e. the CPU BSDF (specular off,
//!   nominal texel, no maps) averaged over the azimuth difference and divided by the lobe's
//!   white-sky albedo `a_X`, for `X` = adaxial reflection, abaxial reflection,
//!   transmission. A Lambertian lobe gives `1/pi` everywhere. The GPU evaluates
//!   `f cos = albedo_X(texel) * g_X(mu_o, mu_i) * mu_i`. Layer 3 holds the Fresnel
//!   reflectance of the adaxial (`r`) and abaxial (`g`) epidermis against the cosine
//!   (row 0), from [`lamina_leaf::layers::fresnel_dielectric`], and the specular lobe's
//!   directional albedo per side (`b`, `a`) from [`lamina_leaf::specular::eval`].
//! * **Uniforms**: GGX roughness per side, specular weight, the sine of the blend width,
//!   all read from [`LeafParams`].
//!
//! # glTF metallic-roughness materials ([`Material::Pbr`], [`lamina_leaf::PbrBsdf`])
//! * **Albedo maps**: `diffuse_albedo()` of `PbrMaterial::bsdf(uv)` at every texel centre
//!   over the largest of the base colour, metallic-roughness, transmission and alpha maps:
//!   `front` = `back` = the diffuse reflectance (the surface is two-sided; it already holds
//!   `1 − metallic`, `1 − transmission` and the `1 − E_avg` the specular coat takes),
//!   `trans` = the diffuse transmittance, alpha from the mask.
//! * **Specular**: one GGX lobe, the same on both sides, `alpha = r²` with `r` the mean
//!   perceptual roughness over the (opaque) texels, i.e. the factor times the mean of the
//!   roughness map: **per-texel roughness is averaged on the GPU** (per-texel metallic is
//!   not for the diffuse maps, only for the specular weights). The dielectric part has
//!   weight `1 − mean metallic` (`spec.z`) and the exact Fresnel of `max(ior, 1/ior)` in
//!   layer 3; the metallic part is carried by [`MaterialUniform::metal`] (mean
//!   `metallic · base_colour` and mean `metallic`), so metals get their coloured Schlick
//!   Fresnel as on the CPU. The blend width is [`PBR_BLEND_SIN`] (no fade: the CPU model has
//!   none).
//! * **Angular tables** ([`pbr_lut`]): the diffuse lobes' shape from the CPU model's
//!   public `eval` (the energy-conserving coupling `(1 − E(mu_o))(1 − E(mu_i))` makes them
//!   darker than Lambertian towards grazing), layer 3 the Fresnel, the dielectric
//!   specular albedo and (row 1) the metal albedo moments for the sky's reflection.
//! * **Normal map**: baked on its own grid (downscaled with a warning like the others) to
//!   a linear 8-bit map of the unit tangent-space normal with the map's scale applied
//!   (`rgb = n · 0.5 + 0.5`), `shape.y = 1`. The shader has no vertex tangents: it solves
//!   `dP/du`, `dP/dv` from the screen-space derivatives of position and uv (as the glTF
//!   sample viewer does without tangents) and builds lamina-render's frame (`x` = `dP/du`
//!   orthogonal to the normal, `y` towards increasing lamina `v`).
//!
//! # Leaf bump maps
//! A leaf with a bump map (and `bump_scale > 0`) gets it baked into the same normal map,
//! on the grid of its other maps (the bump map counts towards that grid's size and its
//! downscaling): at every texel centre the shading normal that
//! [`LeafMaterial::bsdf`] builds from the bump map's gradient (`LeafBsdf::shading_normal`,
//! so the formula, scale and clamp are lamina-leaf's), in the CPU leaf frame (`x` = `dP/du`,
//! `y` = `z × x`, which is towards increasing `v` unless the uv mapping is mirrored,
//! `z` = the adaxial normal). `shape.y = 1` as for glTF maps; `shape.z = 1` marks every
//! leaf, telling the shader that the normal map lives *inside* the BSDF as on the CPU:
//! adaxial/abaxial, reflection/transmission, the angular tables' cosines and the blend
//! band stay geometric, while the diffuse lobes' cosine becomes LeafBsdf's blended
//! shading cosine (`max(0, wi · ±n_s)`, `-n_s` on the abaxial side) and the specular lobe
//! and the sky's irradiance use `±n_s`. Leaves without a bump map keep the flat 1x1 map.
//!
//! Mip levels are box-filtered here in linear space. Maps larger than the device's texture
//! limit are **downscaled with a warning** (returned in [`BakedMaterial::warnings`]).

use glam::Vec3;
#[cfg(doc)]
use lamina_leaf::{LeafMaterial, LeafParams};
use lamina_scene::{AlphaMask, ColorInput, Material};
use maps::{bake_texels, colour_size, fill_transparent, fit, flat_normal, mip_chain};

mod leaf;
mod maps;
mod pbr;
#[cfg(test)]
mod tests;

pub use leaf::{leaf_lut, leaf_uniform};
pub use pbr::{PBR_BLEND_SIN, pbr_lut};

/// Side of the angular tables (cosine samples at midpoints `(k + 0.5) / LUT_N`).
pub const LUT_N: usize = 32;
/// Layers of the angular table: adaxial R, abaxial R, T, Fresnel.
pub const LUT_LAYERS: usize = 4;

/// Per-material shading constants as the WGSL `MaterialParams` struct sees them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MaterialUniform {
    /// `x`: GGX alpha of the adaxial (upper, +normal) side; `y`: of the abaxial side;
    /// `z`: specular weight in `[0, 1]` (0 for non-leaf materials); `w`: `sin` of the
    /// front/back blend width (`LeafParams::blend_width_deg`).
    pub spec: [f32; 4],
    /// `x`: radius (m) of a disc with the area of one card (two triangles) of this
    /// material, set by the renderer from the meshes: light a leaf transmits leaves it
    /// diffusely, so a receiver `d` behind it gets the fraction `a² / (a² + d²)` of it (the
    /// on-axis form factor of a disc of radius `a`). `y`: 1 when the material has a
    /// tangent-space normal map (`BakedMaterial::normal`), else 0. `zw` unused.
    pub shape: [f32; 4],
    /// The metallic (coloured, Schlick-Fresnel) specular lobe of [`Material::Pbr`]: `rgb` =
    /// the mean of `metallic · base_colour` (the metal's F0 times its weight), `a` = the
    /// mean `metallic`; its Fresnel at `v·h` is `rgb + (a − rgb)(1 − v·h)⁵`. Zero for every
    /// other material.
    pub metal: [f32; 4],
}

/// One 2D RGBA8 map with its mip chain (level 0 first), sRGB-encoded colour, linear alpha.
#[derive(Clone, Debug)]
pub struct MipMap {
    /// Width of level 0.
    pub width: u32,
    /// Height of level 0.
    pub height: u32,
    /// Texels per level, row-major, top row (`v = 1`) first.
    pub levels: Vec<Vec<[u8; 4]>>,
}

/// A material ready for upload.
#[derive(Clone, Debug)]
pub struct BakedMaterial {
    /// The scene material's name.
    pub name: String,
    /// Adaxial diffuse reflectance, alpha = matte.
    pub front: MipMap,
    /// Abaxial diffuse reflectance.
    pub back: MipMap,
    /// Diffuse transmittance.
    pub trans: MipMap,
    /// Tangent-space normal map, linear (`rgb = n · 0.5 + 0.5`, scale applied), used when
    /// `uniform.shape.y` is 1; a flat 1x1 map otherwise.
    pub normal: MipMap,
    /// Angular tables, `LUT_LAYERS` layers of `LUT_N x LUT_N` RGBA (index `x` = `mu_o`,
    /// `y` = `mu_i`), 1/sr.
    pub lut: Vec<[f32; 4]>,
    /// Shading constants.
    pub uniform: MaterialUniform,
    /// Messages for the user (downscaled maps).
    pub warnings: Vec<String>,
}

/// Bakes one scene material under the texture side limit `max_dim`.
pub fn bake_material(material: &Material, max_dim: u32) -> BakedMaterial {
    let warnings = Vec::new();
    match material {
        Material::Leaf { name, leaf } => leaf::bake_leaf(name, leaf, max_dim, warnings),
        Material::Diffuse {
            name,
            reflectance,
            alpha,
        } => bake_diffuse(name, reflectance, None, alpha.as_ref(), max_dim, warnings),
        Material::Pbr(p) => pbr::bake_pbr(p, max_dim, warnings),
        Material::DiffuseTransmission {
            name,
            reflectance,
            transmittance,
            alpha,
        } => bake_diffuse(
            name,
            reflectance,
            Some(transmittance),
            alpha.as_ref(),
            max_dim,
            warnings,
        ),
    }
}

/// Bakes a Lambertian material (with diffuse transmission when `transmittance` is given).
fn bake_diffuse(
    name: &str,
    reflectance: &ColorInput,
    transmittance: Option<&ColorInput>,
    alpha: Option<&AlphaMask>,
    max_dim: u32,
    mut warnings: Vec<String>,
) -> BakedMaterial {
    let (mut w, mut h) = colour_size(reflectance);
    if let Some(t) = transmittance {
        let (tw, th) = colour_size(t);
        (w, h) = (w.max(tw), h.max(th));
    }
    if let Some(a) = alpha {
        (w, h) = (w.max(a.map.width()), h.max(a.map.height()));
    }
    let (w, h) = fit(name, "the colour/alpha maps", w, h, max_dim, &mut warnings);
    let mut maps = bake_texels(w, h, &|uv| {
        let r = reflectance.at(uv).clamp(Vec3::ZERO, Vec3::ONE);
        let t = transmittance.map_or(Vec3::ZERO, |t| t.at(uv).clamp(Vec3::ZERO, Vec3::ONE));
        let a = alpha.is_none_or(|m| m.opaque(uv));
        [
            [r.x, r.y, r.z, if a { 1.0 } else { 0.0 }],
            [r.x, r.y, r.z, 1.0],
            [t.x, t.y, t.z, 1.0],
        ]
    });
    fill_transparent(&mut maps);
    let [f, b, t] = maps;
    BakedMaterial {
        name: name.to_string(),
        front: mip_chain(w, h, f),
        back: mip_chain(w, h, b),
        trans: mip_chain(w, h, t),
        normal: flat_normal(),
        lut: lambert_lut(),
        uniform: MaterialUniform::default(),
        warnings,
    }
}

/// Lambertian angular tables (`1/pi` for the three lobes, no Fresnel).
fn lambert_lut() -> Vec<[f32; 4]> {
    let mut lut = vec![[std::f32::consts::FRAC_1_PI; 4]; LUT_N * LUT_N * LUT_LAYERS];
    for t in &mut lut[3 * LUT_N * LUT_N..] {
        *t = [0.0; 4];
    }
    lut
}
