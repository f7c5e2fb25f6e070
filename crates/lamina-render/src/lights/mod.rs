//! Light sources: what next-event estimation samples and what escaping or emitter-hitting
//! rays see.
//!
//! Every light returns a [`LightSample`] with its solid-angle density at the shaded point
//! (1 for delta lights), so the path integrator can weight light samples against BSDF
//! samples with the power heuristic. Scene light `i` keeps index `i` here; the sky, if
//! any, comes last.

mod area;
mod pick;
mod point;
mod sky;
mod sun;

pub use area::{QuadLight, SphereLight};
pub use pick::{LightPick, scene_radius};
pub use point::PointLight;
pub use sky::{EnvMap, SkyLight};
pub use sun::SunLight;

use crate::error::RenderError;
use glam::{Vec2, Vec3};
use lamina_core::{Light, Scene, Sky};

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
    /// For a sample of a sky map: the index of its texel (row-major), so that the same sky
    /// in other channels reads its radiance there without converting `wi` again;
    /// [`NO_TEXEL`] otherwise.
    pub texel: u32,
}

/// [`LightSample::texel`] of samples that are not of a sky map.
pub const NO_TEXEL: u32 = u32::MAX;

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

    /// Whether [`AnyLight::sample`] reads its `u`: a delta sun and a point light do not,
    /// so a caller may skip drawing it (the stream then advances as if it had).
    #[inline]
    pub fn uses_sample(&self) -> bool {
        match self {
            AnyLight::Sun(l) => !l.is_delta(),
            AnyLight::Point(_) => false,
            AnyLight::Quad(_) | AnyLight::Sphere(_) | AnyLight::Sky(_) => true,
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
        let (le, pdf, _) = self.escaped_texel(dir);
        (le, pdf)
    }

    /// [`AnyLight::escaped`], and for a sky map the texel `dir` falls in ([`NO_TEXEL`]
    /// otherwise): what [`AnyLight::escaped_radiance`] of the same sky in other channels
    /// reads.
    #[inline]
    pub fn escaped_texel(&self, dir: Vec3) -> (Vec3, f32, u32) {
        match self {
            AnyLight::Sun(l) => {
                let (le, pdf) = l.escaped(dir);
                (le, pdf, NO_TEXEL)
            }
            AnyLight::Sky(l) => l.le_pdf(dir),
            _ => (Vec3::ZERO, 0.0, NO_TEXEL),
        }
    }

    /// Radiance along `dir` escaping the scene, as [`AnyLight::escaped`], without the
    /// density: what a light of the same geometry in other channels needs. `texel` is the
    /// sky texel of `dir` from [`AnyLight::escaped_texel`] of a sky of the same size.
    #[inline]
    pub fn escaped_radiance(&self, dir: Vec3, texel: u32) -> Vec3 {
        match self {
            AnyLight::Sun(l) => l.escaped(dir).0,
            AnyLight::Sky(l) => l.le_texel(dir, texel),
            _ => Vec3::ZERO,
        }
    }

    /// The `li` this light gives for `ls`, a sample of a light of the same geometry (the
    /// same light in other channels): its radiance (or, for delta lights, the irradiance
    /// `I / d²` or `E`) along `ls.wi`, whether or not its own sampling would have drawn it.
    #[inline]
    pub fn li_along(&self, ls: &LightSample) -> Vec3 {
        match self {
            AnyLight::Sun(l) => l.li(),
            AnyLight::Point(l) => l.intensity / (ls.dist * ls.dist),
            AnyLight::Quad(l) => l.radiance(),
            AnyLight::Sphere(l) => l.radiance,
            AnyLight::Sky(l) => l.le_texel(ls.wi, ls.texel),
        }
    }

    /// Radiance toward a ray from `origin` along `dir` that hits this emitter at distance
    /// `t`, and the density with which next-event estimation from `origin` samples that
    /// point; `(0, 0)` for lights that are not geometry.
    #[inline]
    pub fn hit(&self, origin: Vec3, dir: Vec3, t: f32) -> (Vec3, f32) {
        match self {
            AnyLight::Quad(q) => q.hit(dir, t),
            AnyLight::Sphere(s) => s.hit(origin, dir, t),
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
    /// How next-event estimation picks lights: `None` samples every light of
    /// [`LightSet::nee`] at every vertex ([`lamina_core::LightSampling::All`]); `Some` draws
    /// one of them ([`lamina_core::LightSampling::One`]).
    pub pick: Option<LightPick>,
    /// How many of the lights, from the first, next-event estimation samples: all of them,
    /// or all but the sky when BSDF samples alone reach it
    /// ([`lamina_core::SkySampling`]); a BSDF sample that escapes to a light past this
    /// count is counted in full (MIS weight 1).
    pub nee_count: usize,
    /// The lights a ray that leaves the scene can see, as indices into `lights`: the sky
    /// and suns with a disc (a delta sun is never hit). Made with `lights`.
    pub escaping: Vec<usize>,
}

impl LightSet {
    /// Prepares the lights of `scene`. An error for non-finite values or a zero sun
    /// direction.
    /// With the scene's path integrator set to `light_sampling = "one"`, it draws one light
    /// per vertex ([`LightPick`]); with its `sky_sampling` leaving the sky to BSDF samples
    /// ([`lamina_core::SkySampling`]), next-event estimation never samples the sky.
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        let mut set = Self::from_parts(&scene.lights, scene.sky.as_ref())?;
        if let lamina_core::Integrator::Path {
            light_sampling,
            sky_sampling,
            ..
        } = scene.integrator
        {
            if let Some(sky) = &scene.sky
                && !sky_sampling.light_samples(sky)
            {
                // The sky is the last light.
                set.nee_count = set.lights.len() - 1;
            }
            if light_sampling == lamina_core::LightSampling::One {
                set.pick = LightPick::new(&set.lights[..set.nee_count], scene_radius(scene));
            }
        }
        Ok(set)
    }

    /// What every escaping ray sees where that does not depend on its direction: the only
    /// light an escaping ray can see ([`LightSet::escaping`]) is a constant sky of non-zero
    /// radiance. Then its radiance (W m⁻² sr⁻¹, linear Rec.709) and the density MIS weighs
    /// a BSDF sample reaching it with (the sky's sampling density times its pick
    /// probability, as `escaped` and [`LightSet::pick_prob`] give them along any ray);
    /// `None` otherwise. The radiance is finite (a set is not made with a sky that is
    /// not): the wavefront adds it to every lane times 1 or 0.
    pub fn constant_escape(&self) -> Option<(Vec3, f32)> {
        let &[i] = self.escaping.as_slice() else {
            return None;
        };
        match &self.lights[i] {
            AnyLight::Sky(SkyLight::Constant(c)) if *c != Vec3::ZERO => {
                let (le, pdf) = self.lights[i].escaped(Vec3::Z);
                Some((le, pdf * self.pick_prob(i)))
            }
            _ => None,
        }
    }

    /// The lights next-event estimation samples (the first [`LightSet::nee_count`]).
    #[inline]
    pub fn nee(&self) -> &[AnyLight] {
        &self.lights[..self.nee_count]
    }

    /// [`Self::new`] from a scene's lights and sky.
    pub fn from_parts(scene_lights: &[Light], sky: Option<&Sky>) -> Result<Self, RenderError> {
        Self::from_parts_with(scene_lights, sky, true)
    }

    /// [`Self::from_parts`] for a spectral render's channel set: the same lights in other
    /// channels, only looked up along directions the scene's own lights drew, so a map sky
    /// gets no sampling distribution ([`EnvMap::new_unsampled`]).
    pub fn for_channel_set(scene_lights: &[Light], sky: Option<&Sky>) -> Result<Self, RenderError> {
        Self::from_parts_with(scene_lights, sky, false)
    }

    fn from_parts_with(
        scene_lights: &[Light],
        sky: Option<&Sky>,
        sampled: bool,
    ) -> Result<Self, RenderError> {
        let mut lights = Vec::with_capacity(scene_lights.len() + 1);
        for (i, l) in scene_lights.iter().enumerate() {
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
        if let Some(sky) = sky {
            let s = SkyLight::with_sampling(sky, sampled)?;
            sky_mean = s.mean();
            lights.push(AnyLight::Sky(s));
        }
        let escaping = (lights.iter().enumerate())
            .filter(|(_, l)| match l {
                AnyLight::Sun(s) => !s.is_delta(),
                l => l.is_infinite(),
            })
            .map(|(i, _)| i)
            .collect();
        Ok(LightSet {
            nee_count: lights.len(),
            lights,
            sky_mean,
            pick: None,
            escaping,
        })
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A ray that leaves the scene sees the sky and the suns with a disc, and nothing
    /// else: the lights `escaping` lists are the ones whose `escaped` can be non-zero.
    #[test]
    fn escaping_rays_see_skies_and_suns_with_a_disc() {
        let up = Vec3::Y;
        let lights = [
            Light::Sun {
                direction: up,
                irradiance: Vec3::ONE,
                angular_diameter_deg: 0.0,
            },
            Light::Point {
                position: up,
                intensity: Vec3::ONE,
            },
            Light::Sun {
                direction: up,
                irradiance: Vec3::ONE,
                angular_diameter_deg: 10.0,
            },
            Light::Quad {
                corner: Vec3::ZERO,
                edge_u: Vec3::X,
                edge_v: Vec3::Z,
                radiance: Vec3::ONE,
                two_sided: true,
            },
            Light::Sphere {
                center: up,
                radius: 0.5,
                radiance: Vec3::ONE,
            },
        ];
        let sky = Sky::Constant(Vec3::splat(0.5));
        let set = LightSet::from_parts(&lights, Some(&sky)).unwrap();
        assert_eq!(set.lights.len(), 6, "the sky comes last");
        assert_eq!(set.escaping, vec![2, 5]);
        // Straight up: the disc sun and the sky show something, every other light nothing.
        for (i, l) in set.lights.iter().enumerate() {
            let seen = l.escaped(up).0 != Vec3::ZERO;
            assert_eq!(seen, set.escaping.contains(&i), "light {i}");
        }
        let none = LightSet::from_parts(&lights[..2], None).unwrap();
        assert!(none.escaping.is_empty());
    }

    /// An escaping ray's light is constant only where a constant sky is all it can see;
    /// its density then carries the sky's pick probability.
    #[test]
    fn a_constant_sky_alone_is_a_constant_escape() {
        let sun = |deg: f32| Light::Sun {
            direction: Vec3::Y,
            irradiance: Vec3::ONE,
            angular_diameter_deg: deg,
        };
        let c = Vec3::new(0.2, 0.3, 0.4);
        let sky = Sky::Constant(c);
        let set = LightSet::from_parts(&[sun(0.0)], Some(&sky)).unwrap();
        let (le, pdf) = set
            .constant_escape()
            .expect("a delta sun and a constant sky");
        assert_eq!(le, c);
        assert_eq!(pdf, lamina_leaf::sampling::UNIFORM_SPHERE_PDF);
        // Left to BSDF samples (past `nee_count`): density 0, so the BSDF sample weighs 1.
        let mut bsdf_only = set.clone();
        bsdf_only.nee_count = 1;
        assert_eq!(bsdf_only.constant_escape(), Some((c, 0.0)));
        // A sun with a disc is seen too; a black sky shows nothing; no sky, no light.
        let disc = LightSet::from_parts(&[sun(10.0)], Some(&sky)).unwrap();
        assert_eq!(disc.constant_escape(), None);
        let black = LightSet::from_parts(&[sun(0.0)], Some(&Sky::Constant(Vec3::ZERO))).unwrap();
        assert_eq!(black.constant_escape(), None);
        let no_sky = LightSet::from_parts(&[sun(0.0)], None).unwrap();
        assert_eq!(no_sky.constant_escape(), None);
        // A sky that is not finite makes no set (the wavefront's lane sum relies on it).
        let inf = Sky::Constant(Vec3::new(f32::INFINITY, 0.3, 0.4));
        assert!(LightSet::from_parts(&[sun(0.0)], Some(&inf)).is_err());
    }
}
