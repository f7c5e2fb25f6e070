//! A leaf driven by pigments: PROSPECT gives its spectra, the three-layer model its
//! angular shape, its sides and its response to the thickness and extinction maps.
//!
//! # The mapping (what the README's "pigment leaves" section says in full)
//! At each wavelength `λ` the layered model gets:
//!
//! * **Absorption from the pigments.** PROSPECT's leaf absorbs `τ(λ) = N k(λ) = Σ C_i K_i(λ)`
//!   (optical depth at normal incidence, [`crate::prospect::Pigments::plate_absorption`]
//!   times `N`). Chlorophyll, carotenoids, anthocyanins and brown pigments sit in the
//!   mesophyll (the epidermis has no chloroplasts): `σ_a,meso += τ_pig / (f_meso d)`. Water
//!   and dry matter fill every cell: `σ_a += τ_wd / d` in all three layers. `d` is
//!   `thickness_mm`, `f_meso` the mesophyll fraction; scattering, refractive indices, phase
//!   function, roughness and specular weight stay the leaf's parameters (they are not
//!   pigments).
//! * **Colours from PROSPECT.** The colour maps of an RGB leaf are white-sky albedos that
//!   the physics is normalised to ([`crate::material`]); here they are set per wavelength
//!   so that at the nominal texel the leaf's directional-hemispherical `R` and `T` for light
//!   at [`CALIBRATION_THETA_DEG`] on the adaxial side (the integrating sphere's geometry,
//!   specular lobe included) equal PROSPECT's: `C_R = A_R (R_P - s) / ρ_R`,
//!   `C_T = A_T T_P / ρ_T`, with `ρ` the physical subsurface lobes' directional albedos at 8°
//!   (the layer model before colours and energy scale) and `A` their white-sky albedos (both
//!   integrated from the BSDF by the quadrature the energy
//!   table uses, every wavelength triple of a render at once; [`crate::albedo`]'s sampled
//!   estimate, what `lamina leaf albedo` prints, agrees within its noise) and `s` the
//!   specular lobe's albedo at 8°. The abaxial colour keeps the physics' adaxial/abaxial ratio,
//!   `C_B = C_R A_B / A_R` (PROSPECT has one side).
//! * **Maps modulate pigments.** The extinction map scales the absorption (so the pigment
//!   contents) by `1 + s (2e - 1)` and the thickness map the path length, as for an RGB leaf;
//!   alpha and bump maps work as usual. Colour maps (front, back, translucency) would
//!   override PROSPECT and are refused with pigments.
//!
//! A material only carries three channels, so the spectral leaf is a set of
//! [`LeafMaterial`]s, each for three wavelengths ([`PigmentLeaf::material`]), built on
//! demand: the same code path as an RGB leaf, per wavelength.

use crate::LeafError;
use crate::maps::LeafMaps;
use crate::material::LeafMaterial;
use crate::params::{LeafMode, LeafParams};
use crate::prospect::{LeafSpectrum, Pigments, constants, prospect};
use crate::spectrum::{Spectrum, reflectance_to_linear_rec709};
use crate::texture::Texture;
use glam::Vec3;

/// Incidence angle (degrees, adaxial side) at which a pigment leaf equals PROSPECT.
pub const CALIBRATION_THETA_DEG: f32 = 8.0;

/// A leaf whose optics come from PROSPECT pigments (see the module docs).
#[derive(Clone, Debug)]
pub struct PigmentLeaf {
    pigments: Pigments,
    params: LeafParams,
    /// The non-colour maps (alpha, thickness, extinction, bump).
    maps: LeafMaps,
    spectrum: LeafSpectrum,
    /// The specular lobe's albedo (times its weight) for light at
    /// [`CALIBRATION_THETA_DEG`] on the adaxial side: what the calibration takes off
    /// PROSPECT's reflectance, made once (a 64-point integration).
    spec_calibration: f32,
}

/// Index into PROSPECT's 1 nm grid of `nm`, clamped to 400-2500 nm.
fn grid_index(nm: f32) -> usize {
    (nm.round().clamp(400.0, 2500.0) as usize) - 400
}

impl PigmentLeaf {
    /// A pigment leaf. `pigments` are checked against their published ranges, `params` as
    /// any leaf's (their absorption is replaced, see the module docs); `maps` may hold
    /// alpha, thickness, extinction and bump maps, not colour maps.
    pub fn new(pigments: Pigments, params: LeafParams, maps: LeafMaps) -> Result<Self, LeafError> {
        pigments.validate("pigments.")?;
        params.validate()?;
        for (name, m) in [
            ("front", &maps.front),
            ("back", &maps.back),
            ("translucency", &maps.translucency),
        ] {
            if m.is_some() {
                return Err(LeafError::InvalidPigment {
                    field: format!("maps.{name}"),
                    value: "a colour map".into(),
                    allowed: "a leaf described by pigments takes its colours from PROSPECT: \
                              drop the colour maps (front, back, translucency) or the pigments"
                        .into(),
                });
            }
        }
        if params.mode != LeafMode::Layered {
            return Err(LeafError::InvalidParam {
                field: "mode",
                value: format!("{:?}", params.mode),
                allowed: "a leaf described by pigments uses the layered model".into(),
            });
        }
        let (s, c) = CALIBRATION_THETA_DEG.to_radians().sin_cos();
        let spec_calibration = params.specular
            * crate::specular::albedo(
                Vec3::new(s, 0.0, c),
                params.roughness_adaxial,
                params.upper.ior,
                64,
            );
        Ok(PigmentLeaf {
            spectrum: prospect(&pigments),
            pigments,
            params,
            maps,
            spec_calibration,
        })
    }

    /// The pigments.
    pub fn pigments(&self) -> &Pigments {
        &self.pigments
    }

    /// PROSPECT's spectra of these pigments (400-2500 nm, 1 nm).
    pub fn prospect_spectrum(&self) -> &LeafSpectrum {
        &self.spectrum
    }

    /// The leaf parameters with each layer's absorption (1/mm) at the three wavelengths
    /// `nm` (one per channel) from the pigments.
    pub fn params_at(&self, nm: [f32; 3]) -> LeafParams {
        let c = constants();
        let p = &self.pigments;
        let d = self.params.thickness_mm;
        let mut pig = [0.0f32; 3];
        let mut wd = [0.0f32; 3];
        for (ch, &l) in nm.iter().enumerate() {
            let k = &c[grid_index(l)];
            pig[ch] = (p.cab * k.k_cab + p.car * k.k_car + p.anth * k.k_anth + p.cbrown * k.k_brown)
                as f32;
            wd[ch] = (p.cw * k.k_w + p.cm * k.k_m + p.prot * k.k_prot + p.cbc * k.k_cbc) as f32;
        }
        let pig = Vec3::from(pig);
        let wd = Vec3::from(wd) / d;
        let mut q = self.params;
        q.upper.absorption = wd;
        q.lower.absorption = wd;
        q.mesophyll.absorption = wd + pig / (q.mesophyll.fraction * d);
        q
    }

    /// The white-sky colour targets (adaxial R, abaxial R, T) at the three wavelengths
    /// `nm`, calibrated so that the nominal texel's directional R and T at 8° equal
    /// PROSPECT's (module docs).
    pub fn colours_at(&self, nm: [f32; 3]) -> Result<[Vec3; 3], LeafError> {
        let mut c = self.colours_each(&[nm])?;
        Ok(c.pop().expect("one colour triple per wavelength triple"))
    }

    /// [`Self::colours_at`] at each wavelength triple of `nms`, bit for bit, the bare
    /// materials' precomputations run together ([`LeafMaterial::new_each`]).
    fn colours_each(&self, nms: &[[f32; 3]]) -> Result<Vec<[Vec3; 3]>, LeafError> {
        let items = nms
            .iter()
            .map(|&nm| {
                let mut physical = self.params_at(nm);
                physical.specular = 0.0;
                (LeafMaps::default(), physical)
            })
            .collect();
        let bare = LeafMaterial::new_each(items)?;
        let rho = LeafMaterial::nominal_directional_albedos_each(
            &bare,
            CALIBRATION_THETA_DEG.to_radians().cos(),
        );
        let spec = self.spec_calibration;
        Ok(nms
            .iter()
            .zip(&bare)
            .zip(rho)
            .map(|((nm, bare), (rho_r, rho_t))| {
                let [a_r, a_b, a_t] = bare.physical_albedos();
                let mut cr = [0.0f32; 3];
                let mut ct = [0.0f32; 3];
                for ch in 0..3 {
                    let (r, t) = self.spectrum.at(nm[ch] as f64);
                    let (r, t) = (r as f32, t as f32);
                    cr[ch] = safe_div(a_r[ch] * (r - spec).max(0.0), rho_r[ch]);
                    ct[ch] = safe_div(a_t[ch] * t, rho_t[ch]);
                }
                let cr = Vec3::from(cr).clamp(Vec3::ZERO, Vec3::ONE);
                let ct = Vec3::from(ct).clamp(Vec3::ZERO, Vec3::ONE);
                let cb = Vec3::from_array([0, 1, 2].map(|ch| safe_div(cr[ch] * a_b[ch], a_r[ch])))
                    .clamp(Vec3::ZERO, Vec3::ONE);
                [cr, cb, ct]
            })
            .collect())
    }

    /// The leaf at three wavelengths `nm` (one per channel of the material): the renderer's
    /// material, built in a few tens of milliseconds.
    pub fn material(&self, nm: [f32; 3]) -> Result<LeafMaterial, LeafError> {
        LeafMaterial::new(self.maps_at(nm)?, self.params_at(nm))
    }

    /// [`Self::material`], sharing the data maps' interleaved grid with `like` (a material
    /// of this leaf, e.g. [`Self::rgb_material`]'s) instead of building its own: what renders
    /// that hold this leaf at many wavelengths at once use. Bit-identical to
    /// [`Self::material`].
    pub fn material_like(
        &self,
        nm: [f32; 3],
        like: &LeafMaterial,
    ) -> Result<LeafMaterial, LeafError> {
        LeafMaterial::new_like(self.maps_at(nm)?, self.params_at(nm), like)
    }

    /// [`Self::material_like`] at each wavelength triple of `nms` (a spectral render's
    /// channel sets): each material bit for bit `material_like`'s, their precomputations run
    /// together ([`LeafMaterial::new_like_each`]), several times faster than one by one.
    pub fn materials_like(
        &self,
        nms: &[[f32; 3]],
        like: &LeafMaterial,
    ) -> Result<Vec<LeafMaterial>, LeafError> {
        let colours = self.colours_each(nms)?;
        let items = nms
            .iter()
            .zip(colours)
            .map(|(&nm, c)| (self.maps_with(c), self.params_at(nm)))
            .collect();
        LeafMaterial::new_like_each(items, like)
    }

    /// The data maps with the calibrated colours at `nm` as constant colour maps.
    fn maps_at(&self, nm: [f32; 3]) -> Result<LeafMaps, LeafError> {
        let [c] = self.colours_each(&[nm])?[..] else {
            unreachable!("one colour triple per wavelength triple")
        };
        Ok(self.maps_with(c))
    }

    /// The data maps with the colours `[front, back, translucency]` as constant maps.
    fn maps_with(&self, [cr, cb, ct]: [Vec3; 3]) -> LeafMaps {
        let mut maps = self.maps.clone();
        maps.front = Some(Texture::constant(cr.extend(1.0)));
        maps.back = Some(Texture::constant(cb.extend(1.0)));
        maps.translucency = Some(Texture::constant(ct.extend(1.0)));
        maps
    }

    /// The leaf for an RGB render: colours are the linear Rec.709 colours (under D65) of the
    /// calibrated white-sky spectra, computed at `step_nm` over 400-830 nm (constant below
    /// 400 nm, where PROSPECT stops and the eye barely sees), and each channel's absorption is
    /// taken at its nominal wavelength ([`crate::spectrum::REC709_NOMINAL_NM`]).
    pub fn rgb_material(&self, step_nm: f32) -> Result<LeafMaterial, LeafError> {
        let nodes: Vec<f32> = {
            let n = ((830.0 - 400.0) / step_nm).ceil() as usize;
            (0..=n)
                .map(|k| (400.0 + k as f32 * step_nm).min(830.0))
                .collect()
        };
        let mut targets: [Vec<(f64, f64)>; 3] = Default::default();
        for triple in nodes.chunks(3) {
            let nm = [0, 1, 2].map(|k| triple[k.min(triple.len() - 1)]);
            let cols = self.colours_at(nm)?;
            for (k, &l) in triple.iter().enumerate() {
                for x in 0..3 {
                    let v = (l as f64, cols[x][k] as f64);
                    if targets[x].last().is_none_or(|p| p.0 < v.0) {
                        targets[x].push(v);
                    }
                }
            }
        }
        let rgb = |x: usize| -> Vec3 {
            let s = Spectrum::from_samples(&targets[x]).expect("increasing nodes");
            reflectance_to_linear_rec709(|nm| s.eval(nm)).clamp(Vec3::ZERO, Vec3::ONE)
        };
        let mut maps = self.maps.clone();
        maps.front = Some(Texture::constant(rgb(0).extend(1.0)));
        maps.back = Some(Texture::constant(rgb(1).extend(1.0)));
        maps.translucency = Some(Texture::constant(rgb(2).extend(1.0)));
        LeafMaterial::new(maps, self.params_at(crate::spectrum::REC709_NOMINAL_NM))
    }
}

fn safe_div(a: f32, b: f32) -> f32 {
    if b > 1e-12 { a / b } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec4;

    #[test]
    fn materials_together_equal_one_by_one() {
        use crate::texture::Wrap;
        use glam::Vec2;
        let ramp = |f: fn(f32, f32) -> f32| {
            let (w, h) = (24u32, 20u32);
            Some(Texture::from_fn(w, h, Wrap::Repeat, |x, y| {
                Vec4::splat(f(x as f32 / w as f32, y as f32 / h as f32)).with_w(1.0)
            }))
        };
        let maps = LeafMaps {
            thickness: ramp(|x, y| 0.3 + 0.4 * x * y),
            extinction: ramp(|x, y| 0.2 + 0.7 * (1.0 - x) * y),
            ..LeafMaps::default()
        };
        let leaf = PigmentLeaf::new(Pigments::default(), LeafParams::default(), maps).unwrap();
        let like = leaf.material([550.0, 560.0, 570.0]).unwrap();
        let nms = [
            [450.0, 620.0, 700.0],
            [800.0, 1450.0, 1940.0],
            [500.0, 510.0, 2400.0],
        ];
        let together = leaf.materials_like(&nms, &like).unwrap();
        assert_eq!(together.len(), nms.len());
        for (nm, m) in nms.iter().zip(&together) {
            let one = leaf.material_like(*nm, &like).unwrap();
            assert_eq!(m.physical_albedos(), one.physical_albedos(), "{nm:?}");
            for uv in [
                Vec2::new(0.1, 0.2),
                Vec2::new(0.5, 0.5),
                Vec2::new(0.93, 0.71),
            ] {
                assert_eq!(m.bsdf(uv), one.bsdf(uv), "{nm:?} at {uv}");
            }
        }
    }

    #[test]
    fn colour_maps_are_refused_with_pigments() {
        let maps = LeafMaps {
            front: Some(Texture::constant(Vec4::ONE)),
            ..LeafMaps::default()
        };
        let e = PigmentLeaf::new(Pigments::default(), LeafParams::default(), maps)
            .unwrap_err()
            .to_string();
        assert!(e.contains("maps.front"), "{e}");
    }
}
