//! `[domain]` and `[[sensor]]`: what they read, and that every mistake names file, line
//! and key.

use lamina_scene::radiometry::{FisheyeProjection, SensorKind};
use lamina_scene::{Scene, SceneError, parse_scene};
use std::path::Path;

/// A 2 m periodic cell with a ground spanning it, a leaf crossing its border, a sun.
const BASE: &str = r#"
[camera]
position = [1, 3, 5]
look_at = [1, 0, 1]

[domain]
periodic = { min = [0, 0], max = [2, 2] }

[[light]]
type = "sun"
direction = [0.3, 1, 0]
irradiance = 1

[[material]]
name = "leaf"
type = "diffuse_transmission"

[[material]]
name = "soil"
type = "diffuse"

[[object]]
type = "quad"
name = "soil"
material = "soil"
corner = [0, 0, 2]
edge_u = [2, 0, 0]
edge_v = [0, 0, -2]

[[object]]
type = "quad"
name = "leaf"
material = "leaf"
corner = [1.9, 0.5, 1]
edge_u = [0.3, 0, 0]
edge_v = [0, 0.1, -0.2]
"#;

fn parse(text: &str) -> Result<Scene, SceneError> {
    parse_scene(text, Path::new("/tmp/canopy/scene.toml"))
}

fn err(extra: &str) -> String {
    match parse(&format!("{BASE}{extra}")) {
        Ok(_) => panic!("expected an error for:\n{extra}"),
        Err(e) => e.to_string(),
    }
}

/// The 1-based line of `needle`'s first occurrence in `BASE + extra`.
fn line_of(extra: &str, needle: &str) -> usize {
    let text = format!("{BASE}{extra}");
    text.lines().position(|l| l.contains(needle)).unwrap() + 1
}

#[test]
fn sensors_are_read_with_their_paths_relative_to_the_scene() {
    let s = parse(&format!(
        "{BASE}{}",
        r#"
[[sensor]]
type = "brf"
channel = "G"
samples = 100
planes = [{ plane = "principal", zenith_max = 10, step = 5, file = "pp.csv" }]
directions = [[0, 0], [30, 400]]
file = "dirs.csv"
plot = "brf.png"

[[sensor]]
type = "absorbed"
ground = ["soil"]
file = "out/fluxes.csv"

[[sensor]]
type = "irradiance"
height = 0.01
grid = [2, 3]
file = "e.csv"

[[sensor]]
type = "fisheye"
position = [1, 0.01, 1]
projection = "equisolid"
file = "eye.png"
gap_file = "gap.csv"
"#
    ))
    .unwrap();
    let r = &s.radiometry;
    assert_eq!(r.periodic.unwrap().cell.max, glam::Vec2::new(2.0, 2.0));
    assert_eq!(r.objects.len(), 2);
    assert_eq!(r.objects[1].name, "leaf");
    assert_eq!(r.sensors.len(), 4);
    let SensorKind::Brf { sweeps, plot, .. } = &r.sensors[0].kind else {
        panic!()
    };
    assert_eq!(r.sensors[0].channel, Some(1));
    assert_eq!(r.sensors[0].samples, 100);
    assert_eq!(sweeps[0].directions.len(), 5);
    let signed: Vec<f32> = sweeps[0]
        .directions
        .iter()
        .map(|d| d.signed_zenith)
        .collect();
    assert_eq!(signed, vec![-10.0, -5.0, 0.0, 5.0, 10.0]);
    assert_eq!(sweeps[0].directions[0].relative_azimuth, 180.0);
    assert_eq!(sweeps[1].directions[1].relative_azimuth, 40.0);
    assert_eq!(sweeps[0].file, Path::new("/tmp/canopy/pp.csv"));
    assert_eq!(plot.as_deref(), Some(Path::new("/tmp/canopy/brf.png")));
    let SensorKind::Absorbed { ground, file, .. } = &r.sensors[1].kind else {
        panic!()
    };
    assert_eq!(ground, &vec![1]);
    assert_eq!(file, Path::new("/tmp/canopy/out/fluxes.csv"));
    assert_eq!(r.sensors[1].samples, 1_000_000);
    let SensorKind::Irradiance { grid, .. } = &r.sensors[2].kind else {
        panic!()
    };
    assert_eq!(*grid, [2, 3]);
    let SensorKind::Fisheye { projection, up, .. } = &r.sensors[3].kind else {
        panic!()
    };
    assert_eq!((*projection, *up), (FisheyeProjection::Equisolid, true));
}

#[test]
fn view_directions_below_the_horizon_are_refused() {
    let extra = "\n[[sensor]]\ntype = \"brf\"\ndirections = [[95, 0]]\nfile = \"d.csv\"\n";
    let e = err(extra);
    let line = line_of(extra, "directions =");
    assert!(e.contains(&format!("scene.toml:{line}:")), "{e}");
    assert!(
        e.contains("sensor[0].directions") && e.contains("not above the horizon"),
        "{e}"
    );
    let e = err(
        "\n[[sensor]]\ntype = \"brf\"\nplanes = [{ plane = \"principal\", zenith_max = 90, file = \"p.csv\" }]\n",
    );
    assert!(
        e.contains("sensor[0].planes[0].zenith_max") && e.contains("89.9"),
        "{e}"
    );
}

#[test]
fn a_target_outside_the_periodic_cell_is_refused() {
    let extra = "\n[[sensor]]\ntype = \"brf\"\ntarget = { min = [1, 1], max = [3, 2] }\ndirections = [[0, 0]]\nfile = \"d.csv\"\n";
    let e = err(extra);
    let line = line_of(extra, "target =");
    assert!(e.contains(&format!("scene.toml:{line}:")), "{e}");
    assert!(
        e.contains("sensor[0].target") && e.contains("outside the periodic cell"),
        "{e}"
    );
}

#[test]
fn a_cell_smaller_than_an_object_or_without_size_is_refused() {
    // The leaf quad is 0.3 m wide along x; a 0.2 m cell is smaller.
    let text = BASE.replace("max = [2, 2]", "max = [0.2, 2]");
    let e = parse(&text).unwrap_err().to_string();
    // The error points at the object's `name` line (the last `name = "leaf"`).
    let lines: Vec<&str> = text.lines().collect();
    let line = lines
        .iter()
        .rposition(|l| l.contains("name = \"leaf\""))
        .unwrap()
        + 1;
    assert!(
        e.contains("object[1]") && e.contains("does not fit the periodic cell"),
        "{e}"
    );
    assert!(e.contains("wide along x"), "{e}");
    assert!(e.contains(&format!("scene.toml:{line}:")), "{e}");
    let e = parse(&BASE.replace("max = [2, 2]", "max = [0, 2]"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("domain.periodic.max") && e.contains("no size"),
        "{e}"
    );
    // A periodic domain with no geometry has no height range.
    let empty = "[camera]\nposition = [0, 1, 3]\nlook_at = [0, 0, 0]\n[domain]\nperiodic = { min = [0, 0], max = [1, 1] }\n";
    let e = parse(empty).unwrap_err().to_string();
    assert!(
        e.contains("domain.periodic") && e.contains("no geometry"),
        "{e}"
    );
}

#[test]
fn sensors_without_the_channel_or_the_area_they_need_are_refused() {
    let e = err("\n[[sensor]]\ntype = \"absorbed\"\nchannel = \"nir\"\nfile = \"f.csv\"\n");
    assert!(
        e.contains("sensor[0].channel") && e.contains("not a channel of the film (R, G, B)"),
        "{e}"
    );
    let e = err("\n[[sensor]]\ntype = \"absorbed\"\nground = [\"sand\"]\nfile = \"f.csv\"\n");
    assert!(
        e.contains("sensor[0].ground") && e.contains("no material named 'sand'"),
        "{e}"
    );
    let e = err("\n[[sensor]]\ntype = \"brf\"\n");
    assert!(
        e.contains("sensor[0].planes") && e.contains("needs view directions"),
        "{e}"
    );
    let e = err("\n[[sensor]]\ntype = \"bfr\"\n");
    assert!(
        e.contains("sensor[0].type") && e.contains("unknown sensor type 'bfr'"),
        "{e}"
    );
    let e = err("\n[[sensor]]\ntype = \"irradiance\"\nheight = 1\nfile = \"e.txt\"\n");
    assert!(e.contains("sensor[0].file") && e.contains(".csv"), "{e}");
    // Without a periodic domain an absorbed sensor needs its area.
    let open = BASE.replace("periodic = { min = [0, 0], max = [2, 2] }", "");
    let open = open.replace("[domain]\n", "");
    let e = parse(&format!(
        "{open}\n[[sensor]]\ntype = \"absorbed\"\nfile = \"f.csv\"\n"
    ))
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("sensor[0].area") && e.contains("no periodic domain"),
        "{e}"
    );
}

#[test]
fn only_the_sun_and_sky_light_a_periodic_domain() {
    let e = err("\n[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 1\n");
    assert!(
        e.contains("light[1].type") && e.contains("only the sun and the sky"),
        "{e}"
    );
}
