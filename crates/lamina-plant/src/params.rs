//! Plant parameters: what a scene file (`type = "plant"`) or the command line gives.
//!
//! Units: lengths in metres, angles in degrees, fractions in `[0, 1]`. Fields marked
//! *kind-dependent* are optional; when absent they take the default of the plant's
//! [`PlantKind`] (see [`PlantParams::resolve`]).

use crate::PlantError;
use glam::Vec3;
use lamina_leafmaps::Species;
use serde::{Deserialize, Serialize};

/// Largest leaf count accepted (20 million cards is about 1 GB of leaf cards).
pub const MAX_LEAVES: u32 = 20_000_000;

/// Largest `leaf_variants × leaf_resolution²` accepted: 2^24 texels of generated leaf maps
/// per plant (16 variants at 1024 px, 4 at 2048, 1 at 4096). Each texel costs about 150
/// bytes while a leaf is generated (seven RGBA `f32` maps plus intermediates), so this keeps
/// a plant's leaf maps to about 2.5 GB at most.
pub const MAX_LEAF_MAP_TEXELS: u64 = 1 << 24;

/// Largest plant parameter file accepted (bytes): 1 MiB (a parameter file is a few lines).
pub const MAX_PARAM_FILE_BYTES: u64 = 1 << 20;

/// What kind of plant to grow.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlantKind {
    /// A shrub like the paper's Fig. 5: several stems from the ground, a dense rounded
    /// crown of about 0.5-1.5 m, leaves all over its outside.
    #[default]
    Bush,
    /// A broadleaf tree: one trunk, a crown above a clear bole, 4-20 m typical.
    Tree,
}

/// The envelope the crown grows into (the attraction points fill it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CrownShape {
    /// An ellipsoid between the crown base and the top (oak, lime, most shrubs).
    #[default]
    Ellipsoid,
    /// A cone, widest at the crown base (young broadleaf trees, poplar-like).
    Cone,
    /// The upper half of an ellipsoid: flat below, domed above (spreading, umbrella crowns).
    Dome,
}

/// Parameters of a procedural plant. Deserialises from TOML/JSON with unknown fields
/// rejected; every field has a default, so `{}` is a valid (bush) plant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlantParams {
    /// Bush or tree.
    pub kind: PlantKind,
    /// Seed of every random choice: the same parameters give the same plant.
    pub seed: u64,
    /// Total height (m), ground to the top of the crown. Kind-dependent: bush 1.0 (allowed
    /// 0.1-5), tree 10 (allowed 1-60).
    pub height_m: Option<f32>,
    /// Crown envelope shape.
    pub crown_shape: CrownShape,
    /// Horizontal radius of the crown envelope (m). Kind-dependent: bush 0.55 × height,
    /// tree 0.42 × height. Allowed: 0.05-1.5 × height.
    pub crown_radius_m: Option<f32>,
    /// Height of the crown's bottom as a fraction of the total height. Kind-dependent: bush
    /// 0.08, tree 0.22. Allowed 0-0.9.
    pub crown_base: Option<f32>,
    /// Stems from the ground. Kind-dependent: bush 7, tree 1. Allowed 1-32.
    pub stems: Option<u32>,
    /// Target number of leaves (the result is within a fraction of a percent of it; exact
    /// unless leaves had to be dropped). Kind-dependent: bush 4000, tree 100,000. Allowed
    /// 1-20,000,000.
    pub leaf_count: Option<u32>,
    /// Leaf species: a built-in preset of lamina-leafmaps (beech, maple, oak, birch, ivy,
    /// grass, willow).
    pub species: String,
    /// Leaf size as a multiple of the species' natural size (allowed 0.05-20).
    pub leaf_scale: f32,
    /// Random leaf size variation: sizes are scaled by `1 ± variation` (uniform). 0-0.9.
    pub leaf_size_variation: f32,
    /// Number of distinct generated leaves (same species, different seeds) the leaves are
    /// spread over, for colour and shape variation. 1-16.
    pub leaf_variants: u32,
    /// Resolution of each generated leaf's maps (pixels along the longer side), 16-4096,
    /// with `leaf_variants × leaf_resolution²` at most [`MAX_LEAF_MAP_TEXELS`].
    pub leaf_resolution: u32,
    /// How far each blade turns its adaxial (upper) side toward the light: 0 = natural
    /// orientation from the twig, 1 = facing the light. 0-1.
    pub phototropism: f32,
    /// Direction *toward* the light the blades turn to (need not be unit; not zero).
    pub light_direction: [f32; 3],
    /// Gravitropism of the leaves: how much blade tips droop under their weight, 0-1
    /// (1 ≈ 60° of droop); also lets the outer branches sag slightly.
    pub gravitropism: f32,
    /// Largest angle (degrees) between a lateral branch and its mother branch; laterals
    /// leave at 60-100 % of it. 5-90.
    pub branch_angle_deg: f32,
    /// Phyllotactic divergence angle (degrees) between successive leaves along a twig;
    /// 137.5 is the golden angle (spiral), 180 distichous. 0-360.
    pub phyllotaxis_deg: f32,
    /// Pipe-model exponent `a` in `r^a = Σ r_child^a` (da Vinci's rule is 2). 1.5-3.5.
    pub pipe_exponent: f32,
    /// Radius of the trunk (or the thickest stem of a bush) at the ground (m).
    /// Kind-dependent: bush 0.012 × height, tree 0.022 × height. Allowed (0, 0.2 × height].
    pub trunk_radius_m: Option<f32>,
    /// Smallest branch radius (m): the radius of the youngest twigs. Kind-dependent: bush
    /// 0.0012, tree 0.003. Allowed 0.0002-0.05.
    pub twig_radius_m: Option<f32>,
    /// Number of attraction points of the space colonisation (sets how finely the crown is
    /// branched). Default: from the leaf count (about one per 6 leaves, 400-150,000).
    /// Allowed 50-2,000,000.
    pub attraction_points: Option<u32>,
}

impl Default for PlantParams {
    fn default() -> Self {
        PlantParams {
            kind: PlantKind::Bush,
            seed: 1,
            height_m: None,
            crown_shape: CrownShape::Ellipsoid,
            crown_radius_m: None,
            crown_base: None,
            stems: None,
            leaf_count: None,
            species: "beech".into(),
            leaf_scale: 1.0,
            leaf_size_variation: 0.2,
            leaf_variants: 3,
            leaf_resolution: 256,
            phototropism: 0.5,
            light_direction: [0.0, 1.0, 0.0],
            gravitropism: 0.3,
            branch_angle_deg: 45.0,
            phyllotaxis_deg: 137.5,
            pipe_exponent: 2.3,
            trunk_radius_m: None,
            twig_radius_m: None,
            attraction_points: None,
        }
    }
}

/// Parameters with every kind-dependent default filled in and checked.
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    /// Bush or tree.
    pub kind: PlantKind,
    /// Seed.
    pub seed: u64,
    /// Total height (m).
    pub height: f32,
    /// Crown shape.
    pub crown_shape: CrownShape,
    /// Crown radius (m).
    pub crown_radius: f32,
    /// Crown bottom as a fraction of the height.
    pub crown_base: f32,
    /// Number of stems.
    pub stems: u32,
    /// Target leaf count.
    pub leaf_count: u32,
    /// Leaf species.
    pub species: Species,
    /// Leaf size multiplier.
    pub leaf_scale: f32,
    /// Leaf size variation.
    pub leaf_size_variation: f32,
    /// Number of leaf variants.
    pub leaf_variants: u32,
    /// Leaf map resolution (px).
    pub leaf_resolution: u32,
    /// Phototropism, 0-1.
    pub phototropism: f32,
    /// Unit direction toward the light.
    pub light_direction: Vec3,
    /// Gravitropism, 0-1.
    pub gravitropism: f32,
    /// Maximum branching angle (radians).
    pub branch_angle: f32,
    /// Phyllotactic divergence (radians).
    pub phyllotaxis: f32,
    /// Pipe-model exponent.
    pub pipe_exponent: f32,
    /// Trunk radius (m).
    pub trunk_radius: f32,
    /// Twig radius (m).
    pub twig_radius: f32,
    /// Attraction points.
    pub attraction_points: u32,
}

fn bad(field: &'static str, reason: String) -> PlantError {
    PlantError::Param { field, reason }
}

fn check(field: &'static str, v: f32, lo: f32, hi: f32, unit: &str) -> Result<f32, PlantError> {
    if v >= lo && v <= hi {
        Ok(v)
    } else {
        Err(bad(
            field,
            format!("must be in [{lo}, {hi}]{unit}, got {v}"),
        ))
    }
}

fn check_u(field: &'static str, v: u32, lo: u32, hi: u32) -> Result<u32, PlantError> {
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(bad(field, format!("must be in [{lo}, {hi}], got {v}")))
    }
}

impl PlantParams {
    /// A bush with the given seed and the defaults otherwise.
    pub fn bush(seed: u64) -> Self {
        PlantParams {
            seed,
            ..Default::default()
        }
    }

    /// A tree with the given seed and leaf count, the defaults otherwise.
    pub fn tree(seed: u64, leaf_count: u32) -> Self {
        PlantParams {
            kind: PlantKind::Tree,
            seed,
            leaf_count: Some(leaf_count),
            ..Default::default()
        }
    }

    /// Parses TOML text (unknown fields are errors) and validates it. A panic in the parser
    /// is an error.
    pub fn from_toml(text: &str) -> Result<Self, PlantError> {
        lamina_leaf::guard::catch_panic(|| {
            crate::fault_point("plant_params");
            let p: PlantParams =
                toml::from_str(text).map_err(|e| PlantError::Parse(e.to_string()))?;
            p.validate()?;
            Ok(p)
        })
        .unwrap_or_else(|m| {
            Err(PlantError::Parse(lamina_leaf::guard::panic_error_message(
                &m,
            )))
        })
    }

    /// Reads and validates a TOML parameter file (at most [`MAX_PARAM_FILE_BYTES`]). Errors
    /// name the file.
    pub fn load(path: &std::path::Path) -> Result<Self, PlantError> {
        let read = |source| PlantError::Read {
            path: path.to_owned(),
            source,
        };
        let meta = std::fs::metadata(path).map_err(read)?;
        if !meta.is_file() {
            return Err(read(std::io::Error::other("not a regular file")));
        }
        let len = meta.len();
        if len > MAX_PARAM_FILE_BYTES {
            return Err(read(std::io::Error::other(format!(
                "the file is {len} bytes, more than the {MAX_PARAM_FILE_BYTES} a parameter file may have"
            ))));
        }
        let text = std::fs::read_to_string(path).map_err(read)?;
        Self::from_toml(&text).map_err(|e| PlantError::File {
            path: path.to_owned(),
            source: Box::new(e),
        })
    }

    /// Checks every field; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<(), PlantError> {
        self.resolve().map(|_| ())
    }

    /// The parameters with kind-dependent defaults filled in, validated.
    pub fn resolve(&self) -> Result<Resolved, PlantError> {
        let tree = self.kind == PlantKind::Tree;
        let height = match (self.height_m, tree) {
            (Some(h), false) => check("height_m", h, 0.1, 5.0, " m for a bush")?,
            (Some(h), true) => check("height_m", h, 1.0, 60.0, " m for a tree")?,
            (None, false) => 1.0,
            (None, true) => 10.0,
        };
        let crown_radius = match self.crown_radius_m {
            Some(r) => check("crown_radius_m", r, 0.05 * height, 1.5 * height, " m")?,
            None => height * if tree { 0.42 } else { 0.55 },
        };
        let crown_base = match self.crown_base {
            Some(c) => check("crown_base", c, 0.0, 0.9, " (fraction of the height)")?,
            None => {
                if tree {
                    0.22
                } else {
                    0.08
                }
            }
        };
        let stems = check_u(
            "stems",
            self.stems.unwrap_or(if tree { 1 } else { 7 }),
            1,
            32,
        )?;
        let leaf_count = check_u(
            "leaf_count",
            self.leaf_count.unwrap_or(if tree { 100_000 } else { 4000 }),
            1,
            MAX_LEAVES,
        )?;
        let species: Species = self
            .species
            .parse()
            .map_err(|e: lamina_leafmaps::UnknownSpecies| bad("species", e.to_string()))?;
        let leaf_scale = check("leaf_scale", self.leaf_scale, 0.05, 20.0, "")?;
        let leaf_size_variation = check(
            "leaf_size_variation",
            self.leaf_size_variation,
            0.0,
            0.9,
            "",
        )?;
        let leaf_variants = check_u("leaf_variants", self.leaf_variants, 1, 16)?;
        let leaf_resolution = check_u("leaf_resolution", self.leaf_resolution, 16, 4096)?;
        let texels = leaf_variants as u64 * (leaf_resolution as u64).pow(2);
        if texels > MAX_LEAF_MAP_TEXELS {
            return Err(bad(
                "leaf_resolution",
                format!(
                    "leaf_variants x leaf_resolution² = {leaf_variants} x {leaf_resolution}² = {texels} texels of leaf maps, more than the {MAX_LEAF_MAP_TEXELS} supported (e.g. 16 variants at 1024, 4 at 2048, 1 at 4096)"
                ),
            ));
        }
        let phototropism = check("phototropism", self.phototropism, 0.0, 1.0, "")?;
        let l = Vec3::from(self.light_direction);
        let len2 = l.length_squared();
        if !(len2.is_finite() && len2 >= 1e-12) {
            return Err(bad(
                "light_direction",
                format!(
                    "must be a finite non-zero vector, got {:?}",
                    self.light_direction
                ),
            ));
        }
        let gravitropism = check("gravitropism", self.gravitropism, 0.0, 1.0, "")?;
        let branch_angle = check("branch_angle_deg", self.branch_angle_deg, 5.0, 90.0, "°")?;
        let phyllotaxis = check("phyllotaxis_deg", self.phyllotaxis_deg, 0.0, 360.0, "°")?;
        let pipe_exponent = check("pipe_exponent", self.pipe_exponent, 1.5, 3.5, "")?;
        let trunk_radius = match self.trunk_radius_m {
            Some(r) if r > 0.0 && r <= 0.2 * height => r,
            Some(r) => {
                return Err(bad(
                    "trunk_radius_m",
                    format!("must be in (0, {}] m (0.2 × height), got {r}", 0.2 * height),
                ));
            }
            None => height * if tree { 0.022 } else { 0.012 },
        };
        let twig_radius = check(
            "twig_radius_m",
            self.twig_radius_m
                .unwrap_or(if tree { 0.003 } else { 0.0012 }),
            0.0002,
            0.05,
            " m",
        )?;
        let twig_radius = twig_radius.min(trunk_radius);
        let attraction_points = match self.attraction_points {
            Some(n) => check_u("attraction_points", n, 50, 2_000_000)?,
            None => (leaf_count / 6).clamp(400, 150_000),
        };
        Ok(Resolved {
            kind: self.kind,
            seed: self.seed,
            height,
            crown_shape: self.crown_shape,
            crown_radius,
            crown_base,
            stems,
            leaf_count,
            species,
            leaf_scale,
            leaf_size_variation,
            leaf_variants,
            leaf_resolution,
            phototropism,
            light_direction: l.normalize(),
            gravitropism,
            branch_angle: branch_angle.to_radians(),
            phyllotaxis: phyllotaxis.to_radians(),
            pipe_exponent,
            trunk_radius,
            twig_radius,
            attraction_points,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_map_budget_and_file_errors() {
        // 16 variants of 4096 px maps would be ~40 GB while generating.
        let mut p = PlantParams::bush(1);
        p.leaf_variants = 16;
        p.leaf_resolution = 4096;
        let e = p.validate().unwrap_err().to_string();
        assert!(
            e.contains("leaf_resolution") && e.contains("16777216"),
            "{e}"
        );
        p.leaf_variants = 1;
        assert!(p.validate().is_ok());

        let dir = std::env::temp_dir().join(format!("lamina-plant-params-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("bush.toml");
        std::fs::write(&f, "leaf_count = 0\n").unwrap();
        let e = PlantParams::load(&f).unwrap_err().to_string();
        assert!(e.contains("bush.toml") && e.contains("leaf_count"), "{e}");
        std::fs::write(&f, "leaf_count = \"many\"\n").unwrap();
        let e = PlantParams::load(&f).unwrap_err().to_string();
        assert!(e.contains("bush.toml") && e.contains("leaf_count"), "{e}");
        let big = dir.join("big.toml");
        std::fs::File::create(&big)
            .unwrap()
            .set_len(MAX_PARAM_FILE_BYTES + 1)
            .unwrap();
        let e = PlantParams::load(&big).unwrap_err().to_string();
        assert!(e.contains("big.toml") && e.contains("1048576"), "{e}");
    }

    #[test]
    fn a_parser_panic_is_an_error_naming_the_file() {
        let dir = std::env::temp_dir().join(format!("lamina-plant-panic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("ok.toml");
        std::fs::write(&f, "seed = 3\n").unwrap();
        assert!(PlantParams::load(&f).is_ok());
        let e = lamina_leaf::guard::with_fault("plant_params", || PlantParams::load(&f));
        let e = e.unwrap_err().to_string();
        assert!(e.contains("ok.toml") && e.contains("injected fault"), "{e}");
    }
}
