//! Built-in species presets: outline, venation, colours and physical parameters of the
//! procedural leaves. They live in code, so the demo and procedural plants need no files.
//!
//! Colours are given as sRGB-encoded 8-bit triples (as a photographer would pick them from a
//! specular-free photo) and converted to linear on use. The front, back and translucency
//! colours are diffuse *reflectance* and *transmittance* (albedos), so they stay in the range
//! real leaves show: 5-15 % reflectance and 5-20 % transmittance in the green, far less in
//! red and blue (`LEAF_MODEL.md`, "Leaves in numbers").

use glam::Vec3;
use lamina_leaf::{LeafMode, LeafParams};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A built-in leaf species preset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Species {
    /// European beech (*Fagus sylvatica*): elliptic-ovate, wavy margin with small teeth at
    /// the vein ends, 7-9 pairs of straight parallel secondaries; glossy, about 8 cm.
    Beech,
    /// Norway maple (*Acer platanoides*): palmate with five pointed, sparsely toothed lobes
    /// and five primary veins from the petiole; about 14 cm.
    Maple,
    /// English oak (*Quercus robur*): obovate, pinnately lobed with 4-6 rounded lobes per
    /// side, one secondary vein to each lobe; about 10 cm.
    Oak,
    /// Silver birch (*Betula pendula*): deltoid (triangular-ovate) with a truncate base, an
    /// acuminate tip and a doubly serrate margin; about 5 cm.
    Birch,
    /// Common ivy (*Hedera helix*): cordate, 3-5 shallow lobes, palmate venation, dark glossy
    /// with pale veins; about 7 cm.
    Ivy,
    /// A grass blade (e.g. *Lolium*): linear, parallel veins, 5 mm wide, about 20 cm long.
    Grass,
    /// White willow (*Salix alba*): narrowly lanceolate, finely serrate, silvery underside;
    /// about 9 cm.
    Willow,
}

impl Species {
    /// Every preset, in a stable order.
    pub const ALL: [Species; 7] = [
        Species::Beech,
        Species::Maple,
        Species::Oak,
        Species::Birch,
        Species::Ivy,
        Species::Grass,
        Species::Willow,
    ];

    /// The preset's name as used on the command line and in files (lower case).
    pub fn name(self) -> &'static str {
        match self {
            Species::Beech => "beech",
            Species::Maple => "maple",
            Species::Oak => "oak",
            Species::Birch => "birch",
            Species::Ivy => "ivy",
            Species::Grass => "grass",
            Species::Willow => "willow",
        }
    }

    /// The full preset: outline, venation, colours and parameters.
    pub fn preset(self) -> Preset {
        preset(self)
    }

    /// The preset's physical parameters of the leaf model (also used by `prepare --species`).
    pub fn params(self) -> LeafParams {
        self.preset().params
    }
}

impl fmt::Display for Species {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A species name that is not a preset.
#[derive(Debug, Clone, thiserror::Error)]
#[error("unknown leaf species '{0}' (known: beech, maple, oak, birch, ivy, grass, willow)")]
pub struct UnknownSpecies(pub String);

impl FromStr for Species {
    type Err = UnknownSpecies;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let l = s.trim().to_ascii_lowercase();
        Species::ALL
            .into_iter()
            .find(|sp| sp.name() == l || (l == "grass_blade" && *sp == Species::Grass))
            .ok_or_else(|| UnknownSpecies(s.to_owned()))
    }
}

/// Half-width profile of a lobe along its axis, `t` in `[0, 1]` from base to tip.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Profile {
    /// `t^a (1 - t)^b`, scaled to a maximum of 1 (at `t = a / (a + b)`): `a < 1` gives a
    /// rounded base, `a > 1` a wedge-shaped one; `b > 1` an acuminate (drawn-out) tip,
    /// `b < 1` a blunt one.
    Beta {
        /// Base exponent.
        a: f32,
        /// Tip exponent.
        b: f32,
    },
    /// Parallel margins with a short rounded base and a straight taper over the last
    /// `taper` of the length (grass blades).
    Linear {
        /// Fraction of the length over which the blade tapers to its tip.
        taper: f32,
    },
}

/// Teeth on the margin.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Teeth {
    /// Teeth per unit of lobe length (both sides each get this many).
    pub per_length: f32,
    /// Tooth height as a fraction of the lobe's maximum half-width.
    pub amplitude: f32,
    /// Doubly serrate: every tooth carries smaller teeth (birch).
    pub double: bool,
    /// Rounded (crenate, wavy) instead of saw-like (serrate) teeth.
    pub rounded: bool,
}

/// One lobe of the outline: a leaf-shaped region along an axis from the petiole junction.
/// A simple leaf has one lobe; a palmate one has one per primary vein.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lobe {
    /// Axis angle in degrees from the leaf's main axis (0 = toward the tip, positive to the
    /// left when the adaxial side faces the viewer).
    pub angle_deg: f32,
    /// Length relative to the main lobe (1 for the main lobe).
    pub length: f32,
    /// Maximum half-width relative to this lobe's length.
    pub half_width: f32,
    /// Half-width profile.
    pub profile: Profile,
    /// Relative width of this lobe's primary vein (1 for the midrib).
    pub vein_weight: f32,
}

/// Pinnate lobing of the main lobe (oak): the half-width is modulated so that `count`
/// rounded lobes per side are separated by sinuses of relative `depth`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sinuses {
    /// Lobes per side.
    pub count: f32,
    /// Depth of the sinuses as a fraction of the local half-width, in `[0, 1)`.
    pub depth: f32,
}

/// The leaf outline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outline {
    /// The lobes, the first being the main one (along the leaf axis).
    pub lobes: Vec<Lobe>,
    /// Margin teeth, if any.
    pub teeth: Option<Teeth>,
    /// Pinnate lobing of the main lobe, if any.
    pub sinuses: Option<Sinuses>,
    /// Blend radius of the union of the lobes, relative to the main lobe length (rounds the
    /// sinuses between palmate lobes).
    pub blend: f32,
    /// Length of the visible petiole stub relative to the main lobe length.
    pub petiole: f32,
}

/// How the veins are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VenationKind {
    /// Pinnate or palmate: a primary vein along each lobe axis with secondaries branching
    /// off it, and a reticulate net of higher-order veins.
    Reticulate,
    /// Parallel veins along the blade (grasses and other monocots), `count` of them.
    Parallel {
        /// Number of longitudinal veins across the blade.
        count: u32,
    },
}

/// Venation parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Venation {
    /// Layout.
    pub kind: VenationKind,
    /// Secondary veins per side of the main lobe's primary.
    pub secondaries: u32,
    /// Angle of the secondaries to their primary at the base, degrees.
    pub angle_base_deg: f32,
    /// Angle of the secondaries to their primary near the tip, degrees.
    pub angle_tip_deg: f32,
    /// How strongly secondaries bend toward the tip (1/leaf length).
    pub curvature: f32,
    /// Craspedodromous: secondaries run into the margin (teeth). Otherwise
    /// brochidodromous: they arch toward the tip before reaching it and loop.
    pub craspedodromous: bool,
    /// Side branches (tertiaries toward the margin) per secondary.
    pub branches: u32,
    /// Midrib width at the base in millimetres.
    pub midrib_mm: f32,
    /// Width of the reticulate areoles (tertiary mesh) in millimetres; 0 disables the net.
    pub areole_mm: f32,
}

/// Colours of a species as sRGB-encoded 8-bit triples (albedos, see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Palette {
    /// Adaxial (upper) mesophyll reflectance.
    pub front: [u8; 3],
    /// Adaxial colour of the major veins.
    pub front_vein: [u8; 3],
    /// Abaxial (lower) mesophyll reflectance.
    pub back: [u8; 3],
    /// Abaxial colour of the (raised, more visible) veins.
    pub back_vein: [u8; 3],
    /// Diffuse transmittance of the mesophyll (through-light colour).
    pub translucency: [u8; 3],
    /// How much the major veins show on the upper side, `[0, 1]`.
    pub vein_contrast: f32,
    /// Strength of the blotchy colour variation, `[0, 1]`.
    pub mottle: f32,
}

/// A complete species preset: everything [`crate::generate()`] needs besides the seed and
/// the resolution. Public and serde so that callers can make their own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Preset {
    /// Name (for messages and `leaf.toml` comments).
    pub name: String,
    /// Typical card height in metres (leaf blade plus the petiole stub); the card width
    /// follows from the outline.
    pub height_m: f32,
    /// The outline.
    pub outline: Outline,
    /// The veins.
    pub venation: Venation,
    /// The colours.
    pub palette: Palette,
    /// Relief of the major veins (their height on the abaxial side), millimetres.
    pub vein_relief_mm: f32,
    /// Physical parameters of the leaf model.
    pub params: LeafParams,
}

/// Linear RGB of an sRGB-encoded 8-bit triple.
pub fn srgb8_to_linear(c: [u8; 3]) -> Vec3 {
    Vec3::new(
        lamina_leaf::texture::srgb_to_linear(c[0] as f32 / 255.0),
        lamina_leaf::texture::srgb_to_linear(c[1] as f32 / 255.0),
        lamina_leaf::texture::srgb_to_linear(c[2] as f32 / 255.0),
    )
}

fn lobe(angle_deg: f32, length: f32, half_width: f32, a: f32, b: f32, vein: f32) -> Lobe {
    Lobe {
        angle_deg,
        length,
        half_width,
        profile: Profile::Beta { a, b },
        vein_weight: vein,
    }
}

/// Parameters: start from the default green leaf and set the per-species differences.
/// Mesophyll absorption is scaled with the pigment load (darker leaves absorb more),
/// roughness after the cuticle (glossy beech and ivy, matte hairy willow underside).
fn params(thickness_mm: f32, chlorophyll: f32, rough_ad: f32, rough_ab: f32) -> LeafParams {
    let mut p = LeafParams {
        mode: LeafMode::Layered,
        thickness_mm,
        roughness_adaxial: rough_ad,
        roughness_abaxial: rough_ab,
        ..LeafParams::default()
    };
    p.mesophyll.absorption *= chlorophyll;
    p
}

fn preset(s: Species) -> Preset {
    match s {
        Species::Beech => Preset {
            name: "beech".into(),
            height_m: 0.095,
            outline: Outline {
                lobes: vec![lobe(0.0, 1.0, 0.34, 0.75, 0.95, 1.0)],
                teeth: Some(Teeth {
                    per_length: 8.5,
                    amplitude: 0.035,
                    double: false,
                    rounded: true,
                }),
                sinuses: None,
                blend: 0.0,
                petiole: 0.1,
            },
            venation: Venation {
                kind: VenationKind::Reticulate,
                secondaries: 8,
                angle_base_deg: 50.0,
                angle_tip_deg: 38.0,
                curvature: 1.2,
                craspedodromous: true,
                branches: 0,
                midrib_mm: 0.9,
                areole_mm: 2.2,
            },
            palette: Palette {
                front: [62, 92, 30],
                front_vein: [96, 124, 52],
                back: [104, 132, 66],
                back_vein: [150, 170, 110],
                translucency: [118, 146, 34],
                vein_contrast: 0.7,
                mottle: 0.45,
            },
            vein_relief_mm: 0.35,
            params: params(0.2, 1.1, 0.08, 0.4),
        },
        Species::Maple => Preset {
            name: "maple".into(),
            height_m: 0.16,
            outline: Outline {
                lobes: vec![
                    lobe(0.0, 1.0, 0.24, 0.45, 1.15, 1.0),
                    lobe(52.0, 0.9, 0.25, 0.45, 1.15, 0.85),
                    lobe(-52.0, 0.9, 0.25, 0.45, 1.15, 0.85),
                    lobe(108.0, 0.5, 0.28, 0.5, 1.1, 0.6),
                    lobe(-108.0, 0.5, 0.28, 0.5, 1.1, 0.6),
                ],
                teeth: Some(Teeth {
                    per_length: 3.2,
                    amplitude: 0.32,
                    double: false,
                    rounded: false,
                }),
                sinuses: None,
                blend: 0.06,
                petiole: 0.25,
            },
            venation: Venation {
                kind: VenationKind::Reticulate,
                secondaries: 6,
                angle_base_deg: 55.0,
                angle_tip_deg: 40.0,
                curvature: 1.5,
                craspedodromous: true,
                branches: 1,
                midrib_mm: 1.2,
                areole_mm: 2.8,
            },
            palette: Palette {
                front: [68, 104, 32],
                front_vein: [128, 148, 66],
                back: [112, 140, 74],
                back_vein: [160, 176, 112],
                translucency: [130, 150, 30],
                vein_contrast: 0.8,
                mottle: 0.5,
            },
            vein_relief_mm: 0.45,
            params: params(0.18, 1.0, 0.2, 0.5),
        },
        Species::Oak => Preset {
            name: "oak".into(),
            height_m: 0.11,
            outline: Outline {
                lobes: vec![lobe(0.0, 1.0, 0.3, 1.25, 0.7, 1.0)],
                teeth: None,
                sinuses: Some(Sinuses {
                    count: 4.5,
                    depth: 0.6,
                }),
                blend: 0.0,
                petiole: 0.06,
            },
            venation: Venation {
                kind: VenationKind::Reticulate,
                secondaries: 5,
                angle_base_deg: 55.0,
                angle_tip_deg: 45.0,
                curvature: 1.0,
                craspedodromous: true,
                branches: 1,
                midrib_mm: 1.1,
                areole_mm: 2.4,
            },
            palette: Palette {
                front: [56, 84, 30],
                front_vein: [110, 126, 60],
                back: [110, 134, 84],
                back_vein: [156, 168, 116],
                translucency: [112, 136, 30],
                vein_contrast: 0.75,
                mottle: 0.5,
            },
            vein_relief_mm: 0.4,
            params: params(0.28, 1.2, 0.25, 0.55),
        },
        Species::Birch => Preset {
            name: "birch".into(),
            height_m: 0.065,
            outline: Outline {
                lobes: vec![lobe(0.0, 1.0, 0.38, 0.45, 1.3, 1.0)],
                teeth: Some(Teeth {
                    per_length: 11.0,
                    amplitude: 0.06,
                    double: true,
                    rounded: false,
                }),
                sinuses: None,
                blend: 0.0,
                petiole: 0.15,
            },
            venation: Venation {
                kind: VenationKind::Reticulate,
                secondaries: 9,
                angle_base_deg: 50.0,
                angle_tip_deg: 40.0,
                curvature: 0.4,
                craspedodromous: true,
                branches: 2,
                midrib_mm: 0.6,
                areole_mm: 1.8,
            },
            palette: Palette {
                front: [78, 118, 36],
                front_vein: [112, 142, 56],
                back: [126, 152, 80],
                back_vein: [160, 180, 112],
                translucency: [140, 160, 36],
                vein_contrast: 0.7,
                mottle: 0.3,
            },
            vein_relief_mm: 0.25,
            params: params(0.15, 0.9, 0.2, 0.5),
        },
        Species::Ivy => Preset {
            name: "ivy".into(),
            height_m: 0.085,
            outline: Outline {
                lobes: vec![
                    lobe(0.0, 1.0, 0.32, 0.45, 1.1, 1.0),
                    lobe(62.0, 0.72, 0.34, 0.45, 1.0, 0.8),
                    lobe(-62.0, 0.72, 0.34, 0.45, 1.0, 0.8),
                    lobe(128.0, 0.45, 0.42, 0.5, 0.9, 0.6),
                    lobe(-128.0, 0.45, 0.42, 0.5, 0.9, 0.6),
                ],
                teeth: None,
                sinuses: None,
                blend: 0.07,
                petiole: 0.2,
            },
            venation: Venation {
                kind: VenationKind::Reticulate,
                secondaries: 4,
                angle_base_deg: 60.0,
                angle_tip_deg: 45.0,
                curvature: 1.8,
                craspedodromous: false,
                branches: 1,
                midrib_mm: 0.9,
                areole_mm: 2.6,
            },
            palette: Palette {
                front: [38, 62, 26],
                front_vein: [150, 164, 118],
                back: [92, 116, 64],
                back_vein: [140, 156, 104],
                translucency: [84, 112, 22],
                vein_contrast: 0.75,
                mottle: 0.3,
            },
            vein_relief_mm: 0.3,
            params: params(0.4, 1.4, 0.06, 0.35),
        },
        Species::Grass => Preset {
            name: "grass".into(),
            height_m: 0.2,
            outline: Outline {
                lobes: vec![Lobe {
                    angle_deg: 0.0,
                    length: 1.0,
                    half_width: 0.014,
                    profile: Profile::Linear { taper: 0.3 },
                    vein_weight: 1.0,
                }],
                teeth: None,
                sinuses: None,
                blend: 0.0,
                petiole: 0.0,
            },
            venation: Venation {
                kind: VenationKind::Parallel { count: 9 },
                secondaries: 0,
                angle_base_deg: 0.0,
                angle_tip_deg: 0.0,
                curvature: 0.0,
                craspedodromous: false,
                branches: 0,
                midrib_mm: 0.4,
                areole_mm: 0.0,
            },
            palette: Palette {
                front: [72, 116, 34],
                front_vein: [92, 132, 46],
                back: [90, 130, 48],
                back_vein: [112, 146, 60],
                translucency: [136, 164, 36],
                vein_contrast: 0.35,
                mottle: 0.25,
            },
            vein_relief_mm: 0.1,
            params: params(0.15, 0.9, 0.25, 0.3),
        },
        Species::Willow => Preset {
            name: "willow".into(),
            height_m: 0.1,
            outline: Outline {
                lobes: vec![lobe(0.0, 1.0, 0.12, 0.9, 1.15, 1.0)],
                teeth: Some(Teeth {
                    per_length: 30.0,
                    amplitude: 0.05,
                    double: false,
                    rounded: false,
                }),
                sinuses: None,
                blend: 0.0,
                petiole: 0.08,
            },
            venation: Venation {
                kind: VenationKind::Reticulate,
                secondaries: 14,
                angle_base_deg: 45.0,
                angle_tip_deg: 35.0,
                curvature: 3.0,
                craspedodromous: false,
                branches: 0,
                midrib_mm: 0.7,
                areole_mm: 1.6,
            },
            palette: Palette {
                front: [74, 102, 50],
                front_vein: [130, 146, 92],
                back: [150, 164, 132],
                back_vein: [170, 180, 150],
                translucency: [120, 140, 40],
                vein_contrast: 0.55,
                mottle: 0.25,
            },
            vein_relief_mm: 0.2,
            params: params(0.2, 1.0, 0.3, 0.7),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_params_validate() {
        for s in Species::ALL {
            assert_eq!(s.name().parse::<Species>().unwrap(), s);
            assert_eq!(s.to_string(), s.name());
            s.params().validate().unwrap();
            let p = s.preset();
            assert!(p.height_m > 0.0 && !p.outline.lobes.is_empty());
        }
        assert!("Maple".parse::<Species>().is_ok());
        assert!(
            "fern"
                .parse::<Species>()
                .unwrap_err()
                .to_string()
                .contains("fern")
        );
    }
}
