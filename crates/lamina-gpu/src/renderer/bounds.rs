//! The two bounding spheres the renderer frames things with: all geometry (the camera's
//! depth range) and the shadow casters' core (the region the sun's and the sky's
//! light-view maps cover).

use glam::Vec3;
use lamina_scene::Scene;

/// Bounding spheres of a scene: centre and radius (m).
#[derive(Clone, Copy, Debug)]
pub(super) struct SceneBounds {
    /// All geometry, instances included ([`scene_bounds`]).
    pub all: (Vec3, f32),
    /// The shadow casters' core ([`caster_bounds`]).
    pub casters: (Vec3, f32),
}

impl SceneBounds {
    pub fn of(scene: &Scene) -> Self {
        SceneBounds {
            all: scene_bounds(scene),
            casters: caster_bounds(scene),
        }
    }
}

/// Bounding sphere of the scene's geometry (instances included).
fn scene_bounds(scene: &Scene) -> (Vec3, f32) {
    match scene.geometry_bounds() {
        Some((lo, hi)) => (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3)),
        None => (Vec3::ZERO, 1.0),
    }
}

/// Bounding sphere of the *shadow casters' core*: per axis, the 0.5th to 99.5th percentile of
/// the vertex positions (instances by their transformed prototype corners, weighted by
/// vertex count). A large ground quad has four vertices, a plant thousands, so the sun's
/// and the sky's maps spend their texels on the plants instead of on the ground's extent.
/// Points outside the maps count as unshadowed.
fn caster_bounds(scene: &Scene) -> (Vec3, f32) {
    let mut pts: Vec<Vec3> = scene
        .meshes
        .iter()
        .flat_map(|m| m.positions.iter().copied())
        .filter(|p| p.is_finite())
        .collect();
    for inst in &scene.instances {
        if let Some(p) = scene.prototypes.get(inst.prototype as usize) {
            for m in &p.meshes {
                // Every 16th vertex is plenty for the percentiles.
                pts.extend(
                    m.positions
                        .iter()
                        .step_by(16)
                        .map(|&q| inst.transform.transform_point3(q)),
                );
            }
        }
    }
    if pts.len() < 16 {
        return scene_bounds(scene);
    }
    let n = pts.len();
    let (lo_i, hi_i) = (n / 200, n - 1 - n / 200);
    let mut lo = Vec3::ZERO;
    let mut hi = Vec3::ZERO;
    for axis in 0..3 {
        let mut v: Vec<f32> = pts.iter().map(|p| p[axis]).collect();
        lo[axis] = *v.select_nth_unstable_by(lo_i, f32::total_cmp).1;
        hi[axis] = *v.select_nth_unstable_by(hi_i, f32::total_cmp).1;
    }
    let c = 0.5 * (lo + hi);
    (c, (0.5 * (hi - lo).length()).max(1e-3))
}
