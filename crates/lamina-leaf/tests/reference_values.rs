//! Fixed BSDF values of two leaves (the default RGB leaf and a PROSPECT pigment leaf) at
//! fixed directions and texels, kept in `tests/data/bsdf_reference.csv`. The Python
//! package's tests (crates/lamina-py/tests) check that `lamina.Leaf.eval` and `pdf` return
//! exactly these values, so both sides are pinned to the same numbers.
//!
//! After a deliberate change of the leaf model: `LAMINA_BLESS=1 cargo test -p lamina-leaf
//! --test reference_values` rewrites the file.

use glam::{Vec2, Vec3};
use lamina_leaf::{Bsdf, LeafMaps, LeafMaterial, LeafParams, Pigments};

fn leaves() -> Vec<(&'static str, LeafMaterial)> {
    vec![
        (
            "default",
            LeafMaterial::new(LeafMaps::default(), LeafParams::default()).unwrap(),
        ),
        (
            "pigments_cab40",
            LeafMaterial::from_parts(
                LeafMaps::default(),
                LeafParams::default(),
                Some(Pigments {
                    cab: 40.0,
                    ..Pigments::default()
                }),
            )
            .unwrap(),
        ),
    ]
}

/// The rows: every pair of a few `wo` and `wi` (both sides, grazing, normal).
fn directions() -> Vec<(Vec3, Vec3)> {
    let ws = [
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.3, 0.1, 0.9).normalize(),
        Vec3::new(-0.6, 0.5, 0.2).normalize(),
        Vec3::new(0.2, -0.3, -0.9).normalize(),
        Vec3::new(0.7, 0.7, -0.1).normalize(),
    ];
    let mut out = Vec::new();
    for wo in ws {
        for wi in ws {
            out.push((wo, -wi));
        }
    }
    out
}

fn table() -> String {
    let mut s = String::from("leaf,wo_x,wo_y,wo_z,wi_x,wi_y,wi_z,f_r,f_g,f_b,pdf\n");
    for (name, leaf) in leaves() {
        let b = leaf.bsdf(Vec2::splat(0.5));
        for (wo, wi) in directions() {
            let f = b.eval(wo, wi);
            let p = b.pdf(wo, wi);
            s += &format!(
                "{name},{},{},{},{},{},{},{},{},{},{p}\n",
                wo.x, wo.y, wo.z, wi.x, wi.y, wi.z, f.x, f.y, f.z
            );
        }
    }
    s
}

#[test]
fn bsdf_reference_values_are_pinned() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bsdf_reference.csv");
    let now = table();
    if std::env::var_os("LAMINA_BLESS").is_some() {
        std::fs::write(&path, &now).unwrap();
    }
    let kept = std::fs::read_to_string(&path).expect("tests/data/bsdf_reference.csv");
    assert_eq!(
        now, kept,
        "the leaf BSDF's values changed; if on purpose, LAMINA_BLESS=1 rewrites the file"
    );
}
