//! Renders a procedural bush and a procedural tree, to look at them.
//!
//! `cargo run --release -p lamina-plant --example preview -- out/plant.png [tree_leaves] [spp]`
//! writes `out/plant_bush.png`, `out/plant_bush_close.png` and `out/plant_tree.png` (320x320) and prints the plants'
//! statistics.

use glam::Vec3;
use lamina_core::*;
use lamina_plant::{PlantParams, generate_plant};
use std::path::{Path, PathBuf};

fn scene_for(
    plant: lamina_plant::Plant,
    eye: Vec3,
    target: Vec3,
    sun_dir: Vec3,
    spp: u32,
) -> Scene {
    let ground_half = 4.0 * plant.stats.bounds[1].y.max(1.0);
    let mut materials = vec![Material::Diffuse {
        name: "ground".into(),
        reflectance: ColorInput::Constant(Vec3::new(0.10, 0.08, 0.05)),
        alpha: None,
    }];
    let (meshes, mats) = plant.into_scene_parts(1);
    materials.extend(mats);
    let mut all = vec![Mesh::quad(
        Vec3::new(-ground_half, 0.0, ground_half),
        Vec3::new(2.0 * ground_half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * ground_half),
        0,
    )];
    all.extend(meshes);
    Scene {
        radiometry: Default::default(),
        camera: Camera {
            position: eye,
            look_at: target,
            up: Vec3::Y,
            fov_deg: 40.0,
            aperture_radius: 0.0,
            focus_distance: eye.distance(target),
        },
        film: Film::new(320, 320, spp),
        integrator: Integrator::Path {
            max_depth: 6,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: sun_dir.normalize(),
            irradiance: Vec3::new(3.2, 3.0, 2.7),
            angular_diameter_deg: 0.53,
        }],
        sky: Some(Sky::Constant(Vec3::new(0.16, 0.22, 0.32))),
        materials,
        meshes: all,
        prototypes: Vec::new(),
        instances: Vec::new(),
    }
}

fn with_suffix(path: &Path, suffix: &str) -> PathBuf {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("plant");
    path.with_file_name(format!("{stem}_{suffix}.png"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let out = PathBuf::from(args.get(1).map(String::as_str).unwrap_or("out/plant.png"));
    let tree_leaves: u32 = args
        .get(2)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(100_000);
    let spp: u32 = args.get(3).map(|s| s.parse()).transpose()?.unwrap_or(16);
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    let sun = Vec3::new(0.5, 0.8, 0.6);
    let opts = lamina_render::RenderOptions {
        seed: 1,
        ..Default::default()
    };

    let mut bush = PlantParams::bush(7);
    bush.light_direction = sun.to_array();
    let bush = generate_plant(&bush)?;
    println!("bush: {:#?}", bush.stats);
    // The bark texture, tiled 2x2, as sRGB.
    let bark = &bush.bark;
    let (bw, bh) = (bark.width(), bark.height());
    let tiled = image::RgbImage::from_fn(2 * bw, 2 * bh, |x, y| {
        let c = bark.texel((x % bw) as i64, (y % bh) as i64);
        let enc = |v: f32| (lamina_leaf::texture::linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0) as u8;
        image::Rgb([enc(c.x), enc(c.y), enc(c.z)])
    });
    let path = with_suffix(&out, "bark");
    lamina_io::save_image(&path, &tiled)?;
    println!("wrote {}", path.display());
    // A close look at the crown's edge: leaf orientation, petioles, bark.
    let h = bush.stats.bounds[1].y;
    let scene = scene_for(
        bush.clone(),
        Vec3::new(0.25 * h, 0.55 * h, 1.05 * h),
        Vec3::new(0.1 * h, 0.45 * h, 0.3 * h),
        sun,
        spp,
    );
    let img = lamina_render::render(&scene, &opts)?;
    let path = with_suffix(&out, "bush_close");
    lamina_render::write_image(&path, &img.image, &scene.film)?;
    println!("wrote {}", path.display());
    let h = bush.stats.bounds[1].y;
    let scene = scene_for(
        bush,
        Vec3::new(0.0, 0.6 * h, 2.3 * h),
        Vec3::new(0.0, 0.45 * h, 0.0),
        sun,
        spp,
    );
    let img = lamina_render::render(&scene, &opts)?;
    let path = with_suffix(&out, "bush");
    lamina_render::write_image(&path, &img.image, &scene.film)?;
    println!("wrote {}", path.display());

    let mut tree = PlantParams::tree(3, tree_leaves);
    tree.light_direction = sun.to_array();
    let tree = generate_plant(&tree)?;
    println!("tree: {:#?}", tree.stats);
    let h = tree.stats.bounds[1].y;
    let scene = scene_for(
        tree,
        Vec3::new(0.0, 0.42 * h, 1.9 * h),
        Vec3::new(0.0, 0.48 * h, 0.0),
        sun,
        spp,
    );
    let img = lamina_render::render(&scene, &opts)?;
    let path = with_suffix(&out, "tree");
    lamina_render::write_image(&path, &img.image, &scene.film)?;
    println!("wrote {}", path.display());
    Ok(())
}
