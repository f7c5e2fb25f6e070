//! Tests of the procedural plants: determinism, counts, geometry sanity, phototropism,
//! parameter validation and scene parts. (The glTF export is tested through the importer in
//! `lamina-scene/tests/plant_glb.rs`.)

use glam::Vec3;
use lamina_plant::skeleton::{NONE, grow};
use lamina_plant::{Plant, PlantKind, PlantParams, generate_plant};

/// Small and fast: low-resolution leaf maps, one or two variants.
fn bush(seed: u64) -> PlantParams {
    PlantParams {
        leaf_resolution: 32,
        leaf_variants: 2,
        leaf_count: Some(3000),
        ..PlantParams::bush(seed)
    }
}

fn tree(seed: u64, leaves: u32) -> PlantParams {
    PlantParams {
        leaf_resolution: 32,
        leaf_variants: 1,
        ..PlantParams::tree(seed, leaves)
    }
}

fn check_leaves(plant: &Plant) {
    for c in plant.leaves.iter().flatten() {
        assert!(c.center.is_finite() && c.normal.is_finite() && c.up.is_finite());
        assert!(
            (c.normal.length() - 1.0).abs() < 1e-4,
            "normal {:?}",
            c.normal
        );
        assert!((c.up.length() - 1.0).abs() < 1e-4, "up {:?}", c.up);
        assert!(c.normal.dot(c.up).abs() < 1e-3);
        assert!(c.width > 0.0 && c.height > 0.0 && c.width.is_finite());
        let right = c.up.cross(c.normal);
        let low = c.center.y - 0.5 * c.height * c.up.y.abs() - 0.5 * c.width * right.y.abs();
        assert!(low >= -1e-4, "leaf below the ground: {c:?}");
    }
}

fn check_branches(plant: &Plant) {
    let m = &plant.branches;
    assert!(!m.indices.is_empty());
    assert_eq!(m.positions.len(), m.normals.len());
    assert_eq!(m.positions.len(), m.uvs.len());
    assert!(m.positions.iter().all(|p| p.is_finite()));
    assert!(m.uvs.iter().all(|p| p.is_finite()));
    assert!(m.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3));
    for t in &m.indices {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        let area = 0.5 * (b - a).cross(c - a).length();
        assert!(area > 1e-12, "degenerate triangle {a} {b} {c}");
    }
}

#[test]
fn same_seed_same_plant_other_seed_other_plant() {
    let a = generate_plant(&bush(5)).unwrap();
    let b = generate_plant(&bush(5)).unwrap();
    assert_eq!(a.branches.positions, b.branches.positions);
    assert_eq!(a.branches.indices, b.branches.indices);
    assert_eq!(a.leaves, b.leaves);
    let c = generate_plant(&bush(6)).unwrap();
    assert_ne!(a.leaves, c.leaves);
}

#[test]
fn bush_is_sane() {
    let p = generate_plant(&bush(1)).unwrap();
    let n = p.leaf_count();
    assert!((n as f32 - 3000.0).abs() <= 300.0, "{n} leaves for 3000");
    assert_eq!(p.leaves.len(), 2);
    assert!(
        p.leaves.iter().all(|v| v.len() > 1000),
        "both variants used"
    );
    check_leaves(&p);
    check_branches(&p);
    let [lo, hi] = p.stats.bounds;
    assert!(hi.y > 0.8 && hi.y < 1.4, "bush height {}", hi.y);
    assert!(lo.y > -0.05);
    assert!(hi.x - lo.x > 0.6, "bush width {}", hi.x - lo.x);
}

#[test]
fn tree_is_sane_and_counts_scale() {
    for leaves in [1_000, 20_000] {
        let p = generate_plant(&tree(2, leaves)).unwrap();
        let n = p.leaf_count() as f32;
        assert!(
            (n - leaves as f32).abs() <= 0.1 * leaves as f32,
            "{n} leaves for {leaves}"
        );
        check_leaves(&p);
        check_branches(&p);
        let hi = p.stats.bounds[1];
        assert!(hi.y > 8.0 && hi.y < 12.0, "tree height {}", hi.y);
        // The trunk is thick, the twigs are thin.
        assert!(p.stats.trunk_radius_m > 0.1);
    }
}

#[test]
fn radii_decrease_toward_the_tips_pipe_model() {
    for params in [bush(3), tree(3, 5000)] {
        let r = params.resolve().unwrap();
        let sk = grow(&r);
        let a = r.pipe_exponent;
        for i in 0..sk.pos.len() {
            let par = sk.parent[i];
            if par != NONE {
                assert!(sk.radius[i] <= sk.radius[par as usize] * (1.0 + 1e-5));
            }
            let ch = sk.children(i);
            if !ch.is_empty() && sk.radius[i] > r.twig_radius * 1.001 {
                let sum: f32 = ch.iter().map(|&c| sk.radius[c as usize].powf(a)).sum();
                let own = sk.radius[i].powf(a);
                assert!(own >= sum * 0.999, "pipe model: {own} < {sum}");
            }
        }
        let roots = (0..sk.pos.len()).filter(|&i| sk.parent[i] == NONE).count();
        let expect = if r.kind == PlantKind::Bush {
            r.stems
        } else {
            1
        };
        assert_eq!(roots as u32, expect);
    }
}

#[test]
fn phototropism_turns_blades_to_the_light() {
    let mean_up = |photo: f32| {
        let mut p = bush(4);
        p.phototropism = photo;
        p.gravitropism = 0.0;
        let plant = generate_plant(&p).unwrap();
        let all: Vec<Vec3> = plant.leaves.iter().flatten().map(|c| c.normal).collect();
        all.iter().map(|n| n.y).sum::<f32>() / all.len() as f32
    };
    let (none, half, full) = (mean_up(0.0), mean_up(0.5), mean_up(1.0));
    assert!(half > none + 0.1, "{none} -> {half}");
    assert!(full > half + 0.1, "{half} -> {full}");
    assert!(full > 0.8, "{full}");
}

#[test]
fn gravitropism_makes_tips_droop() {
    let mean_tip = |g: f32| {
        let mut p = bush(4);
        p.gravitropism = g;
        let plant = generate_plant(&p).unwrap();
        let all: Vec<Vec3> = plant.leaves.iter().flatten().map(|c| c.up).collect();
        all.iter().map(|n| n.y).sum::<f32>() / all.len() as f32
    };
    assert!(mean_tip(1.0) < mean_tip(0.0) - 0.2);
}

#[test]
fn bad_parameters_are_rejected_with_the_field_named() {
    let cases: Vec<(PlantParams, &str)> = vec![
        (
            PlantParams {
                height_m: Some(f32::NAN),
                ..Default::default()
            },
            "height_m",
        ),
        (
            PlantParams {
                height_m: Some(-1.0),
                ..Default::default()
            },
            "height_m",
        ),
        (
            PlantParams {
                species: "baobab".into(),
                ..Default::default()
            },
            "species",
        ),
        (
            PlantParams {
                leaf_count: Some(0),
                ..Default::default()
            },
            "leaf_count",
        ),
        (
            PlantParams {
                leaf_count: Some(25_000_000),
                ..Default::default()
            },
            "leaf_count",
        ),
        (
            PlantParams {
                phototropism: 1.5,
                ..Default::default()
            },
            "phototropism",
        ),
        (
            PlantParams {
                light_direction: [0.0, 0.0, 0.0],
                ..Default::default()
            },
            "light_direction",
        ),
        (
            PlantParams {
                leaf_variants: 0,
                ..Default::default()
            },
            "leaf_variants",
        ),
        (
            PlantParams {
                trunk_radius_m: Some(f32::INFINITY),
                ..Default::default()
            },
            "trunk_radius_m",
        ),
    ];
    for (params, field) in cases {
        let e = generate_plant(&params).unwrap_err().to_string();
        assert!(e.contains(field), "{e}");
        assert!(params.validate().is_err());
    }
    // Unknown fields in a file are rejected, known ones parse.
    let e = PlantParams::from_toml("kind = \"tree\"\nhieght_m = 3").unwrap_err();
    assert!(e.to_string().contains("hieght_m"), "{e}");
    let e = PlantParams::from_toml("kind = \"tree\"\nheight_m = 100").unwrap_err();
    assert!(e.to_string().contains("height_m"), "{e}");
    let p = PlantParams::from_toml(
        "kind = \"tree\"\nheight_m = 6\nleaf_count = 500\nspecies = \"oak\"",
    )
    .unwrap();
    assert_eq!(p.kind, PlantKind::Tree);
}

#[test]
fn scene_parts_index_the_materials() {
    let plant = generate_plant(&bush(9)).unwrap();
    let leaves = plant.leaf_count();
    let (meshes, materials) = plant.into_scene_parts(3);
    assert_eq!(materials.len(), 3);
    assert_eq!(meshes[0].material, 3);
    let leaf_tris: usize = meshes[1..].iter().map(|m| m.indices.len()).sum();
    assert_eq!(leaf_tris, 2 * leaves);
    assert!(meshes[1..].iter().all(|m| (4..6).contains(&m.material)));
    assert!(matches!(materials[1], lamina_core::Material::Leaf { .. }));
}
