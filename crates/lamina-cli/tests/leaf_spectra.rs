//! `lamina leaf prospect | albedo | fit` through the real binary: the files they write,
//! their numbers, and clear errors on bad input with nothing left behind.

mod common;

use common::{names, scratch};
use std::path::Path;
use std::process::{Command, Output};

fn lamina(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lamina"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(o: &Output) -> String {
    let e = stderr(o);
    assert!(o.status.success(), "failed:\n{e}");
    e
}

fn fails(o: &Output, words: &[&str]) {
    let e = stderr(o);
    assert!(!o.status.success(), "should fail:\n{e}");
    assert!(!e.contains("panicked"), "panic:\n{e}");
    for w in words {
        assert!(e.contains(w), "expected '{w}' in:\n{e}");
    }
}

/// `(nm, R, T)` rows of a lamina CSV (skipping its mark and header).
fn rows(path: &Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(2)
        .map(|l| {
            l.split(',')
                .map(|x| x.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect()
}

#[test]
fn prospect_writes_the_model_at_every_nanometre() {
    let d = scratch("spectra", "prospect");
    ok(&lamina(
        &[
            "leaf", "prospect", "--n", "1.8", "--cab", "45", "--anth", "2", "-o", "p.csv",
        ],
        &d,
    ));
    let text = std::fs::read_to_string(d.join("p.csv")).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("# lamina"));
    assert_eq!(
        lines.next().unwrap(),
        "wavelength_nm,reflectance,transmittance"
    );
    let r = rows(&d.join("p.csv"));
    assert_eq!(r.len(), 2101);
    let want = lamina_leaf::prospect(&lamina_leaf::Pigments {
        n: 1.8,
        cab: 45.0,
        anth: 2.0,
        ..Default::default()
    });
    for (i, row) in r.iter().enumerate() {
        assert_eq!(row[0], 400.0 + i as f64);
        assert!((row[1] - want.r[i]).abs() < 1e-6 && (row[2] - want.t[i]).abs() < 1e-6);
    }
    // PRO.
    ok(&lamina(
        &[
            "leaf", "prospect", "--model", "pro", "--prot", "0.0015", "-o", "p.csv",
        ],
        &d,
    ));
    // Bad flags: named, nothing written.
    let e = scratch("spectra", "prospect-bad");
    fails(
        &lamina(&["leaf", "prospect", "--cab", "300", "-o", "x.csv"], &e),
        &["--cab", "300", "[0, 120]"],
    );
    fails(
        &lamina(&["leaf", "prospect", "--prot", "0.001", "-o", "x.csv"], &e),
        &["--prot", "--model pro"],
    );
    fails(
        &lamina(
            &[
                "leaf", "prospect", "--model", "pro", "--cm", "0.01", "-o", "x.csv",
            ],
            &e,
        ),
        &["--cm", "prot"],
    );
    fails(
        &lamina(&["leaf", "prospect", "--n", "nan", "-o", "x.csv"], &e),
        &["--n"],
    );
    assert!(names(&e).is_empty(), "{:?}", names(&e));
    // A file lamina did not write is kept.
    std::fs::write(e.join("mine.csv"), "my data").unwrap();
    fails(
        &lamina(&["leaf", "prospect", "-o", "mine.csv"], &e),
        &["mine.csv", "--force"],
    );
    assert_eq!(
        std::fs::read_to_string(e.join("mine.csv")).unwrap(),
        "my data"
    );
}

#[test]
fn fit_recovers_a_leaf_and_the_folder_renders_and_integrates() {
    let d = scratch("spectra", "fit");
    ok(&lamina(
        &[
            "leaf", "prospect", "--n", "1.6", "--cab", "55", "--car", "12", "--cw", "0.014",
            "--cm", "0.007", "-o", "full.csv",
        ],
        &d,
    ));
    // Every 10 nm, as a spectrometer export with a header and whitespace.
    let r = rows(&d.join("full.csv"));
    let mut text = String::from("lambda R T\n");
    for row in r.iter().step_by(10) {
        text += &format!("{} {} {}\n", row[0], row[1], row[2]);
    }
    std::fs::write(d.join("meas.txt"), text).unwrap();
    let e = ok(&lamina(
        &["leaf", "fit", "--spectrum", "meas.txt", "-o", "fitted"],
        &d,
    ));
    assert!(e.contains("RMSE") && e.contains("NIR 800-900 nm"), "{e}");
    assert_eq!(
        names(&d.join("fitted")),
        ["fit.csv", "fit.png", "leaf.toml"]
    );
    let desc = lamina_leaf::LeafDescription::from_toml_file(&d.join("fitted/leaf.toml")).unwrap();
    let p = desc.pigments.unwrap();
    assert!(
        (p.n - 1.6).abs() < 0.02 && (p.cab - 55.0).abs() < 1.0,
        "{p:?}"
    );
    assert!(
        (p.cw - 0.014).abs() < 5e-4 && (p.cm - 0.007).abs() < 5e-4,
        "{p:?}"
    );
    // fit.csv: measured and model columns, the model (the BSDF) within 0.01 of the data.
    let f = rows(&d.join("fitted/fit.csv"));
    assert_eq!(f.len(), 211);
    let rmse = |a: usize, b: usize| {
        (f.iter().map(|x| (x[a] - x[b]).powi(2)).sum::<f64>() / f.len() as f64).sqrt()
    };
    assert!(
        rmse(1, 3) < 0.01 && rmse(2, 4) < 0.01,
        "{} {}",
        rmse(1, 3),
        rmse(2, 4)
    );
    // The folder is a leaf: albedo integrates it, a scene renders it.
    ok(&lamina(
        &[
            "leaf",
            "albedo",
            "fitted",
            "--wavelengths",
            "550:850:300",
            "-o",
            "a.csv",
        ],
        &d,
    ));
    let a = rows(&d.join("a.csv"));
    assert_eq!(a.len(), 2);
    assert!(a[1][1] > 0.35 && a[1][2] > 0.35 && a[0][1] < 0.2, "{a:?}");
    std::fs::write(
        d.join("scene.toml"),
        "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n[film]\nwidth = 16\nheight = 16\nspp = 2\n\
         [[light]]\ntype = \"sun\"\ndirection = [0, 0, 1]\nirradiance = 2\n\
         [[material]]\nname = \"l\"\ntype = \"leaf\"\nfile = \"fitted/leaf.toml\"\n\
         [[object]]\ntype = \"quad\"\nmaterial = \"l\"\ncorner = [-0.5, -0.5, 0]\nedge_u = [1, 0, 0]\nedge_v = [0, 1, 0]\n",
    )
    .unwrap();
    ok(&lamina(&["render", "scene.toml", "-o", "leaf.png"], &d));
    // Fitting again replaces lamina's folder.
    ok(&lamina(
        &["leaf", "fit", "--spectrum", "meas.txt", "-o", "fitted"],
        &d,
    ));
}

#[test]
fn fit_refuses_bad_spectra_naming_file_and_line() {
    let d = scratch("spectra", "fit-bad");
    let good: String = (0..20)
        .map(|i| format!("{},0.1,0.2\n", 400 + 50 * i))
        .collect();
    for (name, text, words) in [
        (
            "unsorted.csv",
            format!("{good}500,0.1,0.2\n"),
            vec!["unsorted.csv", "line 21", "below"],
        ),
        (
            "sum.csv",
            good.replace("450,0.1,0.2", "450,0.7,0.6"),
            vec!["sum.csv", "line 2", "above 1"],
        ),
        (
            "few.csv",
            "400,0.1\n500,0.1\n".into(),
            vec!["few.csv", "at least 10"],
        ),
        (
            "nan.csv",
            good.replace("450,0.1,0.2", "450,nan,0.2"),
            vec!["nan.csv", "line 2", "NaN"],
        ),
    ] {
        std::fs::write(d.join(name), text).unwrap();
        fails(
            &lamina(&["leaf", "fit", "--spectrum", name, "-o", "out"], &d),
            &words,
        );
        assert!(!d.join("out").exists());
    }
    fails(
        &lamina(&["leaf", "fit", "--spectrum", "none.csv", "-o", "out"], &d),
        &["none.csv"],
    );
    for w in ["-1", "nan", "heavy"] {
        fails(
            &lamina(
                &[
                    "leaf",
                    "fit",
                    "--spectrum",
                    "sum.csv",
                    "-o",
                    "out",
                    "--band-weight",
                    w,
                ],
                &d,
            ),
            &["--band-weight", w, "0 to 1000"],
        );
        assert!(!d.join("out").exists());
    }
    // Reflectance only: fitted with a warning.
    let r_only: String = (0..30)
        .map(|i| format!("{},{}\n", 400 + 70 * i, if i < 5 { 0.05 } else { 0.45 }))
        .collect();
    std::fs::write(d.join("r.csv"), r_only).unwrap();
    let e = ok(&lamina(
        &["leaf", "fit", "--spectrum", "r.csv", "-o", "out"],
        &d,
    ));
    assert!(e.contains("reflectance only"), "{e}");
    // A folder lamina did not write is refused, and kept as it was.
    std::fs::create_dir_all(d.join("mine")).unwrap();
    std::fs::write(d.join("mine/notes.txt"), "mine").unwrap();
    fails(
        &lamina(&["leaf", "fit", "--spectrum", "r.csv", "-o", "mine"], &d),
        &["mine", "--force"],
    );
    assert_eq!(names(&d.join("mine")), ["notes.txt"]);
}

#[test]
fn sky_prints_the_sun_and_its_split_and_writes_a_sky_a_scene_uses() {
    let d = scratch("spectra", "sky");
    let e = ok(&lamina(
        &[
            "sky",
            "--latitude",
            "39.742476",
            "--longitude",
            "-105.1786",
            "--elevation",
            "1830.14",
            "--pressure",
            "820",
            "--time",
            "2003-10-17T12:30:30-07:00",
            "--width",
            "64",
            "-o",
            "sky.exr",
            "--spectrum",
            "sun.csv",
        ],
        &d,
    ));
    // The SPA paper's example: zenith 50.11162, azimuth 194.34024 at 820 hPa, 11 °C (we
    // use 12 °C: a 1e-4° difference).
    assert!(
        e.contains("zenith 50.11") && e.contains("azimuth 194.340"),
        "{e}"
    );
    for band in [
        "PAR 400-700 nm",
        "NIR 700-1300 nm",
        "diffuse %",
        "irradiance = [",
    ] {
        assert!(e.contains(band), "{band} in {e}");
    }
    assert_eq!(names(&d), ["sky.exr", "sun.csv"]);
    let sun = std::fs::read_to_string(d.join("sun.csv")).unwrap();
    assert!(
        sun.starts_with("# lamina") && sun.lines().count() == 2 + 741,
        "{}",
        sun.lines().count()
    );
    std::fs::write(
        d.join("scene.toml"),
        "[camera]\nposition = [0, 1, 0]\nlook_at = [0, 1, -1]\n[film]\nwidth = 8\nheight = 8\nspp = 2\n\
         [sky]\ntype = \"image\"\nfile = \"sky.exr\"\n",
    )
    .unwrap();
    ok(&lamina(&["render", "scene.toml", "-o", "view.exr"], &d));
    // Night, bad time, bad latitude: named, nothing written.
    let n = scratch("spectra", "sky-bad");
    for (args, words) in [
        (
            vec![
                "--latitude",
                "52.5",
                "--longitude",
                "13.4",
                "--time",
                "2024-06-21T23:30:00+02:00",
            ],
            vec!["below the horizon"],
        ),
        (
            vec![
                "--latitude",
                "52.5",
                "--longitude",
                "13.4",
                "--time",
                "2024-06-21T12:00",
            ],
            vec!["--time", "UTC offset"],
        ),
        (
            vec![
                "--latitude",
                "95",
                "--longitude",
                "13.4",
                "--time",
                "2024-06-21T12:00Z",
            ],
            vec!["--latitude"],
        ),
    ] {
        let mut all = vec!["sky"];
        all.extend(args);
        all.extend(["-o", "s.exr"]);
        fails(&lamina(&all, &n), &words);
    }
    assert!(names(&n).is_empty(), "{:?}", names(&n));
}

#[test]
fn a_scene_renders_in_bands_to_a_named_channel_exr_and_a_false_colour_png() {
    let d = scratch("spectra", "bands");
    std::fs::write(
        d.join("scene.toml"),
        "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n\
         [film]\nwidth = 16\nheight = 12\nspp = 4\n\
         bands = [{ name = \"red\", center = 665, width = 30 }, { name = \"green\", center = 560, width = 30 }, \
                  { name = \"blue\", center = 490, width = 60 }, { name = \"nir\", center = 842, width = 100 }]\n\
         false_color = [\"nir\", \"red\", \"green\"]\n\
         [sky]\ntype = \"constant\"\nradiance = 0.5\n\
         [[light]]\ntype = \"sun\"\ndirection = [0, 0, 1]\nirradiance = 2\n\
         [[material]]\nname = \"l\"\ntype = \"leaf\"\npigments = { cab = 40 }\n\
         [[object]]\ntype = \"quad\"\nmaterial = \"l\"\ncorner = [-2, -2, 0]\nedge_u = [4, 0, 0]\nedge_v = [0, 4, 0]\n",
    )
    .unwrap();
    let e = ok(&lamina(
        &["render", "scene.toml", "-o", "b.exr", "-o", "b.png"],
        &d,
    ));
    // One render for all four bands.
    assert!(e.contains("[red, green, blue, nir]: 16x12, 4 spp"), "{e}");
    let meta = exr::meta::MetaData::read_from_file(d.join("b.exr"), false).unwrap();
    let names: Vec<String> = meta.headers[0]
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, ["blue", "green", "nir", "red"]);
    assert!(d.join("b.png").is_file());
    // The GPU path renders RGB only.
    fails(
        &lamina(&["render", "scene.toml", "--gpu", "-o", "g.png"], &d),
        &["--gpu", "bands"],
    );
    assert!(!d.join("g.png").exists());
}

/// `spectral = "visible"`: an RGB image from a render over visible wavelengths, like the
/// RGB render of the scene; the GPU path refuses it; bad values and `bands` beside it are
/// errors naming the key.
#[test]
fn a_scene_renders_over_visible_wavelengths() {
    let d = scratch("spectra", "visible");
    let scene = |film: &str| {
        format!(
            "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n\
             [film]\nwidth = 16\nheight = 12\nspp = 16\n{film}\n\
             [sky]\ntype = \"constant\"\nradiance = [0.3, 0.4, 0.5]\n\
             [[light]]\ntype = \"sun\"\ndirection = [0, 0, 1]\nirradiance = 2\n\
             [[material]]\nname = \"l\"\ntype = \"leaf\"\npigments = {{ cab = 40 }}\n\
             [[object]]\ntype = \"quad\"\nmaterial = \"l\"\ncorner = [-2, -2, 0]\nedge_u = [4, 0, 0]\nedge_v = [0, 4, 0]\n"
        )
    };
    std::fs::write(d.join("rgb.toml"), scene("")).unwrap();
    std::fs::write(d.join("vis.toml"), scene("spectral = \"visible\"")).unwrap();
    ok(&lamina(&["render", "rgb.toml", "-o", "rgb.exr"], &d));
    let e = ok(&lamina(
        &["render", "vis.toml", "-o", "vis.exr", "-o", "vis.png"],
        &d,
    ));
    assert!(e.contains("making the spectral channels"), "{e}");
    assert!(d.join("vis.png").is_file());
    for c in ["R", "G", "B"] {
        let (a, b) = (
            channel_mean(&d.join("rgb.exr"), c),
            channel_mean(&d.join("vis.exr"), c),
        );
        assert!((a - b).abs() < 0.05 * a + 1e-3, "{c}: RGB {a}, visible {b}");
    }
    fails(
        &lamina(&["render", "vis.toml", "--gpu", "-o", "g.png"], &d),
        &["--gpu", "visible"],
    );
    assert!(!d.join("g.png").exists());
    for (film, words) in [
        (
            "spectral = \"infrared\"",
            &["film.spectral", "unknown mode 'infrared'"][..],
        ),
        ("spectral = 3", &["film.spectral"][..]),
        (
            "spectral = \"visible\"\nbands = [{ name = \"r\", center = 665, width = 30 }]",
            &["film.bands", "one or the other"][..],
        ),
    ] {
        std::fs::write(d.join("bad.toml"), scene(film)).unwrap();
        fails(&lamina(&["render", "bad.toml", "-o", "bad.png"], &d), words);
        assert!(!d.join("bad.png").exists());
    }
}

/// Mean of channel `name` of an EXR file.
fn channel_mean(path: &std::path::Path, name: &str) -> f64 {
    let c = &common::channels(path)[name];
    c.iter().map(|&x| x as f64).sum::<f64>() / c.len() as f64
}

#[test]
fn a_band_given_by_a_response_file_renders_like_the_same_flat_band() {
    let d = scratch("spectra", "response");
    let scene = |nir: &str| {
        format!(
            "[camera]\nposition = [0, 0, 1]\nlook_at = [0, 0, 0]\n\
             [film]\nwidth = 16\nheight = 12\nspp = 8\n\
             bands = [{{ name = \"red\", center = 665, width = 30 }}, {nir}]\n\
             [sky]\ntype = \"constant\"\nradiance = 0.5\n\
             [[light]]\ntype = \"sun\"\ndirection = [0, 0, 1]\nirradiance = 2\n\
             [[material]]\nname = \"l\"\ntype = \"leaf\"\npigments = {{ cab = 40 }}\n\
             [[object]]\ntype = \"quad\"\nmaterial = \"l\"\ncorner = [-2, -2, 0]\nedge_u = [4, 0, 0]\nedge_v = [0, 4, 0]\n"
        )
    };
    // A box from 792 to 892 nm as a response file, and the same band by its edges.
    std::fs::write(
        d.join("nir.csv"),
        "wavelength_nm,response\n791.99,0\n792,1\n892,1\n892.01,0\n",
    )
    .unwrap();
    std::fs::write(
        d.join("file.toml"),
        scene("{ name = \"nir\", response = \"nir.csv\" }"),
    )
    .unwrap();
    std::fs::write(
        d.join("flat.toml"),
        scene("{ name = \"nir\", min = 792, max = 892 }"),
    )
    .unwrap();
    ok(&lamina(&["render", "file.toml", "-o", "file.exr"], &d));
    ok(&lamina(&["render", "flat.toml", "-o", "flat.exr"], &d));
    let (a, b) = (
        channel_mean(&d.join("file.exr"), "nir"),
        channel_mean(&d.join("flat.exr"), "nir"),
    );
    assert!(
        a > 0.0 && ((a - b) / b).abs() < 0.005,
        "response {a}, flat {b}"
    );
    // A broken response file names itself, its line and the key; nothing is written.
    std::fs::write(d.join("nir.csv"), "wavelength_nm,response\n800,1\n790,1\n").unwrap();
    fails(
        &lamina(&["render", "file.toml", "-o", "bad.exr"], &d),
        &["nir.csv:3", "film.bands[1].response", "increase"],
    );
    assert!(!d.join("bad.exr").exists());
}

#[test]
fn spectrum_writes_what_spectral_renders_give_an_rgb_value() {
    let d = scratch("spectra", "spectrum-cmd");
    // White reflects 1 at every wavelength; a green reflects more at 550 nm than at 450 or
    // 650 nm, and holds its 830 nm value beyond.
    ok(&lamina(&["spectrum", "--rgb", "1,1,1", "-o", "w.csv"], &d));
    let w = rows(&d.join("w.csv"));
    assert_eq!(w.len(), 471);
    assert!(w.iter().all(|r| (r[1] - 1.0).abs() < 1e-5), "{w:?}");
    ok(&lamina(
        &[
            "spectrum",
            "--rgb",
            "0.1,0.5,0.1",
            "--wavelengths",
            "450:2450:100",
            "-o",
            "g.csv",
        ],
        &d,
    ));
    let g = rows(&d.join("g.csv"));
    let at = |nm: f64| g.iter().find(|r| r[0] == nm).unwrap()[1];
    assert!(
        at(550.0) > 2.0 * at(450.0) && at(550.0) > 2.0 * at(650.0),
        "{g:?}"
    );
    assert!((at(950.0) - at(2450.0)).abs() < 1e-6);
    // Light of the D65 shape: Y = ∫ L ȳ dλ = 1 for white (ȳ ≈ 1 at 555 nm, so the spectrum
    // is near 1/106.9 per nm there); the solar shape carries infrared.
    ok(&lamina(
        &[
            "spectrum",
            "--rgb",
            "1,1,1",
            "--emission",
            "d65",
            "-o",
            "e.csv",
        ],
        &d,
    ));
    let e = rows(&d.join("e.csv"));
    let at555 = e.iter().find(|r| r[0] == 555.0).unwrap()[1];
    assert!((at555 * 106.857 - 1.0).abs() < 0.05, "{at555}");
    ok(&lamina(
        &[
            "spectrum",
            "--rgb",
            "1,1,1",
            "--emission",
            "solar",
            "--wavelengths",
            "1000:1000:1",
            "-o",
            "s.csv",
        ],
        &d,
    ));
    assert!(rows(&d.join("s.csv"))[0][1] > 0.0);
    // Bad input: named, nothing written.
    for (args, words) in [
        (&["--rgb", "1,2"][..], &["--rgb", "three numbers"][..]),
        (
            &["--rgb", "1.5,0,0"][..],
            &["reflectance", "[0, 1]", "--emission"][..],
        ),
        (
            &["--rgb", "1,1,1", "--emission", "d50"][..],
            &["--emission", "d65 or solar"][..],
        ),
        (
            &["--rgb", "1,1,1", "--wavelengths", "300:900:1"][..],
            &["--wavelengths", "360-2500"][..],
        ),
        (&["--rgb", "nan,0,0"][..], &["--rgb", "finite"][..]),
    ] {
        let mut a = vec!["spectrum"];
        a.extend_from_slice(args);
        a.extend_from_slice(&["-o", "bad.csv"]);
        fails(&lamina(&a, &d), words);
        assert!(!d.join("bad.csv").exists());
    }
}
