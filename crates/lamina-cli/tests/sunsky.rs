//! `[sky] type = "sunsky"` through the real binary: a white floor under the physical sun and
//! sky reflects exactly the horizontal irradiance SPCTRAL2 gives, in RGB (ȳ-weighted) and
//! in a near-infrared band; bad input names the key.

mod common;
use common::{channels, fails, lamina, ok, scratch};

const PLACE: &str =
    "position = { latitude = 48.8566, longitude = 2.3522, time = \"2024-06-21T13:30:00+02:00\" }";

/// A floor of reflectance 0.5 filling the view of a camera looking straight down.
fn scene(film_extra: &str, sky_extra: &str) -> String {
    format!(
        "[camera]\nposition = [0, 1, 0]\nlook_at = [0, 0, 0]\nup = [0, 0, -1]\nfov = 20\n\
         [film]\nwidth = 16\nheight = 16\nspp = 256\n{film_extra}\n\
         [sky]\ntype = \"sunsky\"\n{PLACE}\nresolution = 256\n{sky_extra}\n\
         [[material]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = 0.5\n\
         [[object]]\ntype = \"quad\"\nmaterial = \"floor\"\ncorner = [-50, 0, 50]\nedge_u = [100, 0, 0]\nedge_v = [0, 0, -100]\n"
    )
}

fn mean(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64
}

/// The model the loader builds for `PLACE`.
fn model() -> lamina_sky::SunSky {
    let p = lamina_sky::SunSkyParams::new(
        lamina_sky::Observer {
            latitude: 48.8566,
            longitude: 2.3522,
            elevation: 0.0,
        },
        lamina_sky::parse_local_time("2024-06-21T13:30:00+02:00").unwrap(),
    );
    lamina_sky::SunSky::new(&p).unwrap()
}

#[test]
fn a_white_floor_reflects_spectral2s_horizontal_irradiance_in_rgb_and_in_bands() {
    let d = scratch("sunsky", "floor");
    let m = model();
    let cosz = m.sun().zenith.to_radians().cos();
    // RGB: Y of the floor = 0.5 (E_sun,Y cos z + E_diffuse,Y) / π.
    std::fs::write(d.join("rgb.toml"), scene("", "")).unwrap();
    ok(&lamina(&["render", "rgb.toml", "-o", "rgb.exr"], &d));
    let c = channels(&d.join("rgb.exr"));
    let y = 0.2126 * mean(&c["R"]) + 0.7152 * mean(&c["G"]) + 0.0722 * mean(&c["B"]);
    let sun = m.sun_rgb();
    let sun_y = 0.2126 * sun.x + 0.7152 * sun.y + 0.0722 * sun.z;
    let want = 0.5 * (sun_y * cosz + m.diffuse_y()) / std::f64::consts::PI;
    eprintln!("RGB (ȳ): floor {y:.4}, SPCTRAL2 {want:.4}");
    assert!((y / want - 1.0).abs() < 0.02, "Y {y}, expected {want}");
    // A near-infrared band: 0.5 (E_sun(band) cos z + E_diffuse(band)) / π, per nm.
    std::fs::write(
        d.join("nir.toml"),
        scene(
            "bands = [{ name = \"nir\", min = 850, max = 880 }, { name = \"swir\", min = 1550, max = 1650 }]",
            "",
        ),
    )
    .unwrap();
    ok(&lamina(&["render", "nir.toml", "-o", "nir.exr"], &d));
    let c = channels(&d.join("nir.exr"));
    let s = m.spectrum();
    for (name, lo, hi) in [("nir", 850usize, 880usize), ("swir", 1550, 1650)] {
        let band = lamina_leaf::spectrum::bands::Band::flat(name, lo as f32, hi as f32);
        let diffuse: f64 = (lo..hi)
            .map(|nm| 0.5 * (s.diffuse_horizontal[nm - 300] + s.diffuse_horizontal[nm + 1 - 300]))
            .sum::<f64>()
            / (hi - lo) as f64;
        let want = 0.5 * (m.sun_band(&band) * cosz + diffuse) / std::f64::consts::PI;
        let got = mean(&c[name]);
        eprintln!("{name} {lo}-{hi} nm: floor {got:.5}, SPCTRAL2 {want:.5} W/(m² sr nm)");
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "{name}: {got}, expected {want}"
        );
    }
    // Without its sun, only the sky lights the floor.
    std::fs::write(d.join("nosun.toml"), scene("", "sun = false")).unwrap();
    ok(&lamina(&["render", "nosun.toml", "-o", "nosun.exr"], &d));
    let c = channels(&d.join("nosun.exr"));
    let y = 0.2126 * mean(&c["R"]) + 0.7152 * mean(&c["G"]) + 0.0722 * mean(&c["B"]);
    let want = 0.5 * m.diffuse_y() / std::f64::consts::PI;
    eprintln!("sky only (ȳ): floor {y:.4}, SPCTRAL2 {want:.4}");
    assert!(
        (y / want - 1.0).abs() < 0.02,
        "sky only: Y {y}, expected {want}"
    );
}

#[test]
fn bad_sunsky_input_names_the_key() {
    let d = scratch("sunsky", "bad");
    for (sky, words) in [
        ("", &["sky.position", "required"][..]),
        (
            "position = { latitude = 48.8566, longitude = 2.3522, time = \"2024-06-21T02:00:00+02:00\" }",
            &["sky.position.time", "below the horizon"][..],
        ),
        (
            &format!("{PLACE}\nturbidity = 20"),
            &["sky.turbidity", "20"][..],
        ),
        (&format!("{PLACE}\nresolution = 8"), &["sky.resolution"][..]),
        (&format!("{PLACE}\ncolour = 1"), &["sky.colour"][..]),
    ] {
        std::fs::write(
            d.join("s.toml"),
            format!(
                "[camera]\nposition = [0, 1, 0]\nlook_at = [0, 0, 0]\nup = [0, 0, -1]\n\
                 [sky]\ntype = \"sunsky\"\n{sky}\n"
            ),
        )
        .unwrap();
        fails(&lamina(&["render", "s.toml", "-o", "s.png"], &d), words);
        assert!(!d.join("s.png").exists());
    }
}
