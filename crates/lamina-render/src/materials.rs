//! From a scene [`Material`] to the BSDF at one surface point.
//!
//! All materials are two-sided and evaluated in the local frame of
//! [`crate::shading::ShadingFrame`]: `z` the mesh's interpolated vertex normal flipped to
//! the side of the triangle's geometric normal as wound (for leaves the adaxial side), or
//! that geometric normal where there are no vertex normals; `x` along `dP/du`. Which side a
//! direction is on (reflection or transmission, adaxial or abaxial) is decided by the
//! geometric normal: the integrators drop directions the two normals disagree on. The leaf
//! model handles its bump map internally, relative to this frame.

use glam::{Vec2, Vec3};
use lamina_core::Material;
use lamina_leaf::{Bsdf, BsdfSample, DiffuseTransmission, Lambertian, LeafBsdf, PbrBsdf};

/// The BSDF at a surface point: a closed enum (no allocation, no dynamic dispatch).
// The leaf variant is larger, but the enum lives on the stack for one vertex: boxing it
// would allocate per hit.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum SurfaceBsdf {
    /// [`Material::Diffuse`].
    Diffuse(Lambertian),
    /// [`Material::DiffuseTransmission`].
    DiffuseTransmission(DiffuseTransmission),
    /// [`Material::Leaf`].
    Leaf(LeafBsdf),
    /// [`Material::Pbr`].
    Pbr(PbrBsdf),
}

impl SurfaceBsdf {
    /// A black Lambertian: what room for a BSDF holds before [`Self::set_at`] writes one.
    pub const BLANK: SurfaceBsdf = SurfaceBsdf::Diffuse(Lambertian {
        reflectance: Vec3::ZERO,
    });

    /// The BSDF of `material` at texture coordinates `uv`.
    #[inline]
    pub fn at(material: &Material, uv: Vec2) -> Self {
        let mut b = SurfaceBsdf::BLANK;
        b.set_at(material, uv);
        b
    }

    /// [`Self::at`] written over `self`, in place: where `self` holds the same variant
    /// (consecutive vertices on one kind of surface), only that variant's fields are
    /// written. Returned by value and then stored, or stored as a new variant, the whole
    /// enum (the size of its largest variant, 280 bytes) is copied through a temporary.
    #[inline]
    pub fn set_at(&mut self, material: &Material, uv: Vec2) {
        match material {
            Material::Diffuse { reflectance, .. } => {
                let b = Lambertian {
                    reflectance: reflectance.at(uv),
                };
                match self {
                    SurfaceBsdf::Diffuse(x) => *x = b,
                    o => *o = SurfaceBsdf::Diffuse(b),
                }
            }
            Material::DiffuseTransmission {
                reflectance,
                transmittance,
                ..
            } => {
                let b = DiffuseTransmission {
                    reflectance: reflectance.at(uv),
                    transmittance: transmittance.at(uv),
                };
                match self {
                    SurfaceBsdf::DiffuseTransmission(x) => *x = b,
                    o => *o = SurfaceBsdf::DiffuseTransmission(b),
                }
            }
            Material::Leaf { leaf, .. } => match self {
                SurfaceBsdf::Leaf(x) => *x = leaf.bsdf(uv),
                o => *o = SurfaceBsdf::Leaf(leaf.bsdf(uv)),
            },
            Material::Pbr(p) => match self {
                SurfaceBsdf::Pbr(x) => *x = p.bsdf(uv),
                o => *o = SurfaceBsdf::Pbr(p.bsdf(uv)),
            },
        }
    }

    /// The BSDFs of several materials, one per channel set of a spectral render, at the
    /// same `uv`, into `out`: a leaf's variants read their shared maps once
    /// ([`lamina_leaf::LeafMaterial::bsdf_sets_each`]), and each leaf BSDF is written over
    /// the leaf BSDF already there, in place (a path's vertices mostly hit leaves); other
    /// materials replace theirs. (Built through `from_fn` or `map`, or returned by value,
    /// every element was moved through a temporary the size of the largest variant: a
    /// measured few per cent of a visible render in memmove.)
    #[inline]
    pub fn at_sets_into<const G: usize>(materials: [&Material; G], uv: Vec2, out: &mut [Self; G]) {
        let leaf = |k: usize| match materials[k] {
            Material::Leaf { leaf, .. } => Some(&**leaf),
            _ => None,
        };
        if G > 1 && (0..G).all(|k| leaf(k).is_some()) {
            let leaves: [&lamina_leaf::LeafMaterial; G] =
                std::array::from_fn(|k| leaf(k).expect("checked"));
            lamina_leaf::LeafMaterial::bsdf_sets_each(leaves, uv, |k, t| match &mut out[k] {
                SurfaceBsdf::Leaf(b) => t.write(b),
                o => *o = SurfaceBsdf::Leaf(t.make()),
            });
        } else {
            for (o, m) in out.iter_mut().zip(materials) {
                o.set_at(m, uv);
            }
        }
    }

    /// `eval` of each of `b` (one per channel set) for the same directions, sharing what a
    /// leaf's variants share ([`LeafBsdf::eval_sets`]).
    #[inline]
    pub fn eval_sets<const G: usize>(b: &[Self; G], wo: Vec3, wi: Vec3) -> [Vec3; G] {
        match leaf_refs(b) {
            Some(l) => LeafBsdf::eval_sets(l, wo, wi),
            None => std::array::from_fn(|k| b[k].eval(wo, wi)),
        }
    }

    /// The mean of the `pdf`s of `b` (the one-sample MIS density over the sets).
    #[inline]
    pub fn pdf_mean<const G: usize>(b: &[Self; G], wo: Vec3, wi: Vec3) -> f32 {
        match leaf_refs(b) {
            Some(l) => LeafBsdf::pdf_mean(l, wo, wi),
            None => b.iter().map(|x| x.pdf(wo, wi)).sum::<f32>() / G as f32,
        }
    }

    /// Diffuse hemispherical (reflectance, transmittance), linear RGB: what the paper
    /// integrator's ambient multiple-scattering term multiplies.
    #[inline]
    pub fn diffuse_albedo(&self) -> (Vec3, Vec3) {
        match self {
            SurfaceBsdf::Diffuse(b) => (b.reflectance, Vec3::ZERO),
            SurfaceBsdf::DiffuseTransmission(b) => (b.reflectance, b.transmittance),
            SurfaceBsdf::Leaf(b) => b.diffuse_albedo(),
            SurfaceBsdf::Pbr(b) => b.diffuse_albedo(),
        }
    }
}

/// The leaf BSDFs of `b` when every one is a leaf (and there are several).
#[inline]
fn leaf_refs<const G: usize>(b: &[SurfaceBsdf; G]) -> Option<[&LeafBsdf; G]> {
    if G < 2 || !b.iter().all(|x| matches!(x, SurfaceBsdf::Leaf(_))) {
        return None;
    }
    Some(std::array::from_fn(|k| match &b[k] {
        SurfaceBsdf::Leaf(l) => l,
        _ => unreachable!("checked above"),
    }))
}

impl Bsdf for SurfaceBsdf {
    #[inline]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            SurfaceBsdf::Diffuse(b) => b.eval(wo, wi),
            SurfaceBsdf::DiffuseTransmission(b) => b.eval(wo, wi),
            SurfaceBsdf::Leaf(b) => b.eval(wo, wi),
            SurfaceBsdf::Pbr(b) => b.eval(wo, wi),
        }
    }

    #[inline]
    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample> {
        match self {
            SurfaceBsdf::Diffuse(b) => b.sample(wo, u),
            SurfaceBsdf::DiffuseTransmission(b) => b.sample(wo, u),
            SurfaceBsdf::Leaf(b) => b.sample(wo, u),
            SurfaceBsdf::Pbr(b) => b.sample(wo, u),
        }
    }

    #[inline]
    fn sample_direction(&self, wo: Vec3, u: Vec3) -> Option<Vec3> {
        match self {
            SurfaceBsdf::Diffuse(b) => b.sample_direction(wo, u),
            SurfaceBsdf::DiffuseTransmission(b) => b.sample_direction(wo, u),
            SurfaceBsdf::Leaf(b) => b.sample_direction(wo, u),
            SurfaceBsdf::Pbr(b) => b.sample_direction(wo, u),
        }
    }

    #[inline]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            SurfaceBsdf::Diffuse(b) => b.pdf(wo, wi),
            SurfaceBsdf::DiffuseTransmission(b) => b.pdf(wo, wi),
            SurfaceBsdf::Leaf(b) => b.pdf(wo, wi),
            SurfaceBsdf::Pbr(b) => b.pdf(wo, wi),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tests::scenes::{diffuse, diffuse_transmission};
    use lamina_core::PbrMaterial;
    use lamina_leaf::{LeafMaps, LeafMaterial, LeafParams};
    use std::sync::Arc;

    /// `set_at` over a BSDF of every variant (the same variant: fields written in place;
    /// another: replaced) gives `at`'s BSDF: the same values and densities bit for bit.
    #[test]
    fn set_at_over_any_variant_is_at() {
        // Each kind twice, with other parameters: what is there first differs from what
        // is written over it even where the variant is the same.
        let kinds = |k: f32| {
            let params = LeafParams {
                roughness_adaxial: 0.2 + 0.3 * k,
                ..LeafParams::default()
            };
            let leaf = LeafMaterial::new(LeafMaps::default(), params).unwrap();
            [
                diffuse(0.3 + 0.4 * k),
                diffuse_transmission(Vec3::new(0.1, 0.4 - 0.2 * k, 0.05), Vec3::new(0.2, 0.3, k)),
                Material::Leaf {
                    name: "leaf".into(),
                    leaf: Arc::new(leaf),
                },
                Material::Pbr(Box::new(PbrMaterial::uniform(
                    "p",
                    Vec3::splat(0.6 - 0.3 * k),
                    0.5 * k,
                    0.4,
                ))),
            ]
        };
        let (materials, starts) = (kinds(0.0), kinds(1.0));
        let uv = Vec2::new(0.3, 0.7);
        let dirs = [
            (Vec3::new(0.3, 0.2, 0.93), Vec3::new(-0.5, 0.1, 0.86)),
            (Vec3::new(0.3, 0.2, 0.93), Vec3::new(0.2, -0.4, -0.89)),
            (Vec3::new(0.0, -0.6, -0.8), Vec3::new(0.6, 0.0, 0.8)),
        ];
        let bits = |b: &SurfaceBsdf| -> Vec<u32> {
            dirs.iter()
                .flat_map(|&(wo, wi)| {
                    let (wo, wi) = (wo.normalize(), wi.normalize());
                    let f = b.eval(wo, wi).to_array().map(f32::to_bits);
                    f.into_iter().chain([b.pdf(wo, wi).to_bits()])
                })
                .collect()
        };
        for start in &starts {
            for m in &materials {
                // Something else there first, then `m` written over it.
                let mut b = SurfaceBsdf::at(start, Vec2::new(0.9, 0.1));
                b.set_at(m, uv);
                let want = SurfaceBsdf::at(m, uv);
                assert_eq!(
                    std::mem::discriminant(&b),
                    std::mem::discriminant(&want),
                    "{} over {}",
                    m.name(),
                    start.name()
                );
                assert_eq!(bits(&b), bits(&want), "{} over {}", m.name(), start.name());
            }
        }
    }
}
