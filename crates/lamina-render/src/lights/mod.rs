//! Light sources: what next-event estimation samples and what escaping or emitter-hitting
//! rays see.
//!
//! Every light returns a [`LightSample`] with its solid-angle density at the shaded point
//! (1 for delta lights), so the path integrator can weight light samples against BSDF
//! samples with the power heuristic. Scene light `i` keeps index `i` here; the sky, if
//! any, comes last.

mod area;
mod point;
mod sky;
mod sun;

pub use area::{QuadLight, SphereLight};
pub use point::PointLight;
pub use sky::{EnvMap, SkyLight};
pub use sun::SunLight;

use crate::error::RenderError;
use glam::{Vec2, Vec3};
use lamina_core::{Light, Scene};

/// One light sample seen from a shaded point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shaded point toward the light.
    pub wi: Vec3,
    /// Incident radiance (W m⁻² sr⁻¹) for area and distant lights; for delta lights, the
    /// irradiance on a surface facing the light (W m⁻²), so the estimate is always
    /// `f · li / pdf`.
    pub li: Vec3,
    /// Solid-angle density of `wi` (1/sr); 1 for delta lights.
    pub pdf: f32,
    /// Distance to the sampled point (m), `∞` for distant lights.
    pub dist: f32,
    /// Whether the light is a delta distribution (not reachable by BSDF sampling).
    pub delta: bool,
}

/// Any light of a scene.
#[derive(Clone, Debug)]
pub enum AnyLight {
    /// The sun (delta or cone).
    Sun(SunLight),
    /// A point light.
    Point(PointLight),
    /// An emitting parallelogram.
    Quad(QuadLight),
    /// An emitting sphere.
    Sphere(SphereLight),
    /// The sky.
    Sky(SkyLight),
}

impl AnyLight {
    /// Samples a direction toward the light from `p` with `u ∈ [0, 1)²`.
    #[inline]
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            AnyLight::Sun(l) => Some(l.sample(u)),
            AnyLight::Point(l) => l.sample(p),
            AnyLight::Quad(l) => l.sample(p, u),
            AnyLight::Sphere(l) => l.sample(p, u),
            AnyLight::Sky(l) => l.sample(u),
        }
    }

    /// Whether the light sits at infinity (seen by rays that escape the scene).
    #[inline]
    pub fn is_infinite(&self) -> bool {
        matches!(self, AnyLight::Sun(_) | AnyLight::Sky(_))
    }

    /// Radiance seen along `dir` by a ray that escapes the scene, and the solid-angle density
    /// with which [`AnyLight::sample`] picks `dir` (zero for non-infinite lights).
    #[inline]
    pub fn escaped(&self, dir: Vec3) -> (Vec3, f32) {
        match self {
            AnyLight::Sun(l) => l.escaped(dir),
            AnyLight::Sky(l) => (l.le(dir), l.pdf(dir)),
            _ => (Vec3::ZERO, 0.0),
        }
    }
}

/// All lights of a scene, in scene order, with the sky last.
#[derive(Clone, Debug)]
pub struct LightSet {
    /// The lights.
    pub lights: Vec<AnyLight>,
    /// Mean radiance of the sky over the sphere (zero without a sky).
    pub sky_mean: Vec3,
}

impl LightSet {
    /// Prepares the lights of `scene`. An error for non-finite values or a zero sun
    /// direction.
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        let mut lights = Vec::with_capacity(scene.lights.len() + 1);
        for (i, l) in scene.lights.iter().enumerate() {
            let bad = |what: &str| RenderError::InvalidScene(format!("light {i}: {what}"));
            lights.push(match l {
                Light::Sun {
                    direction,
                    irradiance,
                    angular_diameter_deg,
                } => AnyLight::Sun(
                    SunLight::new(*direction, *irradiance, *angular_diameter_deg)
                        .ok_or_else(|| bad("sun direction must be a finite non-zero vector"))?,
                ),
                Light::Point {
                    position,
                    intensity,
                } => {
                    if !position.is_finite() || !intensity.is_finite() {
                        return Err(bad("point light values must be finite"));
                    }
                    AnyLight::Point(PointLight {
                        position: *position,
                        intensity: *intensity,
                    })
                }
                Light::Quad {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                    two_sided,
                } => AnyLight::Quad(
                    QuadLight::new(*corner, *edge_u, *edge_v, *radiance, *two_sided)
                        .ok_or_else(|| bad("quad light must be finite with non-zero area"))?,
                ),
                Light::Sphere {
                    center,
                    radius,
                    radiance,
                } => {
                    if !(center.is_finite()
                        && radiance.is_finite()
                        && *radius > 0.0
                        && radius.is_finite())
                    {
                        return Err(bad("sphere light must be finite with a positive radius"));
                    }
                    AnyLight::Sphere(SphereLight {
                        center: *center,
                        radius: *radius,
                        radiance: *radiance,
                    })
                }
            });
        }
        let mut sky_mean = Vec3::ZERO;
        if let Some(sky) = &scene.sky {
            let s = SkyLight::new(sky)?;
            sky_mean = s.mean();
            lights.push(AnyLight::Sky(s));
        }
        Ok(LightSet { lights, sky_mean })
    }
}

/// The power heuristic with exponent 2 for a sample drawn with density `a` against a
/// strategy of density `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2.is_infinite() {
        return 1.0;
    }
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// Builds a direction from a cone sample around the local `+z` axis: `h = 1 - cos θmax`,
/// returns the local direction. Uses `sin²θ = uh (2 - uh)` so tiny cones stay precise.
#[inline]
pub(crate) fn sample_cone(u: Vec2, h: f32) -> Vec3 {
    let uh = u.x * h;
    let cos_t = 1.0 - uh;
    let sin_t = (uh * (2.0 - uh)).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t)
}
