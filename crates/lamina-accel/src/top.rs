//! The top level over instances, compact: 8-wide nodes whose child boxes are quantised to
//! 8 bits per plane in the node's own frame (after Ylitie, Karras & Laine, HPG 2017, and
//! Embree's compressed nodes), and whose children are found by rank instead of by stored
//! index: a node's inner children are consecutive nodes, its instance children consecutive
//! instance records. 72 bytes per node, about 11 bytes per instance; with the 52-byte
//! instance record, under 64 bytes per placed leaf.
//!
//! **Decoding** plane `k` of slot `i` is `origin[a] + q[k][i] · 2^exp[a]`; the slab test
//! folds it into one FMA per plane: `t = q · (step · inv) + (origin - o) · inv`.
//! **Conservative**: the step is at least `2⁻²⁰` of the node's magnitude, the quantised box
//! is widened by one step on every side and checked in `f32`, so rounding in the decode or
//! in the slab test never culls a box the ray touches. Unused slots have `lo = 255,
//! hi = 0` (an empty box for every ray direction) and come after the used ones.

use crate::build::{Aabb, Binary};
use crate::layout::wide_children;
use crate::memory::PageArray;

/// A quantised top-level node (see the module docs).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(8))]
pub(crate) struct QNode {
    /// The frame's origin per axis (world space).
    pub origin: [f32; 3],
    /// `log2` of the step per axis.
    pub exp: [i8; 3],
    /// Bit `i`: slot `i` is an inner node (else an instance, or unused past the last).
    pub inner: u8,
    /// The node index of the first inner child.
    pub first_node: u32,
    /// The instance record (top-level order) of the first instance child.
    pub first_leaf: u32,
    /// Quantised planes: lower x, y, z, upper x, y, z, one byte per slot.
    pub q: [[u8; 8]; 6],
}

const _: () = assert!(std::mem::size_of::<QNode>() == 72);

impl QNode {
    /// `2^exp` per axis.
    #[inline(always)]
    pub fn steps(&self) -> [f32; 3] {
        let s = |e: i8| f32::from_bits(((e as i32 + 127) as u32) << 23);
        [s(self.exp[0]), s(self.exp[1]), s(self.exp[2])]
    }

    /// The child code of slot `slot` (a node index, or `LEAF | record`).
    #[inline(always)]
    pub fn child(&self, slot: usize) -> u32 {
        let below = (1u32 << slot) - 1;
        let inner = self.inner as u32;
        if inner & (1 << slot) != 0 {
            self.first_node + (inner & below).count_ones()
        } else {
            crate::layout::LEAF | (self.first_leaf + (!inner & below).count_ones())
        }
    }
}

/// The top level: its nodes and, per record slot (top-level order), the binary-order
/// index of the instance it holds.
pub(crate) struct TopBuild {
    pub nodes: PageArray<QNode>,
    /// Child code of the root: node 0, or `LEAF | 0` for a single instance.
    pub root: u32,
    /// Per top-level record, the index into the boxes the binary tree was built over.
    pub order: Vec<u32>,
}

/// The step exponent for an axis from `lo` to `hi` (see the module docs).
fn step_exp(lo: f32, hi: f32) -> i8 {
    let ext = (hi - lo).max(0.0);
    let mag = lo.abs().max(hi.abs());
    let step = (ext / 252.0)
        .max(mag * (1.0 / (1 << 20) as f32))
        .max(f32::MIN_POSITIVE);
    let mut e = step.log2().ceil() as i32;
    let pow = |e: i32| f32::from_bits(((e.clamp(-126, 127) + 127) as u32) << 23);
    while pow(e) < step && e < 127 {
        e += 1;
    }
    e.clamp(-126, 127) as i8
}

/// Quantises child box `b` into slot `slot` of `n` (frame already set).
fn quantise(n: &mut QNode, slot: usize, b: &Aabb) {
    let steps = n.steps();
    for a in 0..3 {
        let (o, s) = (n.origin[a], steps[a]);
        let decode = |q: u8| q as f32 * s + o;
        let mut lo = (((b.min[a] - o) / s).floor() - 1.0).clamp(0.0, 255.0) as u8;
        while lo > 0 && decode(lo) > b.min[a] {
            lo -= 1;
        }
        let mut hi = (((b.max[a] - o) / s).ceil() + 1.0).clamp(0.0, 255.0) as u8;
        while hi < 255 && decode(hi) < b.max[a] {
            hi += 1;
        }
        n.q[a][slot] = lo;
        n.q[3 + a][slot] = hi;
    }
}

/// Lays out the top level from the binary tree `bin` over the instance boxes `boxes`
/// (leaves of up to 8 instances: a leaf of several becomes one node with an instance in
/// each slot, so the bottom nodes are nearly full; see [`TOP_LEAF`]).
pub(crate) fn build_top(bin: &Binary, boxes: &[Aabb]) -> TopBuild {
    let root = &bin.nodes[0];
    if root.count == 1 {
        return TopBuild {
            nodes: PageArray::default(),
            root: crate::layout::LEAF,
            order: vec![bin.order[root.a as usize]],
        };
    }
    let mut nodes = vec![empty_node()];
    let mut order = Vec::with_capacity(bin.order.len());
    let root = if root.count > 0 {
        Kid::Bundle(
            (root.a..root.a + root.count)
                .map(|j| bin.order[j as usize])
                .collect(),
        )
    } else {
        Kid::Node(0)
    };
    fill(bin, boxes, root, 0, &mut nodes, &mut order);
    TopBuild {
        nodes: PageArray::new(nodes),
        root: 0,
        order,
    }
}

/// An empty node whose frame (origin and steps) covers `bounds`.
fn framed(bounds: &Aabb) -> QNode {
    let mut n = empty_node();
    for a in 0..3 {
        n.exp[a] = step_exp(bounds.min[a], bounds.max[a]);
        n.origin[a] = bounds.min[a] - n.steps()[a];
    }
    n
}

fn empty_node() -> QNode {
    QNode {
        origin: [0.0; 3],
        exp: [0; 3],
        inner: 0,
        first_node: 0,
        first_leaf: 0,
        q: [[255; 8], [255; 8], [255; 8], [0; 8], [0; 8], [0; 8]],
    }
}

/// Most instances in a binary leaf of the top level: such a leaf becomes one node with an
/// instance per slot.
pub(crate) const TOP_LEAF: usize = 8;

/// A child of a top-level node: a binary inner node (a node), a bundle of instances (a
/// node with one instance per slot), or one instance (index into the boxes).
#[derive(Clone)]
enum Kid {
    Node(usize),
    Bundle(Vec<u32>),
    Instance(u32),
}

/// Builds node `me` for `kid` (a node or a bundle), then its node children.
fn fill(
    bin: &Binary,
    boxes: &[Aabb],
    kid: Kid,
    me: usize,
    nodes: &mut Vec<QNode>,
    order: &mut Vec<u32>,
) {
    let mut kids: Vec<Kid> = match kid {
        Kid::Bundle(ids) => ids.into_iter().map(Kid::Instance).collect(),
        Kid::Instance(_) => unreachable!("an instance is a slot, not a node"),
        Kid::Node(i) => {
            let mut kids = Vec::new();
            let mut bundles: Vec<Vec<u32>> = Vec::new();
            for k in wide_children(bin, i, 8) {
                let b = bin.nodes[k];
                let ids = || (b.a..b.a + b.count).map(|j| bin.order[j as usize]);
                match b.count {
                    0 => kids.push(Kid::Node(k)),
                    1 => kids.push(Kid::Instance(bin.order[b.a as usize])),
                    _ => bundles.push(ids().collect()),
                }
            }
            // Sibling leaves that fit together share one node (first fit, largest first):
            // the bottom nodes come out nearly full, which is most of the top level's size.
            bundles.sort_by_key(|b| std::cmp::Reverse(b.len()));
            let mut packed: Vec<Vec<u32>> = Vec::new();
            for b in bundles {
                match packed.iter_mut().find(|p| p.len() + b.len() <= TOP_LEAF) {
                    Some(p) => p.extend(b),
                    None => packed.push(b),
                }
            }
            // Bundles that fit in the free slots become slots of this node.
            packed.sort_by_key(|b| b.len());
            let mut slots = kids.len() + packed.len();
            for b in packed {
                if slots - 1 + b.len() <= 8 {
                    slots += b.len() - 1;
                    kids.extend(b.into_iter().map(Kid::Instance));
                } else {
                    kids.push(Kid::Bundle(b));
                }
            }
            kids
        }
    };
    // Node children first, then instances: the slot order the ranks count in.
    kids.sort_by_key(|k| matches!(k, Kid::Instance(_)));
    let box_of = |k: &Kid| match k {
        Kid::Node(i) => bin.nodes[*i].bounds,
        Kid::Bundle(ids) => ids
            .iter()
            .fold(Aabb::EMPTY, |a, &id| a.union(boxes[id as usize])),
        Kid::Instance(id) => boxes[*id as usize],
    };
    let kid_boxes: Vec<Aabb> = kids.iter().map(box_of).collect();
    let bounds = kid_boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(*b));
    let mut n = framed(&bounds);
    n.first_node = nodes.len() as u32;
    n.first_leaf = order.len() as u32;
    let mut inner = Vec::new();
    for (slot, (k, b)) in kids.into_iter().zip(&kid_boxes).enumerate() {
        quantise(&mut n, slot, b);
        match k {
            Kid::Instance(id) => order.push(id),
            k => {
                n.inner |= 1 << slot;
                inner.push(k);
            }
        }
    }
    let first = nodes.len();
    nodes.extend(std::iter::repeat_n(empty_node(), inner.len()));
    nodes[me] = n;
    for (j, k) in inner.into_iter().enumerate() {
        fill(bin, boxes, k, first + j, nodes, order);
    }
}

/// A node over up to 8 child boxes, quantised as the build does (all children instances),
/// for kernel tests.
#[cfg(test)]
pub(crate) fn node_over(boxes: &[Aabb]) -> QNode {
    assert!(boxes.len() <= 8);
    let mut n = framed(&boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(*b)));
    for (slot, b) in boxes.iter().enumerate() {
        quantise(&mut n, slot, b);
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Every decoded child box contains its true box, whatever the scale.
    #[test]
    fn quantised_boxes_contain_their_children() {
        for (scale, offset) in [(1.0f32, 0.0f32), (1e-3, 5.0), (100.0, -1e5), (1e-6, 1e6)] {
            let parent = Aabb::of_points(&[
                Vec3::splat(offset),
                Vec3::splat(offset) + Vec3::new(3.0, 0.0, 1.0) * scale,
            ]);
            let mut n = framed(&parent);
            let steps = n.steps();
            for k in 0..8 {
                let f = k as f32 / 8.0;
                let c = Aabb::of_points(&[
                    parent.min + (parent.max - parent.min) * f * 0.9,
                    parent.min + (parent.max - parent.min) * (f * 0.9 + 0.1),
                ]);
                quantise(&mut n, k, &c);
                for a in 0..3 {
                    let lo = (n.q[a][k] as f32).mul_add(steps[a], n.origin[a]);
                    let hi = (n.q[3 + a][k] as f32).mul_add(steps[a], n.origin[a]);
                    assert!(
                        lo <= c.min[a] && hi >= c.max[a],
                        "{scale} {offset} axis {a}: {lo}..{hi} vs {c:?}"
                    );
                    assert!(n.q[a][k] <= n.q[3 + a][k]);
                }
            }
        }
    }

    /// Ranks find every child: inner children are consecutive nodes, instances consecutive
    /// records, and every instance appears once.
    #[test]
    fn children_by_rank_cover_every_instance_once() {
        let boxes: Vec<Aabb> = (0..1000)
            .map(|i| {
                let p = Vec3::new((i % 10) as f32, ((i / 10) % 10) as f32, (i / 100) as f32);
                Aabb::of_points(&[p, p + Vec3::splat(0.5)])
            })
            .collect();
        let bin = crate::build::build_binary(
            &boxes,
            crate::build::BuildParams {
                max_leaf: TOP_LEAF,
                pack: TOP_LEAF,
                trav_cost: 1.0,
            },
        );
        let top = build_top(&bin, &boxes);
        let mut seen = vec![0; 1000];
        let mut stack = vec![top.root];
        while let Some(c) = stack.pop() {
            if c & crate::layout::LEAF != 0 {
                seen[top.order[(c & !crate::layout::LEAF) as usize] as usize] += 1;
                continue;
            }
            let n = &top.nodes[c as usize];
            for slot in 0..8 {
                if n.q[0][slot] > n.q[3][slot] {
                    break; // unused slots come last
                }
                stack.push(n.child(slot));
            }
        }
        assert!(seen.iter().all(|&k| k == 1));
    }
}
