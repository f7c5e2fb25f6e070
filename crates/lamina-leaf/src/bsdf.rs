//! The BSDF interface shared by every material.

use glam::Vec3;

/// One direction drawn by [`Bsdf::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// Sampled incident direction (toward the light), unit length, local frame.
    pub wi: Vec3,
    /// `f(wo, wi) |cos θi|`, per RGB channel (same quantity [`Bsdf::eval`] returns).
    pub f: Vec3,
    /// Probability density of `wi`, per unit solid angle. Always `> 0`.
    pub pdf: f32,
}

impl BsdfSample {
    /// The path throughput multiplier `f |cos| / pdf`.
    #[inline]
    pub fn weight(&self) -> Vec3 {
        self.f / self.pdf
    }
}

/// A bidirectional scattering distribution function at one surface point.
///
/// All directions are unit vectors in the local frame (see the crate docs). Implementations
/// must not allocate.
pub trait Bsdf {
    /// `f(wo, wi) |cos θi|` (1/sr), reflection when `wo.z` and `wi.z` share a sign,
    /// transmission otherwise. Zero for directions in the surface plane.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;

    /// Draws `wi` given `wo` from three uniform numbers in `[0, 1)`. `None` when the
    /// sample carries no energy (e.g. `wo` in the plane, or an absorbing lobe chosen).
    fn sample(&self, wo: Vec3, u: Vec3) -> Option<BsdfSample>;

    /// The direction [`Bsdf::sample`] draws from the same numbers, without its value and
    /// density: for callers that weigh it by other BSDFs' values and a mixture density
    /// anyway (the hero of a spectral path). `None` where `sample` draws no direction; a
    /// direction may be returned where `sample` would discard it for a zero density.
    fn sample_direction(&self, wo: Vec3, u: Vec3) -> Option<Vec3> {
        self.sample(wo, u).map(|s| s.wi)
    }

    /// Solid-angle density with which [`Bsdf::sample`] returns `wi` for this `wo`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
}
