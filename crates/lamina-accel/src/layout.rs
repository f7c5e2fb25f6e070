//! The wide layout the kernels traverse.
//!
//! * [`Node`]: `W` children (8 for AVX2, 4 for SSE and the scalar kernel), their boxes as
//!   structure-of-arrays floats (`b[axis]` the `W` lower bounds on `axis`, `b[3 + axis]`
//!   the upper ones), so that one node test is six vector min/max steps. A child code is a
//!   node index, or [`LEAF`]` | k` for leaf `k` (a [`Pack`] in a bottom level, an instance
//!   in the top level); an unused slot has an empty box (`+∞ .. -∞`, never hit) and
//!   [`EMPTY`].
//! * [`Pack`]: up to four primitives in structure-of-arrays form (`v0`, `e1 = v1 - v0`,
//!   `e2 = v2 - v0` per axis, 4 lanes each), tested together; 192 bytes, three cache
//!   lines. Triangles and parallelograms mix in one pack: the lane's `tri` factor (1 for
//!   a triangle, 0 for a parallelogram) turns the bound `b1 + b2 <= 1` into `b2 <= 1`.
//!   Unused lanes are zero (a zero determinant: never hit).
//! * [`AlphaRec`]: per alpha-tested primitive its matte id and texture coordinates, read
//!   only for a candidate hit on it.

use crate::build::{Aabb, Binary};
use crate::desc::{Geometry, Prim};
use crate::memory::PageArray;

/// Child code bit: a leaf.
pub(crate) const LEAF: u32 = 0x8000_0000;
/// Child code of an unused slot (and of an empty level's root).
pub(crate) const EMPTY: u32 = u32::MAX;
/// `Pack::flags` bit: the lane is alpha-tested (low bits: index into `Blas::alpha`).
pub(crate) const ALPHA: u32 = 0x8000_0000;
/// `Pack::flags` bit with [`ALPHA`]: the lane's texture coordinates are `(0, 0), (1, 0),
/// (0, 1)` at its vertices (every leaf card), so `uv = (b1, b2)`, and the low bits are the
/// matte id itself: no record to read for a candidate hit.
pub(crate) const ALPHA_IDENTITY_UV: u32 = 0x4000_0000;
/// Mask of the low bits of `Pack::flags`.
pub(crate) const FLAG_INDEX: u32 = 0x3fff_ffff;
/// Traversal stack entries: at most `W - 1` pushes per level of a tree of depth at most
/// `build::SAH_DEPTH + 32` (median splits past the SAH depth halve at least 2³⁰ primitives).
pub(crate) const STACK: usize = 7 * (crate::build::SAH_DEPTH + 32) + 8;

/// A wide node (see the module docs). Aligned to a cache line, so that an 8-wide node
/// (224 bytes of boxes and codes) fills exactly four lines, padded to 256 bytes: a node's
/// address is its index shifted, not multiplied (a three-cycle `imul` off the walk's
/// critical path), and no node straddles a fifth line (render 2-3 % faster on the Intel
/// VM, 2026-12-07).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Node<const W: usize> {
    pub b: [[f32; W]; 6],
    pub child: [u32; W],
}

/// Four primitives, structure of arrays (see the module docs).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Pack {
    pub v0: [[f32; 4]; 3],
    pub e1: [[f32; 4]; 3],
    pub e2: [[f32; 4]; 3],
    /// 1 for a triangle, 0 for a parallelogram (and for unused lanes).
    pub tri: [f32; 4],
    /// The primitive's index in its [`Geometry`]; `u32::MAX` for unused lanes.
    pub id: [u32; 4],
    /// [`ALPHA`] `|` index into `Blas::alpha`, or [`ALPHA`] `|` [`ALPHA_IDENTITY_UV`] `|`
    /// matte id, or 0.
    pub flags: [u32; 4],
}

const _: () = assert!(std::mem::size_of::<Pack>() == 192);
const _: () = assert!(std::mem::size_of::<Node<8>>() == 256);

/// The alpha test of one primitive: matte id and texture coordinates at its vertices.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AlphaRec {
    pub id: u32,
    pub uv: [[f32; 2]; 3],
}

/// A bottom level: the world geometry or one prototype.
#[derive(Clone, Debug)]
pub(crate) struct Blas<const W: usize> {
    pub nodes: PageArray<Node<W>>,
    /// Child code of the root: a node, a single pack (at most 4 primitives: no nodes at
    /// all), or [`EMPTY`].
    pub root: u32,
    pub packs: PageArray<Pack>,
    pub alpha: PageArray<AlphaRec>,
    /// Bounds of every valid primitive; `None` for an empty level.
    pub bounds: Option<Aabb>,
}

/// One instance as the top level stores it: the world-to-object transform as a 3x4 matrix
/// (columns x, y, z, translation) and the prototype. 52 bytes.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub(crate) struct InstRec {
    pub w2o: [f32; 12],
    pub proto: u32,
}

const _: () = assert!(std::mem::size_of::<InstRec>() == 52);

/// The top level: quantised 8-wide nodes ([`crate::top`]) whose leaves are instance
/// records (child code `LEAF | record`, records in the top level's order).
#[derive(Clone, Debug)]
pub(crate) struct Tlas {
    pub nodes: PageArray<crate::top::QNode>,
    pub root: u32,
}

/// Lays out a wide tree from `bin`: `leaf(start, count)` makes the child code of a binary
/// leaf over `bin.order[start .. start + count]` (`leaves` of them, to size the array).
/// Returns the nodes (root first, parents before children) and the root's code.
pub(crate) fn collapse<const W: usize>(
    bin: &Binary,
    leaves: usize,
    leaf: &mut impl FnMut(usize, usize) -> u32,
) -> (Vec<Node<W>>, u32) {
    // About one wide node per `W / 2` of the `leaves` binary leaves (full nodes need a
    // `W - 1`-th of that): room enough that the array rarely grows (each growth copies it).
    let mut nodes = Vec::with_capacity(leaves.div_ceil((W / 2).max(1)));
    let root = &bin.nodes[0];
    if root.count > 0 {
        let code = leaf(root.a as usize, root.count as usize);
        return (nodes, code);
    }
    emit::<W>(bin, 0, &mut nodes, leaf);
    (nodes, 0)
}

/// The binary nodes that become the children of a wide node at binary inner node `i`:
/// the child of largest area opened until there are `w` or only leaves are left.
pub(crate) fn wide_children(bin: &Binary, i: usize, w: usize) -> Vec<usize> {
    let mut kids: Vec<usize> = vec![bin.nodes[i].a as usize, bin.nodes[i].b as usize];
    while kids.len() < w {
        let best = kids
            .iter()
            .enumerate()
            .filter(|(_, k)| bin.nodes[**k].count == 0)
            .max_by(|a, b| {
                let (aa, ba) = (
                    bin.nodes[*a.1].bounds.half_area(),
                    bin.nodes[*b.1].bounds.half_area(),
                );
                aa.total_cmp(&ba)
            })
            .map(|(j, _)| j);
        let Some(j) = best else { break };
        let k = kids.swap_remove(j);
        kids.push(bin.nodes[k].a as usize);
        kids.push(bin.nodes[k].b as usize);
    }
    kids
}

/// Emits the wide node rooted at binary inner node `i` (and its subtree); returns its index.
fn emit<const W: usize>(
    bin: &Binary,
    i: usize,
    nodes: &mut Vec<Node<W>>,
    leaf: &mut impl FnMut(usize, usize) -> u32,
) -> u32 {
    let kids = wide_children(bin, i, W);
    let me = nodes.len();
    nodes.push(Node {
        b: [
            [f32::INFINITY; W],
            [f32::INFINITY; W],
            [f32::INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::NEG_INFINITY; W],
            [f32::NEG_INFINITY; W],
        ],
        child: [EMPTY; W],
    });
    for (slot, &k) in kids.iter().enumerate() {
        let nd = bin.nodes[k];
        let code = if nd.count > 0 {
            leaf(nd.a as usize, nd.count as usize)
        } else {
            emit::<W>(bin, k, nodes, leaf)
        };
        let n = &mut nodes[me];
        for a in 0..3 {
            n.b[a][slot] = nd.bounds.min[a];
            n.b[3 + a][slot] = nd.bounds.max[a];
        }
        n.child[slot] = code;
    }
    me as u32
}

/// The bounds of a valid primitive.
pub(crate) fn prim_bounds(p: &Prim) -> Aabb {
    let b = Aabb::of_points(&p.v);
    if p.quad {
        b.grow(p.v[1] + p.v[2] - p.v[0])
    } else {
        b
    }
}

/// The pack of primitives `ids` of `geom` (at most four), and the lanes (bit mask) whose
/// alpha record is still to be made: their flags hold [`ALPHA`] and no index yet.
fn pack_of(geom: &Geometry, ids: &[u32]) -> (Pack, u8) {
    let mut p = Pack {
        v0: [[0.0; 4]; 3],
        e1: [[0.0; 4]; 3],
        e2: [[0.0; 4]; 3],
        tri: [0.0; 4],
        id: [u32::MAX; 4],
        flags: [0; 4],
    };
    let mut pending = 0u8;
    for (lane, &id) in ids.iter().enumerate() {
        let prim = &geom.prims[id as usize];
        let (v0, e1, e2) = (prim.v[0], prim.v[1] - prim.v[0], prim.v[2] - prim.v[0]);
        for a in 0..3 {
            p.v0[a][lane] = v0[a];
            p.e1[a][lane] = e1[a];
            p.e2[a][lane] = e2[a];
        }
        p.tri[lane] = if prim.quad { 0.0 } else { 1.0 };
        p.id[lane] = id;
        if let Some(al) = prim.alpha {
            if al.uv == [glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y] && al.id <= FLAG_INDEX {
                p.flags[lane] = ALPHA | ALPHA_IDENTITY_UV | al.id;
            } else {
                p.flags[lane] = ALPHA;
                pending |= 1 << lane;
            }
        }
    }
    (p, pending)
}

impl<const W: usize> Blas<W> {
    /// The bottom level of `geom`: invalid primitives left out, the binary tree made by
    /// `builder` (an error only from Embree's). The passes over every primitive
    /// (validity, boxes, packs) run in parallel, as does the binary build.
    /// `live_uv`: the scene's masks' live cells (`crate::trim::live_uvs`) where boxes bound
    /// only the live part of masked primitives, `None` for whole primitives.
    pub(crate) fn build(
        geom: &Geometry,
        trav_cost: f32,
        builder: crate::Builder,
        live_uv: Option<&[Option<crate::trim::LiveUv>]>,
    ) -> Result<Self, crate::AccelError> {
        use rayon::prelude::*;
        let valid: Vec<u32> = (0..geom.prims.len() as u32)
            .into_par_iter()
            .filter(|&i| geom.prims[i as usize].is_valid())
            .collect();
        let mut blas = Blas {
            nodes: PageArray::default(),
            root: EMPTY,
            packs: PageArray::default(),
            alpha: PageArray::default(),
            bounds: None,
        };
        if valid.is_empty() {
            return Ok(blas);
        }
        let bounds: Vec<Aabb> = valid
            .par_iter()
            .map(|&i| {
                let p = &geom.prims[i as usize];
                match live_uv {
                    Some(l) => crate::trim::live_bounds(p, l),
                    None => prim_bounds(p),
                }
            })
            .collect();
        blas.bounds = Some(
            bounds
                .par_iter()
                .copied()
                .reduce(|| Aabb::EMPTY, Aabb::union),
        );
        // The binary tree, then one pack per binary leaf in leaf order (the order of the
        // primitives in `bin.order`: a depth-first order, so siblings' packs sit together).
        let (packs, pending): (Vec<Pack>, Vec<u8>) = if valid.len() <= 4 {
            let (p, pending) = pack_of(geom, &valid);
            blas.root = LEAF;
            (vec![p], vec![pending])
        } else {
            let params = crate::build::BuildParams {
                max_leaf: 4,
                pack: 4,
                trav_cost,
            };
            let bin = match builder {
                crate::Builder::Lamina => crate::build::build_binary(&bounds, params),
                #[cfg(feature = "embree")]
                crate::Builder::EmbreeHigh => {
                    let polys: Vec<_> = valid
                        .iter()
                        .map(|&i| {
                            let p = &geom.prims[i as usize];
                            crate::embree_build::Poly::of_prim(p.v, p.quad)
                        })
                        .collect();
                    crate::embree_build::build_binary(&polys, &bounds, params)?
                }
            };
            let mut leaves: Vec<(u32, u32)> = bin
                .nodes
                .iter()
                .filter(|n| n.count > 0 && n.count != u32::MAX)
                .map(|n| (n.a, n.count))
                .collect();
            leaves.par_sort_unstable();
            let (nodes, root) = collapse::<W>(&bin, leaves.len(), &mut |start, _| {
                LEAF | leaves.partition_point(|l| (l.0 as usize) < start) as u32
            });
            blas.nodes = PageArray::new(nodes);
            blas.root = root;
            leaves
                .par_iter()
                .map(|&(start, count)| {
                    // A leaf names a primitive once (a builder with spatial splits may
                    // give it two references there).
                    let mut ids = [0u32; 4];
                    let mut n = 0;
                    for &k in &bin.order[start as usize..(start + count) as usize] {
                        let id = valid[k as usize];
                        if !ids[..n].contains(&id) {
                            ids[n] = id;
                            n += 1;
                        }
                    }
                    pack_of(geom, &ids[..n])
                })
                .unzip()
        };
        // The alpha records of lanes whose texture coordinates are not the identity's, in
        // pack order (rare: generated cards have the identity's).
        let mut packs = packs;
        let mut alpha = Vec::new();
        for (p, &lanes) in packs.iter_mut().zip(&pending) {
            if lanes == 0 {
                continue;
            }
            for lane in 0..4 {
                if lanes & (1 << lane) != 0 {
                    let al = geom.prims[p.id[lane] as usize]
                        .alpha
                        .expect("a pending lane has a matte");
                    p.flags[lane] = ALPHA | alpha.len() as u32;
                    alpha.push(AlphaRec {
                        id: al.id,
                        uv: al.uv.map(|u| u.to_array()),
                    });
                }
            }
        }
        blas.packs = PageArray::new(packs);
        blas.alpha = PageArray::new(alpha);
        Ok(blas)
    }

    /// Heap bytes.
    pub(crate) fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node<W>>()
            + self.packs.len() * std::mem::size_of::<Pack>()
            + self.alpha.len() * std::mem::size_of::<AlphaRec>()
    }

    /// SAH cost of the wide tree relative to its root box: node visits cost `trav_cost`,
    /// pack tests 1, each weighted by its box's area over the root's.
    pub(crate) fn sah_cost(&self, trav_cost: f32) -> f64 {
        let Some(root) = self.bounds else { return 0.0 };
        if self.nodes.is_empty() {
            return 1.0;
        }
        let ra = root.half_area().max(f32::MIN_POSITIVE) as f64;
        let mut cost = 0.0;
        let mut stack = vec![(0u32, ra)];
        while let Some((n, area)) = stack.pop() {
            cost += trav_cost as f64 * area / ra;
            let node = &self.nodes[n as usize];
            for s in 0..W {
                let c = node.child[s];
                if c == EMPTY {
                    continue;
                }
                let b = Aabb {
                    min: glam::Vec3::new(node.b[0][s], node.b[1][s], node.b[2][s]),
                    max: glam::Vec3::new(node.b[3][s], node.b[4][s], node.b[5][s]),
                };
                let a = b.half_area() as f64;
                if c & LEAF != 0 {
                    cost += a / ra;
                } else {
                    stack.push((c, a));
                }
            }
        }
        cost
    }
}
