//! A leaf material: the seven maps plus the parameters, queried per texel.

use crate::error::LeafError;
use crate::leaf_bsdf::LeafBsdf;
use crate::maps::{LeafDescription, LeafMaps};
use crate::params::LeafParams;
use glam::{Vec2, Vec3};
use std::path::Path;

/// A leaf's maps and validated parameters. `Send + Sync`; per-texel queries are cheap and
/// do not allocate.
#[derive(Clone, Debug)]
pub struct LeafMaterial {
    maps: LeafMaps,
    params: LeafParams,
}

impl LeafMaterial {
    /// A material from maps already in memory; validates `params`.
    pub fn new(maps: LeafMaps, params: LeafParams) -> Result<Self, LeafError> {
        params.validate()?;
        Ok(LeafMaterial { maps, params })
    }

    /// Loads the maps of `desc` (paths relative to `base_dir`) and validates its parameters.
    /// The error names the map and the file, or the parameter.
    pub fn load(desc: &LeafDescription, base_dir: &Path) -> Result<Self, LeafError> {
        desc.params.validate()?;
        let maps = LeafMaps::load(&desc.maps, base_dir)?;
        Self::new(maps, desc.params)
    }

    /// Alpha test at texture coordinates `uv`: `true` where the leaf is (matte `>= 0.5`).
    pub fn opaque(&self, uv: Vec2) -> bool {
        match &self.maps.alpha {
            None => true,
            Some(t) => t.alpha(uv).min(t.scalar(uv)) >= 0.5,
        }
    }

    /// The BSDF at texture coordinates `uv`.
    pub fn bsdf(&self, uv: Vec2) -> LeafBsdf {
        let front = self
            .maps
            .front
            .as_ref()
            .map_or(Vec3::new(0.05, 0.12, 0.03), |t| t.rgb(uv));
        let back = self.maps.back.as_ref().map_or(front * 1.2, |t| t.rgb(uv));
        let tr = self
            .maps
            .translucency
            .as_ref()
            .map_or(Vec3::new(0.06, 0.15, 0.02), |t| t.rgb(uv));
        LeafBsdf::placeholder(front, back, tr)
    }

    /// The validated parameters.
    pub fn params(&self) -> &LeafParams {
        &self.params
    }

    /// The maps.
    pub fn maps(&self) -> &LeafMaps {
        &self.maps
    }
}
