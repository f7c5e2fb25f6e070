//! lamina's ray-tracing core: the one place that intersects rays with a scene.
//!
//! Input is plain geometry ([`SceneDesc`]: triangles and parallelogram leaf cards per
//! [`Geometry`], prototypes placed by [`Instance`]s, spheres, per-primitive alpha with a
//! 3-state [`OpacityMask`] per matte); it never sees materials or lights. Output is a
//! preliminary [`Hit`] (distance, primitive, instance, barycentrics) from which the
//! renderer rebuilds the surface.
//!
//! * **Wide BVHs** (the `layout` module's docs): a binned-SAH binary build
//!   (multithreaded) collapsed to 8-wide nodes for AVX2 or 4-wide for SSE and the scalar
//!   kernel, chosen at build time by CPU feature detection ([`Kernel::best`]); leaves hold
//!   four primitives in structure-of-arrays form, triangles and cards tested together.
//! * **Two levels**: one bottom level per [`Geometry`] (the world, each prototype), a wide
//!   top level over the instances. A ray enters a prototype in object space with its
//!   direction *not renormalised*, so `t` means the same in every space and one `tmax`
//!   serves all levels. A prototype of at most four primitives (a leaf card) has no tree:
//!   the instance's leaf is its single pack.
//! * **Alpha in the leaf test**: an alpha-tested primitive is hit only where its matte is
//!   opaque. The matte's [`OpacityMask`] decides opaque and transparent cells with one byte
//!   read; only unknown cells ask the caller's [`AlphaFilter`] (the exact matte).
//! * **Queries**: [`Accel::intersect`] (closest accepted hit, children entered nearest
//!   first), [`Accel::occluded`] (any accepted hit, stops at the first), both skipping the
//!   primitive a ray leaves ([`PrimRef`]). Directions with `-0` components are fine.
//! * **Backends**: this crate's engine; with the `embree` feature, Embree 3 through a thin
//!   FFI of ours (the `embree` module), for benchmarks and for users who want it.
//!
//! `unsafe` lives here only (the SIMD kernels and the Embree FFI), each block with the
//! argument that it is sound. Where this crate sits among the others: ARCHITECTURE.md.

#![warn(missing_docs)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Lane and axis loops index several parallel arrays at once (SoA), the form the kernels'
// SIMD code mirrors; comparisons spell out NaN handling; the traversal's inner functions
// take the ray, the level and the caller's filter and counter separately so that
// everything stays in registers.
#![allow(
    clippy::needless_range_loop,
    clippy::manual_range_contains,
    clippy::too_many_arguments
)]
#![deny(unsafe_op_in_unsafe_fn)]

pub mod build;
pub mod desc;
pub mod direction;
#[cfg(feature = "embree")]
pub mod embree;
#[cfg(feature = "embree")]
mod embree_build;
pub mod grid;
mod kernel;
mod layout;
pub mod mask;
mod memory;
#[cfg(test)]
mod tests;
mod top;
mod traverse;
mod trim;
pub mod view;
pub mod wide;

pub use build::Aabb;
pub use desc::{Geometry, Instance, Prim, PrimAlpha, SceneDesc, Sphere};
pub use grid::GridStats;
pub use mask::{MaskWrap, OpacityMask};

use glam::{Vec2, Vec3};
use layout::{Blas, InstRec, Tlas};
use std::cell::Cell;
use traverse::Levels;

/// A ray: `origin + t·dir` for `t ∈ (0, tmax)`. Distances are in units of `dir`'s length
/// (metres for a unit direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin (m).
    pub origin: Vec3,
    /// Direction; need not be unit length, must be finite and non-zero.
    pub dir: Vec3,
    /// Largest distance considered; `f32::INFINITY` for none.
    pub tmax: f32,
}

impl Ray {
    /// Lane `k` of rays from `eye` kept as one direction array per axis (`d[0]` x, `d[1]`
    /// y, `d[2]` z; what [`Accel::intersect_eye`] takes), with no limit.
    ///
    /// # Panics
    /// When `k` is past an array of `d`.
    #[inline(always)]
    pub fn from_eye_lane(eye: Vec3, d: [&[f32]; 3], k: usize) -> Ray {
        Ray {
            origin: eye,
            dir: Vec3::new(d[0][k], d[1][k], d[2][k]),
            tmax: f32::INFINITY,
        }
    }
}

/// [`PrimRef::inst`] of the world geometry.
pub const NO_INSTANCE: u32 = u32::MAX;
/// [`PrimRef::inst`] of a sphere (its index in [`SceneDesc::spheres`] is `prim`).
pub const SPHERE: u32 = u32::MAX - 1;
/// "No primitive" in [`PrimRef::prim`].
pub const NO_PRIM: u32 = u32::MAX;

/// A primitive of the scene: primitive `prim` (index in its [`Geometry`]) of the world
/// (`inst == NO_INSTANCE`) or of instance `inst`'s prototype, or sphere `prim`
/// (`inst == SPHERE`). Instance ids are the top level's order, which keeps instance
/// records next to their tree neighbours and costs no index per instance;
/// [`Accel::scene_instances`] maps them to [`SceneDesc::instances`] indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct PrimRef {
    /// Instance index, [`NO_INSTANCE`] or [`SPHERE`].
    pub inst: u32,
    /// Primitive index, or [`NO_PRIM`].
    pub prim: u32,
}

impl PrimRef {
    /// No primitive: nothing to skip.
    pub const NONE: PrimRef = PrimRef {
        inst: NO_INSTANCE,
        prim: NO_PRIM,
    };
}

/// The closest accepted hit along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray (units of its direction's length).
    pub t: f32,
    /// What was hit.
    pub prim: PrimRef,
    /// Barycentric coordinates of `v[1]` and `v[2]` (parallelograms: `b1, b2 ∈ [0, 1]`
    /// along the two edges); zero on a sphere.
    pub bary: Vec2,
}

/// The exact alpha test, asked only for candidate hits in cells an [`OpacityMask`] cannot
/// decide (or on mattes without one).
pub trait AlphaFilter {
    /// Whether the matte `id` ([`PrimAlpha::id`]) is opaque at texture coordinates `uv`.
    fn opaque(&self, id: u32, uv: Vec2) -> bool;
}

impl<F: Fn(u32, Vec2) -> bool> AlphaFilter for F {
    #[inline(always)]
    fn opaque(&self, id: u32, uv: Vec2) -> bool {
        self(id, uv)
    }
}

/// What a traversal did, for [`TraversalStats`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Event {
    /// A wide node tested.
    Node,
    /// A leaf pack tested.
    Pack,
    /// An instance entered.
    Instance,
    /// A candidate on a matte decided opaque by its mask.
    MaskOpaque,
    /// A candidate on a matte decided transparent by its mask.
    MaskTransparent,
    /// A candidate that asked the [`AlphaFilter`].
    AlphaLookup,
}

/// Counts traversal events; `()` counts nothing and costs nothing.
pub trait Counter {
    /// Records one event.
    fn count(&self, e: Event);
}

impl Counter for () {
    #[inline(always)]
    fn count(&self, _: Event) {}
}

/// Traversal counters (for benchmarks: steps per ray, alpha lookups skipped).
#[derive(Debug, Default)]
pub struct TraversalStats {
    /// Wide nodes tested.
    pub nodes: Cell<u64>,
    /// Leaf packs tested.
    pub packs: Cell<u64>,
    /// Instances entered.
    pub instances: Cell<u64>,
    /// Alpha candidates the masks decided opaque.
    pub mask_opaque: Cell<u64>,
    /// Alpha candidates the masks decided transparent.
    pub mask_transparent: Cell<u64>,
    /// Alpha candidates that asked the exact matte.
    pub alpha_lookups: Cell<u64>,
}

impl Counter for TraversalStats {
    #[inline]
    fn count(&self, e: Event) {
        let c = match e {
            Event::Node => &self.nodes,
            Event::Pack => &self.packs,
            Event::Instance => &self.instances,
            Event::MaskOpaque => &self.mask_opaque,
            Event::MaskTransparent => &self.mask_transparent,
            Event::AlphaLookup => &self.alpha_lookups,
        };
        c.set(c.get() + 1);
    }
}

/// The traversal kernel (instruction set and node width).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// 8-wide nodes, AVX2 + FMA (x86-64; also uses BMI1/2, LZCNT and POPCNT, which every
    /// AVX2 CPU has, for the walk's bit arithmetic).
    Avx2,
    /// 4-wide nodes, SSE2 (every x86-64 CPU).
    Sse,
    /// 4-wide nodes in plain loops (any CPU).
    Scalar,
}

impl Kernel {
    /// The fastest kernel this CPU runs, unless `LAMINA_ACCEL_KERNEL` (`avx2`, `sse`,
    /// `scalar`) names another one it runs. A value that names no kernel, or one this CPU
    /// cannot run, is said once on standard error and the fastest kernel is used.
    pub fn best() -> Kernel {
        let value = std::env::var("LAMINA_ACCEL_KERNEL").ok();
        let (kernel, warning) = Kernel::chosen(value.as_deref());
        if let Some(w) = warning {
            static WARNED: std::sync::Once = std::sync::Once::new();
            WARNED.call_once(|| eprintln!("warning: {w}"));
        }
        kernel
    }

    /// The kernel [`Self::best`] picks for the value of `LAMINA_ACCEL_KERNEL` (`None`:
    /// unset), and what is wrong with the value, if anything.
    pub fn chosen(value: Option<&str>) -> (Kernel, Option<String>) {
        let fastest = [Kernel::Avx2, Kernel::Sse, Kernel::Scalar]
            .into_iter()
            .find(|k| k.available())
            .unwrap_or(Kernel::Scalar);
        let Some(v) = value.filter(|v| !v.trim().is_empty()) else {
            return (fastest, None);
        };
        match Kernel::parse(v) {
            Some(k) if k.available() => (k, None),
            Some(k) => (
                fastest,
                Some(format!(
                    "LAMINA_ACCEL_KERNEL={v}: this CPU cannot run the {k:?} kernel; using \
                     {fastest:?}"
                )),
            ),
            None => (
                fastest,
                Some(format!(
                    "LAMINA_ACCEL_KERNEL={v}: not a kernel (avx2, sse or scalar); using \
                     {fastest:?}"
                )),
            ),
        }
    }

    /// `"avx2"`, `"sse"` or `"scalar"`.
    pub fn parse(s: &str) -> Option<Kernel> {
        match s.trim().to_ascii_lowercase().as_str() {
            "avx2" => Some(Kernel::Avx2),
            "sse" => Some(Kernel::Sse),
            "scalar" => Some(Kernel::Scalar),
            _ => None,
        }
    }

    /// Whether this CPU has the kernel's instructions.
    pub fn available(self) -> bool {
        match self {
            #[cfg(target_arch = "x86_64")]
            Kernel::Avx2 => {
                is_x86_feature_detected!("avx2")
                    && is_x86_feature_detected!("fma")
                    && is_x86_feature_detected!("bmi1")
                    && is_x86_feature_detected!("bmi2")
                    && is_x86_feature_detected!("lzcnt")
                    && is_x86_feature_detected!("popcnt")
            }
            #[cfg(target_arch = "x86_64")]
            Kernel::Sse => true,
            Kernel::Scalar => true,
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }

    /// Children per node.
    pub fn width(self) -> usize {
        match self {
            Kernel::Avx2 => 8,
            _ => 4,
        }
    }
}

/// Why a scene cannot be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum AccelError {
    /// An instance names a prototype that does not exist.
    #[error("instance {instance} uses prototype {prototype}, but there are {count} prototypes")]
    Prototype {
        /// Instance index.
        instance: usize,
        /// The prototype it names.
        prototype: u32,
        /// Number of prototypes.
        count: usize,
    },
    /// An instance transform that is not finite and invertible.
    #[error("instance {0}: the transform is not finite and invertible")]
    Transform(usize),
    /// The requested kernel does not run on this CPU.
    #[error("the {0:?} kernel does not run on this CPU")]
    Kernel(Kernel),
    /// More than 2³⁰ primitives in one geometry, or 2³⁰ instances.
    #[error("{0}: more than 2^30 entries")]
    TooLarge(&'static str),
    /// An error of the Embree backend or of Embree's builder ([`Builder::EmbreeHigh`]).
    #[error("Embree: {0}")]
    Embree(String),
}

/// Build settings.
#[derive(Clone, Copy, Debug)]
pub struct BuildOptions {
    /// The kernel (and so the node width); [`Kernel::best`] by default.
    pub kernel: Kernel,
    /// SAH cost of a node visit relative to a 4-primitive leaf test (default 1.0).
    pub trav_cost: f32,
    /// Which builder makes the bottom levels' trees ([`Builder::Lamina`] by default).
    pub builder: Builder,
    /// Whether boxes and grids bound only the part of a masked primitive its opacity mask
    /// does not call transparent (default `true`; the same answers either way, see
    /// `trim.rs`: `false` is there to measure and test that).
    pub trim_masked: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            kernel: Kernel::best(),
            trav_cost: 1.0,
            builder: Builder::default(),
            trim_masked: true,
        }
    }
}

/// The builder of the bottom levels' binary trees (before the collapse to the wide layout,
/// which is always lamina's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[non_exhaustive]
pub enum Builder {
    /// lamina's binned SAH (`build.rs`).
    #[default]
    Lamina,
    /// Embree 3's builder at `RTC_BUILD_QUALITY_HIGH` (binned SAH with spatial splits),
    /// cargo feature `embree`: lamina's traversal over Embree's tree, to compare the two
    /// builders' trees with the traversal held fixed.
    #[cfg(feature = "embree")]
    EmbreeHigh,
}

#[derive(Clone, Debug)]
enum Engine {
    W8(Levels<8>),
    W4(Levels<4>),
}

/// Memory held by an [`Accel`], in bytes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AccelMemory {
    /// The world geometry's tree and packs.
    pub world: usize,
    /// Every prototype's tree and packs, each once.
    pub prototypes: usize,
    /// The instance records (52 bytes each) and the top level over them.
    pub instances: usize,
    /// Opacity masks.
    pub masks: usize,
    /// Grids for shadow rays toward distant lights ([`Accel::index_direction`]) and for
    /// camera rays ([`Accel::index_view`]).
    pub grids: usize,
    /// Number of instances in the top level.
    pub instance_count: usize,
}

impl AccelMemory {
    /// All of it.
    pub fn total(&self) -> usize {
        self.world + self.prototypes + self.instances + self.masks + self.grids
    }

    /// Bytes per instance of the instance level; 0 without instances.
    pub fn bytes_per_instance(&self) -> f64 {
        if self.instance_count == 0 {
            0.0
        } else {
            self.instances as f64 / self.instance_count as f64
        }
    }
}

/// The acceleration structure of a [`SceneDesc`].
#[derive(Clone, Debug)]
pub struct Accel {
    kernel: Kernel,
    trav_cost: f32,
    engine: Engine,
}

fn build_levels<const W: usize>(
    desc: &SceneDesc,
    opts: &BuildOptions,
) -> Result<Levels<W>, AccelError> {
    let (trav_cost, builder) = (opts.trav_cost, opts.builder);
    let live_uv = opts.trim_masked.then(|| trim::live_uvs(&desc.masks));
    let live = live_uv.as_deref();
    if desc.instances.len() >= 1 << 30 {
        return Err(AccelError::TooLarge("instances"));
    }
    if desc.world.prims.len() >= 1 << 30 || desc.prototypes.iter().any(|g| g.prims.len() >= 1 << 30)
    {
        return Err(AccelError::TooLarge("a geometry"));
    }
    let mut used = vec![false; desc.prototypes.len()];
    let mut recs = Vec::with_capacity(desc.instances.len());
    for (i, inst) in desc.instances.iter().enumerate() {
        let Some(u) = used.get_mut(inst.prototype as usize) else {
            return Err(AccelError::Prototype {
                instance: i,
                prototype: inst.prototype,
                count: desc.prototypes.len(),
            });
        };
        *u = true;
        let m = inst.object_to_world;
        let inv = m.inverse();
        if !(m.matrix3.determinant().abs() > 0.0 && m.is_finite() && inv.is_finite()) {
            return Err(AccelError::Transform(i));
        }
        let mut w2o = [0.0f32; 12];
        inv.write_cols_to_slice(&mut w2o);
        recs.push(InstRec {
            w2o,
            proto: inst.prototype,
        });
    }
    let (world, protos) = rayon::join(
        || Blas::<W>::build(&desc.world, trav_cost, builder, live),
        || {
            use rayon::prelude::*;
            desc.prototypes
                .par_iter()
                .zip(&used)
                .map(|(g, &u)| {
                    if u {
                        Blas::<W>::build(g, trav_cost, builder, live)
                    } else {
                        Blas::<W>::build(&Geometry::default(), trav_cost, builder, None)
                    }
                })
                .collect::<Result<Vec<_>, _>>()
        },
    );
    let (world, protos) = (world?, protos?);
    let (ids, boxes) = top_boxes(desc, &protos);
    let (tlas, top_recs) = if boxes.is_empty() {
        (None, Vec::new())
    } else {
        let top = top::build_top(&build::build_binary(&boxes, top_params(trav_cost)), &boxes);
        let top_recs = top
            .order
            .iter()
            .map(|&k| recs[ids[k as usize] as usize])
            .collect();
        (
            Some(Tlas {
                nodes: top.nodes,
                root: top.root,
            }),
            top_recs,
        )
    };
    Ok(Levels {
        world,
        protos,
        tlas,
        recs: top_recs,
        // Invalid spheres keep their index (a hit names the sphere by it) and are never hit.
        spheres: desc
            .spheres
            .iter()
            .map(|s| {
                let valid = s.center.is_finite() && s.radius > 0.0 && s.radius.is_finite();
                if valid {
                    *s
                } else {
                    Sphere {
                        center: Vec3::ZERO,
                        radius: 0.0,
                    }
                }
            })
            .collect(),
        masks: desc.masks.clone(),
        live_uv,
        dirs: Vec::new(),
        view: None,
    })
}

/// The binary build settings of the top level: one instance per leaf.
fn top_params(trav_cost: f32) -> build::BuildParams {
    build::BuildParams {
        max_leaf: top::TOP_LEAF,
        pack: top::TOP_LEAF,
        trav_cost,
    }
}

/// Most distinct vertices a prototype's instances are bounded by one by one; above it, by
/// the corners of the prototype's box.
const MAX_HULL_POINTS: usize = 64;

/// The object-space points whose transformed box bounds an instance of prototype `g` (box
/// `b`): its distinct vertices (a parallelogram's four corners) when there are at most
/// [`MAX_HULL_POINTS`], so that a turned leaf gets the box of its turned vertices, not the
/// larger box of its turned box; otherwise the eight corners of `b`.
fn hull_points(g: &Geometry, b: Aabb) -> Vec<Vec3> {
    let mut pts: Vec<[u32; 3]> = Vec::new();
    for p in g.prims.iter().filter(|p| p.is_valid()) {
        let mut add = |v: Vec3| pts.push(v.to_array().map(f32::to_bits));
        p.v.iter().for_each(|&v| add(v));
        if p.quad {
            add(p.v[1] + p.v[2] - p.v[0]);
        }
        if pts.len() > 4 * MAX_HULL_POINTS {
            pts.sort_unstable();
            pts.dedup();
            if pts.len() > MAX_HULL_POINTS {
                break;
            }
        }
    }
    pts.sort_unstable();
    pts.dedup();
    if pts.len() > MAX_HULL_POINTS || pts.is_empty() {
        return (0..8)
            .map(|k| {
                Vec3::new(
                    if k & 1 == 0 { b.min.x } else { b.max.x },
                    if k & 2 == 0 { b.min.y } else { b.max.y },
                    if k & 4 == 0 { b.min.z } else { b.max.z },
                )
            })
            .collect();
    }
    pts.into_iter()
        .map(|p| Vec3::from_array(p.map(f32::from_bits)))
        .collect()
}

/// The instances the top level holds (those whose prototype is not empty), as scene
/// indices, and their world boxes: the box of the prototype's [`hull_points`] placed by
/// the instance, widened by a few units in the last place of its coordinates (the
/// transform's rounding; traversal tests the untransformed geometry in object space).
fn top_boxes<const W: usize>(desc: &SceneDesc, protos: &[Blas<W>]) -> (Vec<u32>, Vec<Aabb>) {
    use rayon::prelude::*;
    let hulls: Vec<Option<Vec<Vec3>>> = protos
        .par_iter()
        .zip(&desc.prototypes)
        // Prototypes no instance uses were built empty (no bounds): no hull made for them.
        .map(|(blas, g)| blas.bounds.map(|b| hull_points(g, b)))
        .collect();
    let ids: Vec<u32> = (0..desc.instances.len() as u32)
        .filter(|&i| hulls[desc.instances[i as usize].prototype as usize].is_some())
        .collect();
    let boxes = ids
        .par_iter()
        .map(|&i| {
            let inst = &desc.instances[i as usize];
            let m = inst.object_to_world;
            let pts = hulls[inst.prototype as usize].as_deref().unwrap_or(&[]);
            let b = pts
                .iter()
                .fold(Aabb::EMPTY, |b, &p| b.grow(m.transform_point3(p)));
            let pad = (b.min.abs().max(b.max.abs()) + (b.max - b.min)) * (4.0 * f32::EPSILON);
            Aabb {
                min: b.min - pad,
                max: b.max + pad,
            }
        })
        .collect();
    (ids, boxes)
}

macro_rules! dispatch {
    ($self:ident, $method:ident, $($arg:expr),*) => {
        match (&$self.engine, $self.kernel) {
            #[cfg(target_arch = "x86_64")]
            (Engine::W8(l), Kernel::Avx2) => {
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                unsafe fn go<F: AlphaFilter, C: Counter>(l: &Levels<8>, ray: &Ray, skip: PrimRef, f: &F, c: &C) -> _ret!($method) {
                    // SAFETY: this function's own target features include AVX2 + FMA, which
                    // `Avx2` needs.
                    unsafe { l.$method::<kernel::avx2::Avx2, F, C>(ray, skip, f, c) }
                }
                // SAFETY: an `Accel` holds `Kernel::Avx2` only after `Kernel::available`
                // confirmed AVX2, FMA, BMI1/2, LZCNT and POPCNT on this CPU (`Accel::build_with`).
                unsafe { go(l, $($arg),*) }
            }
            #[cfg(target_arch = "x86_64")]
            (Engine::W4(l), Kernel::Sse) => {
                // SAFETY: SSE2 is part of every x86-64 CPU.
                unsafe { l.$method::<kernel::sse::Sse, _, _>($($arg),*) }
            }
            (Engine::W4(l), _) => {
                // SAFETY: the scalar kernel uses no special instructions.
                unsafe { l.$method::<kernel::scalar::Scalar, _, _>($($arg),*) }
            }
            (Engine::W8(_), _) => unreachable!("8-wide trees are built for the AVX2 kernel only"),
        }
    };
}

macro_rules! _ret {
    (closest) => { Option<Hit> };
    (occluded) => { bool };
}

impl Accel {
    /// Builds the structure with [`BuildOptions::default`] (the best kernel of this CPU).
    pub fn build(desc: &SceneDesc) -> Result<Accel, AccelError> {
        Accel::build_with(desc, BuildOptions::default())
    }

    /// Builds the structure for `opts.kernel`; an error when the CPU lacks it, for an
    /// instance naming a missing prototype or with a transform that is not finite and
    /// invertible, or when Embree's builder (`opts.builder`) fails.
    pub fn build_with(desc: &SceneDesc, opts: BuildOptions) -> Result<Accel, AccelError> {
        if !opts.kernel.available() {
            return Err(AccelError::Kernel(opts.kernel));
        }
        let engine = match opts.kernel.width() {
            8 => Engine::W8(build_levels::<8>(desc, &opts)?),
            _ => Engine::W4(build_levels::<4>(desc, &opts)?),
        };
        Ok(Accel {
            kernel: opts.kernel,
            trav_cost: opts.trav_cost,
            engine,
        })
    }

    /// Adds a grid that answers [`Accel::occluded`] for rays toward a distant light along
    /// `axis` (world space, any length; the sun's direction) with a few leaf tests instead
    /// of a tree walk (the [`direction`] module; answers are the walk's, bit for bit).
    /// Rays in other directions keep the walk. `None` (nothing added) for a zero or
    /// non-finite axis, an empty scene, or one larger than the grid is built for
    /// ([`grid::MAX_PACKS`], [`grid::MAX_ENTRIES`]).
    pub fn index_direction(&mut self, axis: Vec3) -> Option<GridStats> {
        fn add<const W: usize>(l: &mut Levels<W>, axis: Vec3) -> Option<GridStats> {
            let ix = direction::DirIndex::build(l, axis)?;
            let s = ix.stats();
            l.dirs.push(ix);
            Some(s)
        }
        match &mut self.engine {
            Engine::W8(l) => add(l, axis),
            Engine::W4(l) => add(l, axis),
        }
    }

    /// Adds a grid that answers [`Accel::intersect`] for rays starting exactly at `eye` (a
    /// pinhole camera's rays) with a few leaf tests instead of a tree walk (the [`view`]
    /// module), looking along `forward` with `up` fixing the roll, over the picture
    /// `window = [x0, x1, y0, y1]` (tangents of the angles right and up of `forward`; rays
    /// outside it keep the walk). Replaces an earlier one. `None` (nothing added) for a
    /// degenerate frame or window, or a scene larger than the grid is built for.
    pub fn index_view(
        &mut self,
        eye: Vec3,
        forward: Vec3,
        up: Vec3,
        window: [f32; 4],
    ) -> Option<GridStats> {
        fn add<const W: usize>(
            l: &mut Levels<W>,
            eye: Vec3,
            forward: Vec3,
            up: Vec3,
            window: [f32; 4],
        ) -> Option<GridStats> {
            let ix = view::ViewIndex::build(l, eye, forward, up, window)?;
            let s = ix.stats();
            l.view = Some(ix);
            Some(s)
        }
        match &mut self.engine {
            Engine::W8(l) => add(l, eye, forward, up, window),
            Engine::W4(l) => add(l, eye, forward, up, window),
        }
    }

    /// The grid [`Accel::index_view`] added.
    pub fn view_grid(&self) -> Option<GridStats> {
        match &self.engine {
            Engine::W8(l) => l.view.as_ref().map(|v| v.stats()),
            Engine::W4(l) => l.view.as_ref().map(|v| v.stats()),
        }
    }

    /// The grids [`Accel::index_direction`] added.
    pub fn directions(&self) -> Vec<GridStats> {
        match &self.engine {
            Engine::W8(l) => l.dirs.iter().map(|d| d.stats()).collect(),
            Engine::W4(l) => l.dirs.iter().map(|d| d.stats()).collect(),
        }
    }

    /// The kernel queries run with.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The closest accepted hit along `ray`, not counting primitive `skip`
    /// ([`PrimRef::NONE`]: none). `f` decides the alpha-tested candidates no mask decides.
    #[inline]
    pub fn intersect<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> Option<Hit> {
        dispatch!(self, closest, ray, skip, f, &())
    }

    /// [`Accel::intersect`] of each of `rays` (no primitive skipped) into `out`, which must
    /// be as long: the same answers, bit for bit. Rays from the eye of a grid added by
    /// [`Accel::index_view`] (a pixel's camera rays) are tested eight at a time, each pack
    /// against all of them at once, where they cross the same cells of a grid over the
    /// world level alone; the others, and every ray without the AVX2 kernel, one by one.
    ///
    /// # Panics
    /// When `out` is not as long as `rays`.
    pub fn intersect_many<F: AlphaFilter>(&self, rays: &[Ray], f: &F, out: &mut [Option<Hit>]) {
        self.intersect_many_counted(rays, f, &(), out);
    }

    /// [`Accel::intersect_many`], counting what the traversal does into `c`.
    ///
    /// # Panics
    /// When `out` is not as long as `rays`.
    pub fn intersect_many_counted<F: AlphaFilter, C: Counter>(
        &self,
        rays: &[Ray],
        f: &F,
        c: &C,
        out: &mut [Option<Hit>],
    ) {
        assert_eq!(rays.len(), out.len(), "one answer per ray");
        match (&self.engine, self.kernel) {
            #[cfg(target_arch = "x86_64")]
            (Engine::W8(l), Kernel::Avx2) => {
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                unsafe fn go<F: AlphaFilter, C: Counter>(
                    l: &Levels<8>,
                    rays: &[Ray],
                    f: &F,
                    c: &C,
                    out: &mut [Option<Hit>],
                ) {
                    // SAFETY: this function's own target features include AVX2 + FMA.
                    unsafe { l.closest_rays(rays, f, c, out) }
                }
                // SAFETY: an `Accel` holds `Kernel::Avx2` only after `Kernel::available`
                // confirmed AVX2, FMA, BMI1/2, LZCNT and POPCNT on this CPU (`Accel::build_with`).
                unsafe { go(l, rays, f, c, out) }
            }
            _ => {
                for (ray, out) in rays.iter().zip(out.iter_mut()) {
                    *out = dispatch!(self, closest, ray, PrimRef::NONE, f, c);
                }
            }
        }
    }

    /// [`Accel::intersect`] of the rays from `eye` along `(d[0][k], d[1][k], d[2][k])`
    /// (world space, no limit, no primitive skipped) into `out[k]`: a pinhole camera's rays
    /// as a renderer keeps them, one array per axis. The same answers as
    /// [`Accel::intersect_many`] of those rays, bit for bit, without making them into
    /// [`Ray`]s first: with a grid [`Accel::index_view`] added at `eye`, eight at a time
    /// straight from the lanes.
    ///
    /// # Panics
    /// When the three arrays of `d` and `out` are not all as long.
    pub fn intersect_eye<F: AlphaFilter>(
        &self,
        eye: Vec3,
        d: [&[f32]; 3],
        f: &F,
        out: &mut [Option<Hit>],
    ) {
        assert!(
            d.iter().all(|a| a.len() == out.len()),
            "one answer per ray, one direction component per axis"
        );
        match (&self.engine, self.kernel) {
            #[cfg(target_arch = "x86_64")]
            (Engine::W8(l), Kernel::Avx2) => {
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                unsafe fn go<F: AlphaFilter>(
                    l: &Levels<8>,
                    eye: Vec3,
                    d: [&[f32]; 3],
                    f: &F,
                    out: &mut [Option<Hit>],
                ) {
                    // SAFETY: this function's own target features include AVX2 + FMA.
                    unsafe { l.closest_eye(eye, d, f, &(), out) }
                }
                // SAFETY: an `Accel` holds `Kernel::Avx2` only after `Kernel::available`
                // confirmed AVX2, FMA, BMI1/2, LZCNT and POPCNT on this CPU (`Accel::build_with`).
                unsafe { go(l, eye, d, f, out) }
            }
            _ => {
                for (k, out) in out.iter_mut().enumerate() {
                    let ray = Ray::from_eye_lane(eye, d, k);
                    *out = dispatch!(self, closest, &ray, PrimRef::NONE, f, &());
                }
            }
        }
    }

    /// [`Accel::occluded`] of each of `rays`, leaving `skips[k]`, into `out`: the same
    /// answers, bit for bit. Shadow rays toward a distant light indexed with
    /// [`Accel::index_direction`] (a pixel's samples' sun rays) are tested eight at a time,
    /// each pack against all of them at once, where they run the same cells of a grid over
    /// the world level alone; the others, and every ray without the AVX2 kernel, one by
    /// one.
    ///
    /// # Panics
    /// When `skips` or `out` is not as long as `rays`.
    pub fn occluded_many<F: AlphaFilter>(
        &self,
        rays: &[Ray],
        skips: &[PrimRef],
        f: &F,
        out: &mut [bool],
    ) {
        self.occluded_many_counted(rays, skips, f, &(), out);
    }

    /// [`Accel::occluded_many`], counting what the traversal does into `c`.
    ///
    /// # Panics
    /// When `skips` or `out` is not as long as `rays`.
    pub fn occluded_many_counted<F: AlphaFilter, C: Counter>(
        &self,
        rays: &[Ray],
        skips: &[PrimRef],
        f: &F,
        c: &C,
        out: &mut [bool],
    ) {
        assert_eq!(rays.len(), out.len(), "one answer per ray");
        assert_eq!(rays.len(), skips.len(), "one primitive to skip per ray");
        match (&self.engine, self.kernel) {
            #[cfg(target_arch = "x86_64")]
            (Engine::W8(l), Kernel::Avx2) => {
                #[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
                unsafe fn go<F: AlphaFilter, C: Counter>(
                    l: &Levels<8>,
                    rays: &[Ray],
                    skips: &[PrimRef],
                    f: &F,
                    c: &C,
                    out: &mut [bool],
                ) {
                    // SAFETY: this function's own target features include AVX2 + FMA.
                    unsafe { l.occluded_rays(rays, skips, f, c, out) }
                }
                // SAFETY: an `Accel` holds `Kernel::Avx2` only after `Kernel::available`
                // confirmed AVX2, FMA, BMI1/2, LZCNT and POPCNT on this CPU (`Accel::build_with`).
                unsafe { go(l, rays, skips, f, c, out) }
            }
            _ => {
                for ((ray, skip), out) in rays.iter().zip(skips).zip(out.iter_mut()) {
                    *out = dispatch!(self, occluded, ray, *skip, f, c);
                }
            }
        }
    }

    /// Whether any accepted hit lies along `ray` within `(0, tmax)`, not counting `skip`.
    #[inline]
    pub fn occluded<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> bool {
        dispatch!(self, occluded, ray, skip, f, &())
    }

    /// [`Accel::intersect`], counting what the traversal does into `stats`.
    pub fn intersect_counted<F: AlphaFilter>(
        &self,
        ray: &Ray,
        skip: PrimRef,
        f: &F,
        stats: &TraversalStats,
    ) -> Option<Hit> {
        dispatch!(self, closest, ray, skip, f, stats)
    }

    /// [`Accel::occluded`], counting what the traversal does into `stats`.
    pub fn occluded_counted<F: AlphaFilter>(
        &self,
        ray: &Ray,
        skip: PrimRef,
        f: &F,
        stats: &TraversalStats,
    ) -> bool {
        dispatch!(self, occluded, ray, skip, f, stats)
    }

    /// The world-to-object transform of instance `inst` (an instance id as hits report it:
    /// the top level's order, see [`Accel::scene_instances`]) as the traversal applies it;
    /// `None` out of range.
    #[inline]
    pub fn world_to_object(&self, inst: u32) -> Option<glam::Affine3A> {
        let recs = match &self.engine {
            Engine::W8(l) => &l.recs,
            Engine::W4(l) => &l.recs,
        };
        recs.get(inst as usize)
            .map(|r| glam::Affine3A::from_cols_slice(&r.w2o))
    }

    /// For each instance id a hit reports (the top level's order), its index in
    /// [`SceneDesc::instances`]: recomputed from `desc` (the build is deterministic), so
    /// that the structure itself stores nothing for it. `desc` must be the scene this was
    /// built from.
    pub fn scene_instances(&self, desc: &SceneDesc) -> Vec<u32> {
        fn of<const W: usize>(l: &Levels<W>, desc: &SceneDesc, trav_cost: f32) -> Vec<u32> {
            let (ids, boxes) = top_boxes(desc, &l.protos);
            if boxes.is_empty() {
                return Vec::new();
            }
            let top = top::build_top(&build::build_binary(&boxes, top_params(trav_cost)), &boxes);
            top.order.iter().map(|&k| ids[k as usize]).collect()
        }
        match &self.engine {
            Engine::W8(l) => of(l, desc, self.trav_cost),
            Engine::W4(l) => of(l, desc, self.trav_cost),
        }
    }

    /// The prototype of instance `inst` (an instance id as hits report it).
    ///
    /// # Panics
    /// For an instance index out of range.
    #[inline]
    pub fn prototype_of(&self, inst: u32) -> u32 {
        match &self.engine {
            Engine::W8(l) => l.recs[inst as usize].proto,
            Engine::W4(l) => l.recs[inst as usize].proto,
        }
    }

    /// Bytes held, by level.
    pub fn memory(&self) -> AccelMemory {
        fn of<const W: usize>(l: &Levels<W>) -> AccelMemory {
            let tlas = l
                .tlas
                .as_ref()
                .map_or(0, |t| t.nodes.len() * std::mem::size_of::<top::QNode>());
            let count = l.recs.len();
            AccelMemory {
                world: l.world.bytes(),
                prototypes: l.protos.iter().map(Blas::bytes).sum(),
                instances: tlas + l.recs.len() * std::mem::size_of::<InstRec>(),
                masks: l.masks.iter().flatten().map(OpacityMask::bytes).sum(),
                grids: l.dirs.iter().map(|d| d.bytes()).sum::<usize>()
                    + l.view.as_ref().map_or(0, |v| v.bytes()),
                instance_count: count,
            }
        }
        match &self.engine {
            Engine::W8(l) => of(l),
            Engine::W4(l) => of(l),
        }
    }

    /// SAH cost of the world geometry's tree (node visits weighted by the build's
    /// `trav_cost`, pack tests by 1, each by its box's area relative to the root's): the
    /// expected number of steps of a ray through the root box, for comparing builds.
    pub fn world_sah_cost(&self) -> f64 {
        match &self.engine {
            Engine::W8(l) => l.world.sah_cost(self.trav_cost),
            Engine::W4(l) => l.world.sah_cost(self.trav_cost),
        }
    }

    /// Wide nodes and leaf packs of the world geometry's tree.
    pub fn world_counts(&self) -> (usize, usize) {
        match &self.engine {
            Engine::W8(l) => (l.world.nodes.len(), l.world.packs.len()),
            Engine::W4(l) => (l.world.nodes.len(), l.world.packs.len()),
        }
    }
}
