//! Image output: EXR and PNG contents, tone maps and exposure, atomic writes and errors.

use super::scenes::film;
use crate::{Image, write_image};
use glam::Vec3;
use lamina_core::ToneMap;

fn temp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("lamina-render-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// (g) EXR and PNG are valid, hold the right values, leave no temporary file; an unwritable
/// directory is a clean error that leaves nothing behind.
#[test]
fn output_files_are_valid_and_atomic() {
    let dir = temp_dir("out");
    let img = Image {
        width: 3,
        height: 2,
        pixels: vec![
            Vec3::new(0.0, 0.5, 1.0),
            Vec3::new(2.0, 0.25, 0.01),
            Vec3::ZERO,
            Vec3::ONE,
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::splat(100.0),
        ],
    };
    let f = film(3, 2, 1);
    let exr = dir.join("a.exr");
    write_image(&exr, &img, &f).unwrap();
    let back = image::open(&exr).unwrap().into_rgb32f();
    assert_eq!((back.width(), back.height()), (3, 2));
    for (p, q) in back.pixels().zip(&img.pixels) {
        assert_eq!(Vec3::from_array(p.0), *q);
    }
    let png = dir.join("b.PNG");
    write_image(&png, &img, &f).unwrap();
    let back = image::open(&png).unwrap().into_rgb8();
    assert_eq!(back.get_pixel(0, 0).0, [0, 188, 255]);
    assert_eq!(back.get_pixel(2, 1).0, [255, 255, 255]);
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");

    // Tone maps and exposure.
    let mut fr = f;
    fr.tonemap = ToneMap::Reinhard;
    fr.exposure = 1.0;
    write_image(&png, &img, &fr).unwrap();
    let back = image::open(&png).unwrap().into_rgb8();
    // 0.5 · 2 = 1 → 1/2 → sRGB 0.735 → 188.
    assert_eq!(back.get_pixel(0, 0).0[1], 188);

    let missing = dir.join("no/such/dir/c.png");
    let err = write_image(&missing, &img, &f).unwrap_err().to_string();
    assert!(err.contains("c.png"), "{err}");
    let file_as_dir = exr.join("d.exr");
    assert!(write_image(&file_as_dir, &img, &f).is_err());
    assert!(write_image(&dir.join("e.jpg"), &img, &f).is_err());
    let bad = Image {
        width: 4,
        ..img.clone()
    };
    assert!(write_image(&dir.join("f.png"), &bad, &f).is_err());
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
