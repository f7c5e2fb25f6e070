//! `[sky]` (optional; none = black): light from every direction at infinity.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `type` | `constant`, `image`, `sunsky` | required | |
//! | `radiance` | colour | required for `constant` | radiance from every direction |
//! | `file` | path | required for `image` | equirectangular (latitude-longitude) `.exr`/`.hdr` (linear) or 8-bit image (sRGB-decoded); top row = zenith (+y), `u = 0` at azimuth −π with φ = atan2(x, −z) |
//! | `scale` | >= 0 | `1` | multiplier |
//! | `rotation` | degrees | `0` | rotation about +y |
//! | `position` | table | required for `sunsky` | the place and time, as a sun's `position`: `latitude`, `longitude` (degrees, north and east positive), `elevation` (m, 0), `time` (ISO 8601 with its UTC offset), `north` (the scene's horizontal north, `[0, 0, -1]`) |
//! | `turbidity` | [1.7, 10] | `3` | `sunsky`: Preetham's turbidity (the sky's shape and colour) |
//! | `aod` | [0, 10] | `0.1` | `sunsky`: aerosol optical depth at 500 nm (SPCTRAL2) |
//! | `water` | cm, [0, 20] | `1.42` | `sunsky`: precipitable water (SPCTRAL2) |
//! | `ozone` | atm-cm, [0, 1] | `0.344` | `sunsky`: total ozone (SPCTRAL2) |
//! | `ground_albedo` | [0, 1] | `0.2` | `sunsky`: ground albedo of SPCTRAL2's sky-ground reflections |
//! | `sun` | bool | `true` | `sunsky`: also add the sun (the scene's last light), its direct normal irradiance from SPCTRAL2 |
//! | `sun_angular_diameter` | degrees, [0, 90] | `0.53` | `sunsky`: the sun's disc |
//! | `resolution` | pixels, 64-8192 | `512` | `sunsky`: width of the sky's map (height half) |
//!
//! `type = "sunsky"` is a physical sun and clear sky for a place and time (lamina-sky's
//! `SunSky`: NREL's SPA, SPCTRAL2's direct and diffuse spectra, Preetham's sky distribution
//! scaled to SPCTRAL2's diffuse irradiance), in lamina's RGB convention (`Y = ∫ L ȳ dλ`,
//! so an exposure near −6 suits it), and spectral in band renders (the map and the sun
//! remade per band, 300-2500 nm). Black below the horizon: give the scene a ground.

use crate::dict::{Dict, Keys, Kind, S, Table};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::{Light, Sky};
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

/// The keys of `type = "sunsky"`.
pub(crate) const SUNSKY: Keys = Keys {
    own: &[
        ("position", Kind::Table),
        ("turbidity", Kind::Num),
        ("aod", Kind::Num),
        ("water", Kind::Num),
        ("ozone", Kind::Num),
        ("ground_albedo", Kind::Num),
        ("sun", Kind::Bool),
        ("sun_angular_diameter", Kind::Num),
        ("resolution", Kind::Int),
    ],
    common: &[],
    typed: true,
};

/// A physical sun and sky made spectral for band renders: the model and the scene's frame.
#[derive(Debug)]
struct PhysicalSky {
    model: lamina_sky::SunSky,
    /// The scene's horizontal north (unit).
    north: glam::Vec3,
    /// Map width, pixels.
    width: u32,
    /// Whether the sky brought its sun.
    sun: bool,
}

impl PhysicalSky {
    fn to_sky(&self, d: glam::DVec3) -> glam::DVec3 {
        let north = self.north.as_dvec3();
        let east = north.cross(glam::DVec3::Y);
        glam::DVec3::new(d.dot(east), d.y, -d.dot(north))
    }

    fn map(&self, f: impl Fn(glam::DVec3) -> [f32; 3] + Sync) -> lamina_leaf::Texture {
        let px = lamina_sky::sunsky::bake_map(self.width, |d| self.to_sky(d), f);
        let texels = px
            .into_iter()
            .map(|c| glam::Vec4::new(c[0], c[1], c[2], 1.0))
            .collect();
        lamina_leaf::Texture::from_texels(
            self.width,
            (self.width / 2).max(1),
            texels,
            lamina_leaf::Wrap::Repeat,
        )
    }
}

impl lamina_core::SpectralSky for PhysicalSky {
    fn band_map(&self, bands: [&lamina_leaf::spectrum::bands::Band; 3]) -> lamina_leaf::Texture {
        self.band_maps(&[bands])
            .pop()
            .expect("one map per group of bands")
    }

    fn band_maps(
        &self,
        groups: &[[&lamina_leaf::spectrum::bands::Band; 3]],
    ) -> Vec<lamina_leaf::Texture> {
        // Every band of every group from one evaluation of the sky's spectrum per texel.
        let bands: Vec<&lamina_leaf::spectrum::bands::Band> =
            groups.iter().flat_map(|g| g.iter().copied()).collect();
        let n = bands.len();
        let weights = self.model.sky_band_weights(&bands);
        let values = lamina_sky::sunsky::bake_values(
            self.width,
            n,
            |d| self.to_sky(d),
            |v, out| {
                // One scratch row per thread, not an allocation per texel.
                thread_local!(static ROW: std::cell::RefCell<Vec<f64>> = const {
                    std::cell::RefCell::new(Vec::new())
                });
                ROW.with_borrow_mut(|f| {
                    f.resize(n, 0.0);
                    self.model.sky_bands_weighted(v, &weights, f);
                    for (o, x) in out.iter_mut().zip(f.iter()) {
                        *o = *x as f32;
                    }
                });
            },
        );
        let (w, h) = (self.width, (self.width / 2).max(1));
        // One pass over the values, each texel's groups to their maps (a pass per map read
        // the whole array once per group).
        let mut maps: Vec<Vec<glam::Vec4>> = (0..groups.len())
            .map(|_| Vec::with_capacity(values.len() / n.max(1)))
            .collect();
        for px in values.chunks_exact(n) {
            for (g, map) in maps.iter_mut().enumerate() {
                map.push(glam::Vec4::new(
                    px[3 * g],
                    px[3 * g + 1],
                    px[3 * g + 2],
                    1.0,
                ));
            }
        }
        maps.into_iter()
            .map(|texels| {
                lamina_leaf::Texture::from_texels(w, h, texels, lamina_leaf::Wrap::Repeat)
            })
            .collect()
    }

    fn band_sun(&self, bands: [&lamina_leaf::spectrum::bands::Band; 3]) -> Option<glam::Vec3> {
        self.sun
            .then(|| glam::Vec3::from(bands.map(|b| self.model.sun_band(b) as f32)))
    }
}

/// Checks the keys of `[sky]` and their types.
pub(crate) fn check(ld: &Loader, t: &S<Table>) -> Result<(), SceneError> {
    let kind = crate::dict::type_of(ld, "sky", t)?;
    let keys = match *kind.get_ref() {
        "constant" => CONSTANT,
        "image" => IMAGE,
        "sunsky" => SUNSKY,
        _ => return Ok(()),
    };
    Dict::open_among(
        ld,
        "sky",
        Some(*kind.get_ref()),
        t.span(),
        t.get_ref(),
        keys,
        vec![CONSTANT, IMAGE, SUNSKY],
    )
    .map(drop)
}

/// Reads `[sky]`, and the sun a `sunsky` brings (to be the scene's last light).
pub(crate) fn read(ld: &Loader, t: &S<Table>) -> Result<(Sky, Option<Light>), SceneError> {
    let kind = crate::dict::type_of(ld, "sky", t)?;
    let open = |keys| {
        Dict::open_among(
            ld,
            "sky",
            Some(*kind.get_ref()),
            t.span(),
            t.get_ref(),
            keys,
            vec![CONSTANT, IMAGE, SUNSKY],
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
                spectral: None,
            }
        }
        "sunsky" => {
            return read_sunsky(open(SUNSKY)?, t);
        }
        other => {
            return Err(ld.err(
                kind.span(),
                "sky.type",
                format!("unknown sky type '{other}' (constant, image, sunsky)"),
            ));
        }
    };
    Ok((sky, None))
}

/// Reads `type = "sunsky"`: the model, its RGB map, and its sun.
fn read_sunsky(d: Dict, t: &S<Table>) -> Result<(Sky, Option<Light>), SceneError> {
    let pos = d.table("position")?.ok_or_else(|| d.missing("position"))?;
    let place = crate::light::sun::read_place(&d, "position", pos)?;
    let mut p = lamina_sky::SunSkyParams::new(place.observer, place.time);
    p.turbidity = d.float("turbidity", 1.7, 10.0, false, 3.0)? as f64;
    p.aod500 = d.float("aod", 0.0, 10.0, false, 0.1)? as f64;
    p.water = d.float("water", 0.0, 20.0, false, 1.42)? as f64;
    p.ozone = d.float("ozone", 0.0, 1.0, false, 0.344)? as f64;
    p.ground_albedo = d.float("ground_albedo", 0.0, 1.0, false, 0.2)? as f64;
    let sun = d.boolean("sun")?.unwrap_or(true);
    let angular = d.float("sun_angular_diameter", 0.0, 90.0, false, 0.53)?;
    let width = d.count("resolution", 64, 8192, 512)?;
    let model = lamina_sky::SunSky::new(&p).map_err(|e| {
        let span = if e.field == "time" {
            place.time_span.clone()
        } else {
            t.span()
        };
        let key = match e.field {
            "time" | "latitude" | "longitude" | "elevation" => format!("position.{}", e.field),
            "aod500" => "aod".into(),
            "precipitable_water" => "water".into(),
            other => other.to_string(),
        };
        d.err(span, &key, e.message)
    })?;
    d.finish()?;
    let physical = PhysicalSky {
        north: place.north,
        width,
        sun,
        model,
    };
    let map = physical.map(|v| physical.model.sky_rgb(v).as_vec3().to_array());
    let light = sun.then(|| Light::Sun {
        direction: place.to_scene(physical.model.sun_direction()).normalize(),
        irradiance: physical.model.sun_rgb().as_vec3(),
        angular_diameter_deg: angular,
    });
    Ok((
        Sky::Image {
            map,
            scale: 1.0,
            rotation_deg: 0.0,
            spectral: Some(std::sync::Arc::new(physical)),
        },
        light,
    ))
}
