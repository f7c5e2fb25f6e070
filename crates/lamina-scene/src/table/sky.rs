//! `[sky]` (optional; none = black): light from every direction at infinity.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `type` | `constant`, `image` | required | |
//! | `radiance` | colour | required for `constant` | radiance from every direction |
//! | `file` | path | required for `image` | equirectangular (latitude-longitude) `.exr`/`.hdr` (linear) or 8-bit image (sRGB-decoded); top row = zenith (+y), `u = 0` at azimuth −π with φ = atan2(x, −z) |
//! | `scale` | >= 0 | `1` | multiplier |
//! | `rotation` | degrees | `0` | rotation about +y |

use crate::dict::{Dict, Keys, Kind, S, Table};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::Sky;
use lamina_leaf::Encoding;

/// The keys of `type = "constant"`.
pub(crate) const CONSTANT: Keys = Keys {
    own: &[("radiance", Kind::Color)],
    common: &[],
    typed: true,
};

/// The keys of `type = "image"`.
pub(crate) const IMAGE: Keys = Keys {
    own: &[
        ("file", Kind::Str),
        ("scale", Kind::Num),
        ("rotation", Kind::Num),
    ],
    common: &[],
    typed: true,
};

/// Checks the keys of `[sky]` and their types.
pub(crate) fn check(ld: &Loader, t: &S<Table>) -> Result<(), SceneError> {
    let kind = crate::dict::type_of(ld, "sky", t)?;
    let keys = match *kind.get_ref() {
        "constant" => CONSTANT,
        "image" => IMAGE,
        _ => return Ok(()),
    };
    Dict::open_among(
        ld,
        "sky",
        Some(*kind.get_ref()),
        t.span(),
        t.get_ref(),
        keys,
        vec![CONSTANT, IMAGE],
    )
    .map(drop)
}

/// Reads `[sky]`.
pub(crate) fn read(ld: &Loader, t: &S<Table>) -> Result<Sky, SceneError> {
    let kind = crate::dict::type_of(ld, "sky", t)?;
    let open = |keys| {
        Dict::open_among(
            ld,
            "sky",
            Some(*kind.get_ref()),
            t.span(),
            t.get_ref(),
            keys,
            vec![CONSTANT, IMAGE],
        )
    };
    let sky = match *kind.get_ref() {
        "constant" => {
            let d = open(CONSTANT)?;
            let sky = Sky::Constant(d.req_color("radiance")?);
            d.finish()?;
            sky
        }
        "image" => {
            let d = open(IMAGE)?;
            let file = d.req_string("file")?;
            let map = ld.texture(&file, "sky.file", Encoding::Srgb)?;
            if map
                .texels()
                .iter()
                .any(|t| !t.is_finite() || t.min_element() < 0.0)
            {
                return Err(d.err(
                    file.span(),
                    "file",
                    "the image has negative or non-finite texels",
                ));
            }
            let scale = d.float("scale", 0.0, 1e9, false, 1.0)?;
            let rotation_deg = d.float("rotation", -360.0, 360.0, false, 0.0)?;
            d.finish()?;
            Sky::Image {
                map,
                scale,
                rotation_deg,
            }
        }
        other => {
            return Err(ld.err(
                kind.span(),
                "sky.type",
                format!("unknown sky type '{other}' (constant, image)"),
            ));
        }
    };
    Ok(sky)
}
