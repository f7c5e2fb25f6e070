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
//! Splitting a reference: the primitive (a triangle or a parallelogram) is clipped to the
//! reference's box on each side of the plane (Sutherland–Hodgman), each side's box widened
//! by a few units in the last place and cut back to the reference's box, so the pieces
//! cover the primitive despite rounding.

use crate::AccelError;
use crate::build::{Aabb, BNode, Binary, BuildParams};
use crate::embree::ffi::*;
use glam::Vec3;
use std::ffi::{c_uint, c_void};
use std::ptr;
use std::sync::atomic::{AtomicBool, Ordering};

/// The most vertices a triangle or parallelogram clipped to a box can have.
const MAX_VERTS: usize = 10;

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

/// The polygon `v` clipped to the box `b` (Sutherland–Hodgman, one face at a time;
/// crossing points put exactly on the face).
fn clip(v: &[Vec3], b: &Aabb) -> ([Vec3; MAX_VERTS], usize) {
    let mut cur = [Vec3::ZERO; MAX_VERTS];
    let mut n = v.len();
    cur[..n].copy_from_slice(v);
    for axis in 0..3 {
        for (bound, below) in [(b.min[axis], false), (b.max[axis], true)] {
            let inside = |p: Vec3| {
                if below {
                    p[axis] <= bound
                } else {
                    p[axis] >= bound
                }
            };
            let mut out = [Vec3::ZERO; MAX_VERTS];
            let mut m = 0;
            for i in 0..n {
                let (a, c) = (cur[i], cur[(i + 1) % n]);
                if inside(a) && m < MAX_VERTS {
                    out[m] = a;
                    m += 1;
                }
                if inside(a) != inside(c) && m < MAX_VERTS {
                    let t = (bound - a[axis]) / (c[axis] - a[axis]);
                    let mut p = a + (c - a) * t;
                    p[axis] = bound;
                    out[m] = p;
                    m += 1;
                }
            }
            (cur, n) = (out, m);
            if n == 0 {
                return (cur, 0);
            }
        }
    }
    (cur, n)
}

/// The box of `poly`'s part inside `region`, widened by `pad` and cut back to `within`;
/// where rounding leaves nothing inside, the point of `region` nearest its centre.
fn part_box(poly: &Poly, region: &Aabb, within: &Aabb, pad: f32) -> Aabb {
    let (v, n) = clip(&poly.v[..poly.n], region);
    if n == 0 {
        let c = region.center();
        return Aabb { min: c, max: c };
    }
    let b = Aabb::of_points(&v[..n]);
    Aabb {
        min: (b.min - Vec3::splat(pad)).max(within.min),
        max: (b.max + Vec3::splat(pad)).min(within.max),
    }
}

/// One node as the callbacks make it, in Embree's allocator's memory (freed with the
/// BVH): plain data.
#[repr(C)]
struct ENode {
    /// A leaf (`prims[..count]`) or an inner node (`child[..count]`, `bounds[..count]`).
    leaf: bool,
    count: u32,
    child: [*const ENode; 2],
    bounds: [Aabb; 2],
    prims: [u32; 4],
}

/// What the callbacks see through `userPtr`.
struct Ctx<'a> {
    polys: &'a [Poly],
    /// Set when Embree hands a callback more than it was asked for (more children or
    /// leaf references than configured); the build is then refused.
    bad: AtomicBool,
}

fn to_aabb(b: &RTCBounds) -> Aabb {
    Aabb {
        min: Vec3::from(b.lower),
        max: Vec3::from(b.upper),
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

/// A new node from Embree's thread-local allocator; null if it gave none.
///
/// # Safety
/// `alloc` is the allocator Embree passed to the callback.
unsafe fn new_node(alloc: RTCThreadLocalAllocator, node: ENode) -> *mut c_void {
    // SAFETY: `alloc` is Embree's (the caller's contract); it returns memory of the size
    // and alignment asked for, or null.
    let p = unsafe {
        rtcThreadLocalAlloc(alloc, size_of::<ENode>(), align_of::<ENode>()) as *mut ENode
    };
    if !p.is_null() {
        // SAFETY: `p` is non-null, aligned and `size_of::<ENode>()` bytes, unshared.
        unsafe { p.write(node) };
    }
    p.cast()
}

unsafe extern "C" fn create_node(
    alloc: RTCThreadLocalAllocator,
    count: c_uint,
    user: *mut c_void,
) -> *mut c_void {
    // SAFETY: `user` is the `Ctx` that `build_binary` passed, alive for the build.
    let ctx = unsafe { &*(user as *const Ctx) };
    if count > 2 {
        ctx.bad.store(true, Ordering::Relaxed);
    }
    let node = ENode {
        leaf: false,
        count: count.min(2),
        child: [ptr::null(); 2],
        bounds: [Aabb::EMPTY; 2],
        prims: [0; 4],
    };
    // SAFETY: `alloc` is Embree's, passed to this callback.
    unsafe { new_node(alloc, node) }
}

unsafe extern "C" fn set_children(
    node: *mut c_void,
    children: *mut *mut c_void,
    count: c_uint,
    _user: *mut c_void,
) {
    // SAFETY: `node` is one `create_node` made (Embree passes it back), `children` points
    // to `count` node pointers; at most two are read (the node's own `count`).
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
    // SAFETY: as `set_children`, with `count` pointers to bounds.
    unsafe {
        let n = &mut *(node as *mut ENode);
        for i in 0..(count as usize).min(n.count as usize) {
            n.bounds[i] = to_aabb(&**bounds.add(i));
        }
    }
}

unsafe extern "C" fn create_leaf(
    alloc: RTCThreadLocalAllocator,
    prims: *const RTCBuildPrimitive,
    count: usize,
    user: *mut c_void,
) -> *mut c_void {
    // SAFETY: `user` is the build's `Ctx`; `prims` points to `count` build primitives.
    let (ctx, prims) = unsafe {
        (
            &*(user as *const Ctx),
            std::slice::from_raw_parts(prims, count),
        )
    };
    if count > 4 {
        ctx.bad.store(true, Ordering::Relaxed);
    }
    let mut node = ENode {
        leaf: true,
        count: count.min(4) as u32,
        child: [ptr::null(); 2],
        bounds: [Aabb::EMPTY; 2],
        prims: [0; 4],
    };
    for (slot, p) in node.prims.iter_mut().zip(prims) {
        *slot = p.prim_id;
    }
    // SAFETY: `alloc` is Embree's, passed to this callback.
    unsafe { new_node(alloc, node) }
}

unsafe extern "C" fn split_primitive(
    prim: *const RTCBuildPrimitive,
    dim: c_uint,
    pos: f32,
    left: *mut RTCBounds,
    right: *mut RTCBounds,
    user: *mut c_void,
) {
    // SAFETY: `user` is the build's `Ctx`; `prim`, `left` and `right` are valid for one
    // read or write each (Embree's contract for this callback).
    unsafe {
        let ctx = &*(user as *const Ctx);
        let p = &*prim;
        let b = Aabb {
            min: Vec3::from(p.lower),
            max: Vec3::from(p.upper),
        };
        let d = (dim as usize).min(2);
        let (mut lo, mut hi) = (b, b);
        lo.max[d] = pos.clamp(b.min[d], b.max[d]);
        hi.min[d] = lo.max[d];
        let poly = &ctx.polys[p.prim_id as usize];
        let pad = b.min.abs().max(b.max.abs()).max_element() * 8.0 * f32::EPSILON;
        *left = to_bounds(&part_box(poly, &lo, &b, pad));
        *right = to_bounds(&part_box(poly, &hi, &b, pad));
    }
}

/// Copies the subtree at `n` (box `bounds`) into `out`; returns its index.
///
/// # Safety
/// `n` is a node of a finished build whose BVH is still alive.
unsafe fn copy(n: *const ENode, bounds: Aabb, out: &mut Binary) -> u32 {
    // SAFETY: the caller's contract; children are nodes of the same build.
    let node = unsafe { &*n };
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
        return me as u32;
    }
    if node.count == 1 {
        // A node with one child: the child in its place.
        out.nodes.pop();
        // SAFETY: as above.
        return unsafe { copy(node.child[0], bounds, out) };
    }
    // SAFETY: as above.
    let a = unsafe { copy(node.child[0], node.bounds[0], out) };
    // SAFETY: as above.
    let b = unsafe { copy(node.child[1], node.bounds[1], out) };
    out.nodes[me] = BNode {
        bounds,
        a,
        b,
        count: 0,
    };
    me as u32
}

/// The binary tree Embree's high-quality builder makes over the primitives with outlines
/// `polys` and boxes `bounds` (ids = indices): leaves of at most `params.max_leaf`
/// references, leaf cost in blocks of `params.pack`, node visits `params.trav_cost`.
pub(crate) fn build_binary(
    polys: &[Poly],
    bounds: &[Aabb],
    params: BuildParams,
) -> Result<Binary, AccelError> {
    let n = bounds.len();
    // Room for the references spatial splits add (Embree's own scenes allow about 2x).
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
    // SAFETY: a null config asks for Embree's defaults.
    let device = unsafe { rtcNewDevice(ptr::null()) };
    if device.is_null() {
        return Err(AccelError::Embree("rtcNewDevice failed".into()));
    }
    // SAFETY: `device` is live.
    let bvh = unsafe { rtcNewBVH(device) };
    let args = RTCBuildArguments {
        byte_size: size_of::<RTCBuildArguments>(),
        build_quality: RTC_BUILD_QUALITY_HIGH,
        build_flags: 0,
        max_branching_factor: 2,
        max_depth: crate::build::SAH_DEPTH as u32 + 24,
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
    // SAFETY: `args` is laid out as Embree's struct (size asserted), its arrays and `ctx`
    // outlive the call, and the callbacks keep to their contracts above.
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
            "rtcBuildBVH made a node or leaf larger than asked".into(),
        ))
    } else {
        let all = bounds.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
        // SAFETY: `root` is the finished build's root; the BVH is released below.
        unsafe { copy(root, all, &mut out) };
        Ok(out)
    };
    // SAFETY: both handles are live and released once.
    unsafe {
        rtcReleaseBVH(bvh);
        rtcReleaseDevice(device);
    }
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
        let full = Aabb::of_points(&p.v);
        let mut half = full;
        half.max.x = 0.5;
        let b = part_box(&p, &half, &full, 0.0);
        assert_eq!(b.min, Vec3::ZERO);
        assert_eq!(b.max, Vec3::new(0.5, 0.5, 1.0));
        // A region the polygon misses: a point.
        let away = Aabb {
            min: Vec3::new(0.9, 0.0, 0.0),
            max: Vec3::new(1.0, 0.1, 1.0),
        };
        let b = part_box(&p, &away, &full, 0.0);
        assert_eq!(b.min, b.max);
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
