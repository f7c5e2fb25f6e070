//! `lamina canopy rami`: scene folders for RAMI's discrete canopies (the RAdiation transfer
//! Model Intercomparison, JRC): a periodic cell of bi-Lambertian disc leaves over a
//! Lambertian soil, lit by a parallel sun, with the BRF and flux sensors RAMI asks for.
//!
//! The folder holds `scene.toml` (the marker: its first line is lamina's mark), `disc.obj`
//! (one leaf: a 32-gon whose area is the disc's), `leaves.csv` (one placement per leaf) and,
//! once rendered, the sensors' files. Everything is reproducible from the flags.

use anyhow::{Context, Result, bail};
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// `lamina canopy ...`.
#[derive(clap::Subcommand, Debug)]
pub enum CanopyCommand {
    /// Write a RAMI scene folder (scene.toml, the leaf, the placements); `lamina render
    /// DIR/scene.toml` then writes brfpp.csv, brfop.csv, fluxes.csv and brf.png there.
    Rami(RamiArgs),
}

/// `lamina canopy rami`.
#[derive(clap::Args, Debug)]
pub struct RamiArgs {
    /// The case: HOM11, HOM12, HOM13, HOM15 (homogeneous, LAI 1, 2, 3, 5; heights 1, 1, 2,
    /// 1 m) or HET01 (floating spheres of leaves, RAMI-like).
    #[arg(long)]
    pub case: String,
    /// Leaf normal distribution: uni (uniform inclination), ere (erectophile), pla
    /// (planophile).
    #[arg(long, default_value = "uni")]
    pub lad: String,
    /// Band: red (leaf R 0.0546, T 0.0149, soil 0.127), nir (R 0.4957, T 0.4409, soil
    /// 0.159) or nr1 (conservative: R 0.5, T 0.5, soil 1).
    #[arg(long, default_value = "red")]
    pub band: String,
    /// Sun zenith angle (degrees, 0 to 85).
    #[arg(long, default_value_t = 20.0)]
    pub sun_zenith: f64,
    /// Seed of the leaves' positions and orientations.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Leaf radius (m): RAMI's is 0.05; smaller leaves at the same LAI approach the turbid
    /// medium of SAIL-like models.
    #[arg(long, default_value_t = LEAF_RADIUS)]
    pub leaf_radius: f64,
    /// Side of the periodic cell (m); the HOM cases default to 10 m, HET01 to 100 m.
    #[arg(long)]
    pub cell: Option<f64>,
    /// BRF rays per view direction.
    #[arg(long, default_value_t = 16384)]
    pub brf_samples: u32,
    /// Photons of the flux sensor.
    #[arg(long, default_value_t = 1_000_000)]
    pub photons: u32,
    /// The scene folder to write.
    #[arg(short, long = "output", value_name = "DIR")]
    pub output: PathBuf,
    /// Write into a folder lamina did not write (replacing only its own files).
    #[arg(long)]
    pub force: bool,
}

/// Leaf radius (m), RAMI's.
pub const LEAF_RADIUS: f64 = 0.05;
/// Sides of the polygon standing in for a disc leaf.
const DISC_SIDES: usize = 32;

/// One RAMI band: leaf reflectance and transmittance, soil reflectance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Band {
    pub name: &'static str,
    pub leaf_r: f64,
    pub leaf_t: f64,
    pub soil: f64,
}

/// RAMI-3's bands.
pub const BANDS: [Band; 3] = [
    Band {
        name: "red",
        leaf_r: 0.0546,
        leaf_t: 0.0149,
        soil: 0.127,
    },
    Band {
        name: "nir",
        leaf_r: 0.4957,
        leaf_t: 0.4409,
        soil: 0.159,
    },
    Band {
        name: "nr1",
        leaf_r: 0.5,
        leaf_t: 0.5,
        soil: 1.0,
    },
];

/// Leaf normal distributions (Bunnik 1978), densities over inclination `θ ∈ [0, π/2]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lnd {
    /// `g = 2/π`.
    Uniform,
    /// `g = 2/π (1 − cos 2θ)`.
    Erectophile,
    /// `g = 2/π (1 + cos 2θ)`.
    Planophile,
}

impl Lnd {
    fn parse(s: &str) -> Result<Lnd> {
        Ok(match s {
            "uni" => Lnd::Uniform,
            "ere" => Lnd::Erectophile,
            "pla" => Lnd::Planophile,
            other => bail!("--lad {other}: one of uni, ere, pla"),
        })
    }

    /// The cumulative distribution of the inclination at `t` (radians).
    fn cdf(self, t: f64) -> f64 {
        let k = 2.0 / PI;
        match self {
            Lnd::Uniform => k * t,
            Lnd::Erectophile => k * (t - 0.5 * (2.0 * t).sin()),
            Lnd::Planophile => k * (t + 0.5 * (2.0 * t).sin()),
        }
    }

    /// The inclination (radians) at quantile `u`, by bisection.
    pub fn sample(self, u: f64) -> f64 {
        let (mut lo, mut hi) = (0.0, PI / 2.0);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if self.cdf(mid) < u {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }
}

/// A homogeneous case: LAI and canopy height (m).
fn hom_case(name: &str) -> Option<(f64, f64)> {
    Some(match name {
        "HOM11" => (1.0, 1.0),
        "HOM12" => (2.0, 1.0),
        "HOM13" => (3.0, 2.0),
        "HOM15" => (5.0, 1.0),
        _ => return None,
    })
}

/// splitmix64: a small, fixed, seedable generator (the placements must not change with a
/// dependency's version).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One leaf: centre (m), inclination and azimuth of its normal (degrees).
struct Leaf {
    c: [f64; 3],
    incl: f64,
    az: f64,
}

/// The disc's polygon as an OBJ: a fan of `DISC_SIDES` triangles in the x-z plane, normal
/// `+y`, its circumradius chosen so that its area is `π r²`.
fn disc_obj() -> String {
    let n = DISC_SIDES as f64;
    let r = LEAF_RADIUS * (PI / (0.5 * n * (2.0 * PI / n).sin())).sqrt();
    let mut s = format!(
        "{}\n# one RAMI leaf: a {DISC_SIDES}-gon of the area of a disc of radius {LEAF_RADIUS} m, normal +y\n",
        lamina_io::text_mark_line("lamina canopy rami")
    );
    s.push_str("v 0 0 0\n");
    for k in 0..DISC_SIDES {
        let a = -2.0 * PI * k as f64 / n; // clockwise seen from +z: counter-clockwise from +y
        let _ = writeln!(s, "v {:.9} 0 {:.9}", r * a.cos(), r * a.sin());
    }
    for k in 0..DISC_SIDES {
        let _ = writeln!(s, "f 1 {} {}", k + 2, (k + 1) % DISC_SIDES + 2);
    }
    s
}

/// The leaves of a homogeneous layer: `lai` over a `cell`-sided square, centres uniform in
/// the layer `[r, h − r]` (so that no leaf reaches into the soil or above the top).
fn hom_leaves(rng: &mut Rng, lnd: Lnd, lai: f64, h: f64, cell: f64, lr: f64) -> Vec<Leaf> {
    let n = (lai * cell * cell / (PI * lr * lr)).round() as usize;
    (0..n)
        .map(|_| {
            let c = [
                rng.next() * cell,
                lr + rng.next() * (h - 2.0 * lr),
                rng.next() * cell,
            ];
            Leaf {
                c,
                incl: lnd.sample(rng.next()).to_degrees(),
                az: rng.next() * 360.0,
            }
        })
        .collect()
}

/// HET01-like floating spheres: 15 spheres of radius 10 m, centres 11 to 19 m high, placed
/// without overlap in a `cell`-sided square (periodic), leaf area density 0.47 m² m⁻³,
/// leaf centres uniform in each sphere.
fn het_leaves(rng: &mut Rng, lnd: Lnd, cell: f64, lr: f64) -> Result<(Vec<Leaf>, f64)> {
    let (radius, lad, count) = (10.0, 0.47, 15);
    let mut centres: Vec<[f64; 3]> = Vec::new();
    let mut tries = 0;
    while centres.len() < count {
        tries += 1;
        if tries > 100_000 {
            bail!("--cell {cell}: too small for 15 spheres of radius 10 m without overlap");
        }
        let c = [
            rng.next() * cell,
            11.0 + 8.0 * rng.next(),
            rng.next() * cell,
        ];
        let far = centres.iter().all(|o| {
            // Periodic distance in x and z.
            let wrap = |d: f64| d - cell * (d / cell).round();
            let (dx, dy, dz) = (wrap(c[0] - o[0]), c[1] - o[1], wrap(c[2] - o[2]));
            (dx * dx + dy * dy + dz * dz).sqrt() >= 2.0 * radius
        });
        if far {
            centres.push(c);
        }
    }
    let per = (lad * 4.0 / 3.0 * PI * radius.powi(3) / (PI * lr * lr)).round() as usize;
    let mut leaves = Vec::with_capacity(per * count);
    for o in &centres {
        for _ in 0..per {
            let p = loop {
                let p = [
                    2.0 * rng.next() - 1.0,
                    2.0 * rng.next() - 1.0,
                    2.0 * rng.next() - 1.0,
                ];
                if p[0] * p[0] + p[1] * p[1] + p[2] * p[2] <= 1.0 {
                    break p;
                }
            };
            let r = radius - lr;
            leaves.push(Leaf {
                c: [o[0] + r * p[0], o[1] + r * p[1], o[2] + r * p[2]],
                incl: lnd.sample(rng.next()).to_degrees(),
                az: rng.next() * 360.0,
            });
        }
    }
    let lai = leaves.len() as f64 * PI * lr * lr / (cell * cell);
    Ok((leaves, lai))
}

/// The placements file: the disc (radius [`LEAF_RADIUS`]) scaled to radius `lr`, rotated
/// about x by its inclination, then about y by its azimuth, then moved to its centre.
fn leaves_csv(leaves: &[Leaf], lr: f64) -> String {
    let scaled = lr != LEAF_RADIUS;
    let mut s = format!(
        "{}\ntx,ty,tz,rx,ry{}\n",
        lamina_io::text_mark_line("lamina canopy rami: leaf placements"),
        if scaled { ",s" } else { "" }
    );
    let scale = if scaled {
        format!(",{:.9}", lr / LEAF_RADIUS)
    } else {
        String::new()
    };
    for l in leaves {
        let _ = writeln!(
            s,
            "{:.5},{:.5},{:.5},{:.4},{:.4}{scale}",
            l.c[0], l.c[1], l.c[2], l.incl, l.az
        );
    }
    s
}

/// Whether `name` is a file a RAMI folder holds.
fn owns(name: &str) -> bool {
    matches!(
        name,
        "scene.toml"
            | "disc.obj"
            | "leaves.csv"
            | "brfpp.csv"
            | "brfop.csv"
            | "fluxes.csv"
            | "brf.png"
            | "scene.png"
            | "scene.exr"
    )
}

/// Whether the scene file at `path` starts with lamina's mark.
fn marked(path: &Path) -> bool {
    std::fs::read_to_string(path).is_ok_and(|t| t.starts_with("# lamina"))
}

/// Runs `lamina canopy`.
pub fn run(cmd: CanopyCommand) -> Result<()> {
    match cmd {
        CanopyCommand::Rami(a) => rami(&a),
    }
}

fn rami(a: &RamiArgs) -> Result<()> {
    let case = a.case.to_ascii_uppercase();
    let hom = hom_case(&case);
    if hom.is_none() && case != "HET01" {
        bail!(
            "--case {}: unknown RAMI case (HOM11, HOM12, HOM13, HOM15, HET01)",
            a.case
        );
    }
    let lnd = Lnd::parse(&a.lad)?;
    let band = *BANDS
        .iter()
        .find(|b| b.name == a.band)
        .with_context(|| format!("--band {}: one of red, nir, nr1", a.band))?;
    if !(0.0..=85.0).contains(&a.sun_zenith) {
        bail!("--sun-zenith {}: give 0 to 85 degrees", a.sun_zenith);
    }
    let cell = a.cell.unwrap_or(if hom.is_some() { 10.0 } else { 100.0 });
    if !(0.5..=1000.0).contains(&cell) {
        bail!("--cell {cell}: give 0.5 to 1000 m");
    }
    if a.brf_samples < 32 || a.photons < 32 {
        bail!("--brf-samples and --photons must be at least 32");
    }
    let spec = lamina_io::FolderSpec {
        kind: "RAMI scene folder",
        owns: &owns,
        marker: "scene.toml",
        is_marked: &marked,
        inputs: &[],
    };
    let mode = crate::output_file::replace_mode(a.force);
    lamina_io::check_folder(&a.output, &spec, mode)
        .with_context(|| format!("writing '{}'", a.output.display()))?;
    let lr = a.leaf_radius;
    if !(0.001..=0.5).contains(&lr) {
        bail!("--leaf-radius {lr}: give 0.001 to 0.5 m");
    }
    let mut rng = Rng(a.seed ^ 0x6c61_6d69_6e61);
    let (leaves, lai, height) = match hom {
        Some((lai, h)) => {
            if cell < 4.0 * lr {
                bail!("--cell {cell}: give at least twice a leaf's diameter");
            }
            let n = lai * cell * cell / (PI * lr * lr);
            if n > 5e7 {
                bail!("{n:.0} leaves: too many; use a smaller --cell or larger --leaf-radius");
            }
            (hom_leaves(&mut rng, lnd, lai, h, cell, lr), lai, h)
        }
        None => {
            let (l, lai) = het_leaves(&mut rng, lnd, cell, lr)?;
            (l, lai, 29.0)
        }
    };
    let sz = a.sun_zenith.to_radians();
    let title = format!(
        "RAMI {case}, {} leaf normals, band {}, sun zenith {}°, cell {cell} m, leaf radius \
         {lr} m, seed {}: {} leaves, LAI {lai:.3}",
        a.lad,
        band.name,
        a.sun_zenith,
        a.seed,
        leaves.len()
    );
    let scene = format!(
        r#"{mark}
# {title}
# Written by `lamina canopy rami`; `lamina render scene.toml` writes the sensors' files.
# Leaves: bi-Lambertian discs of radius {radius} m (R {lr}, T {lt}); soil Lambertian {soil}.
# The sun lies in the x-y plane: the principal plane is x-y, the orthogonal plane y-z.

[camera]
position = [{cx:.3}, {cy:.3}, {cz:.3}]
look_at = [{lx:.3}, {ly:.3}, {lz:.3}]
fov = 50

[film]
width = 640
height = 400
spp = 32
exposure = {exposure:.2}

[integrator]
type = "path"
max_depth = 1024
rr_depth = 8

[domain]
periodic = {{ min = [0, 0], max = [{cell}, {cell}] }}

[[light]]
type = "sun"
direction = [{sx:.9}, {sy:.9}, 0]
irradiance = 1
angular_diameter = 0

[[material]]
name = "leaf"
type = "diffuse_transmission"
reflectance = {lr}
transmittance = {lt}

[[material]]
name = "soil"
type = "diffuse"
reflectance = {soil}

[[object]]
type = "quad"
name = "soil"
material = "soil"
corner = [0, 0, {cell}]
edge_u = [{cell}, 0, 0]
edge_v = [0, 0, -{cell}]

[[object]]
type = "obj"
name = "leaves"
file = "disc.obj"
material = "leaf"
instances_file = "leaves.csv"

[[sensor]]
type = "brf"
name = "brf"
channel = "R"
samples = {brf}
planes = [
  {{ plane = "principal", zenith_max = 75, step = 2, file = "brfpp.csv" }},
  {{ plane = "orthogonal", zenith_max = 75, step = 2, file = "brfop.csv" }},
]
plot = "brf.png"

[[sensor]]
type = "absorbed"
name = "fluxes"
channel = "R"
samples = {photons}
ground = ["soil"]
file = "fluxes.csv"
"#,
        mark = lamina_io::text_mark_line("lamina canopy rami"),
        radius = lr,
        // A picture that is neither black in the red band nor white in the conservative one.
        exposure = (0.35 / (band.leaf_r + band.leaf_t)).log2().clamp(0.0, 4.0),
        lr = band.leaf_r,
        lt = band.leaf_t,
        soil = band.soil,
        cx = cell * 0.5 - 0.9 * height.max(1.0) * 3.0,
        cy = height * 2.2 + 1.5,
        cz = cell * 0.5 + 0.9 * height.max(1.0) * 3.0,
        lx = cell * 0.5,
        ly = height * 0.4,
        lz = cell * 0.5,
        sx = sz.sin(),
        sy = sz.cos(),
        brf = a.brf_samples,
        photons = a.photons,
    );
    let staged = lamina_io::stage(&a.output, &spec, mode)
        .with_context(|| format!("writing '{}'", a.output.display()))?;
    let dir = staged.path().to_owned();
    let write = |name: &str, text: &str| -> Result<()> {
        std::fs::write(dir.join(name), text).with_context(|| format!("writing {name}"))
    };
    write("disc.obj", &disc_obj())?;
    write("leaves.csv", &leaves_csv(&leaves, lr))?;
    write("scene.toml", &scene)?;
    let out = staged
        .commit(&spec)
        .with_context(|| format!("writing '{}'", a.output.display()))?;
    eprintln!("{title}");
    eprintln!(
        "wrote {}: render it with `lamina render {}`",
        out.display(),
        out.join("scene.toml").display()
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_normal_distributions_have_their_means() {
        // Mean inclination: uniform 45°, erectophile 63.24°, planophile 26.76° (Bunnik).
        for (lnd, mean) in [
            (Lnd::Uniform, 45.0),
            (Lnd::Erectophile, 63.24),
            (Lnd::Planophile, 26.76),
        ] {
            let n = 20000;
            let m: f64 = (0..n)
                .map(|i| lnd.sample((i as f64 + 0.5) / n as f64).to_degrees())
                .sum::<f64>()
                / n as f64;
            assert!((m - mean).abs() < 0.05, "{lnd:?}: {m}");
        }
    }

    #[test]
    fn the_disc_has_the_leaf_area() {
        let n = DISC_SIDES as f64;
        let r = LEAF_RADIUS * (PI / (0.5 * n * (2.0 * PI / n).sin())).sqrt();
        let area = 0.5 * n * r * r * (2.0 * PI / n).sin();
        assert!((area - PI * LEAF_RADIUS * LEAF_RADIUS).abs() < 1e-12);
    }

    #[test]
    fn hom_layer_has_its_lai() {
        let mut rng = Rng(3);
        let l = hom_leaves(&mut rng, Lnd::Uniform, 3.0, 2.0, 4.0, LEAF_RADIUS);
        let lai = l.len() as f64 * PI * LEAF_RADIUS * LEAF_RADIUS / 16.0;
        assert!((lai - 3.0).abs() < 1e-3);
        assert!(
            l.iter()
                .all(|x| x.c[1] >= LEAF_RADIUS && x.c[1] <= 2.0 - LEAF_RADIUS)
        );
    }
}
