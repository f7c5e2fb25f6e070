//! Leaf maps from real captures: photographs of the front (and back), a through-light scan,
//! a matte and a normal or bump map, turned into a leaf folder.
//!
//! # What is taken, what is derived
//! Every input is resampled to the front photo's size when it differs (with a warning).
//! Colour inputs (front, back, scan) are sRGB-decoded; 16-bit and grey-scale images are
//! accepted (grey is expanded to RGB, with a warning for the colour maps); an alpha channel
//! in the front photo serves as the matte when no `--alpha` is given.
//!
//! * **Alpha** — the given matte (its alpha channel if it has a non-constant one, else its
//!   grey value) thresholded at 0.5; otherwise the front photo's own alpha channel; otherwise
//!   *segmented*: the background colour is the per-channel median of the image border, each
//!   pixel's feature is its distance to that colour (in sRGB-encoded units, max over the front
//!   and, when present, the scan), and Otsu's threshold splits leaf from background. All
//!   mattes are cleaned: holes not connected to the border are filled (pale veins and glints
//!   that the threshold cut out) and specks smaller than 0.05 % of the image or 2 % of the
//!   largest part are removed. A matte that keeps nothing is an error naming the file.
//!   A given matte is *refined* against the photo by default (approximate mattes such as
//!   outlines rasterised from a few points are common): see `refine_matte` — the background
//!   colour is the median outside the matte, and within the matte widened by 1.5 % of the
//!   image Otsu's threshold on the distance to it decides; the refinement is kept only when
//!   the separation is clear and the area stays within 50-150 % of the given matte.
//! * **Translucency** — the scan, if given. Otherwise derived from the front (through-light is
//!   yellow-green with dark veins): `T = c_T * (Y/Ȳ)^0.5 * (1 - 0.6 v)`, where `c_T` is a
//!   yellow-green transmittance (sRGB 118, 146, 34) scaled so its green equals the front's
//!   mean green (real leaves transmit about as much as they reflect in the green),
//!   `(Y/Ȳ)^0.5` makes paler patches (less chlorophyll) transmit more, and `v` is the vein
//!   mask: the positive part of the front's relative high-pass `(Y - blur Y) / blur Y`
//!   (veins are paler than the blade on the upper side of most leaves), plus the ridges of
//!   the bump when one is known.
//! * **Extinction** `= 1 - Y'(scan)` and **thickness** = its blur, see
//!   [`crate::folder::extinction_from_translucency`] and
//!   [`crate::folder::thickness_from_extinction`]; the blur radius is in millimetres when the
//!   capture's resolution (`dpi`) is known, else in pixels.
//! * **Back** — the photo, if given. Otherwise derived: 35 % desaturated, 1.35x brighter
//!   (capped at 0.5 linear), and veins 45 % toward a pale grey-green (the lower side is paler
//!   and its veins stand out).
//! * **Bump** — a given bump map as is; else integrated from a tangent-space normal map
//!   (OpenGL convention, green = up; `gx = -nx/nz`, `gy = ny/nz` per pixel, solved as a Poisson
//!   equation by [`crate::plane::integrate_gradients`]), scaled so that the map spans the
//!   relief and [`LeafParams::bump_scale`] reproduces the normal map's slopes; else from the
//!   photo's fine detail: minus the relative high-pass of the front's luminance (veins are
//!   paler and sunken on the upper side), with the parameters' `bump_scale`.
//!
//! `leaf.toml` starts with comments naming each input and what was derived, and the warnings.

use crate::folder::{
    FolderWrite, MapPlanes, check_leaf_folder, decode_srgb, extinction_from_translucency,
    luma_encoded, thickness_from_extinction, write_leaf_folder,
};
use crate::plane::{
    Gray, Plane, Rgb, fill_holes, gaussian_blur, integrate_gradients, otsu, remove_specks,
};
use crate::species::srgb8_to_linear;
use crate::{LeafMapsError, Replace};
use glam::Vec3;
use lamina_leaf::LeafParams;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Inputs and options of [`prepare`].
#[derive(Clone, Debug)]
pub struct PrepareInput {
    /// Adaxial (upper side) photograph, sRGB (required). Sets the output size.
    pub front: PathBuf,
    /// Abaxial (lower side) photograph, sRGB, same texel layout as the front (not mirrored).
    pub back: Option<PathBuf>,
    /// Through-light (translucency) scan, sRGB.
    pub translucency: Option<PathBuf>,
    /// Alpha matte: white = leaf (grey value, or the alpha channel when it has one).
    pub alpha: Option<PathBuf>,
    /// Tangent-space normal map (OpenGL convention: green up), linear.
    pub normal: Option<PathBuf>,
    /// Bump (height) map, linear grey, white = up on the adaxial side. Wins over `normal`.
    pub bump: Option<PathBuf>,
    /// Resolution of the capture in dots per inch, if known (then `blur_radius` is in mm).
    pub dpi: Option<f32>,
    /// Standard deviation of the thickness blur: millimetres when `dpi` is given, else
    /// pixels. `None`: 0.5 mm, or 0.5 % of the longer image side without `dpi`.
    pub blur_radius: Option<f32>,
    /// Refine a given (approximate) matte against the photo's background, see the module
    /// docs. Default `true`.
    pub refine_alpha: bool,
    /// Leaf model parameters written to `leaf.toml` (`bump_scale` is replaced when the bump
    /// comes from a normal map).
    pub params: LeafParams,
    /// The leaf folder to write.
    pub out: PathBuf,
    /// What to do when `out` exists and is not a leaf folder lamina wrote: refuse
    /// ([`Replace::IfOurs`], the default) or write lamina's files into it and keep the others
    /// ([`Replace::Force`]). The inputs are never overwritten either way.
    pub replace: Replace,
}

impl PrepareInput {
    /// Inputs with only a front photo and default options.
    pub fn new(front: impl Into<PathBuf>, out: impl Into<PathBuf>) -> Self {
        PrepareInput {
            front: front.into(),
            back: None,
            translucency: None,
            alpha: None,
            normal: None,
            bump: None,
            dpi: None,
            blur_radius: None,
            refine_alpha: true,
            params: LeafParams::default(),
            out: out.into(),
            replace: Replace::IfOurs,
        }
    }

    /// Every input file given.
    pub fn input_files(&self) -> Vec<PathBuf> {
        std::iter::once(&self.front)
            .chain(&self.back)
            .chain(&self.translucency)
            .chain(&self.alpha)
            .chain(&self.normal)
            .chain(&self.bump)
            .cloned()
            .collect()
    }

    /// How the output folder is written: [`PrepareInput::replace`], the inputs protected.
    pub fn folder_write(&self) -> FolderWrite {
        FolderWrite {
            replace: self.replace,
            inputs: self.input_files(),
            ..FolderWrite::default()
        }
    }
}

/// What [`prepare`] did.
#[derive(Clone, Debug)]
pub struct Prepared {
    /// The leaf folder written.
    pub dir: PathBuf,
    /// The maps (as written).
    pub maps: MapPlanes,
    /// The parameters written.
    pub params: LeafParams,
    /// Warnings (resampled inputs, grey photos, doubtful mattes...), each naming the file.
    pub warnings: Vec<String>,
    /// One line per map saying where it came from (also in `leaf.toml`).
    pub provenance: Vec<String>,
    /// Fraction of the image the alpha matte keeps.
    pub alpha_fraction: f32,
}

/// An input image as stored: RGBA in `[0, 1]` without transfer decoding.
struct Stored {
    rgba: Plane<[f32; 4]>,
    grey: bool,
    has_alpha: bool,
    float: bool,
}

/// Opens an image with its size checked from the header before decoding, a decoder panic
/// made an error (see `lamina_leaf::texture::open_image`).
pub(crate) fn open_checked(path: &Path) -> Result<image::DynamicImage, LeafMapsError> {
    lamina_leaf::texture::open_image(path).map_err(|e| match e {
        lamina_leaf::TextureError::Read { path, source } => LeafMapsError::Read {
            path,
            cause: source,
        },
        other => LeafMapsError::BadInput {
            path: path.to_owned(),
            reason: other.to_string(),
        },
    })
}

fn load_stored(path: &Path) -> Result<Stored, LeafMapsError> {
    let img = open_checked(path)?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    if w == 0 || h == 0 {
        return Err(LeafMapsError::BadInput {
            path: path.to_owned(),
            reason: format!("the image is empty ({w}x{h})"),
        });
    }
    let color = img.color();
    let grey = matches!(
        color,
        image::ColorType::L8
            | image::ColorType::L16
            | image::ColorType::La8
            | image::ColorType::La16
    );
    let float = matches!(color, image::ColorType::Rgb32F | image::ColorType::Rgba32F);
    let has_alpha = color.has_alpha();
    // Convert from the stored bit depth straight to f32 (no full-size f32 intermediate).
    let data: Vec<[f32; 4]> = match color {
        image::ColorType::L8
        | image::ColorType::La8
        | image::ColorType::Rgb8
        | image::ColorType::Rgba8 => img
            .into_rgba8()
            .as_raw()
            .par_chunks(4)
            .map(|c| [c[0], c[1], c[2], c[3]].map(|v| v as f32 / 255.0))
            .collect(),
        image::ColorType::L16
        | image::ColorType::La16
        | image::ColorType::Rgb16
        | image::ColorType::Rgba16 => img
            .into_rgba16()
            .as_raw()
            .par_chunks(4)
            .map(|c| [c[0], c[1], c[2], c[3]].map(|v| v as f32 / 65535.0))
            .collect(),
        _ => img
            .into_rgba32f()
            .as_raw()
            .par_chunks(4)
            .map(|c| {
                let f = |v: f32| if v.is_finite() { v.max(0.0) } else { 0.0 };
                [f(c[0]), f(c[1]), f(c[2]), f(c[3]).min(1.0)]
            })
            .collect(),
    };
    Ok(Stored {
        rgba: Plane {
            width: w,
            height: h,
            data,
        },
        grey,
        has_alpha,
        float,
    })
}

/// Loads an input and resamples it to `size`, warning when it had to.
fn load_sized(
    path: &Path,
    size: (usize, usize),
    warnings: &mut Vec<String>,
) -> Result<Stored, LeafMapsError> {
    let mut s = load_stored(path)?;
    let (w, h) = (s.rgba.width, s.rgba.height);
    if (w, h) != size {
        let a0 = w as f32 / h as f32;
        let a1 = size.0 as f32 / size.1 as f32;
        warnings.push(format!(
            "'{}' is {w}x{h}, the front photo {}x{}: resampled{}",
            path.display(),
            size.0,
            size.1,
            if (a0 / a1 - 1.0).abs() > 0.01 {
                " (aspect ratios differ: stretched, check that the images are aligned)"
            } else {
                ""
            }
        ));
        s.rgba = s.rgba.resample(size.0, size.1);
    }
    Ok(s)
}

/// Colour input to linear RGB (sRGB-decoded unless it is a float image).
fn to_linear_rgb(s: &Stored) -> Rgb {
    let float = s.float;
    s.rgba.map(|c| {
        if float {
            [c[0], c[1], c[2]]
        } else {
            [decode_srgb(c[0]), decode_srgb(c[1]), decode_srgb(c[2])]
        }
    })
}

fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// Errors out on a uniform (all black, all white, constant) colour input.
fn check_not_uniform(path: &Path, rgb: &Rgb, what: &str) -> Result<(), LeafMapsError> {
    let y = rgb.map(luma_encoded);
    let (lo, hi) = y.min_max();
    if hi - lo < 2.0 / 255.0 {
        let kind = if hi < 0.02 {
            "all black"
        } else if lo > 0.98 {
            "all white"
        } else {
            "a single flat colour"
        };
        return Err(LeafMapsError::BadInput {
            path: path.to_owned(),
            reason: format!("the {what} is {kind}: it carries no leaf"),
        });
    }
    Ok(())
}

fn median(mut v: Vec<f32>) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    v[mid]
}

/// Segmentation feature: distance of each pixel from the border's median colour
/// (sRGB-encoded values). Returns the feature and Otsu's separability `eta` in `[0, 1]`.
fn background_distance(stored: &Plane<[f32; 4]>) -> Gray {
    let (w, h) = (stored.width, stored.height);
    let mut border = Vec::new();
    for x in 0..w {
        border.push(stored.get(x, 0));
        border.push(stored.get(x, h - 1));
    }
    for y in 0..h {
        border.push(stored.get(0, y));
        border.push(stored.get(w - 1, y));
    }
    let bg: [f32; 3] =
        std::array::from_fn(|k| median(border.iter().map(|c| c[k].min(1.0)).collect()));
    stored.map(|c| {
        let d = [
            c[0].min(1.0) - bg[0],
            c[1].min(1.0) - bg[1],
            c[2].min(1.0) - bg[2],
        ];
        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
    })
}

/// Otsu's separability `eta = sigma_between^2 / sigma_total^2` of `f` at threshold `t`.
fn separability(f: &Gray, t: f32) -> f32 {
    let n = f.data.len() as f64;
    let mean = f.data.iter().map(|v| *v as f64).sum::<f64>() / n;
    let var = f
        .data
        .iter()
        .map(|v| (*v as f64 - mean).powi(2))
        .sum::<f64>()
        / n;
    let (mut s1, mut n1) = (0.0f64, 0.0f64);
    for v in &f.data {
        if *v > t {
            s1 += *v as f64;
            n1 += 1.0;
        }
    }
    let n0 = n - n1;
    if n0 == 0.0 || n1 == 0.0 || var <= 0.0 {
        return 0.0;
    }
    let m1 = s1 / n1;
    let m0 = (mean * n - s1) / n0;
    ((n0 / n) * (n1 / n) * (m1 - m0).powi(2) / var) as f32
}

fn clean_mask(mask: &mut Plane<bool>, fill: bool) {
    if fill {
        fill_holes(mask);
    }
    let total = mask.width * mask.height;
    let sizes = crate::plane::component_sizes(mask);
    let largest = sizes.iter().copied().max().unwrap_or(0);
    let min_area = ((total as f32 * 0.0005) as usize)
        .max((largest as f32 * 0.02) as usize)
        .max(4);
    remove_specks(mask, min_area);
}

/// Widens a mask by about `r` pixels (blur, then a low threshold).
fn dilate(mask: &Plane<bool>, r: f32) -> Plane<bool> {
    let g = gaussian_blur(&mask.map(|m| if m { 1.0 } else { 0.0 }), 0.5 * r);
    g.map(|v| v > 0.03)
}

/// Refines an approximate matte against the photo: the background colour is the median of
/// the photo outside the (widened) matte; inside the matte widened by 1.5 % of the image,
/// pixels are leaf where their distance to that colour exceeds Otsu's threshold. Accepted
/// only when leaf and background separate well (separability >= 0.5) and the refined matte
/// keeps between 50 % and 150 % of the given one; returns it with the separability and the
/// threshold.
fn refine_matte(mask: &Plane<bool>, photo: &Plane<[f32; 4]>) -> Option<(Plane<bool>, f32, f32)> {
    let (w, h) = (mask.width, mask.height);
    let r = 0.015 * w.max(h) as f32;
    let band = dilate(mask, r);
    let outside: Vec<[f32; 4]> = photo
        .data
        .iter()
        .zip(&band.data)
        .step_by(3)
        .filter(|(_, b)| !**b)
        .map(|(c, _)| *c)
        .collect();
    if outside.len() < 64 {
        return None;
    }
    let bg: [f32; 3] =
        std::array::from_fn(|k| median(outside.iter().map(|c| c[k].min(1.0)).collect()));
    let d = photo.map(|c| {
        let e = [
            c[0].min(1.0) - bg[0],
            c[1].min(1.0) - bg[1],
            c[2].min(1.0) - bg[2],
        ];
        (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
    });
    let t = otsu(&d, Some(&band))?;
    // Separability within the band.
    let inband = Plane {
        width: 1,
        height: 1,
        data: d
            .data
            .iter()
            .zip(&band.data)
            .filter(|(_, b)| **b)
            .map(|(v, _)| *v)
            .collect::<Vec<_>>(),
    };
    let eta = separability(&inband, t);
    let mut refined = Plane {
        width: w,
        height: h,
        data: d
            .data
            .par_iter()
            .zip(band.data.par_iter())
            .map(|(v, b)| *b && *v > t)
            .collect(),
    };
    clean_mask(&mut refined, true);
    let n0 = mask.data.iter().filter(|m| **m).count() as f32;
    let n1 = refined.data.iter().filter(|m| **m).count() as f32;
    if std::env::var_os("LAMINA_LEAFMAPS_TIMING").is_some() {
        eprintln!(
            "  refine_matte: bg {bg:?} threshold {t:.3} separability {eta:.2} area ratio {:.2}",
            n1 / n0
        );
    }
    (eta >= 0.5 && n1 >= 0.5 * n0 && n1 <= 1.5 * n0).then_some((refined, eta, t))
}

/// Prepares a leaf folder from captures (see the module docs for every heuristic).
/// Never writes a partial folder: on error nothing is written.
pub fn prepare(input: &PrepareInput) -> Result<Prepared, LeafMapsError> {
    let mut warnings = Vec::new();
    let mut prov = Vec::new();
    // Refuse a folder that may not be written before the long work, not after it.
    let how = input.folder_write();
    check_leaf_folder(&input.out, &how)?;
    if let Some(d) = input.dpi
        && !(d.is_finite() && d > 0.0)
    {
        return Err(LeafMapsError::Option {
            option: "dpi",
            reason: format!("{d} is not a positive number"),
        });
    }
    if let Some(r) = input.blur_radius
        && !(r.is_finite() && r >= 0.0)
    {
        return Err(LeafMapsError::Option {
            option: "blur_radius",
            reason: format!("{r} is not a non-negative number"),
        });
    }
    input.params.validate()?;

    let mut timer = crate::PhaseTimer::new();
    // Front.
    let front_s = load_stored(&input.front)?;
    let size = (front_s.rgba.width, front_s.rgba.height);
    let (w, h) = size;
    if front_s.grey {
        warnings.push(format!(
            "'{}' is a grey-scale image: the front colour will be grey",
            input.front.display()
        ));
    }
    let front = to_linear_rgb(&front_s);
    check_not_uniform(&input.front, &front, "front photo")?;
    prov.push(format!("front: {}", input.front.display()));

    timer.lap("load front");
    // Translucency scan (loaded early: it helps segmentation).
    let scan = match &input.translucency {
        Some(p) => {
            let s = load_sized(p, size, &mut warnings)?;
            if s.grey {
                warnings.push(format!(
                    "'{}' is a grey-scale scan: the through-light colour will be grey",
                    p.display()
                ));
            }
            let rgb = to_linear_rgb(&s);
            check_not_uniform(p, &rgb, "through-light scan")?;
            Some((p.clone(), s, rgb))
        }
        None => None,
    };

    timer.lap("load scan");
    // Alpha.
    let (mut mask, alpha_src, fill) = if let Some(p) = &input.alpha {
        let s = load_sized(p, size, &mut warnings)?;
        let use_alpha = s.has_alpha && {
            let (lo, hi) = s.rgba.map(|c| c[3]).min_max();
            hi - lo > 0.01
        };
        let m = s.rgba.map(|c| {
            if use_alpha {
                c[3] >= 0.5
            } else {
                (c[0] + c[1] + c[2]) / 3.0 >= 0.5
            }
        });
        prov.push(format!(
            "alpha: the matte {} ({}, thresholded at 0.5, specks removed)",
            p.display(),
            if use_alpha {
                "its alpha channel"
            } else {
                "its grey value"
            }
        ));
        (m, p.clone(), false)
    } else if front_s.has_alpha && {
        let (lo, hi) = front_s.rgba.map(|c| c[3]).min_max();
        hi - lo > 0.01
    } {
        prov.push("alpha: the front photo's alpha channel (thresholded at 0.5)".into());
        (
            front_s.rgba.map(|c| c[3] >= 0.5),
            input.front.clone(),
            false,
        )
    } else {
        let mut f = background_distance(&front_s.rgba);
        if let Some((_, s, _)) = &scan {
            let g = background_distance(&s.rgba);
            f.data
                .par_iter_mut()
                .zip(g.data.par_iter())
                .for_each(|(a, b)| *a = a.max(*b));
        }
        let t = otsu(&f, None).ok_or_else(|| LeafMapsError::BadInput {
            path: input.front.clone(),
            reason: "cannot segment the leaf: the photo has no contrast to its background".into(),
        })?;
        let eta = separability(&f, t);
        if eta < 0.5 {
            warnings.push(format!(
                "'{}': leaf and background are poorly separated (Otsu separability {eta:.2}); check the alpha map or pass --alpha",
                input.front.display()
            ));
        }
        prov.push(format!(
            "alpha: segmented from the {} (distance to the border's median colour, Otsu threshold {t:.3}, separability {eta:.2}; holes filled, specks removed)",
            if scan.is_some() { "front photo and the scan" } else { "front photo" }
        ));
        (f.map(|v| v > t), input.front.clone(), true)
    };
    clean_mask(&mut mask, fill);
    if input.alpha.is_some() && input.refine_alpha {
        match refine_matte(&mask, &front_s.rgba) {
            Some((refined, eta, t)) => {
                mask = refined;
                prov.push(format!(
                    "alpha: refined against the photo (background colour = median outside the matte; within the matte widened by 1.5 % of the image, Otsu threshold {t:.3} on the distance to it, separability {eta:.2})"
                ));
            }
            None => prov.push(
                "alpha: the matte was used as given (refinement against the photo found no clear background)".into(),
            ),
        }
    }
    timer.lap("alpha");
    let kept = mask.data.par_iter().filter(|m| **m).count();
    let alpha_fraction = kept as f32 / (w * h) as f32;
    if kept == 0 {
        return Err(LeafMapsError::BadInput {
            path: alpha_src,
            reason: "the alpha matte keeps nothing (no pixel is leaf)".into(),
        });
    }
    if alpha_fraction > 0.98 {
        warnings.push(format!(
            "'{}': the alpha matte keeps {:.1} % of the image: is there a background?",
            alpha_src.display(),
            100.0 * alpha_fraction
        ));
    } else if alpha_fraction < 0.01 {
        warnings.push(format!(
            "'{}': the alpha matte keeps only {:.2} % of the image",
            alpha_src.display(),
            100.0 * alpha_fraction
        ));
    }
    let alpha: Gray = mask.map(|m| if m { 1.0 } else { 0.0 });

    // Scale of the capture.
    let px_per_mm = input.dpi.map(|d| d / 25.4);
    let sigma_px = match (input.blur_radius, px_per_mm) {
        (Some(r), Some(ppm)) => r * ppm,
        (Some(r), None) => r,
        (None, Some(ppm)) => 0.5 * ppm,
        (None, None) => 0.005 * w.max(h) as f32,
    };

    // Luminance detail of the front: relative high-pass (veins are paler on the upper side).
    let y_front: Gray = front.map(luminance);
    let detail_sigma = (0.004 * w.max(h) as f32).max(1.5);
    // Local mean inside the leaf only (normalised convolution), so the margin against the
    // background does not read as detail.
    let alpha_blur = gaussian_blur(&alpha, detail_sigma);
    let ya = Plane {
        width: w,
        height: h,
        data: y_front
            .data
            .par_iter()
            .zip(alpha.data.par_iter())
            .map(|(y, a)| y * a)
            .collect(),
    };
    let y_blur = gaussian_blur(&ya, detail_sigma);
    let y_blur = Plane {
        width: w,
        height: h,
        data: y_blur
            .data
            .par_iter()
            .zip(alpha_blur.data.par_iter())
            .zip(y_front.data.par_iter())
            .map(|((b, a), y)| if *a > 0.05 { b / a } else { *y })
            .collect(),
    };
    let highpass: Gray = Plane {
        width: w,
        height: h,
        data: y_front
            .data
            .par_iter()
            .zip(y_blur.data.par_iter())
            .map(|(y, b)| (y - b) / b.max(1e-3))
            .collect(),
    };
    let mean_of = |p: &Rgb| -> Vec3 {
        let (s, n) = p
            .data
            .par_iter()
            .zip(mask.data.par_iter())
            .filter(|(_, m)| **m)
            .map(|(c, _)| (Vec3::from_array(*c), 1.0f32))
            .reduce(|| (Vec3::ZERO, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        s / n.max(1.0)
    };
    let front_mean = mean_of(&front);
    let y_mean = luminance(front_mean.to_array()).max(1e-4);

    timer.lap("detail");
    // Bump.
    let mut params = input.params;
    let mut ridge: Option<Gray> = None;
    let bump: Gray = if let Some(p) = &input.bump {
        let s = load_sized(p, size, &mut warnings)?;
        prov.push(format!("bump: {} (grey value as height)", p.display()));
        s.rgba.map(|c| ((c[0] + c[1] + c[2]) / 3.0).clamp(0.0, 1.0))
    } else if let Some(p) = &input.normal {
        let s = load_sized(p, size, &mut warnings)?;
        let n = s.rgba.map(|c| {
            let v = Vec3::new(2.0 * c[0] - 1.0, 2.0 * c[1] - 1.0, 2.0 * c[2] - 1.0);
            let v = if v.length_squared() > 1e-6 {
                v.normalize()
            } else {
                Vec3::Z
            };
            [v.x, v.y, v.z.max(0.2)]
        });
        let (zlo, _) = n.map(|v| v[2]).min_max();
        if zlo >= 0.999 {
            warnings.push(format!("'{}': the normal map is flat", p.display()));
        }
        let gx = n.map(|v| -v[0] / v[2]);
        let gy = n.map(|v| v[1] / v[2]);
        let hf = integrate_gradients(&gx, &gy, 4);
        // Remove the large-scale bend (a leaf card is flat; the bump is for fine relief).
        let base = gaussian_blur(&hf, 0.02 * w.max(h) as f32);
        let rel: Gray = Plane {
            width: w,
            height: h,
            data: hf
                .data
                .par_iter()
                .zip(base.data.par_iter())
                .map(|(a, b)| a - b)
                .collect(),
        };
        // Centre on the leaf's own mean height, so the blade sits at 0.5.
        let centre = rel.masked_mean(&mask).unwrap_or(0.0);
        let rel = rel.map(|v| v - centre);
        let range = percentile_abs(&rel, &mask, 0.995).max(1e-3);
        params.bump_scale = (2.0 * range / (w as f32 * h as f32).sqrt()).clamp(0.0, 1.0);
        prov.push(format!(
            "bump: integrated from the normal map {} (OpenGL convention, Poisson solve, large-scale bend removed); bump_scale {:.5} reproduces its slopes",
            p.display(),
            params.bump_scale
        ));
        let r = rel.map(|v| -v.min(0.0) / range);
        ridge = Some(r);
        rel.map(|v| (0.5 + v / (2.0 * range)).clamp(0.0, 1.0))
    } else {
        let range = percentile_abs(&highpass, &mask, 0.995).max(1e-3);
        prov.push(
            "bump: derived from the front photo's fine detail (minus its relative high-pass: pale veins read as grooves on the upper side)".into(),
        );
        highpass.map(|v| (0.5 - v / (2.0 * range)).clamp(0.0, 1.0))
    };
    let bump = Plane {
        width: w,
        height: h,
        data: bump
            .data
            .par_iter()
            .zip(mask.data.par_iter())
            .map(|(b, m)| if *m { *b } else { 0.5 })
            .collect(),
    };

    timer.lap("bump");
    // Vein mask from the front's detail (and the bump's grooves).
    let hp_range = percentile_abs(&highpass, &mask, 0.99).max(1e-3);
    let veins: Gray = Plane::from_fn(w, h, |x, y| {
        let i = y * w + x;
        let v = (highpass.data[i] / hp_range).clamp(0.0, 1.0);
        let r = ridge.as_ref().map_or(0.0, |r| r.data[i].clamp(0.0, 1.0));
        v.max(r)
    });

    timer.lap("veins");
    // Translucency.
    let translucency: Rgb = match scan {
        Some((p, _, rgb)) => {
            prov.push(format!(
                "translucency: the through-light scan {}",
                p.display()
            ));
            rgb
        }
        None => {
            let c_t = srgb8_to_linear([118, 146, 34]);
            let c_t = c_t * (front_mean.y / c_t.y);
            prov.push(
                "translucency: DERIVED from the front (yellow-green, green scaled to the front's mean, paler patches transmit more, veins 60 % darker); no scan was given"
                .to_string(),
            );
            Plane::from_fn(w, h, |x, y| {
                let i = y * w + x;
                let s = (y_front.data[i] / y_mean).clamp(0.25, 4.0).sqrt();
                let t = c_t * s * (1.0 - 0.6 * veins.data[i]);
                t.clamp(Vec3::ZERO, Vec3::ONE).to_array()
            })
        }
    };

    // Back.
    let back: Rgb = match &input.back {
        Some(p) => {
            let s = load_sized(p, size, &mut warnings)?;
            if s.grey {
                warnings.push(format!(
                    "'{}' is a grey-scale image: the back colour will be grey",
                    p.display()
                ));
            }
            let rgb = to_linear_rgb(&s);
            check_not_uniform(p, &rgb, "back photo")?;
            prov.push(format!("back: {}", p.display()));
            rgb
        }
        None => {
            prov.push(
                "back: DERIVED from the front (35 % desaturated, 1.35x brighter, veins 45 % toward pale grey-green); no back photo was given"
                    .into(),
            );
            let pale = srgb8_to_linear([170, 182, 140]);
            Plane::from_fn(w, h, |x, y| {
                let i = y * w + x;
                let c = Vec3::from_array(front.data[i]);
                let l = luminance(c.to_array());
                let d = (c + (Vec3::splat(l) - c) * 0.35) * 1.35;
                let d = d.min(Vec3::splat(0.5));
                let v = 0.45 * veins.data[i];
                (d + (pale - d) * v).clamp(Vec3::ZERO, Vec3::ONE).to_array()
            })
        }
    };

    timer.lap("translucency+back");
    let extinction = extinction_from_translucency(&translucency);
    let thickness = thickness_from_extinction(&extinction, &alpha, sigma_px, 1.5);
    prov.push(format!(
        "extinction: 1 - luma of the {} translucency; thickness: its blur (sigma {sigma_px:.1} px{}), median re-centred on 0.5",
        if input.translucency.is_some() { "scanned" } else { "derived" },
        px_per_mm.map_or(String::new(), |p| format!(" = {:.2} mm", sigma_px / p))
    ));

    timer.lap("extinction+thickness");
    let maps = MapPlanes {
        front,
        back,
        translucency,
        alpha,
        thickness,
        extinction,
        bump,
    };
    let mut comments = vec![format!(
        "Leaf folder prepared by lamina-leafmaps from captures, {w}x{h} px."
    )];
    comments.extend(prov.iter().cloned());
    for wmsg in &warnings {
        comments.push(format!("warning: {wmsg}"));
    }
    let dir = write_leaf_folder(&input.out, &maps, &params, &comments, &how)?;
    timer.lap("write folder");
    Ok(Prepared {
        dir,
        maps,
        params,
        warnings,
        provenance: prov,
        alpha_fraction,
    })
}

/// The `q`-quantile of `|v|` inside the mask (over a 4096-bin histogram).
fn percentile_abs(p: &Gray, mask: &Plane<bool>, q: f32) -> f32 {
    let mut hi = 0.0f32;
    for (v, m) in p.data.iter().zip(&mask.data) {
        if *m && v.is_finite() {
            hi = hi.max(v.abs());
        }
    }
    if hi <= 0.0 {
        return 0.0;
    }
    let mut hist = vec![0u64; 4096];
    let mut n = 0u64;
    for (v, m) in p.data.iter().zip(&mask.data) {
        if *m && v.is_finite() {
            hist[((v.abs() / hi) * 4095.0) as usize] += 1;
            n += 1;
        }
    }
    let target = (n as f64 * q as f64) as u64;
    let mut acc = 0;
    for (i, c) in hist.iter().enumerate() {
        acc += c;
        if acc >= target {
            return (i as f32 + 1.0) / 4096.0 * hi;
        }
    }
    hi
}
