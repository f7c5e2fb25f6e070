//! `[integrator]`: which light transport, and its depth.
//!
//! | key | unit | default | meaning |
//! |---|---|---|---|
//! | `type` | `path`, `paper` | `path` | `path`: unidirectional path tracer with next-event estimation, MIS and Russian roulette; light passes leaf to leaf. `paper`: the paper's renderer: direct light only, per-light front/back/through-light shading, multiple scattering as an ambient term |
//! | `max_depth` | scattering events, >= 0 | `8` | `path` only: 1 is direct light (with the emission its BSDF sample finds), 0 only what camera rays see directly (emitters and the sky; surfaces black) |
//! | `rr_depth` | >= 1 | `3` | `path` only: depth from which Russian roulette may end a path |
//! | `light_sampling` | `all`, `one` | `all` | `path` only: which lights next-event estimation samples at each scattering vertex. `all`: every light, one shadow ray each (the least noise per sample). `one`: one light, drawn in proportion to its estimated power (distant lights and skies as seen by the scene's bounding sphere) and weighted by that probability: one shadow ray per vertex whatever the number of lights, as Mitsuba 3's `path` traces; more noise per sample, less time per sample |
//! | `sky_sampling` | `auto`, `light`, `bsdf` | `auto` | `path` only: how paths reach the sky. `light`: next-event estimation samples it (a shadow ray toward a direction drawn from the sky, combined with BSDF samples by MIS). `bsdf`: only the BSDF samples that continue paths reach it, counted in full when they escape: no shadow rays toward the sky. `auto`: `bsdf` for a `constant` sky (its own sampling is uniform over the sphere, never better than a diffuse BSDF's: about a quarter less time per sample for the same or less noise per unit time, see bench/README.md), `light` for an `image` or `sunsky` sky (bright regions only their own sampling finds) |
//! | `ambient` | colour (radiance) | the sky's mean radiance | `paper` only: ambient radiance that stands in for multiple scattering |

use crate::dict::{Dict, Keys, Kind, S, Table, Value};
use crate::error::SceneError;
use crate::loader::Loader;
use crate::scene::{Integrator, LightSampling, SkySampling};

/// The keys of `type = "path"`.
pub(crate) const PATH: Keys = Keys {
    own: &[
        ("max_depth", Kind::Int),
        ("rr_depth", Kind::Int),
        ("light_sampling", Kind::Str),
        ("sky_sampling", Kind::Str),
    ],
    common: &[],
    typed: true,
};

/// The keys of `type = "paper"`.
pub(crate) const PAPER: Keys = Keys {
    own: &[("ambient", Kind::Color)],
    common: &[],
    typed: true,
};

/// Reads `[integrator]` (absent: `path`, depth 8, Russian roulette from depth 3).
pub(crate) fn read(ld: &Loader, t: Option<&S<Table>>) -> Result<Integrator, SceneError> {
    let Some(t) = t else {
        return Ok(Integrator::Path {
            max_depth: 8,
            rr_depth: 3,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        });
    };
    let kind_value = t.get_ref().iter().find(|(k, _)| k.get_ref() == "type");
    let kind = match kind_value.map(|(_, v)| (v.get_ref(), v.span())) {
        None => "path",
        Some((Value::String(s), _)) => s.as_str(),
        Some((other, span)) => {
            return Err(ld.err(
                span,
                "integrator.type",
                format!("must be a string, got {}", other.type_name()),
            ));
        }
    };
    let open = |keys| {
        Dict::open_among(
            ld,
            "integrator",
            Some(kind),
            t.span(),
            t.get_ref(),
            keys,
            vec![PATH, PAPER],
        )
    };
    let integrator = match kind {
        "path" => {
            let d = open(PATH)?;
            let max_depth = d.count("max_depth", 0, 1024, 8)?;
            let rr_depth = d.count("rr_depth", 1, 1024, 3)?;
            let light_sampling = d.choice(
                "light_sampling",
                "light sampling",
                &[("all", LightSampling::All), ("one", LightSampling::One)],
                LightSampling::All,
            )?;
            let sky_sampling = d.choice(
                "sky_sampling",
                "sky sampling",
                &[
                    ("auto", SkySampling::Auto),
                    ("light", SkySampling::Light),
                    ("bsdf", SkySampling::Bsdf),
                ],
                SkySampling::Auto,
            )?;
            d.finish()?;
            Integrator::Path {
                max_depth,
                rr_depth,
                light_sampling,
                sky_sampling,
            }
        }
        "paper" => {
            let d = open(PAPER)?;
            let ambient = d.color_opt("ambient", None)?;
            d.finish()?;
            Integrator::Paper { ambient }
        }
        other => {
            let span = kind_value.map_or(t.span(), |(_, v)| v.span());
            return Err(ld.err(
                span,
                "integrator.type",
                format!("unknown integrator '{other}' (path, paper)"),
            ));
        }
    };
    Ok(integrator)
}
