//! The build: a binary BVH by binned SAH (multithreaded), collapsed to the wide layout
//! ([`crate::layout`]) by opening, at every wide node, the binary child of largest surface
//! area until the node has `W` children (the cost-based collapse of Embree's BVH8 and of
//! Ylitie et al.'s wide BVHs, in its greedy form).
//!
//! The binary SAH counts leaf cost in *packs*: a wide leaf tests up to four primitives in
//! one SIMD step, so a leaf of 1 to 4 primitives costs the same and the build prefers full
//! leaves (`C(n) = ⌈n / pack⌉`).

use glam::Vec3;

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
    /// Primitive indices in leaf order.
    pub order: Vec<u32>,
}

const BINS: usize = 32;
/// Below this many primitives a subtree is built on the current thread.
const PARALLEL_MIN: usize = 4096;
/// Past this depth, splits are at the median of the longest axis: bounds the depth (and so
/// the traversal stack, see `layout::STACK`) whatever the input.
pub(crate) const SAH_DEPTH: usize = 40;

/// Builds the binary BVH over the primitives with boxes `bounds` (ids = indices); every box
/// must be non-empty and finite.
pub(crate) fn build_binary(bounds: &[Aabb], params: BuildParams) -> Binary {
    let n = bounds.len();
    assert!(n > 0 && n < (1 << 30));
    let centers: Vec<Vec3> = bounds.iter().map(Aabb::center).collect();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let unused = BNode {
        bounds: Aabb::EMPTY,
        a: 0,
        b: 0,
        count: u32::MAX,
    };
    let mut nodes = vec![unused; 2 * n - 1];
    let ctx = Ctx {
        bounds,
        centers: &centers,
        params,
    };
    ctx.build(&mut nodes, 0, &mut order, 0, 0);
    Binary { nodes, order }
}

struct Ctx<'a> {
    bounds: &'a [Aabb],
    centers: &'a [Vec3],
    params: BuildParams,
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

impl Ctx<'_> {
    fn leaf_cost(&self, n: usize) -> f32 {
        n.div_ceil(self.params.pack) as f32
    }

    /// Builds the subtree over `idx` (global offset `start` in the order) into `nodes`
    /// (`2·len - 1` slots, the first being this subtree's root, global index `base`).
    fn build(&self, nodes: &mut [BNode], base: u32, idx: &mut [u32], start: u32, depth: usize) {
        let n = idx.len();
        let (bounds, cbounds) = idx.iter().fold((Aabb::EMPTY, Aabb::EMPTY), |(b, c), &i| {
            (
                b.union(self.bounds[i as usize]),
                c.grow(self.centers[i as usize]),
            )
        });
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
            self.sah_split(idx, bounds, cbounds)
        } else {
            None
        };
        let k = match split {
            Some((cost, k)) => {
                if n <= self.params.max_leaf && self.leaf_cost(n) <= cost {
                    nodes[0] = leaf;
                    return;
                }
                k
            }
            None if n <= self.params.max_leaf => {
                nodes[0] = leaf;
                return;
            }
            None => median_split(idx, self.centers, cbounds),
        };
        let (left_nodes, right_nodes) = nodes[1..].split_at_mut(2 * k - 1);
        let (left_idx, right_idx) = idx.split_at_mut(k);
        let (lb, rb) = (base + 1, base + 2 * k as u32);
        let go_left = |ln: &mut [BNode], li: &mut [u32]| self.build(ln, lb, li, start, depth + 1);
        let go_right =
            |rn: &mut [BNode], ri: &mut [u32]| self.build(rn, rb, ri, start + k as u32, depth + 1);
        if n >= PARALLEL_MIN {
            rayon::join(
                || go_left(left_nodes, left_idx),
                || go_right(right_nodes, right_idx),
            );
        } else {
            go_left(left_nodes, left_idx);
            go_right(right_nodes, right_idx);
        }
        nodes[0] = BNode {
            bounds,
            a: lb,
            b: rb,
            count: 0,
        };
    }

    /// The best binned-SAH split over the three axes: `(cost, k)`, `idx` partitioned so
    /// that `idx[..k]` goes left. `None` when every centre coincides.
    fn sah_split(&self, idx: &mut [u32], bounds: Aabb, cb: Aabb) -> Option<(f32, usize)> {
        let extent = cb.max - cb.min;
        let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
        let mut best: Option<(f32, usize, usize)> = None; // cost, axis, bin boundary
        let mut bins = [[Bin {
            bounds: Aabb::EMPTY,
            count: 0,
        }; BINS]; 3];
        let scale = Vec3::select(
            extent.cmpgt(Vec3::ZERO),
            Vec3::splat(BINS as f32 * (1.0 - 1e-6)) / extent,
            Vec3::ZERO,
        );
        for &i in idx.iter() {
            let c = (self.centers[i as usize] - cb.min) * scale;
            let b = self.bounds[i as usize];
            for (axis, bins) in bins.iter_mut().enumerate() {
                let k = (c[axis] as usize).min(BINS - 1);
                bins[k].bounds = bins[k].bounds.union(b);
                bins[k].count += 1;
            }
        }
        for (axis, bins) in bins.iter().enumerate() {
            if extent[axis] <= 0.0 {
                continue;
            }
            // Right-to-left sweep: area·cost of everything right of each boundary.
            let mut right = [0.0f32; BINS];
            let (mut rb, mut rn) = (Aabb::EMPTY, 0usize);
            for k in (1..BINS).rev() {
                rb = rb.union(bins[k].bounds);
                rn += bins[k].count as usize;
                right[k] = rb.half_area() * self.leaf_cost(rn);
            }
            let (mut lb, mut ln) = (Aabb::EMPTY, 0usize);
            for k in 1..BINS {
                lb = lb.union(bins[k - 1].bounds);
                ln += bins[k - 1].count as usize;
                if ln == 0 || ln == idx.len() {
                    continue;
                }
                let cost = self.params.trav_cost
                    + (lb.half_area() * self.leaf_cost(ln) + right[k]) / parent_area;
                if best.is_none_or(|b| cost < b.0) {
                    best = Some((cost, axis, k));
                }
            }
        }
        let (cost, axis, k) = best?;
        let s = scale[axis];
        let lo = cb.min[axis];
        let goes_left = |i: u32| {
            let c = ((self.centers[i as usize][axis] - lo) * s) as usize;
            c.min(BINS - 1) < k
        };
        let mid = partition(idx, goes_left);
        Some((cost, mid))
    }
}

/// Splits `idx` at its middle by centre along the longest axis of `cb` (`select_nth`).
fn median_split(idx: &mut [u32], centers: &[Vec3], cb: Aabb) -> usize {
    let e = cb.max - cb.min;
    let axis = if e.x >= e.y && e.x >= e.z {
        0
    } else if e.y >= e.z {
        1
    } else {
        2
    };
    let k = idx.len() / 2;
    idx.select_nth_unstable_by(k, |&a, &b| {
        centers[a as usize][axis].total_cmp(&centers[b as usize][axis])
    });
    k
}

/// Moves the elements for which `left` holds to the front; returns how many there are.
fn partition(idx: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut i = 0;
    for j in 0..idx.len() {
        if left(idx[j]) {
            idx.swap(i, j);
            i += 1;
        }
    }
    i
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
