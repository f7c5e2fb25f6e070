//! Level of detail for foliage by **stochastic simplification** (Cook, Halstead, Planck &
//! Ryu 2007, "Stochastic simplification of aggregate detail"): when a plant's leaves
//! shrink below [`crate::RenderSettings::lod_pixels`] on screen, a random share of them is
//! left out and the survivors grow so that the plant keeps its total leaf area, and with
//! it its coverage, brightness and colour. Leaves enter and leave through a fade (they grow
//! from nothing), so nothing pops while the camera moves.
//!
//! * **Elements.** A foliage mesh (a leaf material, or any material with an alpha matte)
//!   of at least [`MIN_ELEMENTS`] connected pieces is simplified piece by piece (each
//!   piece, usually one leaf card or curved leaf, is an element). A prototype whose every
//!   mesh is foliage but too small for that (one leaf placed many times) is simplified
//!   instance by instance when it has at least [`MIN_ELEMENTS`] instances.
//! * **Rank.** At load the elements of a mesh are shuffled (a fixed seed) and element `k`
//!   of `N` gets the rank `r = (k + ½) / N`; the index buffer is written in that order, so
//!   the elements of rank below any `u` are a prefix of it. Instances get a hashed rank.
//! * **Fraction kept.** Per instance and frame (on the GPU, [`super::culling`]), the
//!   fraction `f = clamp(A_px / lod_pixels, f_min, 1)`, `A_px` the mean element area
//!   projected at the instance's distance. An element of rank `r` is drawn with the area
//!   weight `w(r) = clamp((u − r) / δ, 0, 1)`, `δ = min(FADE f, 2 (1 − f))` the fade width
//!   and `u = f + δ/2` the last rank drawn, scaled by `sqrt(w / f)` about its centre: the
//!   expected area `∫ w(r)/f dr` stays 1 at every `f`, and `f = 1` is the mesh unchanged.
//! * **Buckets.** Instances are grouped by `f` into [`BUCKETS`] levels `2^(-b/2)`; each
//!   level draws the index prefix its largest `u` needs (elements past an instance's own
//!   `u` get weight 0 and collapse to a point, drawing nothing).
//!
//! The same formulas are in `shaders/lod.wgsl`, which the scene and culling shaders share.

use glam::Vec3;
use lamina_scene::{Material, Mesh};

/// Levels of the fraction kept: level `b` is `2^(-b/2)`, so the smallest is `2^(-7.5)`,
/// about 1/181 of the leaves.
pub(super) const BUCKETS: usize = 16;
/// Fade width as a share of the fraction kept.
pub(super) const FADE: f32 = 0.25;
/// Fewest elements (or instances) a mesh (or prototype) needs to be simplified.
pub(super) const MIN_ELEMENTS: usize = 64;

/// The fraction kept at bucket `b`, `2^(-b/2)`.
pub(super) fn bucket_level(b: usize) -> f32 {
    (-(b as f32) / 2.0).exp2()
}

/// The smallest fraction kept.
pub(super) fn min_fraction() -> f32 {
    bucket_level(BUCKETS - 1)
}

/// The fade width `δ` at fraction `f`.
pub(super) fn fade_width(f: f32) -> f32 {
    (FADE * f).min(2.0 * (1.0 - f)).max(0.0)
}

/// The largest rank drawn at fraction `f`, `u = f + δ/2` (1 at `f = 1`).
pub(super) fn last_rank(f: f32) -> f32 {
    if f >= 1.0 {
        1.0
    } else {
        f + 0.5 * fade_width(f)
    }
}

/// The area factor `w(r) / f` of an element of rank `r` at fraction `f` (the shaders'
/// `lod_area_factor`, here for the tests of the formulas).
#[cfg(test)]
pub(super) fn area_factor(rank: f32, f: f32) -> f32 {
    if f >= 1.0 {
        return 1.0;
    }
    let (d, u) = (fade_width(f), last_rank(f));
    let w = if d > 0.0 {
        ((u - rank) / d).clamp(0.0, 1.0)
    } else if rank < u {
        1.0
    } else {
        0.0
    };
    w / f
}

/// `shaders/lod.wgsl` with the constants it needs from here ([`BUCKETS`], [`FADE`]) in
/// front: the start of every shader that uses level of detail.
pub(super) fn wgsl_prelude() -> String {
    format!(
        "const LOD_BUCKETS: u32 = {BUCKETS}u;\nconst LOD_FADE: f32 = {FADE:?};\n{}",
        include_str!("../shaders/lod.wgsl")
    )
}

/// Whether `m` is foliage, which level of detail may thin out.
pub(super) fn is_foliage(m: &Material) -> bool {
    matches!(m, Material::Leaf { .. }) || m.alpha_mask().is_some()
}

/// A mesh ready for drawing with level of detail.
#[derive(Debug)]
pub(super) struct LodMesh {
    /// Triangle indices, elements in rank order (unchanged for meshes without LOD).
    pub indices: Vec<u32>,
    /// Per vertex: its element's centre (object space, m) and rank; rank −1 for meshes
    /// without LOD (never scaled).
    pub lod: Vec<[f32; 4]>,
    /// Indices to draw at each bucket's level.
    pub bucket_counts: [u32; BUCKETS],
    /// Elements, 0 for meshes without LOD.
    pub elements: u32,
    /// Total triangle area of the elements (m², object space).
    pub area: f32,
    /// Largest distance of a vertex from its element's centre (m).
    pub element_radius: f32,
}

/// A mesh as drawn without level of detail (every rank −1).
pub(super) fn plain(m: &Mesh) -> LodMesh {
    let indices: Vec<u32> = m.indices.iter().flatten().copied().collect();
    let n = indices.len() as u32;
    LodMesh {
        indices,
        lod: vec![[0.0, 0.0, 0.0, -1.0]; m.positions.len()],
        bucket_counts: [n; BUCKETS],
        elements: 0,
        area: 0.0,
        element_radius: 0.0,
    }
}

/// A mesh of instance-level LOD: drawn whole, scaled about `centre` by its instance's
/// factor (rank −2 tells the shader).
pub(super) fn whole(m: &Mesh, centre: Vec3) -> LodMesh {
    let mut l = plain(m);
    l.lod.fill([centre.x, centre.y, centre.z, -2.0]);
    l
}

/// The connected pieces of `m` (triangles sharing a vertex), each a list of triangles.
pub(super) fn elements(m: &Mesh) -> Vec<Vec<usize>> {
    let n = m.positions.len();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            let up = p[p[x as usize] as usize];
            p[x as usize] = up;
            x = up;
        }
        x
    }
    for t in &m.indices {
        let a = find(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = find(&mut parent, v);
            if a != b {
                parent[b as usize] = a;
            }
        }
    }
    let mut slot = vec![u32::MAX; n];
    let mut out: Vec<Vec<usize>> = Vec::new();
    for (k, t) in m.indices.iter().enumerate() {
        let root = find(&mut parent, t[0]) as usize;
        if slot[root] == u32::MAX {
            slot[root] = out.len() as u32;
            out.push(Vec::new());
        }
        out[slot[root] as usize].push(k);
    }
    out
}

/// `m` prepared for element-level LOD (callers check [`is_foliage`]); meshes of fewer
/// than [`MIN_ELEMENTS`] elements come back [`plain`].
pub(super) fn prepare(m: &Mesh) -> LodMesh {
    let pieces = elements(m);
    let n = pieces.len();
    if n < MIN_ELEMENTS {
        return plain(m);
    }
    let mut order: Vec<usize> = (0..n).collect();
    shuffle(&mut order, 0x6c61_6d69_6e61 ^ n as u64);
    let mut lod = vec![[0.0, 0.0, 0.0, -1.0]; m.positions.len()];
    let mut indices = Vec::with_capacity(m.indices.len() * 3);
    // Indices drawn once the first k elements are in.
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0u32);
    let (mut area, mut radius) = (0.0f64, 0.0f32);
    for (k, &e) in order.iter().enumerate() {
        let tris = &pieces[e];
        let (centre, a) = centroid(m, tris);
        area += a as f64;
        let rank = (k as f32 + 0.5) / n as f32;
        for &t in tris {
            for &v in &m.indices[t] {
                lod[v as usize] = [centre.x, centre.y, centre.z, rank];
                radius = radius.max(m.positions[v as usize].distance(centre));
            }
            indices.extend_from_slice(&m.indices[t]);
        }
        prefix.push(indices.len() as u32);
    }
    let bucket_counts = std::array::from_fn(|b| {
        let u = last_rank(bucket_level(b));
        // Elements with (k + 1/2) / n < u, plus one for rounding.
        let k = ((u * n as f32 - 0.5).ceil().max(0.0) as usize + 1).min(n);
        prefix[k]
    });
    LodMesh {
        indices,
        lod,
        bucket_counts,
        elements: n as u32,
        area: area as f32,
        element_radius: radius,
    }
}

/// The area-weighted centroid of triangles `tris` of `m` and their area (the vertex mean
/// when they have none).
fn centroid(m: &Mesh, tris: &[usize]) -> (Vec3, f32) {
    let (mut sum, mut area, mut mean, mut count) = (Vec3::ZERO, 0.0f32, Vec3::ZERO, 0.0f32);
    for &t in tris {
        let [a, b, c] = m.indices[t].map(|i| m.positions[i as usize]);
        let w = 0.5 * (b - a).cross(c - a).length();
        sum += w * (a + b + c) / 3.0;
        area += w;
        mean += a + b + c;
        count += 3.0;
    }
    if area > 0.0 {
        (sum / area, area)
    } else {
        (mean / count.max(1.0), 0.0)
    }
}

/// Fisher-Yates with SplitMix64: the same order for the same `seed` everywhere.
fn shuffle(v: &mut [usize], seed: u64) {
    let mut s = seed;
    for i in (1..v.len()).rev() {
        s = s.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = s;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
        let j = (z % (i as u64 + 1)) as usize;
        v.swap(i, j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` separate unit quads (two triangles each) along x.
    fn cards(n: usize) -> Mesh {
        let mut m = Mesh::default();
        for k in 0..n {
            let o = Vec3::new(2.0 * k as f32, 0.0, 0.0);
            let b = m.positions.len() as u32;
            m.positions
                .extend([o, o + Vec3::X, o + Vec3::X + Vec3::Y, o + Vec3::Y]);
            m.indices.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
        }
        m
    }

    #[test]
    fn the_expected_area_is_kept_at_every_fraction() {
        // ∫ w(r)/f dr over [0, 1] is 1, so the mean element keeps its area.
        for b in 0..200 {
            let f = 0.004 + 0.996 * b as f32 / 199.0;
            let n = 20000;
            let mean: f64 = (0..n)
                .map(|k| area_factor((k as f32 + 0.5) / n as f32, f) as f64)
                .sum::<f64>()
                / n as f64;
            assert!((mean - 1.0).abs() < 2e-3, "f {f}: {mean}");
            // Nothing past the last rank is drawn.
            if f < 1.0 {
                assert_eq!(area_factor(last_rank(f) + 1e-4, f), 0.0);
            }
        }
        assert_eq!(area_factor(0.999, 1.0), 1.0);
        // Continuous as f reaches 1: the fade closes.
        assert!((area_factor(0.999, 0.9999) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn pieces_are_found_shuffled_and_ranked() {
        let m = cards(100);
        let l = prepare(&m);
        assert_eq!(l.elements, 100);
        assert!((l.area - 100.0).abs() < 1e-3);
        assert!((l.element_radius - 0.5f32.sqrt()).abs() < 1e-5);
        // Every vertex of a card carries the card's centre and one rank; ranks are the
        // index order.
        let mut last = -1.0;
        for t in l.indices.chunks(6) {
            let r = l.lod[t[0] as usize][3];
            assert!(r > last);
            last = r;
            for &v in t {
                let c = Vec3::from_slice(&l.lod[v as usize][..3]);
                assert_eq!(l.lod[v as usize][3], r);
                assert!(
                    (c - m.positions[t[0] as usize] - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-5
                );
            }
        }
        // Shuffled: the first drawn card is not the first card of the mesh in general.
        let first: Vec<u32> = l.indices[..6].to_vec();
        assert_ne!(first, vec![0, 1, 2, 0, 2, 3]);
        // Level 0 draws everything; each level draws at least the elements its u needs.
        assert_eq!(l.bucket_counts[0], 600);
        for b in 0..BUCKETS {
            let u = last_rank(bucket_level(b));
            let needed = (0..100).filter(|&k| (k as f32 + 0.5) / 100.0 < u).count() as u32;
            assert!(l.bucket_counts[b] >= 6 * needed, "bucket {b}");
            assert!(l.bucket_counts[b] <= 6 * (needed + 1), "bucket {b}");
        }
    }

    #[test]
    fn small_or_connected_meshes_are_left_whole() {
        let l = prepare(&cards(MIN_ELEMENTS - 1));
        assert_eq!(l.elements, 0);
        assert!(l.lod.iter().all(|v| v[3] == -1.0));
        // One connected strip of 100 cards sharing edges is one element.
        let mut m = Mesh::default();
        for k in 0..=100 {
            m.positions
                .extend([Vec3::new(k as f32, 0.0, 0.0), Vec3::new(k as f32, 1.0, 0.0)]);
        }
        for k in 0..100u32 {
            let b = 2 * k;
            m.indices.extend([[b, b + 2, b + 3], [b, b + 3, b + 1]]);
        }
        assert_eq!(elements(&m).len(), 1);
        assert_eq!(prepare(&m).elements, 0);
    }
}
