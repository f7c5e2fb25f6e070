//! `lamina plant generate`: grow a procedural plant (bush or tree) and export it as binary
//! glTF 2.0. The work is done by `lamina-plant`.

use anyhow::Context;
use lamina_plant::{CrownShape, PlantKind, PlantParams, generate_plant, write_glb};
use std::path::PathBuf;

/// Options of `lamina plant generate`. Options given on the command line override the
/// parameter file; everything else takes the defaults of the plant's kind.
#[derive(clap::Args, Debug)]
pub struct PlantGenerateArgs {
    /// Plant parameters as TOML (the fields of a scene file's `type = "plant"` object,
    /// unknown fields rejected).
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Kind of plant: bush or tree.
    #[arg(long, value_parser = parse_kind)]
    pub kind: Option<PlantKind>,
    /// Random seed (the same parameters and seed give the same plant).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Total height in metres (bush 0.1-5, default 1; tree 1-60, default 10).
    #[arg(long)]
    pub height: Option<f32>,
    /// Horizontal crown radius in metres.
    #[arg(long)]
    pub crown_radius: Option<f32>,
    /// Crown envelope: ellipsoid, cone or dome.
    #[arg(long, value_parser = parse_shape)]
    pub crown_shape: Option<CrownShape>,
    /// Target number of leaves (1 to 20,000,000).
    #[arg(short = 'n', long)]
    pub leaves: Option<u32>,
    /// Leaf species: beech, maple, oak, birch, ivy, grass, willow.
    #[arg(short, long)]
    pub species: Option<String>,
    /// Number of leaf variants (different generated leaves of the species), 1-16.
    #[arg(long)]
    pub variants: Option<u32>,
    /// Resolution of each leaf's maps (pixels along the longer side).
    #[arg(long)]
    pub leaf_resolution: Option<u32>,
    /// Leaf size multiplier (1 = the species' natural size).
    #[arg(long)]
    pub leaf_scale: Option<f32>,
    /// How far blades turn toward the light, 0-1.
    #[arg(long)]
    pub phototropism: Option<f32>,
    /// How far leaf tips droop, 0-1.
    #[arg(long)]
    pub gravitropism: Option<f32>,
    /// Output file (.glb), written atomically. An existing file is replaced only if lamina
    /// wrote it; see --force.
    #[arg(short, long)]
    pub out: PathBuf,
    /// Replace an output file lamina did not write.
    #[arg(long)]
    pub force: bool,
}

fn parse_kind(s: &str) -> Result<PlantKind, String> {
    match s.trim().to_ascii_lowercase().as_str() {
        "bush" => Ok(PlantKind::Bush),
        "tree" => Ok(PlantKind::Tree),
        _ => Err(format!("unknown plant kind '{s}' (bush or tree)")),
    }
}

fn parse_shape(s: &str) -> Result<CrownShape, String> {
    match s.trim().to_ascii_lowercase().as_str() {
        "ellipsoid" => Ok(CrownShape::Ellipsoid),
        "cone" => Ok(CrownShape::Cone),
        "dome" => Ok(CrownShape::Dome),
        _ => Err(format!(
            "unknown crown shape '{s}' (ellipsoid, cone or dome)"
        )),
    }
}

/// The parameters from the file (if any) with the command-line overrides applied.
pub fn params_from_args(args: &PlantGenerateArgs) -> anyhow::Result<PlantParams> {
    let mut p = match &args.params {
        Some(path) => PlantParams::load(path)
            .with_context(|| format!("plant parameters '{}'", path.display()))?,
        None => PlantParams::default(),
    };
    if let Some(k) = args.kind {
        p.kind = k;
    }
    if let Some(s) = args.seed {
        p.seed = s;
    }
    if args.height.is_some() {
        p.height_m = args.height;
    }
    if args.crown_radius.is_some() {
        p.crown_radius_m = args.crown_radius;
    }
    if let Some(s) = args.crown_shape {
        p.crown_shape = s;
    }
    if args.leaves.is_some() {
        p.leaf_count = args.leaves;
    }
    if let Some(s) = &args.species {
        p.species = s.clone();
    }
    if let Some(v) = args.variants {
        p.leaf_variants = v;
    }
    if let Some(v) = args.leaf_resolution {
        p.leaf_resolution = v;
    }
    if let Some(v) = args.leaf_scale {
        p.leaf_scale = v;
    }
    if let Some(v) = args.phototropism {
        p.phototropism = v;
    }
    if let Some(v) = args.gravitropism {
        p.gravitropism = v;
    }
    p.validate()?;
    Ok(p)
}

/// Runs `lamina plant generate`: grows the plant, prints its statistics to stderr and
/// writes the GLB.
pub fn run_generate(args: PlantGenerateArgs) -> anyhow::Result<()> {
    let params = params_from_args(&args)?;
    // Refuse before the work (and again just before writing, below).
    crate::output_file::claim(&args.out, args.force, &[])?;
    let plant = generate_plant(&params)?;
    let s = &plant.stats;
    eprintln!(
        "{:?}: {} leaves in {} variants, {} skeleton nodes, {} branch triangles, \
         trunk radius {:.3} m, {:.2} x {:.2} x {:.2} m, generated in {:.2} s",
        plant.params.kind,
        s.leaves,
        plant.leaves.len(),
        s.nodes,
        s.branch_triangles,
        s.trunk_radius_m,
        s.bounds[1].x - s.bounds[0].x,
        s.bounds[1].y - s.bounds[0].y,
        s.bounds[1].z - s.bounds[0].z,
        s.total_s
    );
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create '{}'", dir.display()))?;
    }
    crate::output_file::claim(&args.out, args.force, &[])?;
    write_glb(&plant, &args.out)?;
    eprintln!("wrote {}", args.out.display());
    Ok(())
}
