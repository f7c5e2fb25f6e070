//! `lamina demo`: the built-in scene, needing no files. Three panels side by side: a
//! procedural leaf lit from the front, the same leaf lit from behind, and a small bush lit
//! by a low sun from behind.

use crate::render_cmd::{Outputs, RenderFlags, options, render_scene, write_result};
use anyhow::{Context, Result};
use glam::{Vec2, Vec3};
use lamina_io::{FolderSpec, Replace};
use lamina_render::{Image, RenderOutput};
use lamina_scene::builtin::{self, BuiltinLeaf};
use std::path::PathBuf;
use std::sync::Arc;

/// `lamina demo`.
#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// Output image(s), `.png` or `.exr`. Repeatable.
    #[arg(short, long = "output", value_name = "OUT", default_value = "demo.png")]
    pub output: Vec<PathBuf>,
    /// Height of each of the three square panels, in pixels.
    #[arg(long, default_value_t = 384, value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub size: u32,
    /// The species of the procedural leaf.
    #[arg(long, default_value = "beech")]
    pub species: String,
    /// Instead of rendering, write the demo bush as a scene folder (TOML, CSV cards, OBJ
    /// branches, alpha PNG) with diffuse-transmission leaves, for other renderers.
    #[arg(long, value_name = "DIR")]
    pub export_bush: Option<PathBuf>,
    /// Replace an output image lamina did not write; with --export-bush, also write into a
    /// folder that is not a bush export of lamina's, replacing only the files the export
    /// writes and keeping every other file.
    #[arg(long)]
    pub force: bool,
    #[command(flatten)]
    pub flags: RenderFlags,
}

/// The demo's leaf: a procedural leaf of the given species, 512x512 maps.
pub fn demo_leaf(species: &str, seed: u64) -> Result<BuiltinLeaf> {
    let species: lamina_leafmaps::Species = species.parse().map_err(|e| anyhow::anyhow!("{e}"))?;
    let spec = lamina_leafmaps::LeafSpec::new(species, seed, 512);
    let leaf = lamina_leafmaps::generate(&spec);
    let (w, h) = leaf.size_m;
    // A flat card has none of the curvature that breaks a real blade's sun glint into a
    // small spot: with the preset's waxy roughness, whole cards in the bush flash white.
    // The demo widens the adaxial lobe (an effective roughness for unmodelled curvature).
    let params = lamina_leaf::LeafParams {
        roughness_adaxial: leaf.params.roughness_adaxial.max(0.35),
        ..leaf.params
    };
    let material =
        lamina_leaf::LeafMaterial::new(leaf.maps, params).context("building the demo leaf")?;
    Ok(BuiltinLeaf {
        material: Arc::new(material),
        size_m: Vec2::new(w, h),
    })
}

/// Places images side by side (all the same height).
pub fn side_by_side(images: &[Image]) -> Image {
    let height = images.iter().map(|i| i.height).max().unwrap_or(0);
    let width = images.iter().map(|i| i.width).sum();
    let mut pixels = vec![Vec3::ZERO; (width * height) as usize];
    let mut x0 = 0;
    for img in images {
        for y in 0..img.height {
            for x in 0..img.width {
                pixels[(y * width + x0 + x) as usize] = img.pixels[(y * img.width + x) as usize];
            }
        }
        x0 += img.width;
    }
    Image {
        width,
        height,
        pixels,
    }
}

pub fn run(args: DemoArgs) -> Result<()> {
    let leaf = demo_leaf(&args.species, 1)?;
    let spp = args.flags.spp.unwrap_or(64);
    if let Some(dir) = &args.export_bush {
        let replace = crate::output_file::replace_mode(args.force);
        return export_bush(dir, &leaf, args.size, spp, replace);
    }
    let outputs = Outputs {
        paths: args.output.clone(),
        force: args.force,
        inputs: Vec::new(),
    };
    outputs.check()?;
    let size = (args.size, args.size);
    let panels = [
        ("front-lit leaf", builtin::leaf_front_lit(&leaf, size, spp)),
        ("back-lit leaf", builtin::leaf_back_lit(&leaf, size, spp)),
        ("bush", builtin::bush_scene(&leaf, size, spp)),
    ];
    // Ctrl-C quits at once until the last panel has a completed pass (before that there is
    // no demo image to write); after it, it stops the last panel at a pass boundary.
    let mut outs = Vec::new();
    for (i, (label, scene)) in panels.iter().enumerate() {
        let (opts, bar) = options(&args.flags, label, i + 1 == panels.len())?;
        outs.push(render_scene(scene, &opts, bar, label)?);
    }
    let images: Vec<Image> = outs.iter().map(|o| o.image.clone()).collect();
    let combined = RenderOutput {
        image: side_by_side(&images),
        stats: outs.last().expect("three panels").stats,
        sums: None,
    };
    write_result(&outputs, &combined, &panels[0].1.film)
}

/// The files a bush export writes (and so may replace in a folder it wrote before).
fn bush_export_file(name: &str) -> bool {
    let numbered = |prefix: &str, ext: &str| {
        name.strip_prefix(prefix)
            .and_then(|r| r.strip_suffix(ext))
            .is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
    };
    name == "bush.toml"
        || name == "bush_wood.obj"
        || numbered("bush_cards_", ".csv")
        || numbered("leaf_alpha_", ".png")
}

/// The first line of an exported `bush.toml`: marks the folder as a lamina export.
const BUSH_MARKER: &str = "# The lamina demo bush, exported by `lamina demo --export-bush`.";

fn is_bush_export(toml: &std::path::Path) -> bool {
    std::fs::read_to_string(toml).is_ok_and(|t| t.starts_with(BUSH_MARKER))
}

/// Writes the demo bush as an ordinary scene folder (for other renderers and benchmarks):
/// `bush.toml`, `bush_cards_<i>.csv` and `leaf_alpha_<i>.png` per leaf variant, and
/// `bush_wood.obj`. Leaves become `diffuse_transmission` cards with each variant's alpha
/// matte, since other renderers do not have lamina's leaf model; bark is a constant colour;
/// the sun is a delta light (angular diameter 0) so that it matches a directional light
/// elsewhere.
pub fn export_bush(
    dir: &std::path::Path,
    leaf: &BuiltinLeaf,
    size: u32,
    spp: u32,
    replace: Replace,
) -> Result<()> {
    use std::fmt::Write as _;
    let spec = FolderSpec {
        kind: "bush export",
        owns: &bush_export_file,
        marker: "bush.toml",
        is_marked: &is_bush_export,
        inputs: &[],
    };
    let staged = lamina_io::stage(dir, &spec, replace)?;
    let out = staged.path().to_owned();
    let plant = lamina_plant::generate_plant(&builtin::bush_params(7))?;
    let scene = builtin::bush_scene_with(&plant, leaf, (size, size), spp)?;
    let wood = &plant.branches;
    let mut leaf_tables = String::new();
    for (i, (cards, variant)) in plant.leaves.iter().zip(&plant.leaf_variants).enumerate() {
        // The alpha matte as an 8-bit grey PNG.
        let alpha = variant
            .maps
            .alpha
            .as_ref()
            .context("a procedural leaf has no alpha map")?;
        let (w, h) = (alpha.width(), alpha.height());
        let grey: Vec<u8> = alpha
            .texels()
            .iter()
            .map(|t| (t.x.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        let img = image::GrayImage::from_raw(w, h, grey).context("alpha size")?;
        lamina_io::save_image(&out.join(format!("leaf_alpha_{i}.png")), &img)?;
        let mut csv = String::from("cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height\n");
        for c in cards {
            let v = [c.center.to_array(), c.normal.to_array(), c.up.to_array()].concat();
            let nums: Vec<String> = v
                .iter()
                .chain(&[c.width, c.height])
                .map(|x| format!("{x:.6}"))
                .collect();
            writeln!(csv, "{}", nums.join(","))?;
        }
        lamina_io::write_bytes(&out.join(format!("bush_cards_{i}.csv")), csv.as_bytes())?;
        write!(
            leaf_tables,
            r#"
[[material]]
name = "leaf_{i}"
type = "diffuse_transmission"
reflectance = [0.06, 0.12, 0.03]
transmittance = [0.05, 0.16, 0.02]
alpha = "leaf_alpha_{i}.png"

[[object]]
type = "leaf_cards"
material = "leaf_{i}"
file = "bush_cards_{i}.csv"
"#
        )?;
    }
    let mut obj = String::from("# lamina demo bush: branches (m)\n");
    for p in &wood.positions {
        writeln!(obj, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for n in &wood.normals {
        writeln!(obj, "vn {} {} {}", n.x, n.y, n.z)?;
    }
    for t in &wood.indices {
        let [a, b, c] = t.map(|i| i + 1);
        writeln!(obj, "f {a}//{a} {b}//{b} {c}//{c}")?;
    }
    lamina_io::write_bytes(&out.join("bush_wood.obj"), obj.as_bytes())?;
    let cam = &scene.camera;
    let (sun_dir, sun_e) = match &scene.lights[0] {
        lamina_scene::Light::Sun {
            direction,
            irradiance,
            ..
        } => (*direction, *irradiance),
        _ => unreachable!("the bush scene is lit by a sun"),
    };
    let sky = match &scene.sky {
        Some(lamina_scene::Sky::Constant(c)) => *c,
        _ => Vec3::ZERO,
    };
    let a = |v: Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
    let toml = format!(
        r#"{BUSH_MARKER}
# Leaves are diffuse_transmission cards with each leaf variant's alpha matte.

[camera]
position = {pos}
look_at = {look}
fov = {fov}

[film]
width = {size}
height = {size}
spp = {spp}
filter = "box"

[integrator]
type = "path"
max_depth = 8
rr_depth = 3

[sky]
type = "constant"
radiance = {sky}

[[light]]
type = "sun"
direction = {sun_dir}
irradiance = {sun_e}
angular_diameter = 0.0

[[material]]
name = "bark"
type = "diffuse"
reflectance = [0.09, 0.06, 0.04]

[[material]]
name = "soil"
type = "diffuse"
reflectance = [0.12, 0.09, 0.06]

[[object]]
type = "obj"
material = "bark"
file = "bush_wood.obj"

[[object]]
type = "quad"
material = "soil"
corner = [-6.0, 0.0, 6.0]
edge_u = [12.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -12.0]
{leaf_tables}"#,
        pos = a(cam.position),
        look = a(cam.look_at),
        fov = cam.fov_deg,
        sky = a(sky),
        sun_dir = a(sun_dir),
        sun_e = a(sun_e),
    );
    lamina_io::write_bytes(&out.join("bush.toml"), toml.as_bytes())?;
    staged.commit(&spec)?;
    eprintln!(
        "wrote {} ({} leaf cards, {} branch triangles)",
        dir.join("bush.toml").display(),
        plant.leaf_count(),
        wood.indices.len()
    );
    Ok(())
}
