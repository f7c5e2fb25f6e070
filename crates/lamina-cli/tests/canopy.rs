//! `lamina canopy rami` and the sensors through the real binary: the folder, the files a
//! render of it writes, RAMI's CSV layout, the energy budget, and bad input.

mod common;
use common::{fails, lamina, ok, scratch};
use std::path::Path;

/// `lamina canopy rami ARGS` run in `cwd`.
fn rami(args: &[&str], cwd: &Path) -> std::process::Output {
    lamina(&[&["canopy", "rami"], args].concat(), cwd)
}

/// The rows of a lamina CSV (mark line and header dropped), split on commas.
fn rows(path: &Path) -> (String, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert!(lines.next().unwrap().starts_with("# lamina"), "{text}");
    let header = lines.next().unwrap().to_string();
    let rows = lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    (header, rows)
}

fn value(rows: &[Vec<String>], measure: &str) -> f64 {
    rows.iter().find(|r| r[0] == measure).unwrap()[1]
        .parse()
        .unwrap()
}

#[test]
fn a_rami_folder_renders_to_rami_files_whose_budget_closes() {
    let d = scratch("canopy", "rami");
    let dir = d.join("hom12");
    let o = rami(
        &[
            "--case",
            "HOM12",
            "--lad",
            "pla",
            "--band",
            "nir",
            "--sun-zenith",
            "50",
            "--cell",
            "3",
            "--brf-samples",
            "256",
            "--photons",
            "100000",
            "-o",
            dir.to_str().unwrap(),
        ],
        &d,
    );
    let msg = ok(&o);
    assert!(msg.contains("LAI 2.000"), "{msg}");
    for f in ["scene.toml", "disc.obj", "leaves.csv"] {
        assert!(dir.join(f).is_file(), "{f}");
    }
    let o = lamina(&["render", "scene.toml", "--threads", "2"], &dir);
    let msg = ok(&o);
    assert!(
        msg.contains("sensor 'fluxes'") && msg.contains("sensor 'brf'"),
        "{msg}"
    );
    assert!(!dir.join("scene.png").exists(), "no -o: sensors only");
    for f in ["brfpp.csv", "brfop.csv"] {
        let (header, r) = rows(&dir.join(f));
        assert_eq!(header, "sza,vza,raa,brf,std");
        assert_eq!(r.len(), 76, "-75..75 in 2° steps");
        for row in &r {
            assert_eq!(row[0], "50.00");
            let brf: f64 = row[3].parse().unwrap();
            assert!(brf > 0.1 && brf < 1.0, "{row:?}");
        }
    }
    let (header, r) = rows(&dir.join("fluxes.csv"));
    assert_eq!(header, "measure,value,std");
    let (a, fa, ft) = (value(&r, "albedo"), value(&r, "fabs"), value(&r, "ftran"));
    let budget = a + fa + ft * (1.0 - 0.159);
    assert!(
        (budget - 1.0).abs() < 0.01,
        "{a} + {fa} + {ft}·(1 − 0.159) = {budget}"
    );
    let png = image::open(dir.join("brf.png")).unwrap();
    assert_eq!((png.width(), png.height()), (960, 540));
    // The folder is lamina's: writing it again (results and all) is allowed.
    let o = rami(&["--case", "HOM11", "-o", dir.to_str().unwrap()], &d);
    ok(&o);
    // A foreign file where a sensor writes is kept, and the render refused before work.
    std::fs::write(dir.join("brfpp.csv"), "my own data\n").unwrap();
    let o = lamina(&["render", "scene.toml", "--sensor-scale", "0.01"], &dir);
    fails(&o, &["brfpp.csv", "not written by lamina"]);
    assert_eq!(
        std::fs::read_to_string(dir.join("brfpp.csv")).unwrap(),
        "my own data\n"
    );
}

#[test]
fn bad_rami_arguments_are_named() {
    let d = scratch("canopy", "bad");
    let out = d.join("x");
    let o = rami(&["--case", "HOM99", "-o", out.to_str().unwrap()], &d);
    fails(&o, &["--case HOM99", "unknown RAMI case", "HOM11"]);
    let o = rami(
        &[
            "--case",
            "HOM11",
            "--band",
            "blue",
            "-o",
            out.to_str().unwrap(),
        ],
        &d,
    );
    fails(&o, &["--band blue", "red, nir, nr1"]);
    let o = rami(
        &[
            "--case",
            "HOM11",
            "--lad",
            "sph",
            "-o",
            out.to_str().unwrap(),
        ],
        &d,
    );
    fails(&o, &["--lad sph"]);
    let o = rami(
        &[
            "--case",
            "HOM11",
            "--sun-zenith",
            "90",
            "-o",
            out.to_str().unwrap(),
        ],
        &d,
    );
    fails(&o, &["--sun-zenith 90"]);
    assert!(!out.exists());
}

#[test]
fn smaller_leaves_keep_the_lai_and_the_render_reads_their_scale() {
    let d = scratch("canopy", "radius");
    let dir = d.join("small");
    let o = rami(
        &[
            "--case",
            "HOM11",
            "--leaf-radius",
            "0.02",
            "--cell",
            "1.5",
            "--brf-samples",
            "64",
            "--photons",
            "20000",
            "-o",
            dir.to_str().unwrap(),
        ],
        &d,
    );
    let msg = ok(&o);
    assert!(
        msg.contains("leaf radius 0.02 m") && msg.contains("LAI 1.000"),
        "{msg}"
    );
    let csv = std::fs::read_to_string(dir.join("leaves.csv")).unwrap();
    assert_eq!(csv.lines().nth(1), Some("tx,ty,tz,rx,ry,s"));
    assert!(
        csv.lines().nth(2).unwrap().ends_with(",0.400000000"),
        "{csv:.200}"
    );
    let o = lamina(&["render", "scene.toml", "--threads", "2"], &dir);
    let msg = ok(&o);
    assert!(msg.contains("albedo"), "{msg}");
    let o = rami(
        &[
            "--case",
            "HOM11",
            "--leaf-radius",
            "0",
            "-o",
            dir.to_str().unwrap(),
        ],
        &d,
    );
    fails(&o, &["--leaf-radius 0"]);
}

#[test]
fn sensors_measure_every_band_of_a_band_film() {
    let d = scratch("canopy", "bands");
    let dir = d.join("nir");
    ok(&rami(
        &[
            "--case",
            "HOM11",
            "--band",
            "nir",
            "--cell",
            "2",
            "--brf-samples",
            "256",
            "--photons",
            "20000",
            "-o",
            dir.to_str().unwrap(),
        ],
        &d,
    ));
    // RGB first (the grey scene's three channels are equal).
    ok(&lamina(&["render", "scene.toml", "--threads", "2"], &dir));
    let (_, rgb) = rows(&dir.join("brfpp.csv"));
    // Four bands (two groups of three), every channel written for the fluxes.
    let bands = "film.bands=[{name=\"red\",center=665,width=30},{name=\"nir\",center=865,width=40},\
                 {name=\"swir\",center=1600,width=50},{name=\"green\",center=550,width=40}]";
    let o = lamina(
        &[
            "render",
            "scene.toml",
            "--threads",
            "2",
            "--set",
            bands,
            "--set",
            "sensor[0].channel=\"swir\"",
            "--set",
            "sensor[1].channel=\"nir\"",
        ],
        &dir,
    );
    let msg = ok(&o);
    assert!(msg.contains("(swir)"), "{msg}");
    let (header, banded) = rows(&dir.join("brfpp.csv"));
    assert_eq!(header, "sza,vza,raa,brf,std");
    for (a, b) in rgb.iter().zip(&banded) {
        let (x, y): (f64, f64) = (a[3].parse().unwrap(), b[3].parse().unwrap());
        assert!((x - y).abs() < 1e-4, "{a:?} vs {b:?}");
    }
    // A band no film channel names is refused, naming the key.
    let o = lamina(
        &[
            "render",
            "scene.toml",
            "--set",
            bands,
            "--set",
            "sensor[0].channel=\"R\"",
        ],
        &dir,
    );
    fails(
        &o,
        &[
            "sensor[0].channel",
            "'R' is not a channel of the film (red, nir, swir, green)",
        ],
    );
}

/// A scratch folder `name` holding a copy of the meadow example (`canopy_sensors.toml`
/// and its `cards.csv`).
fn meadow_copy(name: &str) -> std::path::PathBuf {
    let d = scratch("canopy", name);
    let ex = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples");
    for f in ["canopy_sensors.toml", "cards.csv"] {
        std::fs::copy(ex.join(f), d.join(f)).unwrap();
    }
    d
}

#[test]
fn the_meadow_example_measures_and_its_budget_closes_with_real_leaves() {
    let d = meadow_copy("meadow");
    let o = lamina(
        &[
            "render",
            "canopy_sensors.toml",
            "--sensor-scale",
            "0.1",
            "--threads",
            "2",
        ],
        &d,
    );
    let msg = ok(&o);
    assert!(msg.contains("sensor 'meadow_fisheye'"), "{msg}");
    for f in [
        "meadow_brf.csv",
        "meadow_brf.png",
        "meadow_fisheye.png",
        "meadow_gap.csv",
    ] {
        assert!(d.join(f).is_file(), "{f}");
    }
    // Every channel (no `channel` key): rows `measure,channel,value,std`. The leaves are the
    // layered beech model, not bi-Lambertian: the budget still closes, per channel.
    let (header, r) = rows(&d.join("meadow_fluxes.csv"));
    assert_eq!(header, "measure,channel,value,std");
    for (c, soil) in [("R", 0.12), ("G", 0.09), ("B", 0.06)] {
        let get = |m: &str| -> f64 {
            r.iter().find(|x| x[0] == m && x[1] == c).unwrap()[2]
                .parse()
                .unwrap()
        };
        let budget = get("albedo") + get("fabs") + get("ftran") * (1.0 - soil);
        assert!((budget - 1.0).abs() < 0.02, "{c}: {budget}");
    }
}

/// `--time-limit` on a run that only measures sensors (no `-o`) would do nothing: an error
/// naming the flag, before any sensor file is written.
#[test]
fn a_time_limit_on_a_sensors_only_run_is_an_error() {
    let d = meadow_copy("meadow_time_limit");
    let o = lamina(&["render", "canopy_sensors.toml", "--time-limit", "5"], &d);
    fails(&o, &["--time-limit 5", "[[sensor]]", "-o FILE"]);
    for f in ["meadow_brf.csv", "meadow_fluxes.csv", "meadow_gap.csv"] {
        assert!(!d.join(f).exists(), "{f} written");
    }
}
