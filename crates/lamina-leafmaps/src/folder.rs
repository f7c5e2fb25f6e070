//! The seven maps as planes, the derivations shared by `generate` and `prepare`
//! (extinction and thickness from the through-light colour), and the atomic writing of a
//! leaf folder.

use crate::LeafMapsError;
use crate::plane::{Gray, Plane, Rgb, gaussian_blur};
use glam::Vec4;
use lamina_io::{FolderSpec, Replace};
use lamina_leaf::texture::linear_to_srgb;
use lamina_leaf::{LeafDescription, LeafMapPaths, LeafMaps, LeafParams, Texture, Wrap};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// The seven maps of one leaf, all of the same size, row 0 at the top of the card.
#[derive(Clone, Debug)]
pub struct MapPlanes {
    /// Adaxial (upper side) diffuse reflectance, **linear** RGB in `[0, 1]`.
    pub front: Rgb,
    /// Abaxial (lower side) diffuse reflectance, linear RGB, same texel layout as `front`
    /// (not mirrored).
    pub back: Rgb,
    /// Diffuse transmittance (through-light colour), linear RGB.
    pub translucency: Rgb,
    /// Coverage in `[0, 1]`; the leaf model treats `>= 0.5` as opaque.
    pub alpha: Gray,
    /// Thickness map in `[0, 1]`, 0.5 = the nominal blade thickness
    /// ([`LeafParams::thickness_mm`]).
    pub thickness: Gray,
    /// Extinction map in `[0, 1]`, `1 - Y'(translucency)` (0.5 = nominal absorption).
    pub extinction: Gray,
    /// Bump height along the adaxial normal in `[0, 1]`, 0.5 = flat; one unit of map value
    /// is [`LeafParams::bump_scale`] texture-space units.
    pub bump: Gray,
}

/// File names of the maps inside a leaf folder.
pub const MAP_FILES: [&str; 7] = [
    "front.png",
    "back.png",
    "translucency.png",
    "alpha.png",
    "thickness.png",
    "extinction.png",
    "bump.png",
];

impl MapPlanes {
    /// Width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        (self.front.width, self.front.height)
    }

    /// The maps as [`Texture`]s for [`lamina_leaf::LeafMaterial::new`] (clamped addressing:
    /// a leaf card does not tile).
    pub fn to_leaf_maps(&self) -> LeafMaps {
        let rgb = |p: &Rgb| {
            let t = p
                .data
                .par_iter()
                .map(|c| Vec4::new(c[0], c[1], c[2], 1.0))
                .collect();
            Texture::from_texels(p.width as u32, p.height as u32, t, Wrap::Clamp)
        };
        let grey = |p: &Gray| {
            let t = p
                .data
                .par_iter()
                .map(|&v| Vec4::new(v, v, v, 1.0))
                .collect();
            Texture::from_texels(p.width as u32, p.height as u32, t, Wrap::Clamp)
        };
        LeafMaps {
            front: Some(rgb(&self.front)),
            back: Some(rgb(&self.back)),
            translucency: Some(rgb(&self.translucency)),
            alpha: Some(grey(&self.alpha)),
            thickness: Some(grey(&self.thickness)),
            extinction: Some(grey(&self.extinction)),
            bump: Some(grey(&self.bump)),
        }
    }
}

/// Fast [`linear_to_srgb`] for values clamped to `[0, 1]`: a 16384-entry table with linear
/// interpolation, below 1e-4 of the exact curve above linear 0.002 (exact below, where the
/// curve is linear).
#[inline]
pub fn encode_srgb(v: f32) -> f32 {
    use std::sync::LazyLock;
    const N: usize = 16384;
    static LUT: LazyLock<Vec<f32>> = LazyLock::new(|| {
        (0..=N)
            .map(|i| linear_to_srgb(i as f32 / N as f32))
            .collect()
    });
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        return v * 12.92;
    }
    let x = v * N as f32;
    let i = (x as usize).min(N - 1);
    let f = x - i as f32;
    LUT[i] + (LUT[i + 1] - LUT[i]) * f
}

/// Fast sRGB decoding of a stored value in `[0, 1]` that came from an 8- or 16-bit image
/// (a table over the 65536 16-bit codes).
#[inline]
pub fn decode_srgb(v: f32) -> f32 {
    use std::sync::LazyLock;
    static LUT: LazyLock<Vec<f32>> = LazyLock::new(|| {
        (0..=65535u32)
            .map(|i| lamina_leaf::texture::srgb_to_linear(i as f32 / 65535.0))
            .collect()
    });
    LUT[(v.clamp(0.0, 1.0) * 65535.0 + 0.5) as usize]
}

/// Rec. 709 luma of sRGB-*encoded* values: the grey a scanner's grey-scale mode gives.
#[inline]
pub fn luma_encoded(lin: [f32; 3]) -> f32 {
    0.2126 * encode_srgb(lin[0]) + 0.7152 * encode_srgb(lin[1]) + 0.0722 * encode_srgb(lin[2])
}

/// Extinction from the through-light colour (the paper: "a grey-scale version of the image
/// is directly used as an extinction map"; `LEAF_MODEL.md`: darker = more extinction):
/// `e = 1 - Y'` with `Y'` the Rec. 709 luma of the sRGB-encoded scan, i.e. the grey value
/// a scanner's grey-scale mode stores. A mid-grey scan gives the nominal 0.5.
pub fn extinction_from_translucency(translucency: &Rgb) -> Gray {
    translucency.map(|c| (1.0 - luma_encoded(c)).clamp(0.0, 1.0))
}

/// Thickness from extinction (the paper: "the thickness map is a blurred version of this
/// image"): a Gaussian blur of standard deviation `sigma_px`, normalised by the blurred
/// alpha (so the background outside the leaf does not bleed into its rim), then re-centred
/// so that the *median* inside the leaf is 0.5, the nominal blade thickness, with the
/// deviations scaled by `gain` (veins, which absorb more, come out thicker) and clamped to
/// `[0, 1]`. Outside the leaf the value is 0.5.
pub fn thickness_from_extinction(
    extinction: &Gray,
    alpha: &Gray,
    sigma_px: f32,
    gain: f32,
) -> Gray {
    let ea = Plane {
        width: extinction.width,
        height: extinction.height,
        data: extinction
            .data
            .par_iter()
            .zip(alpha.data.par_iter())
            .map(|(e, a)| e * a)
            .collect(),
    };
    let be = gaussian_blur(&ea, sigma_px);
    let ba = gaussian_blur(alpha, sigma_px);
    let raw: Vec<f32> = be
        .data
        .par_iter()
        .zip(ba.data.par_iter())
        .map(|(e, a)| if *a > 1e-3 { e / a } else { f32::NAN })
        .collect();
    // Median inside the leaf from a 1024-bin histogram (values lie in [0, 1]).
    let mut hist = vec![0u64; 1024];
    let mut n = 0u64;
    for (v, a) in raw.iter().zip(&alpha.data) {
        if *a >= 0.5 && v.is_finite() {
            hist[(v.clamp(0.0, 1.0) * 1023.0) as usize] += 1;
            n += 1;
        }
    }
    let mut median = 0.5;
    let mut acc = 0;
    for (i, c) in hist.iter().enumerate() {
        acc += c;
        if n > 0 && acc * 2 >= n {
            median = i as f32 / 1023.0;
            break;
        }
    }
    Plane {
        width: extinction.width,
        height: extinction.height,
        data: raw
            .par_iter()
            .zip(alpha.data.par_iter())
            .map(|(v, a)| {
                if *a > 0.0 && v.is_finite() {
                    (0.5 + gain * (v - median)).clamp(0.0, 1.0)
                } else {
                    0.5
                }
            })
            .collect(),
    }
}

fn encode_err(path: &Path, source: image::ImageError) -> LeafMapsError {
    LeafMapsError::Encode {
        path: path.to_owned(),
        cause: source,
    }
}

/// Writes raw image bytes as PNG with fast compression (the maps are large; zlib's fast
/// level costs a few percent of size and saves most of the time).
fn save_png(
    path: &Path,
    bytes: &[u8],
    w: usize,
    h: usize,
    color: image::ExtendedColorType,
) -> Result<(), LeafMapsError> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let file = std::fs::File::create(path).map_err(|cause| LeafMapsError::Write {
        path: path.to_owned(),
        cause,
    })?;
    let enc = PngEncoder::new_with_quality(
        std::io::BufWriter::new(file),
        CompressionType::Fast,
        FilterType::Adaptive,
    );
    enc.write_image(bytes, w as u32, h as u32, color)
        .map_err(|e| encode_err(path, e))
}

/// Writes linear RGB as an 8-bit sRGB PNG.
pub fn write_srgb_png(path: &Path, p: &Rgb) -> Result<(), LeafMapsError> {
    let mut buf = vec![0u8; p.width * p.height * 3];
    buf.par_chunks_mut(3)
        .zip(p.data.par_iter())
        .for_each(|(o, c)| {
            for k in 0..3 {
                o[k] = (encode_srgb(c[k]) * 255.0 + 0.5) as u8;
            }
        });
    save_png(
        path,
        &buf,
        p.width,
        p.height,
        image::ExtendedColorType::Rgb8,
    )
}

/// Writes a grey plane with values in `[0, 1]` as a 16-bit linear PNG.
pub fn write_gray16_png(path: &Path, p: &Gray) -> Result<(), LeafMapsError> {
    let buf: Vec<u16> = p
        .data
        .par_iter()
        .map(|v| (v.clamp(0.0, 1.0) * 65535.0 + 0.5) as u16)
        .collect();
    let bytes: Vec<u8> = buf.iter().flat_map(|v| v.to_ne_bytes()).collect();
    save_png(
        path,
        &bytes,
        p.width,
        p.height,
        image::ExtendedColorType::L16,
    )
}

fn write_err(path: &Path) -> impl FnOnce(std::io::Error) -> LeafMapsError + '_ {
    move |source| LeafMapsError::Write {
        path: path.to_owned(),
        cause: source,
    }
}

/// How [`write_leaf_folder`] treats an existing folder, and what it records.
#[derive(Clone, Debug)]
pub struct FolderWrite {
    /// [`Replace::IfOurs`] (default): replace only a leaf folder lamina wrote that holds
    /// nothing else; [`Replace::Force`]: also write into another folder, replacing only the
    /// seven maps and `leaf.toml` and keeping every other file.
    pub replace: Replace,
    /// The command's input files, which the folder must never overwrite.
    pub inputs: Vec<PathBuf>,
    /// What `leaf.toml`'s `generator` key says (the marker of a lamina-written folder).
    pub generator: String,
}

impl Default for FolderWrite {
    fn default() -> Self {
        FolderWrite {
            replace: Replace::IfOurs,
            inputs: Vec::new(),
            generator: GENERATOR.to_owned(),
        }
    }
}

/// The `generator` of the leaf folders this version writes.
pub const GENERATOR: &str = concat!("lamina ", env!("CARGO_PKG_VERSION"));

fn owns_leaf_file(name: &str) -> bool {
    name == "leaf.toml" || MAP_FILES.contains(&name)
}

/// Whether a `leaf.toml` says lamina wrote it (its `generator` starts with `lamina`).
pub fn written_by_lamina(leaf_toml: &Path) -> bool {
    std::fs::read_to_string(leaf_toml)
        .ok()
        .and_then(|t| toml::from_str::<toml::Table>(&t).ok())
        .and_then(|t| {
            t.get("generator")?
                .as_str()
                .map(|g| g.starts_with("lamina"))
        })
        .unwrap_or(false)
}

fn leaf_folder_spec(inputs: &[PathBuf]) -> FolderSpec<'_> {
    FolderSpec {
        kind: "leaf folder",
        owns: &owns_leaf_file,
        marker: "leaf.toml",
        is_marked: &written_by_lamina,
        inputs,
    }
}

/// Checks, before any work, that [`write_leaf_folder`] could write `dir` with `how`:
/// the same refusals (a foreign folder without `--force`, an input in the way), nothing
/// changed.
pub fn check_leaf_folder(dir: &Path, how: &FolderWrite) -> Result<(), LeafMapsError> {
    lamina_io::check_folder(dir, &leaf_folder_spec(&how.inputs), how.replace)?;
    Ok(())
}

/// Writes a leaf folder: the seven maps ([`MAP_FILES`]) and `leaf.toml`, whose first
/// lines are `comments` (each written as a `# ` line; use them to say which maps were
/// derived and how) followed by `generator = ...` and the serialised [`LeafDescription`]
/// with relative paths and clamped addressing.
///
/// Every file is written into a temporary sibling folder first; what happens then to an
/// existing `dir` is [`lamina_io::folder`]'s rule: a new or empty folder is renamed into
/// place; a leaf folder lamina wrote (its `leaf.toml` has a `generator` naming lamina and it
/// holds only the seven maps and `leaf.toml`) is exchanged with the new one in one step on
/// Linux (elsewhere: moved aside, then replaced); any other folder is an error naming the
/// foreign files, unless `how.replace` is [`Replace::Force`], which writes lamina's eight
/// files into it and keeps every other file. An input named in `how.inputs` is never
/// overwritten. On any error the temporary folder is removed and `dir` is left as it was.
pub fn write_leaf_folder(
    dir: &Path,
    maps: &MapPlanes,
    params: &LeafParams,
    comments: &[String],
    how: &FolderWrite,
) -> Result<PathBuf, LeafMapsError> {
    params.validate()?;
    let spec = leaf_folder_spec(&how.inputs);
    let staged = lamina_io::stage(dir, &spec, how.replace)?;
    let tmp = staged.path().to_owned();
    let [f, b, t, a, th, e, bu] = MAP_FILES;
    // Encode the seven maps in parallel (PNG compression dominates the write time).
    let jobs: Vec<Box<dyn Fn() -> Result<(), LeafMapsError> + Send + Sync>> = vec![
        Box::new(|| write_srgb_png(&tmp.join(f), &maps.front)),
        Box::new(|| write_srgb_png(&tmp.join(b), &maps.back)),
        Box::new(|| write_srgb_png(&tmp.join(t), &maps.translucency)),
        Box::new(|| write_gray16_png(&tmp.join(a), &maps.alpha)),
        Box::new(|| write_gray16_png(&tmp.join(th), &maps.thickness)),
        Box::new(|| write_gray16_png(&tmp.join(e), &maps.extinction)),
        Box::new(|| write_gray16_png(&tmp.join(bu), &maps.bump)),
    ];
    jobs.par_iter()
        .map(|j| j())
        .collect::<Result<Vec<()>, _>>()?;
    let desc = LeafDescription {
        generator: Some(how.generator.clone()),
        maps: LeafMapPaths {
            front: Some(f.into()),
            back: Some(b.into()),
            translucency: Some(t.into()),
            alpha: Some(a.into()),
            thickness: Some(th.into()),
            extinction: Some(e.into()),
            bump: Some(bu.into()),
            wrap: Wrap::Clamp,
        },
        params: *params,
        pigments: None,
    };
    let mut text = String::new();
    for c in comments {
        for line in c.lines() {
            text.push_str("# ");
            text.push_str(line);
            text.push('\n');
        }
    }
    text.push('\n');
    text.push_str(&toml::to_string(&desc)?);
    let toml_path = tmp.join("leaf.toml");
    std::fs::write(&toml_path, text).map_err(write_err(&toml_path))?;
    // The maps were written with plain writes into the temporary folder: flush them before
    // the folder is put in place.
    for name in MAP_FILES.iter().chain(&["leaf.toml"]) {
        let p = tmp.join(name);
        std::fs::File::open(&p)
            .and_then(|f| f.sync_all())
            .map_err(write_err(&p))?;
    }
    Ok(staged.commit(&spec)?)
}
