//! Embree 3's BVH builder making lamina's binary tree (cargo feature `embree`), so that
//! lamina's own traversal can run over a tree Embree built: the two builders compared
//! with everything else held fixed ([`crate::Builder::EmbreeHigh`], `rays --builder`).
//!
//! `rtcBuildBVH` at `RTC_BUILD_QUALITY_HIGH` with a `splitPrimitive` callback is Embree's
//! binned SAH with spatial splits (Stich et al. 2009's SBVH as Embree implements it, the
//! builder its triangle scenes get at that quality); here with branching factor 2, leaves
//! of at most four references, the leaf cost counted in blocks of four (`sahBlockSize`,
//! our pack) and our node-visit cost. Our callbacks record Embree's nodes in its own
//! thread-local memory; the tree is then copied into a [`Binary`], whose leaves may name
//! a primitive more than once across leaves (a spatial split puts a primitive on both
//! sides), and the rest of the build (collapse to the wide layout, packs, a primitive
//! once per pack) is lamina's.
//!
//! Splitting a reference: the primitive (a triangle or a parallelogram) is clipped in
//! `f64` to each half of the reference's box (Sutherland–Hodgman against all six faces,
//! tighter than Embree's own triangle splitter, which clips at the plane and then cuts to
//! the box), and each half's box is the clipped polygon's, widened by two units in the last
//! place of the largest coordinate involved and cut back to that half: the primitive's
//! part on a side lies in that half exactly, so the two boxes cover it despite rounding. A
//! side left empty gets an empty box (Embree then does not split there).
//!
//! Embree asks for one device per application: the builder keeps one for the process
//! (created at its first use, never released), whatever the number of trees it builds.

use crate::AccelError;
use crate::build::{Aabb, BNode, Binary, BuildParams};
use crate::embree::ffi::*;
use glam::{DVec3, Vec3};
use std::ffi::{c_uint, c_void};
use std::ptr;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

/// The most vertices a triangle or parallelogram clipped to a box can have (4 + one per
/// face).
const MAX_VERTS: usize = 10;

/// The deepest tree Embree may build: the depth `layout::STACK` sizes the traversal stack
/// for (each binary level adds at most `W - 1` entries; the collapse only makes it
/// shallower).
const MAX_DEPTH: u32 = crate::build::SAH_DEPTH as u32 + 32;
const _: () = assert!(crate::layout::STACK >= 7 * MAX_DEPTH as usize + 8);

/// A convex planar polygon: a triangle or a parallelogram, vertices in order around it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Poly {
    v: [Vec3; 4],
    n: usize,
}

impl Poly {
    /// The triangle `v`, or with `quad` the parallelogram `v[0], v[1], v[1] + v[2] - v[0],
    /// v[2]` (a [`crate::desc::Prim`]'s outline).
    pub(crate) fn of_prim(v: [Vec3; 3], quad: bool) -> Poly {
        if quad {
            Poly {
                v: [v[0], v[1], v[1] + v[2] - v[0], v[2]],
                n: 4,
            }
        } else {
            Poly {
                v: [v[0], v[1], v[2], v[2]],
                n: 3,
            }
        }
    }
}

/// The polygon `v` clipped to the box `lo..hi` (Sutherland–Hodgman, one face at a time,
/// crossing points put exactly on the face), in `f64`; `None` when rounding would give it
/// more than [`MAX_VERTS`] vertices.
fn clip(v: &[DVec3], lo: DVec3, hi: DVec3) -> Option<([DVec3; MAX_VERTS], usize)> {
    let mut cur = [DVec3::ZERO; MAX_VERTS];
    let mut n = v.len();
    cur[..n].copy_from_slice(v);
    for axis in 0..3 {
        for (bound, below) in [(lo[axis], false), (hi[axis], true)] {
            let inside = |p: DVec3| {
                if below {
                    p[axis] <= bound
                } else {
                    p[axis] >= bound
                }
            };
            let mut out = [DVec3::ZERO; MAX_VERTS];
            let mut m = 0;
            for i in 0..n {
                let (a, c) = (cur[i], cur[(i + 1) % n]);
                if inside(a) {
                    *out.get_mut(m)? = a;
                    m += 1;
                }
                if inside(a) != inside(c) {
                    let t = (bound - a[axis]) / (c[axis] - a[axis]);
                    let mut p = a + (c - a) * t;
                    p[axis] = bound;
                    *out.get_mut(m)? = p;
                    m += 1;
                }
            }
            (cur, n) = (out, m);
            if n == 0 {
                break;
            }
        }
    }
    Some((cur, n))
}

/// The box of `poly`'s part inside `half` (module docs): empty where nothing of it is
/// inside, `half` itself where clipping overflowed.
fn part_box(poly: &Poly, half: &Aabb) -> Aabb {
    let v = poly.v.map(|p| p.as_dvec3());
    let Some((c, n)) = clip(&v[..poly.n], half.min.as_dvec3(), half.max.as_dvec3()) else {
        return *half;
    };
    if n == 0 {
        return Aabb::EMPTY;
    }
    let (mut lo, mut hi) = (c[0], c[0]);
    for p in &c[1..n] {
        (lo, hi) = (lo.min(*p), hi.max(*p));
    }
    // The largest magnitude of any coordinate involved: two of its units in the last place
    // (f32) cover the rounding of the f64 values to f32 and of the clipping itself.
    let m = v[..poly.n]
        .iter()
        .chain([&half.min.as_dvec3(), &half.max.as_dvec3()])
        .fold(0.0f64, |m, p| m.max(p.abs().max_element()));
    let pad = (m * 2.0 * f32::EPSILON as f64) as f32;
    Aabb {
        min: (lo.as_vec3() - Vec3::splat(pad)).max(half.min),
        max: (hi.as_vec3() + Vec3::splat(pad)).min(half.max),
    }
}

/// One node as the callbacks make it, in Embree's allocator's memory (freed with the
/// BVH): plain data, every field written by [`new_node`].
#[repr(C)]
struct ENode {
    /// A leaf (`prims[..count]`) or an inner node (`child[..count]`, `bounds[..count]`).
    leaf: bool,
    count: u32,
    child: [*const ENode; 2],
    bounds: [Aabb; 2],
    prims: [u32; 4],
}

/// What the callbacks see through `userPtr`: shared by Embree's build threads, so only
/// read, or written through atomics.
struct Ctx<'a> {
    polys: &'a [Poly],
    /// Set when a callback meets what it cannot record (more children or leaf references
    /// than configured, none at all, an allocation that failed, an unknown primitive): the
    /// build is then refused.
    bad: AtomicBool,
}

const _: () = {
    const fn sync<T: Sync>() {}
    sync::<Ctx>();
};

impl Ctx<'_> {
    fn fail(&self) {
        self.bad.store(true, Ordering::Relaxed);
    }
}

fn to_bounds(b: &Aabb) -> RTCBounds {
    RTCBounds {
        lower: b.min.to_array(),
        align0: 0.0,
        upper: b.max.to_array(),
        align1: 0.0,
    }
}

/// A new node from Embree's thread-local allocator; null (and the build marked failed)
/// if it gave none.
///
/// # Safety
/// `alloc` is the allocator Embree passed to the callback.
unsafe fn new_node(alloc: RTCThreadLocalAllocator, ctx: &Ctx, node: ENode) -> *mut c_void {
    // SAFETY: `alloc` is Embree's (the caller's contract); it returns memory of the size
    // and alignment asked for, or null.
    let p = unsafe {
        rtcThreadLocalAlloc(alloc, size_of::<ENode>(), align_of::<ENode>()) as *mut ENode
    };
    if p.is_null() {
        ctx.fail();
    } else {
        // SAFETY: `p` is non-null, aligned and `size_of::<ENode>()` bytes, not yet shared.
        unsafe { p.write(node) };
    }
    p.cast()
}

/// The callbacks below keep to Embree's contracts for them (`rtcore_builder.h`) and
/// never panic (a panic cannot unwind through Embree's C++ frames): what they cannot
/// record marks the build failed instead.
unsafe extern "C" fn create_node(
    alloc: RTCThreadLocalAllocator,
    count: c_uint,
    user: *mut c_void,
) -> *mut c_void {
    // SAFETY: `user` is the `Ctx` that `build_binary` passed, alive for the build.
    let ctx = unsafe { &*(user as *const Ctx) };
    if !(1..=2).contains(&count) {
        ctx.fail();
    }
    let node = ENode {
        leaf: false,
        count: count.min(2),
        child: [ptr::null(); 2],
        bounds: [Aabb::EMPTY; 2],
        prims: [0; 4],
    };
    // SAFETY: `alloc` is Embree's, passed to this callback.
    unsafe { new_node(alloc, ctx, node) }
}

unsafe extern "C" fn set_children(
    node: *mut c_void,
    children: *mut *mut c_void,
    count: c_uint,
    _user: *mut c_void,
) {
    if node.is_null() {
        return; // its allocation failed: the build is marked failed
    }
    // SAFETY: a non-null `node` is one `create_node` made and wrote (Embree passes it
    // back, to one thread), `children` points to `count` node pointers, of which at most
    // the node's own `count` (at most two) are read.
    unsafe {
        let n = &mut *(node as *mut ENode);
        for i in 0..(count as usize).min(n.count as usize) {
            n.child[i] = *children.add(i) as *const ENode;
        }
    }
}

unsafe extern "C" fn set_bounds(
    node: *mut c_void,
    bounds: *const *const RTCBounds,
    count: c_uint,
    _user: *mut c_void,
) {
    if node.is_null() {
        return;
    }
    // SAFETY: as `set_children`, with `count` pointers to bounds.
    unsafe {
        let n = &mut *(node as *mut ENode);
        for i in 0..(count as usize).min(n.count as usize) {
            let b = &**bounds.add(i);
            n.bounds[i] = Aabb {
                min: Vec3::from(b.lower),
                max: Vec3::from(b.upper),
            };
        }
    }
}

unsafe extern "C" fn create_leaf(
    alloc: RTCThreadLocalAllocator,
    prims: *const RTCBuildPrimitive,
    count: usize,
    user: *mut c_void,
) -> *mut c_void {
    // SAFETY: `user` is the build's `Ctx`.
    let ctx = unsafe { &*(user as *const Ctx) };
    if !(1..=4).contains(&count) || prims.is_null() {
        ctx.fail();
        return ptr::null_mut();
    }
    // SAFETY: `prims` is non-null and points to `count` build primitives.
    let prims = unsafe { std::slice::from_raw_parts(prims, count) };
    let mut node = ENode {
        leaf: true,
        count: count as u32,
        child: [ptr::null(); 2],
        bounds: [Aabb::EMPTY; 2],
        prims: [0; 4],
    };
    for (slot, p) in node.prims.iter_mut().zip(prims) {
        *slot = p.prim_id;
    }
    // SAFETY: `alloc` is Embree's, passed to this callback.
    unsafe { new_node(alloc, ctx, node) }
}

unsafe extern "C" fn split_primitive(
    prim: *const RTCBuildPrimitive,
    dim: c_uint,
    pos: f32,
    left: *mut RTCBounds,
    right: *mut RTCBounds,
    user: *mut c_void,
) {
    // SAFETY: `user` is the build's `Ctx`; `prim` is valid for one read and `left` and
    // `right` for one write each, distinct (Embree's contract for this callback).
    unsafe {
        let ctx = &*(user as *const Ctx);
        let p = &*prim;
        let b = Aabb {
            min: Vec3::from(p.lower),
            max: Vec3::from(p.upper),
        };
        let poly = ctx.polys.get(p.prim_id as usize);
        let (l, r) = match poly {
            Some(poly) if !b.is_empty() => {
                let d = (dim as usize).min(2);
                let at = pos.max(b.min[d]).min(b.max[d]);
                let (mut lo, mut hi) = (b, b);
                lo.max[d] = at;
                hi.min[d] = at;
                (part_box(poly, &lo), part_box(poly, &hi))
            }
            Some(_) => (Aabb::EMPTY, Aabb::EMPTY),
            None => {
                ctx.fail();
                (Aabb::EMPTY, Aabb::EMPTY)
            }
        };
        *left = to_bounds(&l);
        *right = to_bounds(&r);
    }
}

/// Copies the subtree at `n` (box `bounds`) into `out`; returns its index, or `None` for
/// a null node.
///
/// # Safety
/// `n` is null or a node of a finished build whose BVH is still alive and that no
/// callback marked failed (so every inner node's `count` children were set).
unsafe fn copy(n: *const ENode, bounds: Aabb, out: &mut Binary) -> Option<u32> {
    // SAFETY: the caller's contract: a non-null `n` is a node the callbacks wrote fully.
    let node = unsafe { n.as_ref()? };
    let me = out.nodes.len();
    out.nodes.push(BNode {
        bounds,
        a: out.order.len() as u32,
        b: 0,
        count: node.count,
    });
    if node.leaf {
        out.order
            .extend_from_slice(&node.prims[..node.count as usize]);
        return Some(me as u32);
    }
    if node.count == 1 {
        // A node with one child: the child in its place.
        out.nodes.pop();
        // SAFETY: as above (a child of a node of this build).
        return unsafe { copy(node.child[0], bounds, out) };
    }
    // SAFETY: as above.
    let a = unsafe { copy(node.child[0], node.bounds[0], out)? };
    // SAFETY: as above.
    let b = unsafe { copy(node.child[1], node.bounds[1], out)? };
    out.nodes[me] = BNode {
        bounds,
        a,
        b,
        count: 0,
    };
    Some(me as u32)
}

/// The process's Embree device for building (module docs), as an address.
static DEVICE: Mutex<usize> = Mutex::new(0);

fn device() -> Result<RTCDevice, AccelError> {
    let mut d = DEVICE.lock().unwrap_or_else(|e| e.into_inner());
    if *d == 0 {
        // SAFETY: a null config asks for Embree's defaults.
        let device = unsafe { rtcNewDevice(ptr::null()) };
        if device.is_null() {
            return Err(AccelError::Embree("rtcNewDevice failed".into()));
        }
        *d = device as usize;
    }
    Ok(*d as RTCDevice)
}

/// The binary tree Embree's high-quality builder makes over the primitives with outlines
/// `polys` and boxes `bounds` (ids = indices): leaves of at most `params.max_leaf`
/// references (a primitive may be named in several leaves, and twice in one), leaf cost in
/// blocks of `params.pack`, node visits `params.trav_cost`.
pub(crate) fn build_binary(
    polys: &[Poly],
    bounds: &[Aabb],
    params: BuildParams,
) -> Result<Binary, AccelError> {
    let n = bounds.len();
    // Room for the references spatial splits add: Embree splits only into the capacity
    // beyond `n` (and splits nothing with none).
    let mut prims = vec![RTCBuildPrimitive::default(); 2 * n];
    for (i, (p, b)) in prims.iter_mut().zip(bounds).enumerate() {
        *p = RTCBuildPrimitive {
            lower: b.min.to_array(),
            geom_id: 0,
            upper: b.max.to_array(),
            prim_id: i as u32,
        };
    }
    let ctx = Ctx {
        polys,
        bad: AtomicBool::new(false),
    };
    let device = device()?;
    // SAFETY: `device` is live (never released).
    let bvh = unsafe { rtcNewBVH(device) };
    if bvh.is_null() {
        return Err(AccelError::Embree("rtcNewBVH failed".into()));
    }
    let args = RTCBuildArguments {
        byte_size: size_of::<RTCBuildArguments>(),
        build_quality: RTC_BUILD_QUALITY_HIGH,
        build_flags: 0,
        max_branching_factor: 2,
        max_depth: MAX_DEPTH,
        sah_block_size: params.pack as u32,
        min_leaf_size: 1,
        max_leaf_size: params.max_leaf as u32,
        traversal_cost: params.trav_cost,
        intersection_cost: 1.0,
        bvh,
        primitives: prims.as_mut_ptr(),
        primitive_count: n,
        primitive_array_capacity: prims.len(),
        create_node: Some(create_node),
        set_node_children: Some(set_children),
        set_node_bounds: Some(set_bounds),
        create_leaf: Some(create_leaf),
        split_primitive: Some(split_primitive),
        build_progress: None,
        user_ptr: &ctx as *const Ctx as *mut c_void,
    };
    // SAFETY: `args` is laid out as Embree's struct (size and field offsets asserted in
    // `ffi`); `prims` (32-byte aligned, `2n` long: Embree writes split references past
    // `n`) and `ctx` (`Sync`: the callbacks run on Embree's threads at once) outlive the
    // call; the callbacks keep to their contracts and never unwind.
    let root = unsafe { rtcBuildBVH(&args) } as *const ENode;
    let mut out = Binary {
        nodes: Vec::with_capacity(2 * n),
        order: Vec::with_capacity(2 * n),
    };
    let result = if root.is_null() {
        // SAFETY: `device` is live.
        let code = unsafe { rtcGetDeviceError(device) };
        Err(AccelError::Embree(format!(
            "rtcBuildBVH failed (error {code})"
        )))
    } else if ctx.bad.load(Ordering::Relaxed) {
        Err(AccelError::Embree(
            "rtcBuildBVH: a node or leaf the builder could not record".into(),
        ))
    } else {
        let all = bounds.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
        // SAFETY: `root` is the finished build's root, no callback failed, and the BVH is
        // released only below.
        match unsafe { copy(root, all, &mut out) } {
            Some(_) => Ok(out),
            None => Err(AccelError::Embree(
                "rtcBuildBVH: a node without children".into(),
            )),
        }
    };
    // SAFETY: `bvh` is live and released once.
    unsafe { rtcReleaseBVH(bvh) };
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clipping_keeps_the_part_inside() {
        let c = Vec3::ZERO;
        let p = Poly::of_prim(
            [
                c,
                c + Vec3::new(1.0, 1.0, 0.0),
                c + Vec3::new(0.0, 0.0, 1.0),
            ],
            true,
        );
        let mut half = Aabb::of_points(&p.v);
        half.max.x = 0.5;
        let b = part_box(&p, &half);
        // The part's box, widened by two units in the last place of the largest
        // coordinate (1.0) and cut back to the half.
        let pad = 2.0 * f32::EPSILON;
        assert_eq!(b.min, Vec3::ZERO);
        assert_eq!(b.max, Vec3::new(0.5, 0.5 + pad, 1.0));
        // A region the polygon misses: empty.
        let away = Aabb {
            min: Vec3::new(0.9, 0.0, 0.0),
            max: Vec3::new(1.0, 0.1, 1.0),
        };
        assert!(part_box(&p, &away).is_empty());
    }

    /// The two halves' boxes cover the primitive with no tolerance: points spread over
    /// large, far-off, tilted triangles and parallelograms (in `f64`, on the outline of
    /// `f32` corners the build sees) each lie in the left or the right box of a split at
    /// a random plane.
    #[test]
    fn split_boxes_cover_the_primitive() {
        let mut x = 0x9e37_79b9u32;
        let mut r = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as f32 / u32::MAX as f32
        };
        for i in 0..2000 {
            let far = Vec3::new(r(), r(), r()) * 2000.0 - 1000.0;
            let size = if i % 2 == 0 { 200.0 } else { 0.01 };
            let e = |r: &mut dyn FnMut() -> f32| (Vec3::new(r(), r(), r()) - 0.5) * size;
            let (a, b) = (e(&mut r), e(&mut r));
            let p = Poly::of_prim([far, far + a, far + b], i % 3 == 0);
            let full = Aabb::of_points(&p.v[..p.n]);
            let d = i % 3;
            let at = full.min[d] + (full.max[d] - full.min[d]) * r();
            let (mut lo, mut hi) = (full, full);
            lo.max[d] = at;
            hi.min[d] = at;
            let (lb, hb) = (part_box(&p, &lo), part_box(&p, &hi));
            // Only the test's own f64 rounding of `q` as slack (10^-6 of an f32 unit).
            let inside = |b: &Aabb, q: DVec3| {
                let tol = DVec3::splat(q.abs().max_element() * 1e-13);
                !b.is_empty()
                    && q.cmpge(b.min.as_dvec3() - tol).all()
                    && q.cmple(b.max.as_dvec3() + tol).all()
            };
            let v: Vec<DVec3> = p.v.iter().map(|v| v.as_dvec3()).collect();
            for s in 0..=20 {
                for t in 0..=20 {
                    let (u, w) = (s as f64 / 20.0, t as f64 / 20.0);
                    // Within the outline the build sees (its fourth corner as `f32`).
                    let q = if p.n == 4 {
                        v[0] * ((1.0 - u) * (1.0 - w))
                            + v[1] * (u * (1.0 - w))
                            + v[2] * (u * w)
                            + v[3] * ((1.0 - u) * w)
                    } else if u + w <= 1.0 {
                        v[0] + (v[1] - v[0]) * u + (v[2] - v[0]) * w
                    } else {
                        continue;
                    };
                    assert!(
                        inside(&lb, q) || inside(&hb, q),
                        "primitive {i}: {q} in neither {lb:?} nor {hb:?}"
                    );
                }
            }
        }
    }

    /// Long diagonal slivers get split references: more leaf entries than primitives,
    /// every primitive in some leaf, every leaf within the configured size.
    #[test]
    fn long_slivers_are_split() {
        let n = 256;
        let mut x = 0x2545_f491u32;
        let mut r = move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as f32 / u32::MAX as f32
        };
        // Slivers through a 10 m cube in random diagonal directions.
        let polys: Vec<Poly> = (0..n)
            .map(|_| {
                let a = Vec3::new(r(), r(), r()) * 10.0;
                let b = Vec3::new(r(), r(), r()) * 10.0;
                Poly::of_prim([a, b, a + Vec3::new(0.01, 0.02, 0.0)], false)
            })
            .collect();
        let bounds: Vec<Aabb> = polys.iter().map(|p| Aabb::of_points(&p.v[..p.n])).collect();
        let params = BuildParams {
            max_leaf: 4,
            pack: 4,
            trav_cost: 1.0,
        };
        let bin = build_binary(&polys, &bounds, params).unwrap();
        assert!(bin.order.len() > n, "{} references", bin.order.len());
        let mut seen = vec![false; n];
        for &k in &bin.order {
            seen[k as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert!(bin.nodes.iter().all(|b| b.count <= 4));
    }
}
