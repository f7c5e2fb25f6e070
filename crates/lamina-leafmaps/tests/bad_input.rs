//! Bad input to `prepare` and the folder writer: a clear error or warning naming the file,
//! never a panic, never a half-written folder. Inputs are synthetic images made here.

use image::{GrayImage, ImageBuffer, Luma, LumaA, Rgb, RgbImage, Rgba, RgbaImage};
use lamina_leafmaps::{LeafMapsError, PrepareInput, prepare};
use std::path::{Path, PathBuf};

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("leafmaps_bad_input")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A green ellipse with a paler midrib on a white background.
fn leaf_photo(w: u32, h: u32) -> RgbImage {
    RgbImage::from_fn(w, h, |x, y| {
        let u = (x as f32 + 0.5) / w as f32 - 0.5;
        let v = (y as f32 + 0.5) / h as f32 - 0.5;
        if (u / 0.35).powi(2) + (v / 0.45).powi(2) < 1.0 {
            if u.abs() < 0.01 {
                Rgb([120, 150, 70])
            } else {
                Rgb([60, 100, 30])
            }
        } else {
            Rgb([245, 245, 240])
        }
    })
}

fn leaf_matte(w: u32, h: u32) -> GrayImage {
    GrayImage::from_fn(w, h, |x, y| {
        let u = (x as f32 + 0.5) / w as f32 - 0.5;
        let v = (y as f32 + 0.5) / h as f32 - 0.5;
        Luma([if (u / 0.35).powi(2) + (v / 0.45).powi(2) < 1.0 {
            255
        } else {
            0
        }])
    })
}

fn no_folder(out: &Path) {
    assert!(!out.exists(), "a folder was written at {}", out.display());
    let parent = out.parent().unwrap();
    for e in std::fs::read_dir(parent).unwrap() {
        let n = e.unwrap().file_name().to_string_lossy().into_owned();
        assert!(!n.contains(".tmp-"), "temporary folder {n} left behind");
    }
}

#[test]
fn unreadable_and_missing_files_name_the_file() {
    let d = tmp("unreadable");
    let junk = d.join("junk.png");
    std::fs::write(&junk, b"this is not a png").unwrap();
    let out = d.join("leaf");
    let e = prepare(&PrepareInput::new(&junk, &out)).unwrap_err();
    assert!(matches!(e, LeafMapsError::Read { .. }), "{e}");
    assert!(e.to_string().contains("junk.png"), "{e}");
    no_folder(&out);

    let front = d.join("front.png");
    leaf_photo(64, 80).save(&front).unwrap();
    let mut input = PrepareInput::new(&front, &out);
    input.translucency = Some(d.join("missing_scan.png"));
    let e = prepare(&input).unwrap_err();
    assert!(e.to_string().contains("missing_scan.png"), "{e}");
    no_folder(&out);
}

#[test]
fn all_black_or_white_scan_is_an_error() {
    let d = tmp("uniform");
    let front = d.join("front.png");
    leaf_photo(64, 80).save(&front).unwrap();
    for (name, v) in [("black.png", 0u8), ("white.png", 255u8)] {
        let scan = d.join(name);
        RgbImage::from_pixel(64, 80, Rgb([v, v, v]))
            .save(&scan)
            .unwrap();
        let out = d.join("leaf");
        let mut input = PrepareInput::new(&front, &out);
        input.translucency = Some(scan);
        let e = prepare(&input).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains(name) && (msg.contains("all black") || msg.contains("all white")),
            "{msg}"
        );
        no_folder(&out);
    }
    // An all-white front photo too.
    let white = d.join("white_front.png");
    RgbImage::from_pixel(32, 32, Rgb([255, 255, 255]))
        .save(&white)
        .unwrap();
    let e = prepare(&PrepareInput::new(&white, d.join("leaf"))).unwrap_err();
    assert!(e.to_string().contains("white_front.png"), "{e}");
}

#[test]
fn alpha_that_keeps_nothing_is_an_error() {
    let d = tmp("empty_alpha");
    let front = d.join("front.png");
    leaf_photo(64, 80).save(&front).unwrap();
    let alpha = d.join("empty_matte.png");
    GrayImage::from_pixel(64, 80, Luma([0]))
        .save(&alpha)
        .unwrap();
    let out = d.join("leaf");
    let mut input = PrepareInput::new(&front, &out);
    input.alpha = Some(alpha);
    let e = prepare(&input).unwrap_err();
    assert!(
        e.to_string().contains("empty_matte.png") && e.to_string().contains("keeps nothing"),
        "{e}"
    );
    no_folder(&out);
}

#[test]
fn different_sizes_are_resampled_with_a_warning() {
    let d = tmp("sizes");
    let front = d.join("front.png");
    leaf_photo(96, 120).save(&front).unwrap();
    let alpha = d.join("matte_small.png");
    leaf_matte(48, 60).save(&alpha).unwrap();
    let scan = d.join("scan_wide.png");
    RgbImage::from_fn(200, 100, |x, _| Rgb([150, 180 - (x % 7) as u8, 40]))
        .save(&scan)
        .unwrap();
    let out = d.join("leaf");
    let mut input = PrepareInput::new(&front, &out);
    input.alpha = Some(alpha);
    input.translucency = Some(scan);
    let r = prepare(&input).unwrap();
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("matte_small.png") && w.contains("resampled")),
        "{:?}",
        r.warnings
    );
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("scan_wide.png") && w.contains("aspect")),
        "{:?}",
        r.warnings
    );
    assert_eq!(r.maps.size(), (96, 120));
    let toml = std::fs::read_to_string(out.join("leaf.toml")).unwrap();
    assert!(toml.contains("warning:"));
    for f in ["front.png", "alpha.png", "bump.png", "leaf.toml"] {
        assert!(out.join(f).exists(), "{f}");
    }
}

#[test]
fn grey_16bit_and_rgba_inputs() {
    let d = tmp("formats");
    let (w, h) = (64u32, 80u32);
    // 16-bit RGBA front whose alpha channel is the matte.
    let photo = leaf_photo(w, h);
    let matte = leaf_matte(w, h);
    let front: ImageBuffer<Rgba<u16>, Vec<u16>> = ImageBuffer::from_fn(w, h, |x, y| {
        let c = photo.get_pixel(x, y).0;
        let a = matte.get_pixel(x, y).0[0];
        Rgba([
            c[0] as u16 * 257,
            c[1] as u16 * 257,
            c[2] as u16 * 257,
            a as u16 * 257,
        ])
    });
    let fp = d.join("front16_rgba.png");
    front.save(&fp).unwrap();
    // 16-bit grey scan, grey+alpha back photo, 8-bit RGBA bump with opaque alpha.
    let scan: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_fn(w, h, |x, _| Luma([30000 + (x as u16 % 5) * 1000]));
    let sp = d.join("scan16_grey.png");
    scan.save(&sp).unwrap();
    let back: ImageBuffer<LumaA<u8>, Vec<u8>> =
        ImageBuffer::from_fn(w, h, |x, _| LumaA([120 + (x % 9) as u8, 255]));
    let bp = d.join("back_grey_alpha.png");
    back.save(&bp).unwrap();
    let bump = RgbaImage::from_fn(w, h, |x, y| Rgba([((x * y) % 256) as u8, 0, 0, 255]));
    let bu = d.join("bump_rgba.png");
    bump.save(&bu).unwrap();
    let out = d.join("leaf");
    let mut input = PrepareInput::new(&fp, &out);
    input.translucency = Some(sp);
    input.back = Some(bp);
    input.bump = Some(bu);
    let r = prepare(&input).unwrap();
    assert!(
        r.provenance.iter().any(|p| p.contains("alpha channel")),
        "{:?}",
        r.provenance
    );
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("scan16_grey.png") && w.contains("grey")),
        "{:?}",
        r.warnings
    );
    assert!(
        (0.45..0.55).contains(&r.alpha_fraction),
        "{}",
        r.alpha_fraction
    );
    // The folder loads.
    let desc = lamina_leaf::LeafDescription::from_toml_file(&out.join("leaf.toml")).unwrap();
    lamina_leaf::LeafMaterial::load(&desc, &out).unwrap();
}

#[test]
fn failed_write_keeps_the_old_folder() {
    let d = tmp("atomic");
    let front = d.join("front.png");
    leaf_photo(64, 80).save(&front).unwrap();
    let out = d.join("leaf");
    prepare(&PrepareInput::new(&front, &out)).unwrap();
    let before = std::fs::read(out.join("leaf.toml")).unwrap();
    // A second run that fails (bad scan) leaves the first folder untouched.
    let mut input = PrepareInput::new(&front, &out);
    input.translucency = Some(d.join("nope.png"));
    assert!(prepare(&input).is_err());
    assert_eq!(std::fs::read(out.join("leaf.toml")).unwrap(), before);
    // A successful rerun replaces it whole.
    let mut input = PrepareInput::new(&front, &out);
    input.dpi = Some(300.0);
    prepare(&input).unwrap();
    let after = std::fs::read_to_string(out.join("leaf.toml")).unwrap();
    assert!(after.contains("mm"), "{after}");
    // An output path under a regular file cannot be created: error, no panic.
    let file = d.join("a_file");
    std::fs::write(&file, b"x").unwrap();
    let e = prepare(&PrepareInput::new(&front, file.join("leaf"))).unwrap_err();
    assert!(e.to_string().contains("a_file"), "{e}");
}

#[test]
fn bad_options_are_errors() {
    let d = tmp("options");
    let front = d.join("front.png");
    leaf_photo(32, 40).save(&front).unwrap();
    let mut input = PrepareInput::new(&front, d.join("leaf"));
    input.dpi = Some(-3.0);
    assert!(matches!(
        prepare(&input).unwrap_err(),
        LeafMapsError::Option { .. }
    ));
    let mut input = PrepareInput::new(&front, d.join("leaf"));
    input.params.thickness_mm = f32::NAN;
    assert!(
        prepare(&input)
            .unwrap_err()
            .to_string()
            .contains("thickness_mm")
    );
}

#[test]
fn a_huge_image_header_is_rejected_before_decoding() {
    let d = tmp("huge");
    // 16384 x 16384 grey: 256 MiB as stored, gigabytes once converted.
    let front = d.join("front.png");
    std::fs::write(&front, lamina_leaf::testing::png_header_only(16384, 16384)).unwrap();
    let out = d.join("leaf");
    let e = prepare(&PrepareInput::new(&front, &out)).unwrap_err();
    assert!(matches!(e, LeafMapsError::BadInput { .. }), "{e}");
    let e = e.to_string();
    assert!(
        e.contains("front.png") && e.contains("too large") && e.contains("67108864"),
        "{e}"
    );
    no_folder(&out);
}
