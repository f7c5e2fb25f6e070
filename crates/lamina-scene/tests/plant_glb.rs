//! The procedural plant's binary glTF export, read back by lamina's glTF importer.

use lamina_plant::{PlantParams, generate_plant};

fn bush(seed: u64) -> PlantParams {
    PlantParams {
        leaf_resolution: 32,
        leaf_variants: 2,
        leaf_count: Some(3000),
        ..PlantParams::bush(seed)
    }
}

#[test]
fn glb_round_trips_through_the_gltf_importer() {
    let plant = generate_plant(&bush(11)).unwrap();
    let dir = std::env::temp_dir().join(format!("lamina-plant-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("bush.glb");
    lamina_plant::write_glb(&plant, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
        bytes.len()
    );
    assert_eq!(bytes.len() % 4, 0);
    let scene =
        lamina_scene::gltf_import::load_gltf(&path, &lamina_scene::transform::Transform::default())
            .unwrap();
    let tris: usize = scene.meshes.iter().map(|m| m.indices.len()).sum();
    assert_eq!(tris, plant.branches.indices.len() + 2 * plant.leaf_count());
    for name in ["bark", "leaf_beech_0", "leaf_beech_1"] {
        assert!(
            scene.material_names.iter().any(|n| n == name),
            "{name} in {:?}",
            scene.material_names
        );
    }
    // The leaves are cut out by their alpha and transmit light.
    let leaf = scene
        .material_names
        .iter()
        .position(|n| n == "leaf_beech_0")
        .unwrap();
    match &scene.materials[leaf] {
        lamina_scene::Material::Leaf { .. } => {}
        m => assert!(m.alpha_mask().is_some(), "{m:?}"),
    }
    // No temporary file is left behind.
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert_eq!(left.len(), 1);
    std::fs::remove_dir_all(&dir).unwrap();
}
