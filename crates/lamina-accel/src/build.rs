//! The build: a binary BVH by binned SAH (multithreaded), collapsed to the wide layout
//! (the `layout` module) by opening, at every wide node, the binary child of largest surface
//! area until the node has `W` children (the cost-based collapse of Embree's BVH8 and of
//! Ylitie et al.'s wide BVHs, in its greedy form).
//!
//! The binary SAH counts leaf cost in *packs*: a wide leaf tests up to four primitives in
//! one SIMD step, so a leaf of 1 to 4 primitives costs the same and the build prefers full
//! leaves (`C(n) = ⌈n / pack⌉`).

use glam::{Vec3, Vec3A};

/// An axis-aligned box; `EMPTY` has `min = +∞, max = -∞`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box around `points`.
    pub fn of_points(points: &[Vec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p))
    }

    /// This box grown to contain `p`.
    #[inline]
    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The union.
    #[inline]
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Half the surface area (0 for an empty box).
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = self.max - self.min;
        if e.x < 0.0 || e.y < 0.0 || e.z < 0.0 {
            return 0.0;
        }
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// The centre.
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Whether it contains nothing.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }
}

/// Build settings.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BuildParams {
    /// Most primitives in a binary leaf (the pack width for bottom levels, 1 for the top).
    pub max_leaf: usize,
    /// Primitives one leaf test handles at once (SAH leaf cost is `⌈n / pack⌉`).
    pub pack: usize,
    /// Cost of one node visit relative to one pack test.
    pub trav_cost: f32,
}

/// A binary node: inner (`count == 0`: children `a`, `b`) or leaf (primitives
/// `order[a .. a + count]`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BNode {
    pub bounds: Aabb,
    pub a: u32,
    pub b: u32,
    pub count: u32,
}

/// A binary BVH; node 0 is the root. Unused arena slots have `count == u32::MAX`.
pub(crate) struct Binary {
    pub nodes: Vec<BNode>,
    /// Primitive indices in leaf order (each once from `build_binary`; Embree's builder,
    /// `embree_build`, may name one in several leaves, and twice in one).
    pub order: Vec<u32>,
}

const BINS: usize = 32;
/// Below this many primitives a subtree is built on the current thread.
const PARALLEL_MIN: usize = 4096;
/// Past this depth, splits are at the median of the longest axis: bounds the depth (and so
/// the traversal stack, see `layout::STACK`) whatever the input.
pub(crate) const SAH_DEPTH: usize = 40;

/// One primitive as the build moves it around: its box and id, 32 bytes, partitioned in
/// place so that every pass over a node's primitives reads memory in order.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct PRef {
    min: Vec3,
    id: u32,
    max: Vec3,
    _pad: u32,
}

impl PRef {
    #[inline(always)]
    fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    #[inline(always)]
    fn aabb(&self) -> Aabb {
        Aabb {
            min: self.min,
            max: self.max,
        }
    }
}

/// Bounds and centroid bounds of `refs` (in parallel when there are many).
fn bounds_of(refs: &[PRef]) -> (Aabb, Aabb) {
    let fold = |(b, c): (Aabb, Aabb), r: &PRef| (b.union(r.aabb()), c.grow(r.center()));
    let merge = |(b1, c1): (Aabb, Aabb), (b2, c2): (Aabb, Aabb)| (b1.union(b2), c1.union(c2));
    let empty = (Aabb::EMPTY, Aabb::EMPTY);
    if refs.len() < PARALLEL_BINNING {
        refs.iter().fold(empty, fold)
    } else {
        use rayon::prelude::*;
        refs.par_chunks(PARALLEL_BINNING / 4)
            .map(|c| c.iter().fold(empty, fold))
            .reduce(|| empty, merge)
    }
}

/// Above this many primitives a node's binning runs on several threads.
const PARALLEL_BINNING: usize = 1 << 16;

/// Builds the binary BVH over the primitives with boxes `bounds` (ids = indices); every box
/// must be non-empty and finite.
pub(crate) fn build_binary(bounds: &[Aabb], params: BuildParams) -> Binary {
    let n = bounds.len();
    assert!(n > 0 && n < (1 << 30));
    let mut refs: Vec<PRef> = bounds
        .iter()
        .enumerate()
        .map(|(i, b)| PRef {
            min: b.min,
            id: i as u32,
            max: b.max,
            _pad: 0,
        })
        .collect();
    let unused = BNode {
        bounds: Aabb::EMPTY,
        a: 0,
        b: 0,
        count: u32::MAX,
    };
    let mut nodes = vec![unused; 2 * n - 1];
    assert!(
        params.pack.is_power_of_two(),
        "the leaf pack is a power of two"
    );
    let ctx = Ctx {
        params,
        pack_shift: params.pack.trailing_zeros(),
    };
    let (b, c) = bounds_of(&refs);
    ctx.build(&mut nodes, 0, &mut refs, 0, 0, b, c);
    Binary {
        nodes,
        order: refs.iter().map(|r| r.id).collect(),
    }
}

struct Ctx {
    params: BuildParams,
    /// `log2(params.pack)`: the SAH sweep's leaf costs by shifts, not divisions.
    pack_shift: u32,
}

/// One bin: the box of the primitives in it (SIMD lanes) and their number.
#[derive(Clone, Copy)]
struct Bin {
    min: Vec3A,
    max: Vec3A,
    count: u32,
}

const EMPTY_BIN: Bin = Bin {
    min: Vec3A::INFINITY,
    max: Vec3A::NEG_INFINITY,
    count: 0,
};

impl Ctx {
    #[inline(always)]
    fn leaf_cost(&self, n: usize) -> f32 {
        ((n + self.params.pack - 1) >> self.pack_shift) as f32
    }

    /// Builds the subtree over `refs` (global offset `start` in the order) into `nodes`
    /// (`2·len - 1` slots, the first being this subtree's root, global index `base`);
    /// `bounds` and `cbounds` are the boxes of `refs` and of their centres.
    #[allow(clippy::too_many_arguments)]
    fn build(
        &self,
        nodes: &mut [BNode],
        base: u32,
        refs: &mut [PRef],
        start: u32,
        depth: usize,
        bounds: Aabb,
        cbounds: Aabb,
    ) {
        let n = refs.len();
        let leaf = BNode {
            bounds,
            a: start,
            b: 0,
            count: n as u32,
        };
        if n == 1 {
            nodes[0] = leaf;
            return;
        }
        let split = if depth < SAH_DEPTH {
            // Fewer bins for small nodes: the sweep costs O(bins) whatever the node's
            // size, and so does clearing the bins (most nodes are small).
            match refs.len() / 2 + 4 {
                0..=8 => self.sah_split::<8>(refs, bounds, cbounds),
                9..=16 => self.sah_split::<16>(refs, bounds, cbounds),
                _ => self.sah_split::<BINS>(refs, bounds, cbounds),
            }
        } else {
            None
        };
        let (k, sides) = match split {
            Some((cost, k, sides)) => {
                if n <= self.params.max_leaf && self.leaf_cost(n) <= cost {
                    nodes[0] = leaf;
                    return;
                }
                (k, sides)
            }
            None if n <= self.params.max_leaf => {
                nodes[0] = leaf;
                return;
            }
            None => {
                let k = median_split(refs, cbounds);
                (k, [bounds_of(&refs[..k]), bounds_of(&refs[k..])])
            }
        };
        let [(lbox, lcb), (rbox, rcb)] = sides;
        let (left_nodes, right_nodes) = nodes[1..].split_at_mut(2 * k - 1);
        let (left, right) = refs.split_at_mut(k);
        let (lb, rb) = (base + 1, base + 2 * k as u32);
        let go_left =
            |ln: &mut [BNode], l: &mut [PRef]| self.build(ln, lb, l, start, depth + 1, lbox, lcb);
        let go_right = |rn: &mut [BNode], r: &mut [PRef]| {
            self.build(rn, rb, r, start + k as u32, depth + 1, rbox, rcb)
        };
        if n >= PARALLEL_MIN {
            rayon::join(
                || go_left(left_nodes, left),
                || go_right(right_nodes, right),
            );
        } else {
            go_left(left_nodes, left);
            go_right(right_nodes, right);
        }
        nodes[0] = BNode {
            bounds,
            a: lb,
            b: rb,
            count: 0,
        };
    }

    /// The best binned-SAH split over the three axes: `(cost, k, [(box, centre box); 2])`,
    /// `refs` partitioned so that `refs[..k]` goes left. `None` when every centre coincides.
    #[allow(clippy::type_complexity)]
    fn sah_split<const B: usize>(
        &self,
        refs: &mut [PRef],
        bounds: Aabb,
        cb: Aabb,
    ) -> Option<(f32, usize, [(Aabb, Aabb); 2])> {
        let extent = cb.max - cb.min;
        let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
        let mut best: Option<(f32, usize, usize)> = None; // cost, axis, bin boundary
        let nb = (refs.len() / 2 + 4).min(B);
        let scale = Vec3::select(
            extent.cmpgt(Vec3::ZERO),
            Vec3::splat(nb as f32 * (1.0 - 1e-6)) / extent,
            Vec3::ZERO,
        );
        let (cmin, scale_a) = (Vec3A::from(cb.min), Vec3A::from(scale));
        let last = Vec3A::splat((nb - 1) as f32);
        let bin_all = |chunk: &[PRef]| {
            let mut bins = [[EMPTY_BIN; B]; 3];
            for r in chunk {
                let (lo, hi) = (Vec3A::from(r.min), Vec3A::from(r.max));
                let k = bin_index((((lo + hi) * 0.5 - cmin) * scale_a).min(last));
                for (axis, bins) in bins.iter_mut().enumerate() {
                    let b = &mut bins[k[axis]];
                    b.min = b.min.min(lo);
                    b.max = b.max.max(hi);
                    b.count += 1;
                }
            }
            bins
        };
        let bins = if refs.len() < PARALLEL_BINNING {
            bin_all(refs)
        } else {
            use rayon::prelude::*;
            refs.par_chunks(PARALLEL_BINNING / 4).map(bin_all).reduce(
                || [[EMPTY_BIN; B]; 3],
                |mut a, b| {
                    for (x, y) in a.iter_mut().flatten().zip(b.iter().flatten()) {
                        x.min = x.min.min(y.min);
                        x.max = x.max.max(y.max);
                        x.count += y.count;
                    }
                    a
                },
            )
        };
        // Half the area of a box given as SIMD corners (0 when empty).
        let half_area = |min: Vec3A, max: Vec3A| {
            let e = (max - min).max(Vec3A::ZERO);
            e.x * e.y + e.y * e.z + e.z * e.x
        };
        for (axis, bins) in bins.iter().enumerate() {
            if extent[axis] <= 0.0 {
                continue;
            }
            // Right-to-left sweep: area·cost of everything right of each boundary.
            let mut right = [0.0f32; B];
            let (mut rmin, mut rmax, mut rn) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY, 0usize);
            for k in (1..nb).rev() {
                rmin = rmin.min(bins[k].min);
                rmax = rmax.max(bins[k].max);
                rn += bins[k].count as usize;
                right[k] = half_area(rmin, rmax) * self.leaf_cost(rn);
            }
            // Left to right: the split's area·cost (the SAH cost times the parent's area,
            // less the traversal step: both the same for every candidate).
            let (mut lmin, mut lmax, mut ln) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY, 0usize);
            for k in 1..nb {
                lmin = lmin.min(bins[k - 1].min);
                lmax = lmax.max(bins[k - 1].max);
                ln += bins[k - 1].count as usize;
                if ln == 0 || ln == refs.len() {
                    continue;
                }
                let cost = half_area(lmin, lmax) * self.leaf_cost(ln) + right[k];
                if best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, axis, k));
                }
            }
        }
        let (cost, axis, k) = best?;
        let cost = self.params.trav_cost + cost / parent_area;
        // The sides' boxes from the bins (the same bin of each centre as the binning's:
        // the same arithmetic on the same lanes); their centre boxes from the partition.
        let side_box = |range: std::ops::Range<usize>| {
            let (min, max) = bins[axis][range]
                .iter()
                .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(a, b), bin| {
                    (a.min(bin.min), b.max(bin.max))
                });
            Aabb {
                min: min.into(),
                max: max.into(),
            }
        };
        let boxes = [side_box(0..k), side_box(k..nb)];
        // Bin `⌊min(x, nb - 1)⌋ < k` is `x < k` (as `k <= nb - 1`): no conversion.
        let kf = k as f32;
        let (mid, centres) = partition(refs, |c: Vec3A| ((c - cmin) * scale_a)[axis] < kf);
        let sides = [(boxes[0], centres[0]), (boxes[1], centres[1])];
        Some((cost, mid, sides))
    }
}

/// `⌊x⌋` of each lane of `x`, non-negative and below 2³¹: the bins of a centre.
#[inline(always)]
fn bin_index(x: Vec3A) -> [usize; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        // One truncating conversion for the three lanes (SSE2, always there on x86-64;
        // `as` converts one lane at a time and saturates).
        use std::arch::x86_64::{_mm_cvtsi128_si32, _mm_cvttps_epi32, _mm_shuffle_epi32};
        // SAFETY: these intrinsics need SSE2 only, which every x86-64 CPU has (it is in
        // the target's baseline features); they read and write registers, no memory.
        unsafe {
            let v = _mm_cvttps_epi32(x.into());
            [
                _mm_cvtsi128_si32(v) as usize,
                _mm_cvtsi128_si32(_mm_shuffle_epi32::<0b01_01_01_01>(v)) as usize,
                _mm_cvtsi128_si32(_mm_shuffle_epi32::<0b10_10_10_10>(v)) as usize,
            ]
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        [x.x as usize, x.y as usize, x.z as usize]
    }
}

/// Splits `refs` at its middle by centre along the longest axis of `cb` (`select_nth`).
fn median_split(refs: &mut [PRef], cb: Aabb) -> usize {
    let e = cb.max - cb.min;
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let k = refs.len() / 2;
    refs.select_nth_unstable_by(k, |a, b| a.center()[axis].total_cmp(&b.center()[axis]));
    k
}

/// Moves the elements whose centre `left` accepts to the front (Hoare-style, from both
/// ends); returns how many there are and the boxes of the two sides' centres.
fn partition(refs: &mut [PRef], left: impl Fn(Vec3A) -> bool) -> (usize, [Aabb; 2]) {
    let centre = |r: &PRef| (Vec3A::from(r.min) + Vec3A::from(r.max)) * 0.5;
    let (mut i, mut j) = (0, refs.len());
    let (mut lmin, mut lmax) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let (mut rmin, mut rmax) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    loop {
        while i < j {
            let c = centre(&refs[i]);
            if !left(c) {
                break;
            }
            (lmin, lmax) = (lmin.min(c), lmax.max(c));
            i += 1;
        }
        while i < j {
            let c = centre(&refs[j - 1]);
            if left(c) {
                break;
            }
            (rmin, rmax) = (rmin.min(c), rmax.max(c));
            j -= 1;
        }
        if i >= j {
            let aabb = |min: Vec3A, max: Vec3A| Aabb {
                min: min.into(),
                max: max.into(),
            };
            return (i, [aabb(lmin, lmax), aabb(rmin, rmax)]);
        }
        // refs[i] goes right and refs[j - 1] left: swap them.
        let (ci, cj) = (centre(&refs[i]), centre(&refs[j - 1]));
        refs.swap(i, j - 1);
        (lmin, lmax) = (lmin.min(cj), lmax.max(cj));
        (rmin, rmax) = (rmin.min(ci), rmax.max(ci));
        i += 1;
        j -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_boxes(n: usize) -> Vec<Aabb> {
        let mut s = 1u64;
        let mut r = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let p = Vec3::new(r(), r(), r()) * 10.0;
                Aabb::of_points(&[p, p + Vec3::new(r(), r(), r()) * 0.1])
            })
            .collect()
    }

    /// Every primitive is in exactly one leaf, every child lies inside its parent, no leaf
    /// exceeds the bound.
    #[test]
    fn binary_tree_is_well_formed() {
        for n in [1, 2, 3, 5, 17, 1000, 10_000] {
            let b = random_boxes(n);
            let params = BuildParams {
                max_leaf: 4,
                pack: 4,
                trav_cost: 1.0,
            };
            let t = build_binary(&b, params);
            let mut seen = vec![0; n];
            let mut stack = vec![0usize];
            while let Some(i) = stack.pop() {
                let nd = t.nodes[i];
                assert_ne!(nd.count, u32::MAX, "an unused slot is reachable");
                if nd.count > 0 {
                    assert!(nd.count as usize <= 4 || n == 1);
                    for &p in &t.order[nd.a as usize..(nd.a + nd.count) as usize] {
                        seen[p as usize] += 1;
                        let pb = b[p as usize];
                        assert!(
                            pb.min.cmpge(nd.bounds.min).all() && pb.max.cmple(nd.bounds.max).all()
                        );
                    }
                } else {
                    for c in [nd.a as usize, nd.b as usize] {
                        let cb = t.nodes[c].bounds;
                        assert!(
                            cb.min.cmpge(nd.bounds.min).all() && cb.max.cmple(nd.bounds.max).all()
                        );
                        stack.push(c);
                    }
                }
            }
            assert!(seen.iter().all(|&k| k == 1), "n = {n}");
        }
    }

    /// Identical boxes (no centroid spread) still give leaves of at most `max_leaf` and a
    /// bounded depth.
    #[test]
    fn coincident_primitives_build_a_bounded_tree() {
        let b = vec![Aabb::of_points(&[Vec3::ZERO, Vec3::ONE]); 5000];
        let t = build_binary(
            &b,
            BuildParams {
                max_leaf: 4,
                pack: 4,
                trav_cost: 1.0,
            },
        );
        fn depth(t: &Binary, i: usize) -> usize {
            let n = t.nodes[i];
            if n.count > 0 {
                assert!(n.count <= 4);
                1
            } else {
                1 + depth(t, n.a as usize).max(depth(t, n.b as usize))
            }
        }
        assert!(
            depth(&t, 0) <= 14,
            "median splits: about log2(5000 / 4) levels"
        );
    }
}
