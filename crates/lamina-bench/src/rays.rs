//! Scenes and rays of the `rays` benchmark (lamina-accel against Embree 3), built directly
//! as [`SceneDesc`]s: no renderer, no materials, only what a ray can hit.
//!
//! * [`cards_scene`]: the 200k-triangle leaf-card canopy of `lamina-render`'s ray bench
//!   (`benches/common/canopy.rs`): 100k cards of 0.1 x 0.15 m, uniformly random centres in
//!   `[-5, 5] x [0, 10] x [-5, 5]`, uniformly random normals and in-plane turns, each one
//!   parallelogram with the leaf-shaped matte ([`LeafMatte`]); plus the opaque 16 x 16 m
//!   ground quad at `y = 0`.
//! * [`tree_scene`]: an instanced tree: one curved leaf (4 x 8 quads as 64 triangles, the
//!   prototype of that bench's `LAMINA_INSTANCES` mode), placed by 1M instances with
//!   random rotations and scales in an ellipsoidal crown (radii 5, 4, 5 m around
//!   `(0, 8, 0)`), and a trunk of 384 triangles in world space. Opaque.
//! * Rays from a fixed seed: pinhole [`camera_rays`], [`random_rays`] (origins uniform in a
//!   box, uniform directions) and [`shadow_rays`] (to a random point of the box, `tmax`
//!   its distance).
//!
//! The matte: the analytic leaf outline of `canopy.rs` sampled on a 256 x 256 texel grid.
//! The exact alpha test is the bilinear interpolation of those texels at `uv` (texel
//! centres at `u = (x + 0.5) / w`, `v = 1 - (y + 0.5) / h`, clamped), opaque from 0.5, and
//! the [`OpacityMask`] is built from the same texels, so the mask is exact for it.

use glam::{Affine3A, Quat, Vec2, Vec3};
use lamina_accel::{Geometry, Instance, MaskWrap, OpacityMask, Prim, PrimAlpha, Ray, SceneDesc};

/// How big the benchmark is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Scale {
    /// Leaf cards of the cards scene.
    pub cards: u32,
    /// Leaf instances of the tree.
    pub leaves: u32,
    /// Camera image width and height (pixels).
    pub camera: u32,
    /// Random and shadow rays per case.
    pub rays: usize,
}

impl Scale {
    /// The benchmark: 100k cards, 1M leaves, 1024 x 1024 camera rays, 2^20 random rays.
    pub const FULL: Scale = Scale {
        cards: 100_000,
        leaves: 1_000_000,
        camera: 1024,
        rays: 1 << 20,
    };

    /// A smoke test: 10x fewer cards, leaves and rays (324² ≈ 1024² / 10 camera rays).
    pub const QUICK: Scale = Scale {
        cards: 10_000,
        leaves: 100_000,
        camera: 324,
        rays: (1 << 20) / 10,
    };
}

/// splitmix64: a small, seeded generator (the same rays for every engine and run).
#[derive(Clone, Debug)]
pub struct Rng(pub u64);

impl Rng {
    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Uniform in `[a, b)`.
    pub fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.f32()
    }

    /// Uniform in the box `[lo, hi)`.
    pub fn in_box(&mut self, lo: Vec3, hi: Vec3) -> Vec3 {
        Vec3::new(
            self.range(lo.x, hi.x),
            self.range(lo.y, hi.y),
            self.range(lo.z, hi.z),
        )
    }

    /// Uniform on the unit sphere.
    pub fn unit(&mut self) -> Vec3 {
        let z = self.range(-1.0, 1.0);
        let phi = self.range(0.0, std::f32::consts::TAU);
        let r = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }

    /// A uniformly random rotation (Shoemake's method).
    pub fn rotation(&mut self) -> Quat {
        let (u1, u2, u3) = (
            self.f32(),
            self.f32() * std::f32::consts::TAU,
            self.f32() * std::f32::consts::TAU,
        );
        let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
        Quat::from_xyzw(a * u2.sin(), a * u2.cos(), b * u3.sin(), b * u3.cos()).normalize()
    }
}

/// The analytic leaf outline of `lamina-render`'s canopy bench: opaque inside a pointed
/// ellipse along `v` above `v = 0.12`, and a petiole (2 % either side of `u = 0.5`) below.
pub fn leaf_shape(u: f32, v: f32) -> bool {
    let blade = if v > 0.12 {
        let s = (v - 0.12) / 0.88;
        0.46 * (std::f32::consts::PI * s).sin().powf(0.7) * (1.0 - 0.35 * s)
    } else {
        0.0
    };
    (u - 0.5).abs() < blade || (v <= 0.12 && (u - 0.5).abs() < 0.02)
}

/// Texels per side of the leaf matte.
pub const MATTE_SIZE: u32 = 256;

/// The leaf matte as texels, its bilinear alpha test and its opacity mask.
#[derive(Clone, Debug)]
pub struct LeafMatte {
    size: u32,
    /// Row-major, row 0 at the top (`v` near 1).
    texels: Vec<f32>,
}

impl LeafMatte {
    /// [`leaf_shape`] sampled at the centres of `size x size` texels.
    pub fn new(size: u32) -> Self {
        let mut texels = Vec::with_capacity((size * size) as usize);
        for y in 0..size {
            let v = 1.0 - (y as f32 + 0.5) / size as f32;
            for x in 0..size {
                let u = (x as f32 + 0.5) / size as f32;
                texels.push(if leaf_shape(u, v) { 1.0 } else { 0.0 });
            }
        }
        LeafMatte { size, texels }
    }

    /// Texel `(x, y)`, clamped to the grid.
    pub fn texel(&self, x: i64, y: i64) -> f32 {
        let m = self.size as i64 - 1;
        self.texels[(y.clamp(0, m) * (m + 1) + x.clamp(0, m)) as usize]
    }

    /// The bilinear interpolation of the texels at `uv` (as [`OpacityMask::classify`]
    /// reads them: `x = u·w - 0.5`, `y = (1 - v)·h - 0.5`).
    pub fn alpha(&self, uv: Vec2) -> f32 {
        let s = self.size as f32;
        let x = uv.x * s - 0.5;
        let y = (1.0 - uv.y) * s - 0.5;
        let (fx0, fy0) = (x.floor(), y.floor());
        let (fx, fy) = (x - fx0, y - fy0);
        let (x0, y0) = (fx0 as i64, fy0 as i64);
        self.texel(x0, y0) * (1.0 - fx) * (1.0 - fy)
            + self.texel(x0 + 1, y0) * fx * (1.0 - fy)
            + self.texel(x0, y0 + 1) * (1.0 - fx) * fy
            + self.texel(x0 + 1, y0 + 1) * fx * fy
    }

    /// The exact alpha test: the bilinear matte is at least 0.5.
    pub fn opaque(&self, uv: Vec2) -> bool {
        self.alpha(uv) >= 0.5
    }

    /// The 3-state mask of the same texels (clamped, cutoff 0.5).
    pub fn mask(&self) -> OpacityMask {
        OpacityMask::from_texels(self.size, self.size, MaskWrap::Clamp, 0.5, |x, y| {
            self.texel(x, y)
        })
        .expect("a 256 x 256 mask is within OpacityMask::MAX_CELLS")
    }
}

/// Half width and half height of a leaf card (m): 0.1 x 0.15 m cards.
pub const CARD_HALF: Vec2 = Vec2::new(0.05, 0.075);

/// An orthonormal pair perpendicular to the unit vector `n` (Duff et al. 2017).
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let s = 1.0f32.copysign(n.z);
    let a = -1.0 / (s + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + s * n.x * n.x * a, s * b, -s * n.x),
        Vec3::new(b, s + n.y * n.y * a, -n.y),
    )
}

/// The lower and upper corners of the cards scene's canopy box (m).
pub const CARDS_BOX: (Vec3, Vec3) = (Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 10.0, 5.0));

/// `n` leaf cards in the canopy box plus the ground (see the module docs), from `seed`.
/// With `alpha`, every card has the leaf matte (id 0, mask `matte.mask()`); without, the
/// cards are opaque rectangles and the scene has no mask.
pub fn cards_scene(n: u32, seed: u64, alpha: Option<&LeafMatte>) -> SceneDesc {
    let mut r = Rng(seed);
    let mut prims = Vec::with_capacity(n as usize + 1);
    let uv = [Vec2::ZERO, Vec2::X, Vec2::Y];
    for _ in 0..n {
        let c = r.in_box(CARDS_BOX.0, CARDS_BOX.1);
        let normal = r.unit();
        let (s, t) = basis(normal);
        let a = r.range(0.0, std::f32::consts::TAU);
        let up = s * a.cos() + t * a.sin();
        let side = normal.cross(up);
        let mut p = Prim::parallelogram(
            c - side * CARD_HALF.x - up * CARD_HALF.y,
            side * (2.0 * CARD_HALF.x),
            up * (2.0 * CARD_HALF.y),
        );
        if alpha.is_some() {
            p.alpha = Some(PrimAlpha { id: 0, uv });
        }
        prims.push(p);
    }
    prims.push(Prim::parallelogram(
        Vec3::new(-8.0, 0.0, 8.0),
        Vec3::new(16.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -16.0),
    ));
    SceneDesc {
        world: Geometry { prims },
        masks: alpha.map(|m| vec![Some(m.mask())]).unwrap_or_default(),
        ..Default::default()
    }
}

/// The curved leaf of `lamina-render`'s canopy bench in object space: the card's size,
/// 4 x 8 quads (64 triangles), the midrib drooping and the edges cupped.
pub fn curved_leaf() -> Geometry {
    let (cols, rows) = (4usize, 8usize);
    let mut pos = Vec::with_capacity((cols + 1) * (rows + 1));
    for j in 0..=rows {
        for i in 0..=cols {
            let (u, v) = (i as f32 / cols as f32, j as f32 / rows as f32);
            let (x, y) = (u * 2.0 - 1.0, v * 2.0 - 1.0);
            let z = -0.03 * (v * v) + 0.015 * x * x;
            pos.push(Vec3::new(x * CARD_HALF.x, y * CARD_HALF.y, z));
        }
    }
    let mut prims = Vec::with_capacity(2 * cols * rows);
    for j in 0..rows {
        for i in 0..cols {
            let a = j * (cols + 1) + i;
            let (b, c, d) = (a + 1, a + cols + 2, a + cols + 1);
            prims.push(Prim::triangle([pos[a], pos[b], pos[c]]));
            prims.push(Prim::triangle([pos[a], pos[c], pos[d]]));
        }
    }
    Geometry { prims }
}

/// Centre and radii of the tree's crown (m).
pub const CROWN: (Vec3, Vec3) = (Vec3::new(0.0, 8.0, 0.0), Vec3::new(5.0, 4.0, 5.0));
/// The lower and upper corners of the tree's box (m): the crown and the trunk below it.
pub const TREE_BOX: (Vec3, Vec3) = (Vec3::new(-5.0, 0.0, -5.0), Vec3::new(5.0, 12.0, 5.0));

/// The instanced tree (see the module docs): `leaves` instances of [`curved_leaf`], random
/// rotation, scale in `[0.7, 1.3]`, uniform in the crown; a trunk (radius 0.3 m, from the
/// ground to the crown's centre, 24 sides x 8 rings = 384 triangles) in world space.
pub fn tree_scene(leaves: u32, seed: u64) -> SceneDesc {
    let mut r = Rng(seed);
    let (centre, radii) = CROWN;
    let instances = (0..leaves)
        .map(|_| {
            let p = loop {
                let p = Vec3::new(r.range(-1.0, 1.0), r.range(-1.0, 1.0), r.range(-1.0, 1.0));
                if p.length_squared() <= 1.0 {
                    break p;
                }
            };
            let scale = Vec3::splat(r.range(0.7, 1.3));
            Instance {
                object_to_world: Affine3A::from_scale_rotation_translation(
                    scale,
                    r.rotation(),
                    centre + p * radii,
                ),
                prototype: 0,
            }
        })
        .collect();
    let (sides, rings, radius) = (24usize, 8usize, 0.3f32);
    let at = |i: usize, j: usize| {
        let a = i as f32 / sides as f32 * std::f32::consts::TAU;
        Vec3::new(
            radius * a.cos(),
            centre.y * j as f32 / rings as f32,
            radius * a.sin(),
        )
    };
    let mut trunk = Vec::with_capacity(2 * sides * rings);
    for j in 0..rings {
        for i in 0..sides {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            trunk.push(Prim::triangle([a, b, c]));
            trunk.push(Prim::triangle([a, c, d]));
        }
    }
    SceneDesc {
        world: Geometry { prims: trunk },
        prototypes: vec![curved_leaf()],
        instances,
        ..Default::default()
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct View {
    /// Eye (m).
    pub position: Vec3,
    /// Point looked at (m).
    pub look_at: Vec3,
    /// Horizontal field of view (degrees).
    pub fov_deg: f32,
}

/// The camera of `lamina-render`'s canopy bench.
pub const CARDS_VIEW: View = View {
    position: Vec3::new(9.0, 4.0, 14.0),
    look_at: Vec3::new(0.0, 4.0, 0.0),
    fov_deg: 55.0,
};

/// A camera framing the whole tree.
pub const TREE_VIEW: View = View {
    position: Vec3::new(6.0, 6.5, 11.0),
    look_at: Vec3::new(0.0, 6.5, 0.0),
    fov_deg: 55.0,
};

/// One ray through the centre of each pixel of a `w x h` image (row by row from the top;
/// `+y` up, unit directions).
pub fn camera_rays(view: &View, w: u32, h: u32) -> Vec<Ray> {
    let forward = (view.look_at - view.position).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let tan_x = (view.fov_deg.to_radians() * 0.5).tan();
    let tan_y = tan_x * h as f32 / w as f32;
    (0..w * h)
        .map(|i| {
            let (px, py) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            let sx = (2.0 * px / w as f32 - 1.0) * tan_x;
            let sy = (1.0 - 2.0 * py / h as f32) * tan_y;
            Ray {
                origin: view.position,
                dir: (forward + right * sx + up * sy).normalize(),
                tmax: f32::INFINITY,
            }
        })
        .collect()
}

/// `spp` camera rays per pixel of a `w x h` picture of `view` (pixel after pixel, each
/// pixel's samples together, jittered within it as a renderer's are), and the window
/// `[x0, x1, y0, y1]` they fill (tangents right and up of the view direction) for
/// `Accel::index_view`, with the eye, view direction and up.
#[allow(clippy::type_complexity)]
pub fn pixel_rays(
    view: &View,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
) -> (Vec<Ray>, (Vec3, Vec3, Vec3, [f32; 4])) {
    let forward = (view.look_at - view.position).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let tan_x = (view.fov_deg.to_radians() * 0.5).tan();
    let tan_y = tan_x * h as f32 / w as f32;
    let mut r = Rng(seed);
    let mut rays = Vec::with_capacity((w * h * spp) as usize);
    for i in 0..w * h {
        for _ in 0..spp {
            let (px, py) = ((i % w) as f32 + r.f32(), (i / w) as f32 + r.f32());
            let sx = (2.0 * px / w as f32 - 1.0) * tan_x;
            let sy = (1.0 - 2.0 * py / h as f32) * tan_y;
            rays.push(Ray {
                origin: view.position,
                dir: (forward + right * sx + up * sy).normalize(),
                tmax: f32::INFINITY,
            });
        }
    }
    let pad = 4.0 / w as f32;
    let window = [-tan_x - pad, tan_x + pad, -tan_y - pad, tan_y + pad];
    (rays, (view.position, forward, Vec3::Y, window))
}

/// `n` rays with origins uniform in the box `(lo, hi)` and uniform unit directions.
pub fn random_rays(bx: (Vec3, Vec3), n: usize, seed: u64) -> Vec<Ray> {
    let mut r = Rng(seed);
    (0..n)
        .map(|_| Ray {
            origin: r.in_box(bx.0, bx.1),
            dir: r.unit(),
            tmax: f32::INFINITY,
        })
        .collect()
}

/// `n` shadow rays between two points uniform in the box `(lo, hi)`: unit direction,
/// `tmax` the distance between them.
pub fn shadow_rays(bx: (Vec3, Vec3), n: usize, seed: u64) -> Vec<Ray> {
    let mut r = Rng(seed);
    (0..n)
        .map(|_| {
            loop {
                let (a, b) = (r.in_box(bx.0, bx.1), r.in_box(bx.0, bx.1));
                let d = b - a;
                let len = d.length();
                if len > 1e-3 {
                    break Ray {
                        origin: a,
                        dir: d / len,
                        tmax: len,
                    };
                }
            }
        })
        .collect()
}

/// The sun of the `sun_any_alpha` case: unit direction toward it (45° up, from the side).
pub const SUN: Vec3 = Vec3::new(0.5, std::f32::consts::FRAC_1_SQRT_2, 0.5);

/// `n` sun shadow rays: origins uniform in the box `(lo, hi)`, direction `sun`
/// (normalised), no `tmax`.
pub fn sun_rays(bx: (Vec3, Vec3), n: usize, seed: u64, sun: Vec3) -> Vec<Ray> {
    let mut r = Rng(seed);
    let dir = sun.normalize();
    (0..n)
        .map(|_| Ray {
            origin: r.in_box(bx.0, bx.1),
            dir,
            tmax: f32::INFINITY,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal() {
        let mut r = Rng(3);
        for _ in 0..100 {
            let n = r.unit();
            let (s, t) = basis(n);
            for (a, b) in [(s, t), (s, n), (t, n)] {
                assert!(a.dot(b).abs() < 1e-5);
            }
            assert!((s.length() - 1.0).abs() < 1e-5 && (t.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn bilinear_matte_matches_the_shape_at_texel_centres_and_the_mask_agrees() {
        let m = LeafMatte::new(MATTE_SIZE);
        let mask = m.mask();
        let mut r = Rng(5);
        let (mut decided, mut opaque) = (0, 0);
        for _ in 0..20_000 {
            let uv = Vec2::new(r.f32(), r.f32());
            let o = m.opaque(uv);
            opaque += usize::from(o);
            match mask.classify(uv) {
                lamina_accel::mask::OPAQUE => {
                    assert!(o, "{uv}");
                    decided += 1;
                }
                lamina_accel::mask::TRANSPARENT => {
                    assert!(!o, "{uv}");
                    decided += 1;
                }
                _ => {}
            }
        }
        // The leaf covers ~40-60 % of the card; the mask decides all but the outline.
        assert!((6_000..14_000).contains(&opaque), "{opaque}");
        assert!(decided > 18_000, "{decided}");
        // At a texel centre the bilinear matte is that texel: the shape itself.
        for (x, y) in [(128, 128), (10, 10), (128, 250), (128, 5)] {
            let uv = Vec2::new((x as f32 + 0.5) / 256.0, 1.0 - (y as f32 + 0.5) / 256.0);
            assert_eq!(m.opaque(uv), leaf_shape(uv.x, uv.y), "{x} {y}");
        }
    }
}
