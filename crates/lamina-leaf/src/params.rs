//! Physical parameters of the three-layer leaf model, with units, defaults and validation.
//!
//! The leaf blade is a slab of local thickness `thickness_mm` (scaled per texel by the
//! thickness map) made of three homogeneous layers, from the adaxial (upper, `+z`) side down:
//! the upper epidermis, the mesophyll (the scattering interior) and the lower epidermis. Each
//! layer takes a fixed fraction of the local thickness (Franzke & Deussen, Sec. 4) and has its
//! own index of refraction, absorption and scattering coefficients.

use crate::error::LeafError;
use glam::Vec3;
use serde::{Deserialize, Serialize};

/// Which model evaluates light that enters the blade (the specular lobe is the same in all).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LeafMode {
    /// The full layered model: single scattering through the three refracting layers in
    /// closed form (Hanrahan & Krueger 1993) plus Kubelka-Munk diffusion of the layers
    /// combined with the adding equations. The default.
    #[default]
    Layered,
    /// The paper's fast Eq. (1): `L = (1 + e^{-s_i} e^{-s_o}) L_i (N . w_i)`, a diffuse term
    /// plus an attenuated single-scattering term, with `s` the optical depth of the blade
    /// along the refracted directions.
    Eq1,
    /// The scattering layer made fully diffusing: Lambertian reflection and transmission
    /// whose albedos come from the maps (and the Kubelka-Munk variation with thickness and
    /// extinction). With `specular = 0` and uniform maps this is exactly
    /// [`crate::DiffuseTransmission`].
    Diffuse,
}

/// One homogeneous layer of the blade.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerParams {
    /// Fraction of the local blade thickness taken by this layer, in `[0, 1]`; the three
    /// fractions sum to 1.
    pub fraction: f32,
    /// Real index of refraction of the layer (dimensionless, `>= 1`; cuticle and epidermis
    /// about 1.45-1.5, water-filled mesophyll about 1.35-1.45).
    pub ior: f32,
    /// Absorption coefficient `sigma_a` per linear-RGB channel, in 1/mm (`>= 0`).
    pub absorption: Vec3,
    /// Scattering coefficient `sigma_s` per linear-RGB channel, in 1/mm (`>= 0`).
    pub scattering: Vec3,
}

/// The leaf's physical parameters. Deserialised from the `[params]` table of a `leaf.toml`
/// (every field optional; missing ones take the default, a believable green leaf).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LeafParams {
    /// Which model evaluates the light that enters the blade.
    pub mode: LeafMode,
    /// Blade thickness where the thickness map reads 0.5 (or everywhere without a map),
    /// in millimetres; allowed `(0, 5]`, typical leaves 0.1-0.5.
    pub thickness_mm: f32,
    /// How strongly the thickness map varies the thickness, in `[0, 1]`: the local
    /// thickness is `thickness_mm * (1 + thickness_variation * (2 t - 1))` for map value
    /// `t` in `[0, 1]`.
    pub thickness_variation: f32,
    /// How strongly the extinction map scales absorption, in `[0, 1]`: every layer's
    /// `absorption` is multiplied by `1 + extinction_strength * (2 e - 1)` for map value `e`
    /// (`e = 1 - Y(translucency scan)`: darker in the scan, more absorbing).
    pub extinction_strength: f32,
    /// Upper (adaxial) epidermis with its cuticle, on the `+z` side.
    pub upper: LayerParams,
    /// Mesophyll: palisade and spongy parenchyma, the scattering interior.
    pub mesophyll: LayerParams,
    /// Lower (abaxial) epidermis, on the `-z` side.
    pub lower: LayerParams,
    /// Henyey-Greenstein asymmetry `g` of single scattering inside the blade, in
    /// `[-0.95, 0.95]` (positive: forward scattering).
    pub phase_g: f32,
    /// GGX roughness `alpha` of the waxy adaxial (upper) surface, in `[0.01, 1]`.
    pub roughness_adaxial: f32,
    /// GGX roughness `alpha` of the rougher abaxial (lower) surface, in `[0.01, 1]`.
    pub roughness_abaxial: f32,
    /// Weight of the specular (surface) lobe in `[0, 1]`; 0 switches it off.
    pub specular: f32,
    /// Angular width, in degrees `[0.5, 45]`, of the band next to the leaf plane across
    /// which shading blends from the bump-mapped front-lit (or back-lit) value to zero at
    /// the plane, so that a light crossing the plane causes no popping.
    pub blend_width_deg: f32,
    /// Strength of the bump map, `[0, 1]`: the shading normal is
    /// `normalize(-s dh/du, -s dh/dv, 1)` with `h` the bump map value and `u, v` texture
    /// coordinates (so `s` is height in texture-space units per unit of map value).
    pub bump_scale: f32,
}

impl Default for LeafParams {
    fn default() -> Self {
        LeafParams {
            mode: LeafMode::Layered,
            thickness_mm: 0.25,
            thickness_variation: 0.5,
            extinction_strength: 0.5,
            upper: LayerParams {
                fraction: 0.15,
                ior: 1.45,
                absorption: Vec3::new(0.2, 0.2, 0.6),
                scattering: Vec3::splat(0.5),
            },
            mesophyll: LayerParams {
                fraction: 0.7,
                ior: 1.45,
                absorption: Vec3::new(12.0, 3.0, 60.0),
                scattering: Vec3::splat(4.0),
            },
            lower: LayerParams {
                fraction: 0.15,
                ior: 1.45,
                absorption: Vec3::new(0.2, 0.2, 0.6),
                scattering: Vec3::splat(1.0),
            },
            phase_g: 0.3,
            roughness_adaxial: 0.15,
            roughness_abaxial: 0.45,
            specular: 1.0,
            blend_width_deg: 8.0,
            bump_scale: 0.005,
        }
    }
}

fn check(field: &'static str, v: f32, lo: f32, hi: f32, lo_open: bool) -> Result<(), LeafError> {
    let ok = v.is_finite() && (if lo_open { v > lo } else { v >= lo }) && v <= hi;
    if ok {
        Ok(())
    } else {
        Err(LeafError::InvalidParam {
            field,
            value: format!("{v}"),
            allowed: format!(
                "must be a finite number in {}{lo}, {hi}]",
                if lo_open { "(" } else { "[" }
            ),
        })
    }
}

fn check_rgb(field: &'static str, v: Vec3, hi: f32) -> Result<(), LeafError> {
    if v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= hi {
        Ok(())
    } else {
        Err(LeafError::InvalidParam {
            field,
            value: format!("[{}, {}, {}]", v.x, v.y, v.z),
            allowed: format!("each RGB channel must be a finite number in [0, {hi}] (1/mm)"),
        })
    }
}

impl LayerParams {
    fn validate(&self, names: [&'static str; 4]) -> Result<(), LeafError> {
        check(names[0], self.fraction, 0.0, 1.0, false)?;
        check(names[1], self.ior, 1.0, 3.0, false)?;
        check_rgb(names[2], self.absorption, 1.0e5)?;
        check_rgb(names[3], self.scattering, 1.0e5)
    }
}

impl LeafParams {
    /// Checks every field; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<(), LeafError> {
        check("thickness_mm", self.thickness_mm, 0.0, 5.0, true)?;
        check(
            "thickness_variation",
            self.thickness_variation,
            0.0,
            1.0,
            false,
        )?;
        check(
            "extinction_strength",
            self.extinction_strength,
            0.0,
            1.0,
            false,
        )?;
        self.upper.validate([
            "upper.fraction",
            "upper.ior",
            "upper.absorption",
            "upper.scattering",
        ])?;
        self.mesophyll.validate([
            "mesophyll.fraction",
            "mesophyll.ior",
            "mesophyll.absorption",
            "mesophyll.scattering",
        ])?;
        self.lower.validate([
            "lower.fraction",
            "lower.ior",
            "lower.absorption",
            "lower.scattering",
        ])?;
        let sum = self.upper.fraction + self.mesophyll.fraction + self.lower.fraction;
        if (sum - 1.0).abs() > 1e-3 {
            return Err(LeafError::InvalidParam {
                field: "upper.fraction + mesophyll.fraction + lower.fraction",
                value: format!("{sum}"),
                allowed: "the three layer fractions must sum to 1 (within 0.001)".into(),
            });
        }
        if self.mesophyll.fraction <= 0.0 {
            return Err(LeafError::InvalidParam {
                field: "mesophyll.fraction",
                value: format!("{}", self.mesophyll.fraction),
                allowed: "the scattering layer must have a positive fraction, in (0, 1]".into(),
            });
        }
        check("phase_g", self.phase_g, -0.95, 0.95, false)?;
        check(
            "roughness_adaxial",
            self.roughness_adaxial,
            0.01,
            1.0,
            false,
        )?;
        check(
            "roughness_abaxial",
            self.roughness_abaxial,
            0.01,
            1.0,
            false,
        )?;
        check("specular", self.specular, 0.0, 1.0, false)?;
        check("blend_width_deg", self.blend_width_deg, 0.5, 45.0, false)?;
        check("bump_scale", self.bump_scale, 0.0, 1.0, false)
    }

    /// The three layers from the adaxial (`+z`) side down.
    pub fn layers(&self) -> [LayerParams; 3] {
        [self.upper, self.mesophyll, self.lower]
    }
}
