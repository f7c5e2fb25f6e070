//! `type = "plant"` objects in scene files: what they add to the scene, material overrides,
//! and errors that name the file, the line and the key.

use lamina_scene::{Material, Scene, SceneError, parse_scene};
use std::path::Path;

const CAMERA: &str = "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0.5, 0]\n";

/// A small, fast plant table (few leaves, tiny leaf maps).
const SMALL: &str =
    "leaf_count = 150\nleaf_resolution = 32\nleaf_variants = 2\nattraction_points = 60\n";

fn parse(text: &str) -> Result<Scene, SceneError> {
    parse_scene(text, Path::new("s.toml"))
}

fn err(text: &str) -> String {
    match parse(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

fn name(m: &Material) -> &str {
    m.name()
}

#[test]
fn plant_object_adds_branches_leaves_and_their_materials() {
    let text = format!(
        "{CAMERA}[[material]]\nname = \"ground\"\ntype = \"diffuse\"\n\
         [[object]]\ntype = \"plant\"\ntranslate = [2, 0, 0]\nrotate_y = 30\n\
         [object.plant]\nkind = \"bush\"\nseed = 7\nspecies = \"maple\"\n{SMALL}"
    );
    let s = parse(&text).unwrap();
    // ground, bark, two leaf variants
    let names: Vec<&str> = s.materials.iter().map(name).collect();
    assert_eq!(names, ["ground", "bark", "leaf_maple_0", "leaf_maple_1"]);
    assert!(matches!(s.materials[2], Material::Leaf { .. }));
    assert!(s.meshes.len() >= 2, "branches and leaves");
    assert_eq!(s.meshes[0].material, 1, "the branch mesh uses the bark");
    assert!(s.meshes[1..].iter().all(|m| m.material >= 2));
    let leaves: usize = s.meshes[1..].iter().map(|m| m.indices.len() / 2).sum();
    assert!((100..=200).contains(&leaves), "{leaves} leaves");
    // Translated by +2 in x: the bush (radius ~0.55 m) stands around x = 2.
    let xs: Vec<f32> = s.meshes[0].positions.iter().map(|p| p.x).collect();
    let mean = xs.iter().sum::<f32>() / xs.len() as f32;
    assert!((mean - 2.0).abs() < 0.3, "{mean}");
    assert!(s.prototypes.is_empty() && s.instances.is_empty());

    // Same parameters, same plant.
    let again = parse(&text).unwrap();
    assert_eq!(again.meshes[0].positions, s.meshes[0].positions);
}

#[test]
fn plant_materials_can_be_overridden_by_name() {
    let text = format!(
        "{CAMERA}[[material]]\nname = \"my_bark\"\ntype = \"diffuse\"\n\
         [[object]]\ntype = \"plant\"\nmaterials = {{ bark = \"my_bark\" }}\n\
         [object.plant]\n{SMALL}"
    );
    let s = parse(&text).unwrap();
    let names: Vec<&str> = s.materials.iter().map(name).collect();
    assert_eq!(names, ["my_bark", "leaf_beech_0", "leaf_beech_1"]);
    assert_eq!(s.meshes[0].material, 0);

    let bad = format!(
        "{CAMERA}[[material]]\nname = \"my_bark\"\ntype = \"diffuse\"\n\
         [[object]]\ntype = \"plant\"\nmaterials = {{ trunk = \"my_bark\" }}\n\
         [object.plant]\n{SMALL}"
    );
    let e = err(&bad);
    assert!(
        e.contains("object[0].materials.trunk") && e.contains("bark, leaf_beech_0"),
        "{e}"
    );
}

#[test]
fn plant_errors_name_line_and_key() {
    let cases: &[(&str, &str, &[&str])] = &[
        // Out of range: lamina-plant's validation message at the key's line.
        (
            "leaf_count = 0",
            "leaf_count",
            &[
                "s.toml:7: object[0].plant.leaf_count",
                "must be in [1, 20000000], got 0",
            ],
        ),
        (
            "height_m = 1e9",
            "height_m",
            &["s.toml:7: object[0].plant.height_m", "must be in"],
        ),
        (
            "species = \"banana\"",
            "species",
            &["s.toml:7: object[0].plant.species", "banana"],
        ),
        // Wrong type and unknown key.
        (
            "leaf_count = \"many\"",
            "leaf_count",
            &["s.toml:7: object[0].plant.leaf_count"],
        ),
        (
            "leaf_cont = 10",
            "leaf_cont",
            &["s.toml:7: object[0].plant.leaf_cont", "unknown field"],
        ),
        (
            "kind = \"cactus\"",
            "kind",
            &["s.toml:7: object[0].plant.kind", "cactus"],
        ),
        (
            "light_direction = [0, 0, 0]",
            "light_direction",
            &["s.toml:7: object[0].plant.light_direction", "non-zero"],
        ),
    ];
    for (line, _, want) in cases {
        // Line 7 is the bad key (camera 3 lines, [[object]], type, [object.plant]).
        let text =
            format!("{CAMERA}[[object]]\ntype = \"plant\"\n[object.plant]\n{line}\nseed = 3\n");
        let e = err(&text);
        for w in *want {
            assert!(e.contains(w), "{line}: '{w}' not in: {e}");
        }
    }
    // An object key written below the [object.plant] header.
    let e = err(&format!(
        "{CAMERA}[[object]]\ntype = \"plant\"\n[object.plant]\nseed = 2\ninstances = [{{}}]\n"
    ));
    assert!(
        e.contains("s.toml:8: object[0].plant.instances") && e.contains("above that header"),
        "{e}"
    );
    // plant keys on another object type
    let e = err(&format!(
        "{CAMERA}[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[object]]\ntype = \"quad\"\nmaterial = \"m\"\ncorner = [0,0,0]\nedge_u = [1,0,0]\nedge_v = [0,1,0]\n[object.plant]\nseed = 1\n"
    ));
    assert!(e.contains("object[0].plant") && e.contains("'quad'"), "{e}");
}

#[test]
fn plant_and_forest_examples_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    let t = std::time::Instant::now();
    let s = lamina_scene::load_scene(&dir.join("plant.toml")).unwrap();
    let leaves: usize = s.meshes[2..].iter().map(|m| m.indices.len() / 2).sum();
    assert!((2900..=3100).contains(&leaves), "{leaves}");
    eprintln!("plant.toml loaded in {:.1} s", t.elapsed().as_secs_f64());
    let f = lamina_scene::load_scene(&dir.join("forest.toml")).unwrap();
    assert_eq!(f.meshes.len(), 1, "the meadow");
    assert_eq!((f.prototypes.len(), f.instances.len()), (1, 10));
    eprintln!("examples loaded in {:.1} s", t.elapsed().as_secs_f64());
}

#[test]
fn plant_parameter_file_with_scene_overrides() {
    let d = std::env::temp_dir().join(format!("lamina-plantfile-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(
        d.join("bush.toml"),
        format!("# a parameter file\nspecies = \"oak\"\nseed = 4\n{SMALL}"),
    )
    .unwrap();
    let scene = |plant: &str| {
        parse_scene(
            &format!("{CAMERA}[[object]]\ntype = \"plant\"\nfile = \"bush.toml\"\n{plant}"),
            &d.join("s.toml"),
        )
        .map_err(|e| e.to_string())
    };
    let s = scene("").unwrap();
    assert_eq!(name(&s.materials[1]), "leaf_oak_0");
    // [object.plant] keys override the file's.
    let s = scene("[object.plant]\nspecies = \"birch\"\n").unwrap();
    assert_eq!(name(&s.materials[1]), "leaf_birch_0");
    // Errors in the file name the file and its line; errors in the scene, the scene's.
    std::fs::write(d.join("bush.toml"), "species = \"oak\"\nleaf_scale = 99\n").unwrap();
    let e = scene("").unwrap_err();
    assert!(
        e.contains("bush.toml:2: leaf_scale") && e.contains("got 99"),
        "{e}"
    );
    let e = scene("[object.plant]\nleaf_scale = 0\n").unwrap_err();
    assert!(e.contains("s.toml:8: object[0].plant.leaf_scale"), "{e}");
    std::fs::write(d.join("bush.toml"), "species = oak\n").unwrap();
    let e = scene("").unwrap_err();
    assert!(e.contains("bush.toml:1"), "{e}");
    let e = parse_scene(
        &format!("{CAMERA}[[object]]\ntype = \"plant\"\nfile = \"nothere.toml\"\n"),
        &d.join("s.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("s.toml:6: object[0].file") && e.contains("nothere.toml"),
        "{e}"
    );
}

#[test]
fn curved_leaves_are_instances_placed_like_the_cards() {
    let plant = |leaves: &str| {
        format!(
            "{CAMERA}[[object]]\ntype = \"plant\"\ntranslate = [2, 0, 0]\nrotate_y = 30\n\
             {leaves}[object.plant]\nkind = \"bush\"\nseed = 7\n{SMALL}"
        )
    };
    let cards = parse(&plant("")).unwrap();
    let curved = parse(&plant("leaves = \"curved\"\n")).unwrap();
    // Same materials; one curved leaf prototype per variant; one instance per leaf.
    assert_eq!(
        curved.materials.iter().map(name).collect::<Vec<_>>(),
        cards.materials.iter().map(name).collect::<Vec<_>>()
    );
    assert_eq!(curved.prototypes.len(), 2);
    let card_leaves: usize = cards.meshes[1..].iter().map(|m| m.indices.len() / 2).sum();
    assert_eq!(curved.instances.len(), card_leaves);
    assert_eq!(
        curved.meshes.len(),
        1,
        "only the branches stay world meshes"
    );
    assert_eq!(curved.meshes[0].positions, cards.meshes[0].positions);
    for (pr, leaf_material) in curved.prototypes.iter().zip([1u32, 2]) {
        assert!(pr.meshes.iter().all(|m| m.material == leaf_material));
    }
    // Each instance puts its leaf's centre where the object's transform puts the card's:
    // the card centres (mean of each card's 4 corners) match the instances' origins
    // (curved leaves are centred on the card), as sets.
    let mut centres: Vec<[i64; 3]> = cards.meshes[1..]
        .iter()
        .flat_map(|m| {
            m.positions
                .chunks(4)
                .map(|q| q.iter().sum::<glam::Vec3>() / 4.0)
        })
        .map(|c| (c * 1e4).round().as_i64vec3().to_array())
        .collect();
    let mut origins: Vec<[i64; 3]> = curved
        .instances
        .iter()
        .map(|i| (glam::Vec3::from(i.transform.translation) * 1e4).round())
        .map(|c| c.as_i64vec3().to_array())
        .collect();
    centres.sort();
    origins.sort();
    let close = centres
        .iter()
        .zip(&origins)
        .filter(|(a, b)| (0..3).all(|k| (a[k] - b[k]).abs() <= 2))
        .count();
    assert!(
        close * 10 >= centres.len() * 9,
        "{close} of {}",
        centres.len()
    );

    let e = err(&format!(
        "{CAMERA}[[object]]\ntype = \"plant\"\nleaves = \"curly\"\n[object.plant]\n{SMALL}"
    ));
    assert!(
        e.contains("s.toml:6: object[0].leaves: must be \"cards\" or \"curved\""),
        "{e}"
    );
    let e = err(&format!(
        "{CAMERA}[[material]]\nname = \"g\"\ntype = \"diffuse\"\n[[object]]\ntype = \"quad\"\nmaterial = \"g\"\nleaves = \"curved\"\ncorner = [0, 0, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 0, 1]\n"
    ));
    assert!(e.contains("leaves"), "{e}");
}

/// An instanced plant with curved leaves: the branches become one prototype placed per
/// placement, every leaf instance is composed with every placement (two-level instancing
/// kept), and the result is the same set of leaf placements as the plant written out twice
/// as separate objects.
#[test]
fn instanced_plant_with_curved_leaves_composes_placements() {
    let one = |extra: &str| {
        format!(
            "[[object]]\ntype = \"plant\"\nleaves = \"curved\"\n{extra}[object.plant]\n\
             kind = \"bush\"\nseed = 7\n{SMALL}"
        )
    };
    let placed = parse(&format!(
        "{CAMERA}{}",
        one("instances = [{}, { translate = [3, 0, 0], rotate_y = 90 }]\n")
    ))
    .unwrap();
    let written_twice = parse(&format!(
        "{CAMERA}{}{}",
        one(""),
        one("translate = [3, 0, 0]\nrotate_y = 90\n")
    ))
    .unwrap();
    // Two leaf prototypes + the branches; no world meshes.
    assert!(placed.meshes.is_empty());
    assert_eq!(placed.prototypes.len(), 3);
    let leaves = written_twice.instances.len();
    assert!(leaves > 100);
    assert_eq!(
        placed.instances.len(),
        leaves + 2,
        "leaves + one branch instance each"
    );
    let key = |i: &lamina_scene::Instance| {
        let m = glam::Mat4::from(i.transform).to_cols_array();
        m.map(|x| (x * 1e4).round() as i64)
    };
    let branches = placed.prototypes.len() as u32 - 1;
    let mut a: Vec<_> = placed
        .instances
        .iter()
        .filter(|i| i.prototype != branches)
        .map(key)
        .collect();
    let mut b: Vec<_> = written_twice.instances.iter().map(key).collect();
    a.sort();
    b.sort();
    assert_eq!(a, b, "the same leaf placements");
    // The branch prototype's instances are the placements themselves.
    let branch_at: Vec<_> = placed
        .instances
        .iter()
        .filter(|i| i.prototype == branches)
        .map(|i| glam::Vec3::from(i.transform.translation))
        .collect();
    assert_eq!(
        branch_at,
        vec![glam::Vec3::ZERO, glam::Vec3::new(3.0, 0.0, 0.0)]
    );
    // Its meshes are the first object's branch mesh.
    assert_eq!(
        placed.prototypes[branches as usize].meshes[0].positions,
        written_twice.meshes[0].positions
    );
}
