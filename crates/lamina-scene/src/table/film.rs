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
//! | `spectral` | `rgb`, `visible` | `rgb` | how light is carried: `rgb` in the three Rec.709 channels; `visible` at wavelengths over 360-830 nm (48 bins of 9.8 nm, six per path by hero-wavelength sampling; RGB values upsampled, RGB light of D65 shape; pigment leaves and physical skies from their spectra) seen through the CIE 1931 observer, the image still linear Rec.709; path integrator only; not with `bands` |
//! | `bands` | array of tables, 1-64 | none | render spectral bands instead of RGB: each `{ name, center, width }` or `{ name, min, max }` (nm, inside 360-2500), or `{ name, response = "file.csv" }`: a relative spectral response curve (two columns, nm and response, linear between samples, zero outside; a header line and `#` comments allowed), the band value then weighted by it (its centre, where pigment leaves are evaluated, is the response-weighted mean wavelength); names unique, letters, digits, `_ - .`; the EXR gets one channel per band (band-mean spectral radiance, W m⁻² sr⁻¹ nm⁻¹), the PNG a false-colour composite |
//! | `false_color` | three band names | the first three bands | the bands the PNG shows as red, green, blue |

use crate::dict::{Dict, Keys, Kind, S, Table};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::{Film, PixelFilter, SpectralMode, ToneMap};

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
    ("spectral", Kind::Str),
    ("bands", Kind::Array),
    ("false_color", Kind::Array),
]);

/// The keys of one band.
const BAND_KEYS: Keys = Keys::plain(&[
    ("name", Kind::Str),
    ("center", Kind::Num),
    ("width", Kind::Num),
    ("min", Kind::Num),
    ("max", Kind::Num),
    ("response", Kind::Str),
]);

/// Largest band response file read (bytes): a response curve is a few hundred lines.
const MAX_RESPONSE_FILE_BYTES: u64 = 4 << 20;

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
    if let Some(v) = d.string("spectral")? {
        film.spectral = match *v.get_ref() {
            "rgb" => SpectralMode::Rgb,
            "visible" => SpectralMode::Visible,
            other => {
                return Err(d.err(
                    v.span(),
                    "spectral",
                    format!(
                        "unknown mode '{other}' (rgb, visible; for other wavelengths give `bands`)"
                    ),
                ));
            }
        };
        if film.spectral == SpectralMode::Visible
            && let Some(b) = d.get("bands")
        {
            return Err(d.err(
                b.span(),
                "bands",
                "`spectral = \"visible\"` renders an RGB image over the visible; `bands` renders \
                 the bands you name: give one or the other",
            ));
        }
    }
    read_bands(ld, &d)?;
    d.finish()?;
    Ok(film)
}

/// Reads `bands` and `false_color` into the loader's spectral output (see
/// [`crate::SpectralOutput`]).
fn read_bands(ld: &Loader, d: &Dict) -> Result<(), SceneError> {
    use lamina_leaf::spectrum::bands::Band;
    let fc = d.array("false_color")?;
    let Some(arr) = d.array("bands")? else {
        if let Some(fc) = fc {
            return Err(d.err(fc.span(), "false_color", "needs `bands` to choose from"));
        }
        return Ok(());
    };
    let items = arr.get_ref();
    if items.is_empty() || items.len() > 64 {
        return Err(d.err(
            arr.span(),
            "bands",
            format!("{} bands; give 1 to 64", items.len()),
        ));
    }
    let mut bands: Vec<Band> = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let at = format!("film.bands[{i}]");
        let crate::dict::Value::Table(t) = item.get_ref() else {
            return Err(ld.err(
                item.span(),
                at,
                "each band is a table: { name = \"red\", center = 665, width = 30 } or { name, min, max }",
            ));
        };
        let b = Dict::open(ld, at.clone(), None, item.span(), t, BAND_KEYS)?;
        let name = b.req_string("name")?;
        let n = name.get_ref();
        if n.is_empty()
            || !n
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
        {
            return Err(b.err(
                name.span(),
                "name",
                format!("'{n}': a band name is letters, digits, '_', '-' or '.' (it names an EXR channel)"),
            ));
        }
        if bands.iter().any(|x| x.name == *n) {
            return Err(b.err(name.span(), "name", format!("'{n}' names two bands")));
        }
        if let Some(file) = b.string("response")? {
            for other in ["center", "width", "min", "max"] {
                if let Some(v) = b.get(other) {
                    return Err(b.err(
                        v.span(),
                        other,
                        format!("band '{n}' has a `response` curve, which sets its wavelengths: drop `{other}`"),
                    ));
                }
            }
            let path = ld.path(file.get_ref());
            let key = format!("{at}.response");
            let text =
                crate::error::read_text(&path, "band response file", MAX_RESPONSE_FILE_BYTES)
                    .map_err(|e| SceneError::new(&e.file, e.line, key.clone(), e.message))?;
            let response = lamina_leaf::spectrum::bands::Response::parse(&text).map_err(|e| {
                SceneError::new(
                    &path,
                    (e.line > 0).then_some(e.line),
                    key.clone(),
                    format!("band '{n}': {}", e.message),
                )
            })?;
            bands.push(Band::with_response(n.to_string(), response));
            b.finish()?;
            continue;
        }
        let (lo, hi) = match (b.get("center"), b.get("min")) {
            (Some(_), None) => {
                let c = b.req_float("center", 360.0, 2500.0, false)?;
                let w = b.req_float("width", 0.0, 2140.0, true)?;
                (c - 0.5 * w, c + 0.5 * w)
            }
            (None, Some(_)) => (
                b.req_float("min", 360.0, 2500.0, false)?,
                b.req_float("max", 360.0, 2500.0, false)?,
            ),
            _ => {
                return Err(b.err(
                    item.span(),
                    "center",
                    "give `center` and `width`, `min` and `max` (nm), or a `response` file",
                ));
            }
        };
        if !(lo >= 360.0 && hi <= 2500.0 && hi > lo) {
            return Err(b.err(
                item.span(),
                "width",
                format!("band '{n}' spans {lo}-{hi} nm: it must lie inside 360-2500 nm and be wider than 0"),
            ));
        }
        bands.push(Band::flat(n.to_string(), lo, hi));
        b.finish()?;
    }
    let last = bands.len() - 1;
    let mut false_color = [0, 1.min(last), 2.min(last)];
    if let Some(fc) = fc {
        let names = fc.get_ref();
        if names.len() != 3 {
            return Err(d.err(
                fc.span(),
                "false_color",
                "give three band names (shown as red, green, blue)",
            ));
        }
        for (k, v) in names.iter().enumerate() {
            let crate::dict::Value::String(s) = v.get_ref() else {
                return Err(d.err(v.span(), "false_color", "band names are strings"));
            };
            false_color[k] = bands.iter().position(|b| b.name == *s).ok_or_else(|| {
                d.err(
                    v.span(),
                    "false_color",
                    format!(
                        "no band named '{s}' (the bands: {})",
                        bands
                            .iter()
                            .map(|b| b.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    ),
                )
            })?;
        }
    }
    ld.spectral
        .replace(Some(crate::SpectralOutput { bands, false_color }));
    Ok(())
}
