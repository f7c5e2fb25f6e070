//! `prepare` on the real scans in `../shared/data/textures/` (ambientCG atlases and the
//! Syngonium leaves), with sanity checks and contact sheets, plus side-by-side sheets of a
//! real leaf next to a generated one of a similar species. Skipped, with a note, when the
//! shared data folder is absent; when it is there, at least one scan must be processed.
//! Outputs go to `out/leafmaps/real/` (git-ignored).

use lamina_leaf::LeafParams;
use lamina_leafmaps::sheet::{SheetOptions, save_rgb, sheet_image, side_by_side};
use lamina_leafmaps::{LeafSpec, PrepareInput, Species, generate, prepare};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The shared data folder (`../shared/data` next to the workspace, or `shared/data` inside
/// it), if there is one. When there is, the test must process at least one scan from it.
fn data_dir() -> Option<PathBuf> {
    [root().join("shared/data"), root().join("../shared/data")]
        .into_iter()
        .find(|p| p.is_dir())
}

fn mean_rgb(p: &lamina_leafmaps::plane::Rgb, a: &lamina_leafmaps::plane::Gray) -> [f32; 3] {
    let mut s = [0.0f64; 3];
    let mut n = 0.0;
    for (c, m) in p.data.iter().zip(&a.data) {
        if *m >= 0.5 {
            for k in 0..3 {
                s[k] += c[k] as f64;
            }
            n += 1.0;
        }
    }
    s.map(|v| (v / n) as f32)
}

fn check_sane(name: &str, r: &lamina_leafmaps::Prepared) {
    let m = &r.maps;
    assert!(
        (0.05..0.95).contains(&r.alpha_fraction),
        "{name}: alpha keeps {}",
        r.alpha_fraction
    );
    for (what, p) in [
        ("extinction", &m.extinction),
        ("thickness", &m.thickness),
        ("bump", &m.bump),
    ] {
        let (lo, hi) = p.min_max();
        assert!(
            lo >= 0.0 && hi <= 1.0 && hi > lo,
            "{name}: {what} range {lo}..{hi}"
        );
    }
    let f = mean_rgb(&m.front, &m.alpha);
    let b = mean_rgb(&m.back, &m.alpha);
    let t = mean_rgb(&m.translucency, &m.alpha);
    let y = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    assert!(
        y(b) > y(f),
        "{name}: derived back {b:?} not paler than front {f:?}"
    );
    assert!(
        t[1] >= t[2],
        "{name}: derived translucency {t:?} not yellow-green"
    );
    // The description loads in the leaf model.
    let desc = lamina_leaf::LeafDescription::from_toml_file(&r.dir.join("leaf.toml")).unwrap();
    lamina_leaf::LeafMaterial::load(&desc, &r.dir).unwrap();
    let toml = std::fs::read_to_string(r.dir.join("leaf.toml")).unwrap();
    assert!(
        toml.contains("DERIVED"),
        "{name}: leaf.toml does not say what was derived"
    );
}

#[test]
fn prepare_real_scans() {
    let Some(data) = data_dir() else {
        eprintln!("note: shared/data not found next to the workspace: real-data test skipped");
        return;
    };
    let t0 = std::time::Instant::now();
    // Scans run through `prepare` and checked.
    let mut processed = Vec::new();
    let out = root().join("out/leafmaps/real");
    let ambient = data.join("textures/ambientcg");
    let opts = SheetOptions {
        tile: 200,
        backlit_exposure: 1.0,
    };
    let mut sheets = Vec::new();
    for sp in [
        "birch",
        "bonsai",
        "japanese_maple",
        "maple",
        "oak",
        "poplar",
        "willow",
    ] {
        let front = ambient.join(format!("{sp}_color.jpg"));
        if !front.exists() {
            eprintln!("note: {} missing, skipped", front.display());
            continue;
        }
        let mut input = PrepareInput::new(&front, out.join(sp));
        input.alpha = Some(ambient.join(format!("{sp}_opacity_APPROX_from_outlines.png")));
        input.normal = Some(ambient.join(format!("{sp}_normal.jpg")));
        input.params = sp
            .parse::<Species>()
            .map(Species::params)
            .unwrap_or_else(|_| LeafParams::default());
        let r = prepare(&input).unwrap_or_else(|e| panic!("{sp}: {e}"));
        check_sane(sp, &r);
        processed.push(sp.to_string());
        let img = sheet_image(&r.dir, &opts).unwrap();
        save_rgb(&out.join(format!("sheet_{sp}.png")), &img).unwrap();
        sheets.push((sp, img));
    }
    // Same atlas without matte or normal map: segmented alpha, bump from photo detail.
    let front = ambient.join("oak_color.jpg");
    if front.exists() {
        let r = prepare(&PrepareInput::new(&front, out.join("oak_segmented"))).unwrap();
        check_sane("oak_segmented", &r);
        assert!(r.provenance.iter().any(|p| p.contains("segmented")));
        processed.push("oak_segmented".into());
    }
    // Syngonium: 1024^2, black background, approximate threshold matte.
    let syn = data.join("textures/syngonium");
    let front = syn.join("potted_plant_02_leaves_diff.jpg");
    if front.exists() {
        let mut input = PrepareInput::new(&front, out.join("syngonium"));
        input.alpha = Some(syn.join("potted_plant_02_leaves_opacity_APPROX_threshold.png"));
        input.normal = Some(syn.join("potted_plant_02_leaves_nor_gl.jpg"));
        let r = prepare(&input).unwrap();
        check_sane("syngonium", &r);
        processed.push("syngonium".into());
        save_rgb(
            &out.join("sheet_syngonium.png"),
            &sheet_image(&r.dir, &opts).unwrap(),
        )
        .unwrap();
        // And segmented from the black background.
        let r = prepare(&PrepareInput::new(&front, out.join("syngonium_segmented"))).unwrap();
        check_sane("syngonium_segmented", &r);
        processed.push("syngonium_segmented".into());
    }
    // The data folder is there: a test that skipped every scan (moved or renamed files)
    // would prove nothing.
    eprintln!(
        "real data: {} scans processed from {} ({:?}): {processed:?}",
        processed.len(),
        data.display(),
        t0.elapsed()
    );
    assert!(
        !processed.is_empty(),
        "{} exists but no scan in it was processed (expected textures/ambientcg/*_color.jpg \
         or textures/syngonium/potted_plant_02_leaves_diff.jpg)",
        data.display()
    );
    // Real next to generated, for the species both have.
    for (sp, img) in &sheets {
        let Ok(species) = sp.parse::<Species>() else {
            continue;
        };
        let leaf = generate(&LeafSpec::new(species, 1, 512));
        let dir = out.join(format!("gen_{sp}"));
        leaf.write_folder(&dir).unwrap();
        let gen_img = sheet_image(&dir, &opts).unwrap();
        save_rgb(
            &out.join(format!("real_vs_generated_{sp}.png")),
            &side_by_side(&[img.clone(), gen_img]),
        )
        .unwrap();
    }
}
