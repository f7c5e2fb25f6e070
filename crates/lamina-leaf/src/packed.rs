//! The maps [`crate::LeafMaterial::bsdf`] reads per hit, interleaved into one texel grid.
//!
//! Per hit the material reads the front, back and translucency colours, the thickness and
//! extinction values and the bump gradient (four lookups around the hit): nine bilinear
//! lookups in six separate images, each its own cache misses. [`PackedMaps`] stores one
//! 48-byte record per texel holding every one of those maps' values at that texel, so one
//! bilinear footprint (two rows of two records) serves all of them, and the bump gradient's
//! four footprints read the same records' bump lane.
//!
//! **Same results**: the lookups use the very addressing and filter of
//! [`crate::Texture::sample`] and [`crate::Texture::gradient`] ([`Footprint`]), channel by
//! channel on the same texel values, so every value read is bit-identical to the per-map
//! lookup. Nothing of the (non-linear) layer model is tabulated here: the model still runs
//! on the filtered map values.
//!
//! **When**: maps of 1 x 1 texels are constants and read as such; all other maps present
//! must share one size and wrap mode, and that size must be at most [`MAX_PACKED_TEXELS`]
//! texels (48 bytes each: 192 MiB at the limit, next to the maps' own 16 bytes per texel
//! and map). Otherwise the material reads the maps one by one (same results, slower).

use crate::maps::LeafMaps;
use crate::texture::{Footprint, Lerp, Texture, Wrap, gradient};
use glam::{Vec2, Vec3, Vec4};
use std::sync::Arc;

/// Largest number of texels (2048 x 2048) of the packed grid: 192 MiB of records.
pub const MAX_PACKED_TEXELS: u64 = 1 << 22;

/// One texel of the packed grid: `[front.rgb, thickness]`, `[back.rgb, extinction]`,
/// `[translucency.rgb, bump]` (first channel of the data maps; zero for a map that is
/// absent or constant).
type Record = [Vec4; 3];

impl Lerp for Record {
    #[inline]
    fn lerp(self, b: Self, s: f32) -> Self {
        [
            self[0].lerp(b[0], s),
            self[1].lerp(b[1], s),
            self[2].lerp(b[2], s),
        ]
    }
}

/// Where one map's value comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Source {
    /// No map.
    Absent,
    /// A 1 x 1 map: its texel (what [`Texture::sample`] returns everywhere).
    Constant(Vec4),
    /// A lane of the packed grid.
    Grid,
}

impl Source {
    fn of(map: &Option<Texture>) -> Self {
        match map {
            None => Source::Absent,
            Some(t) if t.width() == 1 && t.height() == 1 => Source::Constant(t.texels()[0]),
            Some(_) => Source::Grid,
        }
    }
}

/// The filtered map values at one hit, as the per-map lookups give them: colours (linear
/// RGB, before any clamping), the thickness and extinction map values and the bump map's
/// gradient (per unit of texture coordinate).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct MapValues {
    pub front: Option<Vec3>,
    pub back: Option<Vec3>,
    pub translucency: Option<Vec3>,
    pub thickness: Option<f32>,
    pub extinction: Option<f32>,
    /// `None` without a bump map or when the gradient was not asked for.
    pub bump_gradient: Option<Vec2>,
}

impl MapValues {
    /// The per-map lookups (the reference the packed grid reproduces).
    pub fn read(maps: &LeafMaps, uv: Vec2, with_bump: bool) -> Self {
        MapValues {
            front: maps.front.as_ref().map(|t| t.rgb(uv)),
            back: maps.back.as_ref().map(|t| t.rgb(uv)),
            translucency: maps.translucency.as_ref().map(|t| t.rgb(uv)),
            thickness: maps.thickness.as_ref().map(|t| t.scalar(uv)),
            extinction: maps.extinction.as_ref().map(|t| t.scalar(uv)),
            bump_gradient: if with_bump {
                maps.bump.as_ref().map(|t| t.gradient(uv))
            } else {
                None
            },
        }
    }
}

/// The six per-hit maps of a leaf interleaved (see the module docs).
#[derive(Clone, Debug)]
pub(crate) struct PackedMaps {
    width: u32,
    height: u32,
    wrap: Wrap,
    /// Row-major, top row first; empty when every map is absent or constant.
    texels: Arc<[Record]>,
    /// front, back, translucency, thickness, extinction, bump.
    sources: [Source; 6],
}

impl PackedMaps {
    /// The grid of `maps`, or `None` where the maps do not share one size and wrap mode or
    /// are larger than [`MAX_PACKED_TEXELS`].
    pub fn new(maps: &LeafMaps) -> Option<Self> {
        let all = [
            &maps.front,
            &maps.back,
            &maps.translucency,
            &maps.thickness,
            &maps.extinction,
            &maps.bump,
        ];
        let sources = all.map(Source::of);
        let mut size = None;
        for (m, s) in all.iter().zip(&sources) {
            if let (Some(t), Source::Grid) = (m, s) {
                let this = (t.width(), t.height(), t.wrap);
                match size {
                    None => size = Some(this),
                    Some(first) if first != this => return None,
                    Some(_) => {}
                }
            }
        }
        let (width, height, wrap) = size.unwrap_or((1, 1, Wrap::Repeat));
        if width as u64 * height as u64 > MAX_PACKED_TEXELS {
            return None;
        }
        let texels: Arc<[Record]> = if size.is_none() {
            Arc::from(Vec::new())
        } else {
            let n = (width * height) as usize;
            let lane = |k: usize| -> Option<&[Vec4]> {
                match (all[k], sources[k]) {
                    (Some(t), Source::Grid) => Some(t.texels()),
                    _ => None,
                }
            };
            let lanes = [0, 1, 2, 3, 4, 5].map(lane);
            (0..n)
                .map(|i| {
                    let rgb = |k: usize| lanes[k].map_or(Vec3::ZERO, |t| t[i].truncate());
                    let x = |k: usize| lanes[k].map_or(0.0, |t| t[i].x);
                    [
                        rgb(0).extend(x(3)),
                        rgb(1).extend(x(4)),
                        rgb(2).extend(x(5)),
                    ]
                })
                .collect()
        };
        Some(PackedMaps {
            width,
            height,
            wrap,
            texels,
            sources,
        })
    }

    /// The grid of `maps` taken from `like`, the grid of `like_maps`, without copying it,
    /// where every map `maps` packs is the very image `like_maps` packed in its place
    /// ([`Texture::is_same_image`]; the colour maps may differ where they are constants, as
    /// in a pigment leaf's per-wavelength materials); otherwise [`Self::new`].
    pub fn new_like(maps: &LeafMaps, like: &PackedMaps, like_maps: &LeafMaps) -> Option<Self> {
        let all = |m: &LeafMaps| {
            [
                m.front.clone(),
                m.back.clone(),
                m.translucency.clone(),
                m.thickness.clone(),
                m.extinction.clone(),
                m.bump.clone(),
            ]
        };
        let (mine, theirs) = (all(maps), all(like_maps));
        let sources = mine.clone().map(|m| Source::of(&m));
        let shared = (0..6).all(|k| match (&mine[k], &theirs[k], sources[k]) {
            (_, _, s) if s != Source::Grid => true,
            (Some(a), Some(b), _) => like.sources[k] == Source::Grid && a.is_same_image(b),
            _ => false,
        });
        if !shared {
            return Self::new(maps);
        }
        Some(PackedMaps {
            sources,
            ..like.clone()
        })
    }

    /// The shared records (tests: which grid a material holds).
    #[cfg(test)]
    pub(crate) fn texels_arc(&self) -> Arc<[Record]> {
        self.texels.clone()
    }

    /// The filtered values at `uv`, bit-identical to [`MapValues::read`].
    #[inline]
    pub fn read(&self, uv: Vec2, with_bump: bool) -> MapValues {
        self.values(&self.lookup(uv, with_bump))
    }

    /// Whether `other` holds this very grid and reads its data maps (thickness, extinction,
    /// bump) the same way (a material in other channels sharing the maps; colour sources
    /// may differ): then one [`Self::lookup`] serves both.
    pub fn shares_grid(&self, other: &PackedMaps) -> bool {
        Arc::ptr_eq(&self.texels, &other.texels)
            && (self.width, self.height, self.wrap) == (other.width, other.height, other.wrap)
            && self.sources[3..] == other.sources[3..]
    }

    /// The grid's filtered record at `uv` and the bump lane's gradient (when asked for and
    /// in the grid): what [`Self::values`] turns into map values.
    #[inline]
    pub fn lookup(&self, uv: Vec2, with_bump: bool) -> Lookup {
        let grid = self.sources.contains(&Source::Grid);
        let rec = if grid {
            Footprint::new(self.width, self.height, self.wrap, uv).filter(|i| self.texels[i])
        } else {
            [Vec4::ZERO; 3]
        };
        let bump = (with_bump && self.sources[5] == Source::Grid).then(|| {
            gradient(self.width, self.height, self.wrap, uv, |i| {
                self.texels[i][2].w
            })
        });
        Lookup {
            rec,
            bump,
            with_bump,
        }
    }

    /// The map values of a [`Self::lookup`] of this grid or of one it
    /// [shares](Self::shares_grid), by this material's sources (its constants, its absent
    /// maps).
    #[inline]
    pub fn values(&self, l: &Lookup) -> MapValues {
        let rec = l.rec;
        let [f, b, tr, th, ex, bu] = self.sources;
        let rgb = |s: Source, lane: usize| match s {
            Source::Absent => None,
            Source::Constant(v) => Some(v.truncate()),
            Source::Grid => Some(rec[lane].truncate()),
        };
        let scalar = |s: Source, lane: usize| match s {
            Source::Absent => None,
            Source::Constant(v) => Some(v.x),
            Source::Grid => Some(rec[lane].w),
        };
        let bump_gradient = match bu {
            _ if !l.with_bump => None,
            Source::Absent => None,
            Source::Constant(_) => Some(Vec2::ZERO),
            Source::Grid => l.bump,
        };
        MapValues {
            front: rgb(f, 0),
            back: rgb(b, 1),
            translucency: rgb(tr, 2),
            thickness: scalar(th, 0),
            extinction: scalar(ex, 1),
            bump_gradient,
        }
    }
}

/// One filtered read of a packed grid ([`PackedMaps::lookup`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lookup {
    rec: Record,
    bump: Option<Vec2>,
    with_bump: bool,
}
