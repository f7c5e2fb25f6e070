//! Built-in scenes that need no files: the demo's three panels (a leaf lit from the front,
//! the same leaf lit from behind, a procedural bush from `lamina-plant` under a low sun
//! behind it).
//!
//! The leaf material is passed in (the CLI makes a procedural one), so this module stays
//! free of texture generation.

use crate::cards::{LeafCard, append_cards};
use crate::scene::*;
use glam::{Vec2, Vec3};
use lamina_core::cards::CardRow;
use lamina_plant::{Plant, PlantParams};
use std::sync::Arc;

/// A leaf as the built-in scenes use it: its material and its card size (m).
#[derive(Clone, Debug)]
pub struct BuiltinLeaf {
    /// The leaf's maps and parameters.
    pub material: Arc<lamina_leaf::LeafMaterial>,
    /// Card width and height (m): the leaf's bounding rectangle.
    pub size_m: Vec2,
}

/// A dark-green-grey backdrop and a soil ground, shared by the leaf panels.
fn studio_materials(leaf: &BuiltinLeaf) -> Vec<Material> {
    vec![
        Material::Leaf {
            name: "leaf".into(),
            leaf: leaf.material.clone(),
        },
        Material::Diffuse {
            name: "ground".into(),
            reflectance: ColorInput::Constant(Vec3::new(0.12, 0.09, 0.06)),
            alpha: None,
        },
    ]
}

fn ground(material: u32, half: f32, y: f32) -> Mesh {
    Mesh::quad(
        Vec3::new(-half, y, half),
        Vec3::new(2.0 * half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * half),
        material,
    )
}

/// One leaf facing the camera, its adaxial side toward the viewer, lit by a sun from
/// `sun_dir` (toward the sun) and a soft sky.
fn leaf_panel(leaf: &BuiltinLeaf, sun_dir: Vec3, sun: Vec3, size: (u32, u32), spp: u32) -> Scene {
    let h = leaf.size_m.y;
    let mut mesh = Mesh {
        material: 0,
        ..Default::default()
    };
    let card = LeafCard::new(&CardRow {
        center: [0.0, 0.0, 0.0],
        normal: [0.0, 0.15, 1.0],
        up: [0.0, 1.0, 0.0],
        width: leaf.size_m.x,
        height: leaf.size_m.y,
    })
    .expect("built-in card is valid");
    append_cards(&mut mesh, &[card]);
    let dist = 1.25 * h / (20f32.to_radians().tan() * 2.0) + 0.0;
    Scene {
        radiometry: Default::default(),
        camera: Camera {
            position: Vec3::new(0.0, 0.0, dist),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 40.0,
            aperture_radius: 0.0,
            focus_distance: dist,
        },
        film: Film::new(size.0, size.1, spp),
        integrator: Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: sun_dir.normalize(),
            irradiance: sun,
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.10, 0.13, 0.18))),
        materials: studio_materials(leaf),
        meshes: vec![mesh, ground(1, 3.0 * h, -0.75 * h)],
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

/// The leaf lit from the front: the sun over the viewer's shoulder.
pub fn leaf_front_lit(leaf: &BuiltinLeaf, size: (u32, u32), spp: u32) -> Scene {
    leaf_panel(leaf, Vec3::new(0.4, 0.6, 1.0), Vec3::splat(3.0), size, spp)
}

/// The same leaf lit from behind: the sun low behind the leaf, so the viewer sees the light
/// that came through it.
pub fn leaf_back_lit(leaf: &BuiltinLeaf, size: (u32, u32), spp: u32) -> Scene {
    leaf_panel(
        leaf,
        Vec3::new(-0.35, 0.65, -1.0),
        Vec3::splat(3.0),
        size,
        spp,
    )
}

/// The parameters of the demo's bush (after the paper's Fig. 5): a procedural beech bush
/// from `lamina-plant`, about 0.8 m tall, its leaves turned toward the upper sky.
pub fn bush_params(seed: u64) -> PlantParams {
    PlantParams {
        leaf_count: Some(1800),
        leaf_variants: 3,
        leaf_resolution: 256,
        ..PlantParams::bush(seed)
    }
}

/// The demo's bush: the plant `plant` lit by a low sun from behind and to the side, under a
/// blue sky, on soil, the camera framing its bounding box. Its leaves keep their own maps
/// (the plant's leaf variants) with the optical parameters of `leaf` (so the three demo
/// panels show one leaf model); materials: 0..n leaf variants, then soil, then bark.
pub fn bush_scene_with(
    plant: &Plant,
    leaf: &BuiltinLeaf,
    size: (u32, u32),
    spp: u32,
) -> Result<Scene, lamina_leaf::LeafError> {
    let mut materials = Vec::new();
    for (i, variant) in plant.leaf_variants.iter().enumerate() {
        let material =
            lamina_leaf::LeafMaterial::new(variant.maps.clone(), *leaf.material.params())?;
        materials.push(Material::Leaf {
            name: format!("leaf_{i}"),
            leaf: Arc::new(material),
        });
    }
    let soil = materials.len() as u32;
    materials.push(Material::Diffuse {
        name: "ground".into(),
        reflectance: ColorInput::Constant(Vec3::new(0.12, 0.09, 0.06)),
        alpha: None,
    });
    materials.push(plant.bark_material());
    let mut meshes = Vec::new();
    for (i, cards) in plant.leaves.iter().enumerate() {
        let mut mesh = Mesh {
            material: i as u32,
            ..Default::default()
        };
        append_cards(&mut mesh, cards);
        meshes.push(mesh);
    }
    let mut wood = plant.branches.clone();
    wood.material = soil + 1;
    meshes.push(wood);
    meshes.push(ground(soil, 6.0, 0.0));

    let [lo, hi] = plant.stats.bounds;
    let target = Vec3::new(
        0.5 * (lo.x + hi.x),
        0.45 * (lo.y + hi.y),
        0.5 * (lo.z + hi.z),
    );
    let radius = 0.5 * (hi - lo).length();
    let fov = 40f32;
    let dist = 0.8 * radius / (0.5 * fov.to_radians()).tan();
    let eye = target + Vec3::new(0.0, 0.12, 1.0).normalize() * dist;
    let elevation = 30f32.to_radians();
    let azimuth = (180.0f32 + 35.0).to_radians();
    let sun_dir = Vec3::new(
        elevation.cos() * azimuth.sin(),
        elevation.sin(),
        elevation.cos() * azimuth.cos(),
    );
    Ok(Scene {
        radiometry: Default::default(),
        camera: Camera {
            position: eye,
            look_at: target,
            up: Vec3::Y,
            fov_deg: fov,
            aperture_radius: 0.0,
            focus_distance: dist,
        },
        film: Film::new(size.0, size.1, spp),
        integrator: Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: sun_dir,
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

/// The demo's bush ([`bush_params`] with seed 7) in [`bush_scene_with`]'s setting.
pub fn bush_scene(leaf: &BuiltinLeaf, size: (u32, u32), spp: u32) -> Scene {
    // Fixed, valid parameters and a leaf material that already exists: neither call can
    // fail (the unit test below builds this scene).
    let plant = lamina_plant::generate_plant(&bush_params(7)).expect("built-in bush parameters");
    bush_scene_with(&plant, leaf, size, spp).expect("the demo leaf's parameters are valid")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small_leaf() -> BuiltinLeaf {
        let g = lamina_leafmaps::generate(&lamina_leafmaps::LeafSpec::new(
            lamina_leafmaps::Species::Beech,
            1,
            32,
        ));
        BuiltinLeaf {
            material: Arc::new(lamina_leaf::LeafMaterial::new(g.maps, g.params).unwrap()),
            size_m: Vec2::new(g.size_m.0, g.size_m.1),
        }
    }

    #[test]
    fn demo_bush_is_the_procedural_plant_in_frame() {
        let params = PlantParams {
            leaf_resolution: 32,
            ..bush_params(7)
        };
        let plant = lamina_plant::generate_plant(&params).unwrap();
        let leaf = small_leaf();
        let scene = bush_scene_with(&plant, &leaf, (64, 48), 4).unwrap();
        let cards: usize = scene.meshes[..plant.leaves.len()]
            .iter()
            .map(|m| m.indices.len() / 2)
            .sum();
        assert_eq!(cards, plant.leaf_count());
        assert!(cards > 1000, "{cards} leaves");
        // Every leaf material carries the demo leaf's optics.
        for m in &scene.materials[..plant.leaf_variants.len()] {
            let Material::Leaf { leaf: l, .. } = m else {
                panic!("leaf variants come first")
            };
            assert_eq!(l.params(), leaf.material.params());
        }
        // The plant's base and top are in front of the camera, inside the field of view.
        let cam = scene.camera;
        let fwd = (cam.look_at - cam.position).normalize();
        let half = (0.5 * cam.fov_deg).to_radians();
        let [lo, hi] = plant.stats.bounds;
        let mid = 0.5 * (lo + hi);
        for p in [Vec3::new(mid.x, lo.y, mid.z), Vec3::new(mid.x, hi.y, mid.z)] {
            let d = p - cam.position;
            let along = d.dot(fwd);
            assert!(along > 0.0);
            assert!((d - fwd * along).length() / along < half.tan() * 1.01);
        }
    }
}
