//! `[film]`: image size, samples, pixel filter, exposure and tone map of the PNG.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `width`, `height` | pixels, 1..16384 | `640`, `480` | image size |
//! | `spp` | samples per pixel, >= 1 | `64` | overridden by `--spp` |
//! | `filter` | `box`, `tent`, `gaussian` | `gaussian` | pixel reconstruction filter |
//! | `filter_radius` | pixels, (0, 8] | tent 1, gaussian 1.5 | filter support |
//! | `filter_sigma` | pixels, (0, 8] | `0.5` | Gaussian standard deviation |
//! | `exposure` | stops, [-30, 30] | `0` | the PNG shows radiance × 2^exposure |
//! | `tonemap` | `clamp`, `aces`, `reinhard` | `aces` | tone map of the PNG; the EXR is never tone-mapped |

use crate::dict::{Dict, Keys, Kind, S, Table};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::{Film, PixelFilter, ToneMap};

/// The keys of the table above.
pub(crate) const KEYS: Keys = Keys::plain(&[
    ("width", Kind::Int),
    ("height", Kind::Int),
    ("spp", Kind::Int),
    ("filter", Kind::Str),
    ("filter_radius", Kind::Num),
    ("filter_sigma", Kind::Num),
    ("exposure", Kind::Num),
    ("tonemap", Kind::Str),
]);

/// Checks the keys of `[film]` and their types.
pub(crate) fn check(ld: &Loader, t: &S<Table>) -> Result<(), SceneError> {
    Dict::open(ld, "film", None, t.span(), t.get_ref(), KEYS).map(drop)
}

/// Reads `[film]` (absent: 640 x 480, 64 spp, the defaults above).
pub(crate) fn read(ld: &Loader, t: Option<&S<Table>>) -> Result<Film, SceneError> {
    let mut film = Film::new(640, 480, 64);
    let Some(t) = t else { return Ok(film) };
    let d = Dict::open(ld, "film", None, t.span(), t.get_ref(), KEYS)?;
    if let Some(w) = d.count_opt("width", 1, 16384)? {
        film.width = w;
    }
    if let Some(h) = d.count_opt("height", 1, 16384)? {
        film.height = h;
    }
    if let Some(spp) = d.count_opt("spp", 1, 1 << 20)? {
        film.spp = spp;
    }
    let radius = d.float_opt("filter_radius", 0.0, 8.0, true)?;
    let sigma = d.float_opt("filter_sigma", 0.0, 8.0, true)?;
    if let Some(v) = d.string("filter")? {
        film.filter = match *v.get_ref() {
            "box" => PixelFilter::Box,
            "tent" => PixelFilter::Tent {
                radius: radius.unwrap_or(1.0),
            },
            "gaussian" => PixelFilter::Gaussian {
                radius: radius.unwrap_or(1.5),
                sigma: sigma.unwrap_or(0.5),
            },
            other => {
                return Err(d.err(
                    v.span(),
                    "filter",
                    format!("unknown filter '{other}' (box, tent, gaussian)"),
                ));
            }
        };
    } else if radius.is_some() || sigma.is_some() {
        film.filter = PixelFilter::Gaussian {
            radius: radius.unwrap_or(1.5),
            sigma: sigma.unwrap_or(0.5),
        };
    }
    if let Some(e) = d.float_opt("exposure", -30.0, 30.0, false)? {
        film.exposure = e;
    }
    if let Some(v) = d.string("tonemap")? {
        film.tonemap = match *v.get_ref() {
            "clamp" => ToneMap::Clamp,
            "aces" => ToneMap::Aces,
            "reinhard" => ToneMap::Reinhard,
            other => {
                return Err(d.err(
                    v.span(),
                    "tonemap",
                    format!("unknown tone map '{other}' (clamp, aces, reinhard)"),
                ));
            }
        };
    }
    d.finish()?;
    Ok(film)
}
