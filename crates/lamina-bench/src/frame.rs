//! The tree of the GPU path's frame-time benchmark (`lamina-gpu`'s `frame_bench` example)
//! and of `lamina view tree:N`: a procedural tree of any leaf count from lamina-plant.
//!
//! It is not [`crate::tree_scene`]: its seed, framing (tighter, centred on the crown), sun
//! direction and ground differ, and the published frame times were measured on it, so it
//! keeps its own shape; both benchmark trees live in this crate.

use glam::Vec3;
use lamina_core::{
    Camera, ColorInput, Film, Integrator, Light, Material, Mesh, PixelFilter, Scene, Sky, ToneMap,
};

/// A generated tree (`PlantParams::tree(1, leaves)`) of flat leaf cards on a ground quad,
/// under a sun and a constant blue sky, the camera (50° horizontal field of view) framing
/// the whole crown; film `size` (pixels), 1 spp, ACES tone map.
pub fn frame_tree_scene(leaves: u32, size: (u32, u32)) -> Result<Scene, lamina_plant::PlantError> {
    let plant = lamina_plant::generate_plant(&lamina_plant::PlantParams::tree(1, leaves))?;
    let [lo, hi] = plant.stats.bounds;
    let (mut meshes, mut materials) = plant.into_scene_parts(0);
    let ground = materials.len() as u32;
    materials.push(Material::Diffuse {
        name: "ground".into(),
        reflectance: ColorInput::Constant(Vec3::new(0.12, 0.09, 0.06)),
        alpha: None,
    });
    let half = 0.75 * (hi - lo).max_element();
    meshes.push(Mesh::quad(
        Vec3::new(-half, 0.0, half),
        Vec3::new(2.0 * half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * half),
        ground,
    ));
    let target = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let dist = radius / (20f32.to_radians().tan());
    Ok(Scene {
        radiometry: Default::default(),
        camera: Camera {
            position: target + Vec3::new(0.0, 0.25, 1.0).normalize() * dist,
            look_at: target,
            up: Vec3::Y,
            fov_deg: 50.0,
            aperture_radius: 0.0,
            focus_distance: dist,
        },
        film: Film {
            width: size.0,
            height: size.1,
            spp: 1,
            filter: PixelFilter::Box,
            exposure: 0.0,
            tonemap: ToneMap::Aces,
            spectral: lamina_core::SpectralMode::Rgb,
        },
        integrator: Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: Vec3::new(0.5, 0.7, 0.4).normalize(),
            irradiance: Vec3::new(3.2, 3.0, 2.7),
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.16, 0.22, 0.32))),
        materials,
        meshes,
        prototypes: Vec::new(),
        instances: Vec::new(),
    })
}

/// A forest for the GPU path's frame times and level-of-detail tests: `trees` instances
/// of one generated tree (`PlantParams::tree(1, leaves)`, its branches and flat leaf cards
/// in one prototype) on a square grid, each turned about `+y`, on a ground quad under a
/// sun and a constant sky, the camera framing the first row and the depth behind it
/// ([`crate::tree_scene`] with [`crate::Representation::Forest`]); film `size`, 1 spp.
pub fn frame_forest_scene(
    trees: u32,
    leaves: u32,
    size: (u32, u32),
) -> Result<Scene, lamina_plant::PlantError> {
    let plant = lamina_plant::generate_plant(&lamina_plant::PlantParams::tree(1, leaves))?;
    Ok(crate::tree_scene(
        plant,
        crate::Representation::Forest,
        trees,
        size.0,
        size.1,
        1,
    ))
}
