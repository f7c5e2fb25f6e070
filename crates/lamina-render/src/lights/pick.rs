//! One light per scattering vertex ([`LightSampling::One`]): which light next-event
//! estimation draws, and with what probability.
//!
//! The probabilities follow each light's estimated emitted flux (the mean of its RGB or
//! channel values, W), after pbrt-v4's power light sampler: a point light `4π I`, a quad
//! `π A L` (twice when two-sided), a sphere `4π² r² L`; distant lights as seen by the
//! scene's bounding sphere of radius `R`: the sun `π R² E`, a sky `4π · π R² · L̄` (`L̄` its
//! mean radiance over the sphere). With only distant lights `R` cancels. Lights of zero
//! estimated power keep a small share so that no light is never sampled.
//!
//! [`LightSampling::One`]: lamina_core::LightSampling::One

use super::{AnyLight, LightSet};
use glam::Vec3;
use std::f32::consts::PI;

/// The share every light keeps whatever its estimated power, relative to the mean share:
/// a light the estimate undervalues (a sky whose mean hides a bright patch) is still drawn.
const FLOOR: f32 = 1e-3;

/// Selection probabilities of a scene's lights for drawing one per vertex.
#[derive(Clone, Debug, PartialEq)]
pub struct LightPick {
    /// Probability of each light, in [`LightSet::lights`] order (sums to 1).
    prob: Vec<f32>,
    /// Running sums of `prob`, the last forced to 1.
    cdf: Vec<f32>,
}

impl LightPick {
    /// Probabilities for `lights` in proportion to their estimated flux; `radius` is the
    /// radius (m) of a sphere around the scene's geometry and lights. `None` without lights.
    pub fn new(lights: &[AnyLight], radius: f32) -> Option<Self> {
        if lights.is_empty() {
            return None;
        }
        let r2 = if radius.is_finite() && radius > 0.0 {
            radius * radius
        } else {
            1.0
        };
        let power: Vec<f32> = lights.iter().map(|l| estimated_power(l, r2)).collect();
        let total: f32 = power.iter().sum();
        let n = lights.len() as f32;
        let prob: Vec<f32> = if total > 0.0 && total.is_finite() {
            let floor = FLOOR / n;
            let raw: Vec<f32> = power.iter().map(|p| (p / total).max(floor)).collect();
            let sum: f32 = raw.iter().sum();
            raw.iter().map(|p| p / sum).collect()
        } else {
            vec![1.0 / n; lights.len()]
        };
        let mut acc = 0.0;
        let mut cdf: Vec<f32> = prob
            .iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Some(LightPick { prob, cdf })
    }

    /// The light drawn by `u ∈ [0, 1)` and its probability.
    #[inline]
    pub fn choose(&self, u: f32) -> (usize, f32) {
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        (i, self.prob[i])
    }

    /// The probability that light `i` is drawn.
    #[inline]
    pub fn prob(&self, i: usize) -> f32 {
        self.prob[i]
    }
}

/// The mean over channels of a light's estimated flux (W); `r2` is the scene's bounding
/// radius squared (m²), for distant lights.
fn estimated_power(light: &AnyLight, r2: f32) -> f32 {
    let mean = |v: Vec3| (v.x + v.y + v.z) / 3.0;
    let p = match light {
        AnyLight::Sun(s) => PI * r2 * mean(s.irradiance()),
        AnyLight::Point(p) => 4.0 * PI * mean(p.intensity),
        AnyLight::Quad(q) => mean(q.power()),
        AnyLight::Sphere(s) => 4.0 * PI * PI * s.radius * s.radius * mean(s.radiance),
        AnyLight::Sky(s) => 4.0 * PI * PI * r2 * mean(s.mean()),
    };
    if p.is_finite() { p.max(0.0) } else { 0.0 }
}

/// Radius (m) of a sphere around the geometry and the local lights of `scene` (half the
/// diagonal of their bounding box; 1 for an empty scene).
pub fn scene_radius(scene: &lamina_core::Scene) -> f32 {
    let (mut lo, mut hi) = scene
        .geometry_bounds()
        .unwrap_or((Vec3::INFINITY, Vec3::NEG_INFINITY));
    let mut grow = |p: Vec3| {
        if p.is_finite() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    };
    for light in &scene.lights {
        match light {
            lamina_core::Light::Point { position, .. } => grow(*position),
            lamina_core::Light::Quad {
                corner,
                edge_u,
                edge_v,
                ..
            } => {
                let c = *corner;
                for p in [c, c + *edge_u, c + *edge_v, c + *edge_u + *edge_v] {
                    grow(p);
                }
            }
            lamina_core::Light::Sphere { center, radius, .. } => {
                grow(*center - Vec3::splat(*radius));
                grow(*center + Vec3::splat(*radius));
            }
            lamina_core::Light::Sun { .. } => {}
        }
    }
    let r = 0.5 * (hi - lo).length();
    if r.is_finite() && r > 0.0 { r } else { 1.0 }
}

impl LightSet {
    /// The probability that next-event estimation draws light `i`: 1 when every light is
    /// sampled at every vertex, 0 for a light it never samples (a sky left to BSDF samples,
    /// [`LightSet::nee_count`]).
    #[inline]
    pub fn pick_prob(&self, i: usize) -> f32 {
        if i >= self.nee_count {
            return 0.0;
        }
        self.pick.as_ref().map_or(1.0, |p| p.prob(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::{PointLight, SkyLight, SunLight};

    fn sun(e: f32) -> AnyLight {
        AnyLight::Sun(SunLight::new(Vec3::Y, Vec3::splat(e), 0.0).unwrap())
    }

    #[test]
    fn distant_lights_share_by_flux_through_the_scene() {
        // A sun of 3 W/m² against a sky of mean 0.25 W/m²/sr: π R² 3 vs 4π² R² 0.25.
        let pick = LightPick::new(&[sun(3.0), sky_of(0.25)], 7.0).unwrap();
        let want = 3.0 / (3.0 + 4.0 * PI * 0.25);
        assert!((pick.prob(0) - want).abs() < 1e-5, "{}", pick.prob(0));
        assert!((pick.prob(0) + pick.prob(1) - 1.0).abs() < 1e-6);
        // The radius cancels between distant lights.
        let other = LightPick::new(&[sun(3.0), sky_of(0.25)], 700.0).unwrap();
        assert!((other.prob(0) - pick.prob(0)).abs() < 1e-5);
    }

    fn sky_of(l: f32) -> AnyLight {
        AnyLight::Sky(SkyLight::Constant(Vec3::splat(l)))
    }

    #[test]
    fn choose_draws_each_light_with_its_probability() {
        let lamp = AnyLight::Point(PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::new(1.0, 2.0, 3.0),
        });
        let pick = LightPick::new(&[sun(1.0), lamp, sky_of(0.1)], 2.0).unwrap();
        let n = 100_000;
        let mut count = [0usize; 3];
        for k in 0..n {
            let u = (k as f32 + 0.5) / n as f32;
            let (i, p) = pick.choose(u);
            assert_eq!(p, pick.prob(i));
            count[i] += 1;
        }
        for (i, c) in count.iter().enumerate() {
            let f = *c as f32 / n as f32;
            assert!(
                (f - pick.prob(i)).abs() < 1e-3,
                "light {i}: {f} vs {}",
                pick.prob(i)
            );
        }
        // The edges of [0, 1) stay in range.
        assert_eq!(pick.choose(0.0).0, 0);
        assert_eq!(pick.choose(0.999_999_94).0, 2);
        assert_eq!(pick.choose(1.0).0, 2);
    }

    /// The radius spans world meshes, instances (their prototype's box, transformed: a
    /// rotated card's box), local lights, and nothing else (the sun adds nothing).
    #[test]
    fn scene_radius_covers_geometry_instances_and_local_lights() {
        use crate::tests::scenes::{card, small_canopy_scene};
        use lamina_core::{Instance, Light, Prototype};
        let mut scene = small_canopy_scene();
        scene.meshes = vec![card(0.5, 0.0, 0)];
        scene.lights.clear();
        assert!((scene_radius(&scene) - 0.5 * 2f32.sqrt()).abs() < 1e-6);
        scene.prototypes = vec![Prototype {
            name: "card".into(),
            meshes: vec![card(0.5, 0.0, 0)],
        }];
        // Turned 45° about z and moved to x = 10: its box spans x 10 ± √½, y ± √½.
        scene.instances = vec![Instance {
            prototype: 0,
            transform: glam::Affine3A::from_rotation_translation(
                glam::Quat::from_rotation_z(std::f32::consts::FRAC_PI_4),
                Vec3::new(10.0, 0.0, 0.0),
            ),
        }];
        let (lo, hi) = scene.geometry_bounds().unwrap();
        assert!((hi.x - (10.0 + 0.5f32.sqrt())).abs() < 1e-5, "{hi}");
        assert!(
            (lo - Vec3::new(-0.5, -(0.5f32.sqrt()), 0.0))
                .abs()
                .max_element()
                < 1e-6,
            "{lo}"
        );
        scene.lights = vec![
            Light::Point {
                position: Vec3::new(0.0, 0.0, -20.0),
                intensity: Vec3::ONE,
            },
            Light::Sun {
                direction: Vec3::Y,
                irradiance: Vec3::ONE,
                angular_diameter_deg: 0.0,
            },
        ];
        let want = 0.5
            * (Vec3::new(10.0 + 0.5f32.sqrt(), 0.5f32.sqrt(), 0.0)
                - Vec3::new(-0.5, -(0.5f32.sqrt()), -20.0))
            .length();
        assert!(
            (scene_radius(&scene) - want).abs() < 1e-4,
            "{} vs {want}",
            scene_radius(&scene)
        );
        // No geometry and no local lights: radius 1.
        scene.meshes.clear();
        scene.instances.clear();
        scene.lights.truncate(0);
        assert!(scene.geometry_bounds().is_none());
        assert_eq!(scene_radius(&scene), 1.0);
    }

    #[test]
    fn dark_lights_keep_a_share_and_no_lights_give_none() {
        let pick = LightPick::new(&[sun(1.0), sky_of(0.0)], 1.0).unwrap();
        assert!(pick.prob(1) > 0.0 && pick.prob(1) < 1e-3);
        let dark = LightPick::new(&[sun(0.0), sky_of(0.0)], 1.0).unwrap();
        assert_eq!((dark.prob(0), dark.prob(1)), (0.5, 0.5));
        assert!(LightPick::new(&[], 1.0).is_none());
    }
}
