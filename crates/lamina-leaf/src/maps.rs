//! The seven leaf maps (Franzke & Deussen, Fig. 3): where they come from on disk, how they
//! load, and their defaults when absent.
//!
//! | map | encoding | meaning | default when absent |
//! |---|---|---|---|
//! | `front` | sRGB colour | adaxial (upper) diffuse reflectance under the reference (diffuse, specular-free) lighting | the layer model's own adaxial albedo |
//! | `back` | sRGB colour | abaxial (lower) diffuse reflectance | derived from `front`: 30 % desaturated and 20 % brighter (the lower side is paler); without `front`, the layer model's abaxial albedo |
//! | `translucency` | sRGB colour | diffuse transmittance (through-light scan) | derived from `front` times the model's transmittance/reflectance ratio (yellow-green); without `front`, the model's transmittance |
//! | `alpha` | linear | cut-out, two states: opaque where `>= 0.5` | opaque everywhere |
//! | `thickness` | linear grey `[0, 1]` | scales the blade thickness (see [`crate::LeafParams::thickness_variation`]) | 0.5 (the nominal thickness) |
//! | `extinction` | linear grey `[0, 1]` | scales absorption (see [`crate::LeafParams::extinction_strength`]) | 0.5 (the nominal absorption) |
//! | `bump` | linear grey | height field perturbing the shading normal | flat |
//!
//! Maps may have different resolutions; all share the texture coordinates and the
//! [`Wrap`] mode of the description.

use crate::error::LeafError;
use crate::params::LeafParams;
use crate::texture::{Encoding, Texture, Wrap};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// File names of the seven maps, relative to the directory of the file that names them.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LeafMapPaths {
    /// Adaxial (upper side) colour photograph, sRGB.
    pub front: Option<PathBuf>,
    /// Abaxial (lower side) colour photograph, sRGB.
    pub back: Option<PathBuf>,
    /// Through-light (translucency) scan, sRGB.
    pub translucency: Option<PathBuf>,
    /// Alpha matte (grey, or the alpha channel when the image has one), linear.
    pub alpha: Option<PathBuf>,
    /// Thickness map, linear grey.
    pub thickness: Option<PathBuf>,
    /// Extinction map, linear grey.
    pub extinction: Option<PathBuf>,
    /// Bump (height) map, linear grey.
    pub bump: Option<PathBuf>,
    /// Addressing of texture coordinates outside `[0, 1]`, for all maps.
    pub wrap: Wrap,
}

/// What a `leaf.toml` file holds, and what a scene's leaf material table holds:
/// `[maps]` with the file names and `[params]` with the physical parameters.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LeafDescription {
    /// The program that wrote this file, e.g. `"lamina 0.1.0 (leaf generate)"`; `None` for
    /// a hand-written file. A leaf folder whose `leaf.toml` names lamina here (and that
    /// holds only lamina's files) is one lamina may replace; see `lamina_io::folder`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub generator: Option<String>,
    /// The map files.
    pub maps: LeafMapPaths,
    /// The physical parameters.
    pub params: LeafParams,
    /// PROSPECT pigments: when given, the leaf's colours come from them
    /// ([`crate::PigmentLeaf`]) and colour maps are refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pigments: Option<crate::Pigments>,
}

/// Largest `leaf.toml` accepted (bytes): 1 MiB; a description is a few hundred bytes.
pub const MAX_DESCRIPTION_BYTES: u64 = 1 << 20;

impl LeafDescription {
    /// Reads and parses a `leaf.toml` (unknown keys are errors; at most
    /// [`MAX_DESCRIPTION_BYTES`]). Does not load the maps: pass the result and the file's
    /// directory to [`crate::LeafMaterial::load`]. A panic in the parser is an error naming
    /// the file.
    pub fn from_toml_file(path: &Path) -> Result<Self, LeafError> {
        let io = |source: std::io::Error| LeafError::Io {
            path: path.to_owned(),
            source: Box::new(source),
        };
        let meta = std::fs::metadata(path).map_err(io)?;
        if !meta.is_file() {
            return Err(io(std::io::Error::other("not a regular file")));
        }
        let len = meta.len();
        if len > MAX_DESCRIPTION_BYTES {
            return Err(io(std::io::Error::other(format!(
                "the file is {len} bytes, more than the {MAX_DESCRIPTION_BYTES} a leaf description may have"
            ))));
        }
        let text = std::fs::read_to_string(path).map_err(io)?;
        Self::from_toml_str(&text, path)
    }

    /// Parses the text of a `leaf.toml`; `path` names it in errors. Checks the parameters'
    /// types, not their ranges (see [`crate::LeafParams::validate`]). A panic in the parser
    /// is an error naming the file.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self, LeafError> {
        crate::guard::catch_panic(|| {
            crate::guard::fault_point("leaf_toml");
            toml::from_str(text).map_err(|source| LeafError::Parse {
                path: path.to_owned(),
                source: Box::new(source),
            })
        })
        .unwrap_or_else(|message| {
            Err(LeafError::Panicked {
                path: path.to_owned(),
                message: crate::guard::panic_error_message(&message),
            })
        })
    }
}

/// The seven maps in memory (linear values). `None` takes the default of the module docs.
#[derive(Clone, Debug, Default)]
pub struct LeafMaps {
    /// Adaxial diffuse reflectance, linear RGB (decoded from sRGB).
    pub front: Option<Texture>,
    /// Abaxial diffuse reflectance, linear RGB.
    pub back: Option<Texture>,
    /// Diffuse transmittance, linear RGB.
    pub translucency: Option<Texture>,
    /// Alpha matte.
    pub alpha: Option<Texture>,
    /// Thickness map, `[0, 1]`.
    pub thickness: Option<Texture>,
    /// Extinction map, `[0, 1]`.
    pub extinction: Option<Texture>,
    /// Bump height map.
    pub bump: Option<Texture>,
}

impl LeafMaps {
    /// Loads the maps named in `paths`, relative to `base_dir`. The error names the map and
    /// the file.
    pub fn load(paths: &LeafMapPaths, base_dir: &Path) -> Result<Self, LeafError> {
        let one = |map: &'static str,
                   p: &Option<PathBuf>,
                   enc: Encoding|
         -> Result<Option<Texture>, LeafError> {
            let Some(p) = p else { return Ok(None) };
            let path = base_dir.join(p);
            let mut t = Texture::load(&path, enc).map_err(|source| LeafError::Map {
                map,
                path: path.clone(),
                source: Box::new(source),
            })?;
            t.wrap = paths.wrap;
            Ok(Some(t))
        };
        Ok(LeafMaps {
            front: one("front", &paths.front, Encoding::Srgb)?,
            back: one("back", &paths.back, Encoding::Srgb)?,
            translucency: one("translucency", &paths.translucency, Encoding::Srgb)?,
            alpha: one("alpha", &paths.alpha, Encoding::Linear)?,
            thickness: one("thickness", &paths.thickness, Encoding::Linear)?,
            extinction: one("extinction", &paths.extinction, Encoding::Linear)?,
            bump: one("bump", &paths.bump, Encoding::Linear)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_toml_errors_name_the_file() {
        let dir = std::env::temp_dir().join(format!("lamina-leaf-desc-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("leaf.toml");
        std::fs::write(&p, "[params]\nthickness_mm = 0.3\n").unwrap();
        assert!(LeafDescription::from_toml_file(&p).is_ok());
        // A panic while parsing (injected) is an error naming the file.
        let e = crate::guard::with_fault("leaf_toml", || LeafDescription::from_toml_file(&p));
        let e = e.unwrap_err().to_string();
        assert!(
            e.contains("leaf.toml") && e.contains("injected fault"),
            "{e}"
        );
        // A file far larger than any description is not read.
        let big = dir.join("big.toml");
        let f = std::fs::File::create(&big).unwrap();
        f.set_len(MAX_DESCRIPTION_BYTES + 1).unwrap();
        let e = LeafDescription::from_toml_file(&big)
            .unwrap_err()
            .to_string();
        assert!(e.contains("big.toml") && e.contains("1048576"), "{e}");
        // A huge map is rejected before it is decoded, naming the map and the file.
        let png = dir.join("huge.png");
        std::fs::write(&png, crate::testing::png_header_only(16384, 16384)).unwrap();
        let d: LeafDescription = toml::from_str("[maps]\nfront = \"huge.png\"\n").unwrap();
        let e = crate::LeafMaterial::load(&d, &dir).unwrap_err().to_string();
        assert!(
            e.contains("front") && e.contains("huge.png") && e.contains("too large"),
            "{e}"
        );
    }

    #[test]
    fn a_panic_while_loading_the_maps_is_an_error() {
        let d = LeafDescription::default();
        assert!(crate::LeafMaterial::load(&d, Path::new("leafdir")).is_ok());
        let e = crate::guard::with_fault("leaf_material", || {
            crate::LeafMaterial::load(&d, Path::new("leafdir"))
        });
        let e = e.unwrap_err().to_string();
        assert!(e.contains("leafdir") && e.contains("injected fault"), "{e}");
    }
}
