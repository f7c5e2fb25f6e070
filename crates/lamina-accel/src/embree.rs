//! Embree 3 as a second backend with [`Accel`](crate::Accel)'s semantics, for benchmarks
//! and for users who want it (cargo feature `embree`; Debian: `libembree-dev`).
//!
//! A thin FFI of our own: the few `rtc*` functions used and `#[repr(C)]` copies of the
//! structs they take, checked against Embree 3.13's headers (`rtcore_*.h`; this build has
//! `RTC_MAX_INSTANCE_LEVEL_COUNT = 1` and `RTC_MIN_WIDTH = 0`, which fix the layouts below).
//!
//! How a [`SceneDesc`] maps onto Embree:
//!
//! * **One device** per [`EmbreeAccel`], with a memory monitor that counts what Embree
//!   allocates (BVHs, buffers) and an error callback whose first message becomes
//!   [`AccelError::Embree`].
//! * **Geometry.** Each [`Geometry`] is split by kind into at most four Embree geometries,
//!   in fixed *slots*: opaque triangles (`RTC_GEOMETRY_TYPE_TRIANGLE`), opaque
//!   parallelograms (`RTC_GEOMETRY_TYPE_QUAD` with vertices `v0, v0+e1, v0+e1+e2, v0+e2`,
//!   whose hit `(u, v)` is then our `(b1, b2)`: Embree parametrises a quad from `p0` with
//!   `u` along `p1 - p0` and `v` along `p3 - p0`), alpha-tested triangles and alpha-tested
//!   parallelograms. Each keeps the map from its Embree `primID` to our primitive index
//!   (`GeomData`); invalid primitives ([`Prim::is_valid`] false) are left out, indices
//!   are kept.
//! * **Levels.** The world's geometries sit in the top scene (geometry ids `n + slot`, `n`
//!   the number of instances); each used, non-empty prototype is its own committed scene
//!   (geometry ids `slot`), attached by one `RTC_GEOMETRY_TYPE_INSTANCE` geometry per
//!   instance whose geometry id *is* the instance's index in [`SceneDesc::instances`], so
//!   `instID[0]` names it directly. Instances of empty prototypes are left out. Embree does
//!   not renormalise the direction in instance space, so `t` is one measure everywhere.
//! * **Build quality** `RTC_BUILD_QUALITY_HIGH` for every scene and geometry (SAH with
//!   spatial splits for the bottom levels). **Scene flags**: [`EmbreeOptions::robust`]
//!   (default on) sets `RTC_SCENE_FLAG_ROBUST`: watertight (Plücker) primitive tests and
//!   conservative box tests, the guarantee lamina's own traversal gives (its box test never
//!   culls a box the ray touches); off gives Embree's fastest (Möller) path.
//!   `RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION` is always set (the skip, below).
//! * **Alpha**: the alpha-tested geometries carry intersection and occlusion filter
//!   functions (`alpha_filter`): `uv = uv0·(1-b1-b2) + uv1·b1 + uv2·b2`, then the matte's
//!   [`OpacityMask`] from [`SceneDesc::masks`] decides opaque and transparent cells (the
//!   same fast path as lamina's leaf test) and only unknown cells ask the caller's
//!   [`AlphaFilter`]. Opaque geometries have no filter, so Embree runs no callback for
//!   them.
//! * **Skip**: only when a query has a primitive to skip, the context filter
//!   (`skip_filter`) rejects it on every geometry; the alpha filter checks it too.
//!   The filters find the query's data (skip, masks, the [`AlphaFilter`]) through the
//!   intersection context, which is the first field of our `QueryContext`.
//! * **Spheres** are tested in Rust after the Embree query (`traverse::intersect_sphere`,
//!   the same function [`Accel`](crate::Accel) uses).
//! * `t` is in `(0, tmax)` as in [`Accel`](crate::Accel): `tnear` is the smallest normal
//!   float and `tfar` the float below `tmax` (Embree's bounds are inclusive).
//!
//! A panic in the [`AlphaFilter`] is caught in the callback (it cannot unwind through
//! Embree's C++ frames), the candidate rejected, and the panic resumed once Embree
//! returns.

use crate::desc::{Geometry, Prim, SceneDesc, Sphere};
use crate::mask::{OPAQUE, OpacityMask, TRANSPARENT};
use crate::traverse::intersect_sphere;
use crate::{AccelError, AlphaFilter, Hit, NO_INSTANCE, NO_PRIM, PrimRef, Ray, SPHERE};
use glam::{Vec2, Vec3};
use std::any::Any;
use std::cell::Cell;
use std::ffi::{CStr, c_char, c_int, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::ptr;
use std::sync::Mutex;
use std::sync::atomic::{AtomicIsize, Ordering};

/// The raw Embree 3 API: just what this module and `embree_build` call (see
/// `/usr/include/embree3`).
#[allow(non_camel_case_types, dead_code, clippy::upper_case_acronyms)]
pub(crate) mod ffi {
    use std::ffi::{c_char, c_int, c_uint, c_void};

    pub type RTCDevice = *mut c_void;
    pub type RTCScene = *mut c_void;
    pub type RTCGeometry = *mut c_void;

    // enum RTCError (rtcore_device.h)
    pub const RTC_ERROR_NONE: c_int = 0;
    // enum RTCGeometryType (rtcore_geometry.h)
    pub const RTC_GEOMETRY_TYPE_TRIANGLE: c_int = 0;
    pub const RTC_GEOMETRY_TYPE_QUAD: c_int = 1;
    pub const RTC_GEOMETRY_TYPE_INSTANCE: c_int = 121;
    // enum RTCBufferType (rtcore_buffer.h)
    pub const RTC_BUFFER_TYPE_INDEX: c_int = 0;
    pub const RTC_BUFFER_TYPE_VERTEX: c_int = 1;
    // enum RTCFormat (rtcore_common.h)
    pub const RTC_FORMAT_UINT3: c_int = 0x5003;
    pub const RTC_FORMAT_UINT4: c_int = 0x5004;
    pub const RTC_FORMAT_FLOAT3: c_int = 0x9003;
    pub const RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR: c_int = 0x9234;
    // enum RTCBuildQuality (rtcore_common.h)
    pub const RTC_BUILD_QUALITY_HIGH: c_int = 2;
    // enum RTCSceneFlags (rtcore_scene.h)
    pub const RTC_SCENE_FLAG_ROBUST: c_int = 1 << 2;
    pub const RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION: c_int = 1 << 3;
    // enum RTCIntersectContextFlags (rtcore_common.h)
    pub const RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT: c_int = 0;
    /// `RTC_INVALID_GEOMETRY_ID` (rtcore_common.h).
    pub const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;

    /// `struct RTCRay` (rtcore_ray.h), `RTC_ALIGN(16)`.
    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCRay {
        pub org_x: f32,
        pub org_y: f32,
        pub org_z: f32,
        pub tnear: f32,
        pub dir_x: f32,
        pub dir_y: f32,
        pub dir_z: f32,
        pub time: f32,
        pub tfar: f32,
        pub mask: c_uint,
        pub id: c_uint,
        pub flags: c_uint,
    }

    /// `struct RTCHit` (rtcore_ray.h), `RTC_ALIGN(16)`, one instance level.
    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCHit {
        pub ng_x: f32,
        pub ng_y: f32,
        pub ng_z: f32,
        pub u: f32,
        pub v: f32,
        pub prim_id: c_uint,
        pub geom_id: c_uint,
        pub inst_id: [c_uint; 1],
    }

    /// `struct RTCRayHit` (rtcore_ray.h).
    #[repr(C)]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCRayHit {
        pub ray: RTCRay,
        pub hit: RTCHit,
    }

    /// `RTCFilterFunctionN` (rtcore_common.h).
    pub type RTCFilterFunctionN = unsafe extern "C" fn(args: *const RTCFilterFunctionNArguments);

    /// `struct RTCIntersectContext` (rtcore_common.h) with `RTC_MAX_INSTANCE_LEVEL_COUNT`
    /// 1 (no `instStackSize`) and `RTC_MIN_WIDTH` 0 (no `minWidthDistanceFactor`).
    #[repr(C)]
    #[derive(Clone, Copy, Debug)]
    pub struct RTCIntersectContext {
        pub flags: c_int,
        pub filter: Option<RTCFilterFunctionN>,
        pub inst_id: [c_uint; 1],
    }

    /// `struct RTCFilterFunctionNArguments` (rtcore_common.h). `ray` and `hit` point to
    /// `N` rays and hits in structure-of-arrays layout (`RTCRayN`, `RTCHitN`).
    #[repr(C)]
    #[derive(Debug)]
    pub struct RTCFilterFunctionNArguments {
        pub valid: *mut c_int,
        pub geometry_user_ptr: *mut c_void,
        pub context: *mut RTCIntersectContext,
        pub ray: *mut c_void,
        pub hit: *mut c_void,
        pub n: c_uint,
    }

    /// `RTCErrorFunction` (rtcore_device.h).
    pub type RTCErrorFunction =
        unsafe extern "C" fn(user: *mut c_void, code: c_int, msg: *const c_char);
    /// `RTCMemoryMonitorFunction` (rtcore_device.h).
    pub type RTCMemoryMonitorFunction =
        unsafe extern "C" fn(user: *mut c_void, bytes: isize, post: bool) -> bool;

    // Layouts as the C compiler lays them out for x86-64 / AArch64 (LP64).
    const _: () = assert!(std::mem::size_of::<RTCRay>() == 48);
    const _: () = assert!(std::mem::size_of::<RTCHit>() == 32);
    const _: () = assert!(std::mem::size_of::<RTCRayHit>() == 80);
    const _: () = assert!(std::mem::align_of::<RTCRayHit>() == 16);
    const _: () = assert!(std::mem::size_of::<RTCIntersectContext>() == 24);
    const _: () = assert!(std::mem::size_of::<RTCFilterFunctionNArguments>() == 48);

    /// `RTCBVH` (rtcore_builder.h).
    pub type RTCBVH = *mut c_void;
    /// `RTCThreadLocalAllocator` (rtcore_builder.h).
    pub type RTCThreadLocalAllocator = *mut c_void;

    /// `struct RTCBuildPrimitive` (rtcore_builder.h).
    #[repr(C, align(32))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCBuildPrimitive {
        pub lower: [f32; 3],
        pub geom_id: c_uint,
        pub upper: [f32; 3],
        pub prim_id: c_uint,
    }

    /// `struct RTCBounds` (rtcore_common.h).
    #[repr(C, align(16))]
    #[derive(Clone, Copy, Debug, Default)]
    pub struct RTCBounds {
        pub lower: [f32; 3],
        pub align0: f32,
        pub upper: [f32; 3],
        pub align1: f32,
    }

    /// `RTCCreateNodeFunction` (rtcore_builder.h).
    pub type RTCCreateNodeFunction = unsafe extern "C" fn(
        alloc: RTCThreadLocalAllocator,
        count: c_uint,
        user: *mut c_void,
    ) -> *mut c_void;
    /// `RTCSetNodeChildrenFunction` (rtcore_builder.h).
    pub type RTCSetNodeChildrenFunction = unsafe extern "C" fn(
        node: *mut c_void,
        children: *mut *mut c_void,
        count: c_uint,
        user: *mut c_void,
    );
    /// `RTCSetNodeBoundsFunction` (rtcore_builder.h).
    pub type RTCSetNodeBoundsFunction = unsafe extern "C" fn(
        node: *mut c_void,
        bounds: *const *const RTCBounds,
        count: c_uint,
        user: *mut c_void,
    );
    /// `RTCCreateLeafFunction` (rtcore_builder.h).
    pub type RTCCreateLeafFunction = unsafe extern "C" fn(
        alloc: RTCThreadLocalAllocator,
        prims: *const RTCBuildPrimitive,
        count: usize,
        user: *mut c_void,
    ) -> *mut c_void;
    /// `RTCSplitPrimitiveFunction` (rtcore_builder.h).
    pub type RTCSplitPrimitiveFunction = unsafe extern "C" fn(
        prim: *const RTCBuildPrimitive,
        dim: c_uint,
        pos: f32,
        left: *mut RTCBounds,
        right: *mut RTCBounds,
        user: *mut c_void,
    );

    /// `struct RTCBuildArguments` (rtcore_builder.h).
    #[repr(C)]
    #[derive(Debug)]
    pub struct RTCBuildArguments {
        pub byte_size: usize,
        pub build_quality: c_int,
        pub build_flags: c_int,
        pub max_branching_factor: c_uint,
        pub max_depth: c_uint,
        pub sah_block_size: c_uint,
        pub min_leaf_size: c_uint,
        pub max_leaf_size: c_uint,
        pub traversal_cost: f32,
        pub intersection_cost: f32,
        pub bvh: RTCBVH,
        pub primitives: *mut RTCBuildPrimitive,
        pub primitive_count: usize,
        pub primitive_array_capacity: usize,
        pub create_node: Option<RTCCreateNodeFunction>,
        pub set_node_children: Option<RTCSetNodeChildrenFunction>,
        pub set_node_bounds: Option<RTCSetNodeBoundsFunction>,
        pub create_leaf: Option<RTCCreateLeafFunction>,
        pub split_primitive: Option<RTCSplitPrimitiveFunction>,
        pub build_progress: Option<unsafe extern "C" fn(user: *mut c_void, n: f64) -> bool>,
        pub user_ptr: *mut c_void,
    }

    const _: () = assert!(std::mem::size_of::<RTCBuildPrimitive>() == 32);
    const _: () = assert!(std::mem::size_of::<RTCBounds>() == 32);
    const _: () = assert!(std::mem::size_of::<RTCBuildArguments>() == 136);
    const _: () = assert!(std::mem::offset_of!(RTCBuildArguments, bvh) == 48);
    const _: () = assert!(std::mem::offset_of!(RTCBuildArguments, primitives) == 56);
    const _: () = assert!(std::mem::offset_of!(RTCBuildArguments, create_node) == 80);
    const _: () = assert!(std::mem::offset_of!(RTCBuildArguments, split_primitive) == 112);
    const _: () = assert!(std::mem::offset_of!(RTCBuildArguments, user_ptr) == 128);

    #[link(name = "embree3")]
    unsafe extern "C" {
        pub fn rtcNewBVH(device: RTCDevice) -> RTCBVH;
        pub fn rtcBuildBVH(args: *const RTCBuildArguments) -> *mut c_void;
        pub fn rtcThreadLocalAlloc(
            alloc: RTCThreadLocalAllocator,
            bytes: usize,
            align: usize,
        ) -> *mut c_void;
        pub fn rtcReleaseBVH(bvh: RTCBVH);
        pub fn rtcNewDevice(config: *const c_char) -> RTCDevice;
        pub fn rtcReleaseDevice(device: RTCDevice);
        pub fn rtcGetDeviceError(device: RTCDevice) -> c_int;
        pub fn rtcSetDeviceErrorFunction(
            device: RTCDevice,
            f: Option<RTCErrorFunction>,
            user: *mut c_void,
        );
        pub fn rtcSetDeviceMemoryMonitorFunction(
            device: RTCDevice,
            f: Option<RTCMemoryMonitorFunction>,
            user: *mut c_void,
        );

        pub fn rtcNewScene(device: RTCDevice) -> RTCScene;
        pub fn rtcReleaseScene(scene: RTCScene);
        pub fn rtcAttachGeometryByID(scene: RTCScene, geometry: RTCGeometry, geom_id: c_uint);
        pub fn rtcCommitScene(scene: RTCScene);
        pub fn rtcSetSceneBuildQuality(scene: RTCScene, quality: c_int);
        pub fn rtcSetSceneFlags(scene: RTCScene, flags: c_int);

        pub fn rtcNewGeometry(device: RTCDevice, kind: c_int) -> RTCGeometry;
        pub fn rtcReleaseGeometry(geometry: RTCGeometry);
        pub fn rtcCommitGeometry(geometry: RTCGeometry);
        pub fn rtcSetGeometryBuildQuality(geometry: RTCGeometry, quality: c_int);
        pub fn rtcSetNewGeometryBuffer(
            geometry: RTCGeometry,
            kind: c_int,
            slot: c_uint,
            format: c_int,
            byte_stride: usize,
            item_count: usize,
        ) -> *mut c_void;
        pub fn rtcSetGeometryIntersectFilterFunction(
            geometry: RTCGeometry,
            f: Option<RTCFilterFunctionN>,
        );
        pub fn rtcSetGeometryOccludedFilterFunction(
            geometry: RTCGeometry,
            f: Option<RTCFilterFunctionN>,
        );
        pub fn rtcSetGeometryUserData(geometry: RTCGeometry, ptr: *mut c_void);
        pub fn rtcSetGeometryInstancedScene(geometry: RTCGeometry, scene: RTCScene);
        pub fn rtcSetGeometryTransform(
            geometry: RTCGeometry,
            time_step: c_uint,
            format: c_int,
            xfm: *const c_void,
        );

        pub fn rtcIntersect1(
            scene: RTCScene,
            context: *mut RTCIntersectContext,
            rayhit: *mut RTCRayHit,
        );
        pub fn rtcOccluded1(scene: RTCScene, context: *mut RTCIntersectContext, ray: *mut RTCRay);
    }
}

use ffi::*;

/// Build settings of an [`EmbreeAccel`].
#[derive(Clone, Copy, Debug)]
pub struct EmbreeOptions {
    /// `RTC_SCENE_FLAG_ROBUST` on every scene (default `true`): watertight primitive tests
    /// and conservative box tests, slower; `false` is Embree's fastest path.
    pub robust: bool,
}

impl Default for EmbreeOptions {
    fn default() -> Self {
        EmbreeOptions { robust: true }
    }
}

/// Slots of a level's Embree geometries (also their geometry ids within a prototype scene,
/// and the offsets of the world's after the instances in the top scene).
const SLOTS: usize = 4;

/// The alpha test of one Embree primitive.
#[derive(Clone, Copy, Debug)]
struct AlphaRec {
    id: u32,
    uv: [Vec2; 3],
}

/// What a filter needs of one Embree geometry: per Embree `primID`, our primitive index
/// and, on an alpha-tested geometry, the matte.
#[derive(Debug, Default)]
struct GeomData {
    ids: Vec<u32>,
    alpha: Vec<AlphaRec>,
}

impl GeomData {
    fn bytes(&self) -> usize {
        self.ids.capacity() * 4 + self.alpha.capacity() * std::mem::size_of::<AlphaRec>()
    }
}

/// The geometries of one level (the world or a prototype), by slot.
type Slots = [Option<Box<GeomData>>; SLOTS];

/// One prototype's committed scene and its geometries.
#[derive(Debug)]
struct Proto {
    scene: RTCScene,
    slots: Slots,
}

/// What the device callbacks write: the first error and the bytes Embree holds.
#[derive(Debug, Default)]
struct DeviceLog {
    error: Mutex<Option<String>>,
    bytes: AtomicIsize,
}

/// Embree's acceleration structure of a [`SceneDesc`], answering the queries of
/// [`Accel`](crate::Accel) with the same semantics (see the module docs).
#[derive(Debug)]
pub struct EmbreeAccel {
    device: RTCDevice,
    /// The top scene: the world's geometries and one instance geometry per instance.
    top: RTCScene,
    /// Per prototype, its scene (`None`: unused or empty).
    protos: Vec<Option<Proto>>,
    world: Slots,
    /// Per instance, its prototype.
    inst_proto: Vec<u32>,
    /// Geometry id of the world's slot 0 in the top scene (the number of instances).
    world_base: u32,
    /// Valid spheres with their index in [`SceneDesc::spheres`].
    spheres: Vec<(u32, Sphere)>,
    masks: Vec<Option<OpacityMask>>,
    /// Boxed: the device callbacks hold its address.
    log: Box<DeviceLog>,
}

// SAFETY: the Embree handles are only read after `build` returns: Embree documents
// `rtcIntersect1`/`rtcOccluded1` on a committed scene as thread-safe, and nothing mutates a
// scene, geometry or device after the commit (only `Drop` releases them, which needs
// `&mut self`). The filter callbacks read the `GeomData` boxes (immutable after build) and
// per-query data on the calling thread's stack. `DeviceLog` is a `Mutex` and an atomic,
// which Embree's callbacks may touch from any thread.
unsafe impl Send for EmbreeAccel {}
// SAFETY: as for `Send`: every `&self` method is a read-only query on committed scenes.
unsafe impl Sync for EmbreeAccel {}

unsafe extern "C" fn on_error(user: *mut c_void, code: c_int, msg: *const c_char) {
    // SAFETY: `user` is the `DeviceLog` box registered with the device, alive until after
    // the device is released (`EmbreeAccel::drop`); `msg` is null or a NUL-terminated
    // string that Embree keeps alive for the duration of the call.
    let (log, msg) = unsafe {
        (
            &*(user as *const DeviceLog),
            if msg.is_null() {
                String::new()
            } else {
                CStr::from_ptr(msg).to_string_lossy().into_owned()
            },
        )
    };
    let mut e = log.error.lock().unwrap_or_else(|p| p.into_inner());
    e.get_or_insert_with(|| format!("error {code}: {msg}"));
}

unsafe extern "C" fn on_memory(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: as in `on_error`: the registered, still alive `DeviceLog`.
    let log = unsafe { &*(user as *const DeviceLog) };
    log.bytes.fetch_add(bytes, Ordering::Relaxed);
    true
}

/// The Rust side of one query, reached from the filters through [`QueryContext`].
struct Query<'a> {
    skip: PrimRef,
    masks: &'a [Option<OpacityMask>],
    filter: &'a dyn AlphaFilter,
    /// The first panic of `filter`, resumed after Embree returns.
    panic: Cell<Option<Box<dyn Any + Send>>>,
}

/// The intersection context of one query: Embree's first (so a pointer to it is a pointer
/// to Embree's), then ours. Embree writes `rtc.inst_id` while it traverses; the filters
/// only read `query`, through raw pointers, never through a reference to the whole struct.
#[repr(C)]
struct QueryContext<'a> {
    rtc: RTCIntersectContext,
    query: *const Query<'a>,
}

/// `RTCHitN` field `k` of ray `i` of `n` (rtcore_ray.h: `((T*)hit)[k*N + i]`).
///
/// # Safety
/// `hit` must point to `n` valid hits in SoA layout and `i < n`, `k < 8`.
#[inline(always)]
unsafe fn hit_u32(hit: *const c_void, n: usize, k: usize, i: usize) -> u32 {
    // SAFETY: the caller's guarantee: element `k*n + i` lies inside the `8n`-word block.
    unsafe { *(hit as *const u32).add(k * n + i) }
}

/// As [`hit_u32`], for float fields.
///
/// # Safety
/// As [`hit_u32`].
#[inline(always)]
unsafe fn hit_f32(hit: *const c_void, n: usize, k: usize, i: usize) -> f32 {
    // SAFETY: as in `hit_u32`.
    unsafe { *(hit as *const f32).add(k * n + i) }
}

// RTCHitN field indices (rtcore_ray.h).
const HIT_U: usize = 3;
const HIT_V: usize = 4;
const HIT_PRIM: usize = 5;
const HIT_INST: usize = 7;

/// Whether the candidate `prim` of instance `inst_id` (Embree's id) is the skipped one.
#[inline(always)]
fn is_skipped(skip: PrimRef, inst_id: u32, prim: u32) -> bool {
    let inst = if inst_id == RTC_INVALID_GEOMETRY_ID {
        NO_INSTANCE
    } else {
        inst_id
    };
    skip.prim == prim && skip.inst == inst
}

/// The filter of every alpha-tested geometry (intersection and occlusion): rejects the
/// skipped primitive and candidates where the matte is transparent.
unsafe extern "C" fn alpha_filter(args: *const RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments: `N` valid flags, rays and hits; the user
    // pointer is this geometry's `GeomData` (set at build, alive as long as the scene);
    // the context is the one our query passed, i.e. the first field of a live
    // `QueryContext` on the querying thread's stack, whose `query` points to its `Query`.
    // `hit_*` reads stay within the `N` hits. We read `query` by a raw-pointer read, not
    // through a reference to the context, which Embree also writes (`instID`).
    unsafe {
        let a = &*args;
        let g = &*(a.geometry_user_ptr as *const GeomData);
        let q = &*ptr::addr_of!((*(a.context as *const QueryContext)).query).read();
        let n = a.n as usize;
        for i in 0..n {
            let valid = a.valid.add(i);
            if *valid == 0 {
                continue;
            }
            let p = hit_u32(a.hit, n, HIT_PRIM, i) as usize;
            let prim = g.ids[p];
            if is_skipped(q.skip, hit_u32(a.hit, n, HIT_INST, i), prim) {
                *valid = 0;
                continue;
            }
            let (b1, b2) = (hit_f32(a.hit, n, HIT_U, i), hit_f32(a.hit, n, HIT_V, i));
            if !opaque(q, &g.alpha[p], b1, b2) {
                *valid = 0;
            }
        }
    }
}

/// The matte test of one candidate: the mask where it decides, else the caller's filter.
#[inline(always)]
fn opaque(q: &Query, rec: &AlphaRec, b1: f32, b2: f32) -> bool {
    let uv = rec.uv[0] * (1.0 - b1 - b2) + rec.uv[1] * b1 + rec.uv[2] * b2;
    if let Some(Some(m)) = q.masks.get(rec.id as usize) {
        match m.classify(uv) {
            OPAQUE => return true,
            TRANSPARENT => return false,
            _ => {}
        }
    }
    match catch_unwind(AssertUnwindSafe(|| q.filter.opaque(rec.id, uv))) {
        Ok(o) => o,
        Err(p) => {
            let first = q.panic.take().unwrap_or(p);
            q.panic.set(Some(first));
            false
        }
    }
}

/// The context filter, set only for queries with a primitive to skip: rejects it on every
/// geometry.
unsafe extern "C" fn skip_filter(args: *const RTCFilterFunctionNArguments) {
    // SAFETY: as in `alpha_filter`: every geometry of ours has its `GeomData` as user
    // pointer, and the context is a live `QueryContext`.
    unsafe {
        let a = &*args;
        let g = &*(a.geometry_user_ptr as *const GeomData);
        let q = &*ptr::addr_of!((*(a.context as *const QueryContext)).query).read();
        let n = a.n as usize;
        for i in 0..n {
            let valid = a.valid.add(i);
            if *valid != 0 {
                let prim = g.ids[hit_u32(a.hit, n, HIT_PRIM, i) as usize];
                if is_skipped(q.skip, hit_u32(a.hit, n, HIT_INST, i), prim) {
                    *valid = 0;
                }
            }
        }
    }
}

/// The slot of a primitive: triangle / parallelogram, opaque / alpha-tested.
fn slot_of(p: &Prim) -> usize {
    usize::from(p.quad) + 2 * usize::from(p.alpha.is_some())
}

impl EmbreeAccel {
    /// Builds the structure with [`EmbreeOptions::default`]. The same errors as
    /// [`Accel::build`](crate::Accel::build) for bad instances; [`AccelError::Embree`] when
    /// Embree fails.
    pub fn build(desc: &SceneDesc) -> Result<Self, AccelError> {
        Self::build_with(desc, EmbreeOptions::default())
    }

    /// Builds the structure with `opts`.
    pub fn build_with(desc: &SceneDesc, opts: EmbreeOptions) -> Result<Self, AccelError> {
        // The checks of `Accel::build`, in its order.
        if desc.instances.len() >= 1 << 30 {
            return Err(AccelError::TooLarge("instances"));
        }
        if desc.world.prims.len() >= 1 << 30
            || desc.prototypes.iter().any(|g| g.prims.len() >= 1 << 30)
        {
            return Err(AccelError::TooLarge("a geometry"));
        }
        let mut used = vec![false; desc.prototypes.len()];
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
            if !(m.matrix3.determinant().abs() > 0.0 && m.is_finite() && m.inverse().is_finite()) {
                return Err(AccelError::Transform(i));
            }
        }

        // SAFETY: a null config string is allowed (defaults).
        let device = unsafe { rtcNewDevice(ptr::null()) };
        if device.is_null() {
            // SAFETY: a null device asks for the error of the last device creation.
            let code = unsafe { rtcGetDeviceError(ptr::null_mut()) };
            return Err(AccelError::Embree(format!(
                "rtcNewDevice failed (error {code})"
            )));
        }
        let mut acc = EmbreeAccel {
            device,
            top: ptr::null_mut(),
            protos: Vec::new(),
            world: Default::default(),
            inst_proto: desc.instances.iter().map(|i| i.prototype).collect(),
            world_base: desc.instances.len() as u32,
            spheres: desc
                .spheres
                .iter()
                .enumerate()
                .filter(|(_, s)| s.center.is_finite() && s.radius > 0.0 && s.radius.is_finite())
                .map(|(k, s)| (k as u32, *s))
                .collect(),
            masks: desc.masks.clone(),
            log: Box::default(),
        };
        let log = ptr::from_ref::<DeviceLog>(&acc.log) as *mut c_void;
        // SAFETY: `device` is live; `log` points to the boxed `DeviceLog`, which `acc` owns
        // and drops only after releasing the device (`Drop`), and the callbacks only read it
        // (interior mutability: a Mutex and an atomic).
        unsafe {
            rtcSetDeviceErrorFunction(device, Some(on_error), log);
            rtcSetDeviceMemoryMonitorFunction(device, Some(on_memory), log);
        }
        let flags = RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION
            | if opts.robust {
                RTC_SCENE_FLAG_ROBUST
            } else {
                0
            };

        // Prototypes: one committed scene each, for the used ones with geometry.
        for (g, &u) in desc.prototypes.iter().zip(&used) {
            if !(u && g.prims.iter().any(Prim::is_valid)) {
                acc.protos.push(None);
                continue;
            }
            let scene = acc.new_scene(flags)?;
            // Owned at once, so that `Drop` releases it on an early return.
            acc.protos.push(Some(Proto {
                scene,
                slots: Default::default(),
            }));
            let slots = acc.add_geometries(scene, g, 0)?;
            if let Some(Some(p)) = acc.protos.last_mut() {
                p.slots = slots;
            }
            // SAFETY: `scene` is a live scene of ours with its geometries attached.
            unsafe { rtcCommitScene(scene) };
            acc.check()?;
        }

        // The top scene: the world's geometries and the instances.
        acc.top = acc.new_scene(flags)?;
        acc.world = acc.add_geometries(acc.top, &desc.world, acc.world_base)?;
        for (i, inst) in desc.instances.iter().enumerate() {
            let Some(proto) = &acc.protos[inst.prototype as usize] else {
                continue;
            };
            let mut xfm = [0.0f32; 12];
            inst.object_to_world.write_cols_to_slice(&mut xfm);
            // SAFETY: `device` is live; the null check follows.
            let geom = unsafe { rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE) };
            if geom.is_null() {
                acc.check()?;
                return Err(AccelError::Embree("rtcNewGeometry(INSTANCE) failed".into()));
            }
            // SAFETY: `geom` is a new instance geometry of this device and `proto.scene` a
            // committed scene of the same device. `xfm` holds the 12 floats of
            // `RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR` (columns x, y, z, translation: glam's
            // column order), which Embree copies. Attaching gives the scene its own
            // reference, so releasing ours leaves the geometry alive in the scene; the id is
            // the instance index (< 2^30, unique in this scene: the world's ids start after
            // the last instance).
            unsafe {
                rtcSetGeometryInstancedScene(geom, proto.scene);
                rtcSetGeometryTransform(
                    geom,
                    0,
                    RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                    xfm.as_ptr().cast(),
                );
                rtcCommitGeometry(geom);
                rtcAttachGeometryByID(acc.top, geom, i as u32);
                rtcReleaseGeometry(geom);
            }
        }
        acc.check()?;
        // SAFETY: the top scene is live, every geometry attached and committed, every
        // instanced scene committed.
        unsafe { rtcCommitScene(acc.top) };
        acc.check()?;
        Ok(acc)
    }

    /// The first error Embree reported, as [`AccelError::Embree`].
    fn check(&self) -> Result<(), AccelError> {
        if let Some(e) = self
            .log
            .error
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
        {
            return Err(AccelError::Embree(e));
        }
        // SAFETY: the device is live.
        let code = unsafe { rtcGetDeviceError(self.device) };
        if code != RTC_ERROR_NONE {
            return Err(AccelError::Embree(format!("error {code}")));
        }
        Ok(())
    }

    /// A new scene with `flags` and high build quality.
    fn new_scene(&self, flags: c_int) -> Result<RTCScene, AccelError> {
        // SAFETY: the device is live; the null check follows.
        let scene = unsafe { rtcNewScene(self.device) };
        if scene.is_null() {
            self.check()?;
            return Err(AccelError::Embree("rtcNewScene failed".into()));
        }
        // SAFETY: `scene` is a live scene; both values are valid enum values.
        unsafe {
            rtcSetSceneFlags(scene, flags);
            rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
        }
        Ok(scene)
    }

    /// Attaches the valid primitives of `g` to `scene`, one Embree geometry per non-empty
    /// slot, with geometry id `id_base + slot`.
    fn add_geometries(
        &self,
        scene: RTCScene,
        g: &Geometry,
        id_base: u32,
    ) -> Result<Slots, AccelError> {
        let mut by_slot: [Vec<u32>; SLOTS] = Default::default();
        for (k, p) in g.prims.iter().enumerate() {
            if p.is_valid() {
                by_slot[slot_of(p)].push(k as u32);
            }
        }
        let mut slots: Slots = Default::default();
        for (slot, ids) in by_slot.into_iter().enumerate() {
            if ids.is_empty() {
                continue;
            }
            let quad = slot & 1 == 1;
            let alpha = slot >= 2;
            let corners = if quad { 4 } else { 3 };
            let data = Box::new(GeomData {
                alpha: if alpha {
                    ids.iter()
                        .map(|&k| {
                            let a = g.prims[k as usize].alpha.expect("alpha slot");
                            AlphaRec { id: a.id, uv: a.uv }
                        })
                        .collect()
                } else {
                    Vec::new()
                },
                ids,
            });
            let n = data.ids.len();
            let kind = if quad {
                RTC_GEOMETRY_TYPE_QUAD
            } else {
                RTC_GEOMETRY_TYPE_TRIANGLE
            };
            // SAFETY: the device is live; the null check follows.
            let geom = unsafe { rtcNewGeometry(self.device, kind) };
            if geom.is_null() {
                self.check()?;
                return Err(AccelError::Embree("rtcNewGeometry failed".into()));
            }
            // SAFETY: `geom` is a live geometry of ours. `rtcSetNewGeometryBuffer` returns
            // an Embree-owned buffer of `item_count` items of `byte_stride` bytes (null on
            // failure, checked) that lives as long as the geometry; we fill exactly that many
            // f32 / u32 and nothing else touches it before the commit. The user pointer is
            // the boxed `GeomData`, which `self` keeps (in `slots`) until after the scenes
            // are released. Attaching gives the scene its reference, so releasing ours keeps
            // the geometry alive in the scene.
            unsafe {
                let vb = rtcSetNewGeometryBuffer(
                    geom,
                    RTC_BUFFER_TYPE_VERTEX,
                    0,
                    RTC_FORMAT_FLOAT3,
                    12,
                    n * corners,
                ) as *mut f32;
                let ib = rtcSetNewGeometryBuffer(
                    geom,
                    RTC_BUFFER_TYPE_INDEX,
                    0,
                    if quad {
                        RTC_FORMAT_UINT4
                    } else {
                        RTC_FORMAT_UINT3
                    },
                    4 * corners,
                    n,
                ) as *mut u32;
                if vb.is_null() || ib.is_null() {
                    rtcReleaseGeometry(geom);
                    self.check()?;
                    return Err(AccelError::Embree("rtcSetNewGeometryBuffer failed".into()));
                }
                let vb = std::slice::from_raw_parts_mut(vb, n * corners * 3);
                let ib = std::slice::from_raw_parts_mut(ib, n * corners);
                for (j, &k) in data.ids.iter().enumerate() {
                    let v = g.prims[k as usize].v;
                    let corners_of: [Vec3; 4] = [v[0], v[1], v[1] + (v[2] - v[0]), v[2]];
                    let c = if quad { &corners_of[..] } else { &v[..] };
                    for (m, p) in c.iter().enumerate() {
                        let at = (j * corners + m) * 3;
                        vb[at..at + 3].copy_from_slice(&p.to_array());
                        ib[j * corners + m] = (j * corners + m) as u32;
                    }
                }
                rtcSetGeometryUserData(geom, ptr::from_ref::<GeomData>(&data) as *mut c_void);
                if alpha {
                    rtcSetGeometryIntersectFilterFunction(geom, Some(alpha_filter));
                    rtcSetGeometryOccludedFilterFunction(geom, Some(alpha_filter));
                }
                rtcSetGeometryBuildQuality(geom, RTC_BUILD_QUALITY_HIGH);
                rtcCommitGeometry(geom);
                rtcAttachGeometryByID(scene, geom, id_base + slot as u32);
                rtcReleaseGeometry(geom);
            }
            slots[slot] = Some(data);
            self.check()?;
        }
        Ok(slots)
    }

    /// The query context for `skip` (the context filter only when there is a primitive to
    /// skip).
    fn context<'a>(query: &'a Query<'a>) -> QueryContext<'a> {
        let skips = query.skip.prim != NO_PRIM && query.skip.inst != SPHERE;
        QueryContext {
            rtc: RTCIntersectContext {
                flags: RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
                filter: if skips { Some(skip_filter) } else { None },
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            },
            query,
        }
    }

    /// The Embree ray for `ray`, `t ∈ (0, tmax)`; `None` when no `t` qualifies or the ray
    /// is not finite.
    fn rtc_ray(ray: &Ray) -> Option<RTCRay> {
        if !(ray.tmax > 0.0 && ray.origin.is_finite() && ray.dir.is_finite()) {
            return None;
        }
        Some(RTCRay {
            org_x: ray.origin.x,
            org_y: ray.origin.y,
            org_z: ray.origin.z,
            // Embree accepts `tnear <= t <= tfar`; we want `0 < t < tmax`.
            tnear: f32::MIN_POSITIVE,
            dir_x: ray.dir.x,
            dir_y: ray.dir.y,
            dir_z: ray.dir.z,
            time: 0.0,
            tfar: if ray.tmax.is_finite() {
                ray.tmax.next_down()
            } else {
                ray.tmax
            },
            mask: u32::MAX,
            id: 0,
            flags: 0,
        })
    }

    /// The closest accepted hit along `ray`, not counting primitive `skip`
    /// ([`PrimRef::NONE`]: none); `f` decides the alpha-tested candidates no mask decides.
    /// As [`Accel::intersect`](crate::Accel::intersect).
    pub fn intersect<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> Option<Hit> {
        let mut best = self.embree_closest(ray, skip, f);
        let mut bound = best.map_or(ray.tmax, |h| h.t);
        for &(k, ref s) in &self.spheres {
            let t = intersect_sphere(s, ray.origin, ray.dir, bound);
            if t < bound {
                bound = t;
                best = Some(Hit {
                    t,
                    prim: PrimRef {
                        inst: SPHERE,
                        prim: k,
                    },
                    bary: Vec2::ZERO,
                });
            }
        }
        best
    }

    fn embree_closest<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> Option<Hit> {
        let r = Self::rtc_ray(ray)?;
        let query = Query {
            skip,
            masks: &self.masks,
            filter: f,
            panic: Cell::new(None),
        };
        let mut ctx = Self::context(&query);
        let mut rh = RTCRayHit {
            ray: r,
            hit: RTCHit {
                ng_x: 0.0,
                ng_y: 0.0,
                ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                prim_id: RTC_INVALID_GEOMETRY_ID,
                geom_id: RTC_INVALID_GEOMETRY_ID,
                inst_id: [RTC_INVALID_GEOMETRY_ID],
            },
        };
        // SAFETY: `self.top` is a committed scene (read-only, thread-safe queries). The
        // context pointer is derived from the whole `ctx` (so the filters may read its
        // `query` field beyond Embree's struct) and outlives the call, as do `query` and
        // what it borrows; `rh` is a 16-byte aligned `RTCRayHit` initialised as Embree
        // requires (valid ray, invalid geometry id).
        unsafe {
            rtcIntersect1(
                self.top,
                ptr::from_mut(&mut ctx).cast::<RTCIntersectContext>(),
                &mut rh,
            )
        };
        if let Some(p) = query.panic.take() {
            resume_unwind(p);
        }
        let h = rh.hit;
        if h.geom_id == RTC_INVALID_GEOMETRY_ID {
            return None;
        }
        let (inst, data) = if h.inst_id[0] == RTC_INVALID_GEOMETRY_ID {
            (
                NO_INSTANCE,
                &self.world[(h.geom_id - self.world_base) as usize],
            )
        } else {
            let i = h.inst_id[0];
            let proto = self.protos[self.inst_proto[i as usize] as usize]
                .as_ref()
                .expect("hit on an instance of a prototype without a scene");
            (i, &proto.slots[h.geom_id as usize])
        };
        let data = data.as_ref().expect("hit on a geometry slot without data");
        Some(Hit {
            t: rh.ray.tfar,
            prim: PrimRef {
                inst,
                prim: data.ids[h.prim_id as usize],
            },
            bary: Vec2::new(h.u, h.v),
        })
    }

    /// Whether any accepted hit lies along `ray` within `(0, tmax)`, not counting `skip`.
    /// As [`Accel::occluded`](crate::Accel::occluded).
    pub fn occluded<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> bool {
        if self
            .spheres
            .iter()
            .any(|(_, s)| intersect_sphere(s, ray.origin, ray.dir, ray.tmax) < ray.tmax)
        {
            return true;
        }
        let Some(mut r) = Self::rtc_ray(ray) else {
            return false;
        };
        let query = Query {
            skip,
            masks: &self.masks,
            filter: f,
            panic: Cell::new(None),
        };
        let mut ctx = Self::context(&query);
        // SAFETY: as in `embree_closest`, with an `RTCRay` (16-byte aligned, valid).
        unsafe {
            rtcOccluded1(
                self.top,
                ptr::from_mut(&mut ctx).cast::<RTCIntersectContext>(),
                &mut r,
            )
        };
        if let Some(p) = query.panic.take() {
            resume_unwind(p);
        }
        // Embree sets `tfar` to -∞ when it finds an occluder.
        r.tfar == f32::NEG_INFINITY
    }

    /// Bytes held: what Embree's memory monitor counted (BVHs, vertex and index buffers)
    /// plus our primitive maps, instance table and opacity masks. Embree's geometry and
    /// scene objects themselves are not counted by its monitor, which matters with many
    /// instances (one geometry each): for the benchmark's 1M-instance tree it counts 80 MB
    /// while the process's peak resident memory grows by ~340 MB.
    pub fn memory_bytes(&self) -> Option<usize> {
        let embree = self.log.bytes.load(Ordering::Relaxed).max(0) as usize;
        let slots = |s: &Slots| s.iter().flatten().map(|d| d.bytes()).sum::<usize>();
        let ours = slots(&self.world)
            + self
                .protos
                .iter()
                .flatten()
                .map(|p| slots(&p.slots))
                .sum::<usize>()
            + self.inst_proto.capacity() * 4
            + self
                .masks
                .iter()
                .flatten()
                .map(OpacityMask::bytes)
                .sum::<usize>();
        Some(embree + ours)
    }
}

impl Drop for EmbreeAccel {
    fn drop(&mut self) {
        // SAFETY: each handle is null or a live one we own one reference to, released once
        // here; scenes before the device. The `GeomData` boxes and the `DeviceLog` are
        // fields, dropped after this body, so no callback outlives what it reads.
        unsafe {
            if !self.top.is_null() {
                rtcReleaseScene(self.top);
            }
            for p in self.protos.iter().flatten() {
                rtcReleaseScene(p.scene);
            }
            rtcReleaseDevice(self.device);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::AccelError;
    use crate::desc::{Instance, PrimAlpha};
    use crate::mask::MaskWrap;
    use glam::{Affine3A, Quat};

    /// lamina's [`crate::Accel`] speaking scene instance indices, as Embree does (lamina's
    /// hits name instances in its top level's order, see `Accel::scene_instances`).
    #[derive(Debug)]
    struct Accel {
        a: crate::Accel,
        /// Per lamina instance id, the scene index, and the inverse.
        to_scene: Vec<u32>,
        to_id: Vec<u32>,
    }

    impl Accel {
        fn build(desc: &SceneDesc) -> Result<Accel, AccelError> {
            let a = crate::Accel::build(desc)?;
            let to_scene = a.scene_instances(desc);
            let mut to_id = vec![u32::MAX; desc.instances.len()];
            for (id, &k) in to_scene.iter().enumerate() {
                to_id[k as usize] = id as u32;
            }
            Ok(Accel { a, to_scene, to_id })
        }

        fn map(p: PrimRef, table: &[u32]) -> PrimRef {
            match p.inst {
                NO_INSTANCE | SPHERE => p,
                k => PrimRef {
                    inst: table[k as usize],
                    prim: p.prim,
                },
            }
        }

        fn intersect<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> Option<Hit> {
            let skip = Accel::map(skip, &self.to_id);
            self.a.intersect(ray, skip, f).map(|h| Hit {
                prim: Accel::map(h.prim, &self.to_scene),
                ..h
            })
        }

        fn occluded<F: AlphaFilter>(&self, ray: &Ray, skip: PrimRef, f: &F) -> bool {
            self.a.occluded(ray, Accel::map(skip, &self.to_id), f)
        }
    }

    /// splitmix64: a small, seeded generator.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        }
        fn f(&mut self) -> f32 {
            (self.next() >> 40) as f32 / (1u64 << 24) as f32
        }
        fn range(&mut self, a: f32, b: f32) -> f32 {
            a + (b - a) * self.f()
        }
        fn vec(&mut self, a: f32, b: f32) -> Vec3 {
            Vec3::new(self.range(a, b), self.range(a, b), self.range(a, b))
        }
        fn dir(&mut self) -> Vec3 {
            let z = self.range(-1.0, 1.0);
            let phi = self.range(0.0, std::f32::consts::TAU);
            let r = (1.0 - z * z).max(0.0).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        }
        fn below(&mut self, n: usize) -> usize {
            (self.next() % n as u64) as usize
        }
    }

    /// Texels of matte 1 (16 x 16, clamped): a hashed pattern in `[0, 1]`.
    fn texel(x: i64, y: i64) -> f32 {
        let (x, y) = (x.clamp(0, 15) as u64, y.clamp(0, 15) as u64);
        let mut r = Rng(x * 131 + y * 7919 + 17);
        r.f()
    }

    /// The bilinear lookup of [`texel`] at `uv` (texel centres at `(x + 0.5) / 16`,
    /// `v = 1 - (y + 0.5) / 16`), as the mask assumes.
    fn bilinear(uv: Vec2) -> f32 {
        let x = uv.x * 16.0 - 0.5;
        let y = (1.0 - uv.y) * 16.0 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        texel(x0, y0) * (1.0 - fx) * (1.0 - fy)
            + texel(x0 + 1, y0) * fx * (1.0 - fy)
            + texel(x0, y0 + 1) * (1.0 - fx) * fy
            + texel(x0 + 1, y0 + 1) * fx * fy
    }

    /// The mattes: 0 a disc (no mask), 1 the bilinear texels (with a mask), others opaque.
    fn matte(id: u32, uv: Vec2) -> bool {
        match id {
            0 => (uv - Vec2::splat(0.5)).length_squared() < 0.16,
            1 => bilinear(uv) >= 0.5,
            _ => true,
        }
    }

    fn with_alpha(mut p: Prim, r: &mut Rng, uv: [Vec2; 3]) -> Prim {
        if r.f() < 0.45 {
            p.alpha = Some(PrimAlpha {
                id: r.below(3) as u32,
                uv,
            });
        }
        p
    }

    const QUAD_UV: [Vec2; 3] = [Vec2::ZERO, Vec2::X, Vec2::Y];

    /// `tris` triangles and `quads` parallelograms of size ~`size` in `[-extent, extent]^3`,
    /// ~45 % alpha-tested, with invalid primitives interleaved.
    fn random_geometry(r: &mut Rng, tris: usize, quads: usize, extent: f32, size: f32) -> Geometry {
        let mut g = Geometry::default();
        for k in 0..tris + quads {
            if k % 37 == 5 {
                // Invalid: collinear, then not finite. Their indices must be kept.
                let a = r.vec(-extent, extent);
                g.prims
                    .push(Prim::triangle([a, a + Vec3::X, a + 2.0 * Vec3::X]));
                g.prims
                    .push(Prim::parallelogram(Vec3::NAN, Vec3::X, Vec3::Y));
            }
            let c = r.vec(-extent, extent);
            let p = if k < tris {
                let uv = [
                    Vec2::new(r.f(), r.f()),
                    Vec2::new(r.f(), r.f()),
                    Vec2::new(r.f(), r.f()),
                ];
                let p = Prim::triangle([c, c + r.vec(-size, size), c + r.vec(-size, size)]);
                with_alpha(p, r, uv)
            } else {
                let p = Prim::parallelogram(c, r.vec(-size, size), r.vec(-size, size));
                with_alpha(p, r, QUAD_UV)
            };
            g.prims.push(p);
        }
        g
    }

    fn random_transform(r: &mut Rng) -> Affine3A {
        let mut scale = r.vec(0.4, 1.8);
        if r.f() < 0.3 {
            scale.x = -scale.x; // mirroring
        }
        let rot = Quat::from_axis_angle(r.dir(), r.range(0.0, std::f32::consts::TAU));
        Affine3A::from_scale_rotation_translation(scale, rot, r.vec(-3.0, 3.0))
    }

    /// A random scene: world triangles and parallelograms, four prototypes (a cluster, a
    /// single alpha card, an empty one, an unused one), instances with rotation,
    /// non-uniform scale and mirroring, spheres, and a mask for matte 1.
    fn random_scene(seed: u64) -> SceneDesc {
        let mut r = Rng(seed);
        let world = random_geometry(&mut r, 180, 120, 3.0, 0.7);
        let cluster = random_geometry(&mut r, 30, 20, 0.6, 0.4);
        let card = Geometry {
            prims: vec![Prim {
                alpha: Some(PrimAlpha { id: 0, uv: QUAD_UV }),
                ..Prim::parallelogram(
                    Vec3::new(-0.3, -0.45, 0.0),
                    Vec3::new(0.6, 0.0, 0.0),
                    Vec3::new(0.0, 0.9, 0.0),
                )
            }],
        };
        let empty = Geometry {
            prims: vec![Prim::triangle([Vec3::ZERO; 3])],
        };
        let unused = random_geometry(&mut r, 5, 5, 1.0, 0.5);
        let instances = (0..70)
            .map(|_| Instance {
                object_to_world: random_transform(&mut r),
                prototype: [0, 0, 1, 1, 2][r.below(5)],
            })
            .collect();
        let spheres = (0..3)
            .map(|_| Sphere {
                center: r.vec(-2.5, 2.5),
                radius: r.range(0.2, 0.5),
            })
            .collect();
        SceneDesc {
            world,
            prototypes: vec![cluster, card, empty, unused],
            instances,
            spheres,
            masks: vec![
                None,
                OpacityMask::from_texels(16, 16, MaskWrap::Clamp, 0.5, texel),
            ],
        }
    }

    /// Random rays: origins around the scene, directions of random length (so `t` is not a
    /// distance), some aimed at primitives, some with `±0` components.
    fn random_rays(r: &mut Rng, desc: &SceneDesc, n: usize) -> Vec<Ray> {
        (0..n)
            .map(|_| {
                let origin = r.vec(-4.5, 4.5);
                let mut dir = if r.f() < 0.3 {
                    let target = if r.f() < 0.5 {
                        let p = &desc.world.prims[r.below(desc.world.prims.len())];
                        (p.v[0] + p.v[1] + p.v[2]) / 3.0
                    } else {
                        desc.instances[r.below(desc.instances.len())]
                            .object_to_world
                            .translation
                            .into()
                    };
                    (target - origin).normalize_or(Vec3::X)
                } else {
                    r.dir()
                };
                if r.f() < 0.15 {
                    // One or two components exactly ±0.
                    for a in 0..3 {
                        if r.f() < 0.5 {
                            dir[a] = if r.f() < 0.5 { 0.0 } else { -0.0 };
                        }
                    }
                    if dir == Vec3::ZERO {
                        dir.y = -1.0;
                    }
                }
                Ray {
                    origin,
                    dir: dir * r.range(0.5, 2.0),
                    tmax: f32::INFINITY,
                }
            })
            .collect()
    }

    /// `|cos|` of the angle between the ray and the normal of the primitive `h` names.
    fn cos_incidence(desc: &SceneDesc, ray: &Ray, h: &Hit) -> f32 {
        let (prims, m) = match h.prim.inst {
            SPHERE => return 1.0,
            NO_INSTANCE => (&desc.world.prims, Affine3A::IDENTITY),
            i => {
                let inst = &desc.instances[i as usize];
                (
                    &desc.prototypes[inst.prototype as usize].prims,
                    inst.object_to_world,
                )
            }
        };
        let v = prims[h.prim.prim as usize].v.map(|x| m.transform_point3(x));
        let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
        n.dot(ray.dir.normalize()).abs()
    }

    /// How two closest-hit answers compare.
    enum Agree {
        /// Both miss, or the same primitive with `t` within 1e-4 relative (1e-5 absolute
        /// at least: the rounding of the origin, transformed into an instance, is ~1e-6)
        /// and barycentrics within 1e-4.
        Yes,
        /// The same primitive with `t` within 1e-3 relative and barycentrics within 3e-3:
        /// ill-conditioned hits (grazing incidence, slivers), where both engines err by
        /// up to ~1e-3 against an f64 reference; any `t` and barycentrics at `|cos| < 1e-3`
        /// (lamina's Möller-Trumbore `t` is then off by up to ~1e-3 relative, Embree's
        /// watertight one by ~1e-4). Counted; must be rare.
        Close,
        /// Different primitives at the same `t` (within 1e-5 relative): a tie that float
        /// rounding decides (two primitives crossing, a shared edge). Counted; must be rare.
        Tie,
        /// Anything else: a wrong answer of one engine.
        No(String),
    }

    fn compare(desc: &SceneDesc, ray: &Ray, a: Option<Hit>, e: Option<Hit>) -> Agree {
        let (a, e) = match (a, e) {
            (None, None) => return Agree::Yes,
            (Some(a), Some(e)) => (a, e),
            _ => return Agree::No(format!("{ray:?}: lamina {a:?} embree {e:?}")),
        };
        let dt = (a.t - e.t).abs() / a.t.abs().max(0.1);
        let db = (a.bary - e.bary).abs().max_element();
        if a.prim != e.prim {
            if dt <= 1e-5 {
                return Agree::Tie;
            }
        } else if dt <= 1e-4 && db <= 1e-4 {
            return Agree::Yes;
        } else if dt <= 1e-3 && db <= 3e-3 || cos_incidence(desc, ray, &a) < 1e-3 {
            return Agree::Close;
        }
        Agree::No(format!("{ray:?}: lamina {a:?} embree {e:?}"))
    }

    fn fail_report(what: &str, bad: &[String], n: usize) -> String {
        format!(
            "{what}: {} of {n} rays differ; first ones:\n{}",
            bad.len(),
            bad[..bad.len().min(10)].join("\n")
        )
    }

    #[test]
    fn random_scenes_agree_with_lamina() {
        for seed in [1u64, 2, 3] {
            let desc = random_scene(seed);
            let accel = Accel::build(&desc).unwrap();
            let emb = EmbreeAccel::build(&desc).unwrap();
            let mut r = Rng(seed * 1000 + 7);
            let rays = random_rays(&mut r, &desc, 5000);
            let (mut bad, mut bad_occ) = (Vec::new(), Vec::new());
            let (mut world, mut inst, mut sphere, mut alpha, mut zero_dir) = (0, 0, 0, 0, 0);
            let (mut close, mut ties) = (0, 0);
            let mut occluded = 0;
            for ray in &rays {
                let a = accel.intersect(ray, PrimRef::NONE, &matte);
                let e = emb.intersect(ray, PrimRef::NONE, &matte);
                match compare(&desc, ray, a, e) {
                    Agree::Yes => {}
                    Agree::Close => close += 1,
                    Agree::Tie => ties += 1,
                    Agree::No(d) => bad.push(d),
                }
                if let Some(h) = a {
                    match h.prim.inst {
                        NO_INSTANCE => {
                            world += 1;
                            alpha +=
                                usize::from(desc.world.prims[h.prim.prim as usize].alpha.is_some());
                        }
                        SPHERE => sphere += 1,
                        _ => inst += 1,
                    }
                    zero_dir += usize::from(ray.dir.to_array().contains(&0.0));
                }
                // Occlusion up to a random distance.
                let short = Ray {
                    tmax: r.range(0.2, 5.0),
                    ..*ray
                };
                let (oa, oe) = (
                    accel.occluded(&short, PrimRef::NONE, &matte),
                    emb.occluded(&short, PrimRef::NONE, &matte),
                );
                occluded += usize::from(oa);
                if oa != oe {
                    bad_occ.push(format!("{short:?}: lamina {oa} embree {oe}"));
                }
                // Occlusion must agree with the closest hit.
                let closest = emb.intersect(&short, PrimRef::NONE, &matte);
                assert_eq!(oe, closest.is_some(), "{short:?}: occluded vs intersect");
            }
            assert!(
                bad.is_empty(),
                "{}",
                fail_report("intersect", &bad, rays.len())
            );
            assert!(
                bad_occ.is_empty(),
                "{}",
                fail_report("occluded", &bad_occ, rays.len())
            );
            assert!(
                close + ties <= rays.len() / 500,
                "{close} close answers, {ties} ties"
            );
            let hits = world + inst + sphere;
            assert!(
                hits > rays.len() / 5 && hits < rays.len(),
                "{hits} hits of {}",
                rays.len()
            );
            assert!(
                world > 300 && inst > 100 && sphere > 10 && alpha > 50 && zero_dir > 20,
                "seed {seed}: world {world} instances {inst} spheres {sphere} alpha {alpha} ±0 {zero_dir}"
            );
            assert!(
                occluded > 300 && occluded < rays.len() - 300,
                "{occluded} occluded"
            );
        }
    }

    /// Without `RTC_SCENE_FLAG_ROBUST`, Embree's Möller test of a quad as two triangles
    /// leaves a crack along the split diagonal `v1-v3` (Embree issue #538: "enable
    /// RTC_SCENE_FLAG_ROBUST ... should fix the missed quad intersections"); rays aimed at a
    /// card's centre find it. Elsewhere the fast path agrees with lamina.
    #[test]
    fn fast_path_misses_only_on_quad_diagonals() {
        let desc = random_scene(9);
        let accel = Accel::build(&desc).unwrap();
        let fast = EmbreeAccel::build_with(&desc, EmbreeOptions { robust: false }).unwrap();
        let robust = EmbreeAccel::build(&desc).unwrap();
        let mut r = Rng(99);
        let rays = random_rays(&mut r, &desc, 4000);
        let (mut bad, mut cracks) = (Vec::new(), 0);
        for ray in &rays {
            let a = accel.intersect(ray, PrimRef::NONE, &matte);
            if let Agree::No(d) =
                compare(&desc, ray, a, robust.intersect(ray, PrimRef::NONE, &matte))
            {
                bad.push(format!("robust: {d}"));
            }
            if let Agree::No(d) = compare(&desc, ray, a, fast.intersect(ray, PrimRef::NONE, &matte))
            {
                let on_diagonal = a.is_some_and(|h| {
                    let p = match h.prim.inst {
                        NO_INSTANCE => &desc.world.prims[h.prim.prim as usize],
                        SPHERE => return false,
                        i => {
                            let proto = desc.instances[i as usize].prototype as usize;
                            &desc.prototypes[proto].prims[h.prim.prim as usize]
                        }
                    };
                    p.quad && (h.bary.x + h.bary.y - 1.0).abs() < 1e-5
                });
                if on_diagonal {
                    cracks += 1;
                } else {
                    bad.push(format!("fast: {d}"));
                }
            }
        }
        assert!(
            bad.is_empty(),
            "{}",
            fail_report("intersect", &bad, rays.len())
        );
        assert!(
            cracks < rays.len() / 100,
            "{cracks} misses on quad diagonals"
        );
    }

    #[test]
    fn skip_agrees_with_lamina() {
        let desc = random_scene(4);
        let accel = Accel::build(&desc).unwrap();
        let emb = EmbreeAccel::build(&desc).unwrap();
        let mut r = Rng(44);
        let mut bad = Vec::new();
        let (mut tested, mut without_skip_self) = (0, 0);
        for ray in random_rays(&mut r, &desc, 4000) {
            let Some(h) = accel.intersect(&ray, PrimRef::NONE, &matte) else {
                continue;
            };
            if h.prim.inst == SPHERE {
                continue;
            }
            // A secondary ray leaving the hit point, skipping the primitive it leaves.
            let next = Ray {
                origin: ray.origin + ray.dir * h.t,
                dir: r.dir(),
                tmax: f32::INFINITY,
            };
            tested += 1;
            let (a, e) = (
                accel.intersect(&next, h.prim, &matte),
                emb.intersect(&next, h.prim, &matte),
            );
            if let Agree::No(d) = compare(&desc, &next, a, e) {
                bad.push(format!("skip {:?}: {d}", h.prim));
            }
            for x in [a, e].into_iter().flatten() {
                assert_ne!(x.prim, h.prim, "{next:?}: the skipped primitive was hit");
            }
            let short = Ray { tmax: 1.0, ..next };
            let (oa, oe) = (
                accel.occluded(&short, h.prim, &matte),
                emb.occluded(&short, h.prim, &matte),
            );
            if oa != oe {
                bad.push(format!(
                    "{short:?} skip {:?}: occluded lamina {oa} embree {oe}",
                    h.prim
                ));
            }
            // Without the skip, the ray often finds its own origin again.
            if let Some(x) = emb.intersect(&next, PrimRef::NONE, &matte) {
                without_skip_self += usize::from(x.prim == h.prim);
            }
        }
        assert!(tested > 1000, "{tested}");
        assert!(bad.is_empty(), "{}", fail_report("skip", &bad, tested));
        // The skip matters: self-hits exist without it (not asserted per ray: rounding).
        assert!(
            without_skip_self > 0,
            "no self-hit without the skip: the test proves nothing"
        );
    }

    /// A quad `[-1, 1]²` in the `y = 0` plane, the same quad in a mirroring, scaled instance
    /// at `x = 5`, and rays along `-y` with `±0` in `x` and `z`.
    #[test]
    fn negative_zero_directions() {
        let quad = Prim::parallelogram(
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0),
        );
        let desc = SceneDesc {
            world: Geometry { prims: vec![quad] },
            prototypes: vec![Geometry { prims: vec![quad] }],
            instances: vec![Instance {
                object_to_world: Affine3A::from_scale_rotation_translation(
                    Vec3::new(2.0, 1.0, -1.0),
                    Quat::IDENTITY,
                    Vec3::new(5.0, 0.0, 0.0),
                ),
                prototype: 0,
            }],
            ..Default::default()
        };
        let accel = Accel::build(&desc).unwrap();
        let emb = EmbreeAccel::build(&desc).unwrap();
        let f = |_: u32, _: Vec2| true;
        for (x, inst, b1) in [(0.5, NO_INSTANCE, 0.75), (5.5, 0, 0.625)] {
            for (dx, dz) in [(0.0, 0.0), (-0.0, -0.0), (-0.0, 0.0), (0.0, -0.0)] {
                for len in [1.0f32, 2.0] {
                    let ray = Ray {
                        origin: Vec3::new(x, 3.0, 0.5),
                        dir: Vec3::new(dx, -len, dz),
                        tmax: f32::INFINITY,
                    };
                    for h in [
                        accel.intersect(&ray, PrimRef::NONE, &f),
                        emb.intersect(&ray, PrimRef::NONE, &f),
                    ] {
                        let h = h.unwrap_or_else(|| panic!("{ray:?}: no hit"));
                        assert_eq!(h.prim, PrimRef { inst, prim: 0 }, "{ray:?}");
                        assert!((h.t - 3.0 / len).abs() < 1e-5, "{ray:?}: t {}", h.t);
                        // z = 0.5 maps to b2 = 0.75 in the world; the mirrored instance's
                        // object z is -0.5: b2 = 0.25.
                        let b2 = if inst == NO_INSTANCE { 0.75 } else { 0.25 };
                        assert!(
                            (h.bary - Vec2::new(b1, b2)).abs().max_element() < 1e-5,
                            "{ray:?}: {h:?}"
                        );
                    }
                    let up = Ray {
                        dir: Vec3::new(dx, len, dz),
                        ..ray
                    };
                    assert_eq!(emb.intersect(&up, PrimRef::NONE, &f), None);
                    assert!(emb.occluded(&ray, PrimRef::NONE, &f));
                    assert!(!emb.occluded(
                        &Ray {
                            tmax: 2.9 / len,
                            ..ray
                        },
                        PrimRef::NONE,
                        &f
                    ));
                }
            }
        }
    }

    #[test]
    fn tmax_is_exclusive_and_alpha_holes_let_rays_through() {
        // Two parallel quads at y = 0 (a disc matte: a hole at its corners) and y = -1.
        let mut top = Prim::parallelogram(
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0),
        );
        top.alpha = Some(PrimAlpha { id: 0, uv: QUAD_UV });
        let bottom = Prim::parallelogram(
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 2.0),
        );
        let desc = SceneDesc {
            world: Geometry {
                prims: vec![top, bottom],
            },
            ..Default::default()
        };
        let emb = EmbreeAccel::build(&desc).unwrap();
        let down = |x: f32, z: f32, tmax: f32| Ray {
            origin: Vec3::new(x, 2.0, z),
            dir: -Vec3::Y,
            tmax,
        };
        // The centre is opaque: the top quad at t = 2, uv (0.5, 0.5) (Embree's watertight
        // test rounds t by an ulp or so).
        let top = emb
            .intersect(&down(0.0, 0.0, f32::INFINITY), PrimRef::NONE, &matte)
            .unwrap();
        assert_eq!(top.prim.prim, 0);
        assert!((top.t - 2.0).abs() < 1e-6, "{top:?}");
        assert!((top.bary - Vec2::splat(0.5)).length() < 1e-6);
        // A corner is a hole: the bottom quad at t = 3.
        let bottom = emb
            .intersect(&down(0.9, 0.9, f32::INFINITY), PrimRef::NONE, &matte)
            .unwrap();
        assert_eq!(bottom.prim.prim, 1);
        assert!((bottom.t - 3.0).abs() < 1e-6, "{bottom:?}");
        // tmax exactly at the hit: no hit (t < tmax); one ulp past it: the hit.
        for (x, h) in [(0.0, top), (0.9, bottom)] {
            assert_eq!(emb.intersect(&down(x, x, h.t), PrimRef::NONE, &matte), None);
            assert!(!emb.occluded(&down(x, x, h.t), PrimRef::NONE, &matte));
            let past = down(x, x, h.t.next_up());
            assert_eq!(emb.intersect(&past, PrimRef::NONE, &matte), Some(h));
            assert!(emb.occluded(&past, PrimRef::NONE, &matte));
        }
        // Skipping the top quad reveals the bottom one.
        let top_ref = PrimRef {
            inst: NO_INSTANCE,
            prim: 0,
        };
        assert_eq!(
            emb.intersect(&down(0.0, 0.0, f32::INFINITY), top_ref, &matte)
                .unwrap()
                .prim
                .prim,
            1
        );
        // A filter that rejects everything on matte 0 makes the top quad vanish.
        let none = |_: u32, _: Vec2| false;
        assert_eq!(
            emb.intersect(&down(0.0, 0.0, f32::INFINITY), PrimRef::NONE, &none)
                .unwrap()
                .prim
                .prim,
            1
        );
        // Bad rays hit nothing.
        assert_eq!(
            emb.intersect(&down(0.0, 0.0, 0.0), PrimRef::NONE, &matte),
            None
        );
        assert_eq!(
            emb.intersect(&down(f32::NAN, 0.0, 9.0), PrimRef::NONE, &matte),
            None
        );
    }

    #[test]
    fn sphere_ids_are_scene_indices() {
        // An invalid sphere first: the valid one keeps its index, 1.
        let desc = SceneDesc {
            spheres: vec![
                Sphere {
                    center: Vec3::ZERO,
                    radius: 0.0,
                },
                Sphere {
                    center: Vec3::new(0.0, 0.0, -5.0),
                    radius: 1.0,
                },
            ],
            ..Default::default()
        };
        let emb = EmbreeAccel::build(&desc).unwrap();
        let ray = Ray {
            origin: Vec3::ZERO,
            dir: -Vec3::Z,
            tmax: f32::INFINITY,
        };
        let h = emb.intersect(&ray, PrimRef::NONE, &matte).unwrap();
        assert_eq!(
            h.prim,
            PrimRef {
                inst: SPHERE,
                prim: 1
            }
        );
        assert!((h.t - 4.0).abs() < 1e-5);
        assert!(emb.occluded(&ray, PrimRef::NONE, &matte));
        assert!(!emb.occluded(&Ray { tmax: 3.9, ..ray }, PrimRef::NONE, &matte));
    }

    #[test]
    fn bad_instances_are_the_same_errors_as_lamina() {
        let card = Geometry {
            prims: vec![Prim::parallelogram(Vec3::ZERO, Vec3::X, Vec3::Y)],
        };
        let mut desc = SceneDesc {
            prototypes: vec![card],
            instances: vec![
                Instance {
                    object_to_world: Affine3A::IDENTITY,
                    prototype: 0,
                },
                Instance {
                    object_to_world: Affine3A::IDENTITY,
                    prototype: 3,
                },
            ],
            ..Default::default()
        };
        let want = AccelError::Prototype {
            instance: 1,
            prototype: 3,
            count: 1,
        };
        assert_eq!(EmbreeAccel::build(&desc).unwrap_err(), want);
        assert_eq!(Accel::build(&desc).unwrap_err(), want);
        desc.instances[1] = Instance {
            object_to_world: Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0)),
            prototype: 0,
        };
        assert_eq!(
            EmbreeAccel::build(&desc).unwrap_err(),
            AccelError::Transform(1)
        );
        assert_eq!(Accel::build(&desc).unwrap_err(), AccelError::Transform(1));
    }

    #[test]
    fn memory_is_counted_and_empty_scenes_work() {
        let desc = random_scene(5);
        let emb = EmbreeAccel::build(&desc).unwrap();
        let bytes = emb.memory_bytes().unwrap();
        // At least the vertex buffers: 3 or 4 corners of 12 bytes per valid primitive.
        assert!(bytes > 300 * 36, "{bytes}");
        let empty = EmbreeAccel::build(&SceneDesc::default()).unwrap();
        let ray = Ray {
            origin: Vec3::ZERO,
            dir: Vec3::X,
            tmax: f32::INFINITY,
        };
        assert_eq!(empty.intersect(&ray, PrimRef::NONE, &matte), None);
        assert!(!empty.occluded(&ray, PrimRef::NONE, &matte));
    }

    #[test]
    fn queries_run_on_many_threads() {
        use rayon::prelude::*;
        let desc = random_scene(6);
        let emb = EmbreeAccel::build(&desc).unwrap();
        let accel = Accel::build(&desc).unwrap();
        let mut r = Rng(66);
        let rays = random_rays(&mut r, &desc, 4000);
        let serial: Vec<_> = rays
            .iter()
            .map(|ray| emb.intersect(ray, PrimRef::NONE, &matte))
            .collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let parallel: Vec<_> = pool.install(|| {
            rays.par_iter()
                .map(|ray| emb.intersect(ray, PrimRef::NONE, &matte))
                .collect()
        });
        assert_eq!(serial, parallel);
        let lamina: Vec<_> = rays
            .iter()
            .map(|ray| accel.intersect(ray, PrimRef::NONE, &matte))
            .collect();
        assert_eq!(
            serial.iter().filter(|h| h.is_some()).count(),
            lamina.iter().filter(|h| h.is_some()).count()
        );
    }

    #[test]
    #[should_panic(expected = "matte exploded")]
    fn a_panicking_filter_panics_the_query() {
        let mut card =
            Prim::parallelogram(Vec3::new(-1.0, -1.0, 0.0), 2.0 * Vec3::X, 2.0 * Vec3::Y);
        card.alpha = Some(PrimAlpha { id: 7, uv: QUAD_UV });
        let desc = SceneDesc {
            world: Geometry { prims: vec![card] },
            ..Default::default()
        };
        let emb = EmbreeAccel::build(&desc).unwrap();
        let ray = Ray {
            origin: Vec3::new(0.0, 0.0, 2.0),
            dir: -Vec3::Z,
            tmax: f32::INFINITY,
        };
        emb.intersect(&ray, PrimRef::NONE, &|_: u32, _: Vec2| -> bool {
            panic!("matte exploded")
        });
    }
}
