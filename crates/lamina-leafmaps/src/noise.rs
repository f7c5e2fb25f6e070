//! Seeded procedural noise: a small integer hash, a random number generator, 2-D gradient
//! noise with fractal sums, and cellular (Worley) distances for the reticulate vein net.
//!
//! Everything is a pure function of the seed and the coordinates, so a leaf generated twice
//! with the same seed is bit-identical, whatever the number of threads.

/// A 32-bit integer hash (the "lowbias32" finaliser by C. Wellons), good enough to seed
/// lattice noise.
pub use lamina_leaf::sampling::hash_u32 as hash32;

/// Hash of a lattice point and a seed.
#[inline]
pub fn hash2(ix: i32, iy: i32, seed: u32) -> u32 {
    hash32(
        (ix as u32).wrapping_mul(0x8da6_b343)
            ^ hash32((iy as u32).wrapping_mul(0xd816_3841) ^ seed),
    )
}

/// Uniform float in `[0, 1)` from a hash.
#[inline]
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// A small deterministic random number generator (PCG-like state, hashed output).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    /// A generator for `seed` and a stream name, so each use of the seed is independent.
    pub fn new(seed: u64, stream: u32) -> Self {
        Rng(seed ^ ((stream as u64) << 32 | stream as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15))
    }

    /// Next uniform float in `[0, 1)`.
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        unit(hash32((self.0 >> 32) as u32 ^ self.0 as u32))
    }

    /// Uniform float in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }
}

#[inline]
fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// Gradient at a lattice point: one of 16 evenly spaced unit directions picked by the hash
/// (a table instead of trigonometry: this is the inner loop of every noise call).
#[inline]
fn grad(ix: i32, iy: i32, seed: u32, dx: f32, dy: f32) -> f32 {
    const DIRS: [(f32, f32); 16] = [
        (1.0, 0.0),
        (0.923_879_5, 0.382_683_43),
        (0.707_106_77, 0.707_106_77),
        (0.382_683_43, 0.923_879_5),
        (0.0, 1.0),
        (-0.382_683_43, 0.923_879_5),
        (-0.707_106_77, 0.707_106_77),
        (-0.923_879_5, 0.382_683_43),
        (-1.0, 0.0),
        (-0.923_879_5, -0.382_683_43),
        (-0.707_106_77, -0.707_106_77),
        (-0.382_683_43, -0.923_879_5),
        (0.0, -1.0),
        (0.382_683_43, -0.923_879_5),
        (0.707_106_77, -0.707_106_77),
        (0.923_879_5, -0.382_683_43),
    ];
    let (gx, gy) = DIRS[(hash2(ix, iy, seed) >> 28) as usize];
    gx * dx + gy * dy
}

/// 2-D gradient (Perlin-style) noise, roughly in `[-0.7, 0.7]`, zero at lattice points.
pub fn gradient(x: f32, y: f32, seed: u32) -> f32 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (ix, iy) = (x0 as i32, y0 as i32);
    let n00 = grad(ix, iy, seed, fx, fy);
    let n10 = grad(ix + 1, iy, seed, fx - 1.0, fy);
    let n01 = grad(ix, iy + 1, seed, fx, fy - 1.0);
    let n11 = grad(ix + 1, iy + 1, seed, fx - 1.0, fy - 1.0);
    let (u, v) = (fade(fx), fade(fy));
    let a = n00 + (n10 - n00) * u;
    let b = n01 + (n11 - n01) * u;
    a + (b - a) * v
}

/// Fractal sum of `octaves` octaves of [`gradient`] noise (lacunarity 2, gain 0.5),
/// normalised to roughly `[-1, 1]`.
pub fn fbm(x: f32, y: f32, seed: u32, octaves: u32) -> f32 {
    let (mut s, mut amp, mut f, mut norm) = (0.0, 1.0, 1.0, 0.0);
    for o in 0..octaves {
        s += amp * gradient(x * f, y * f, seed.wrapping_add(o * 0x9e37));
        norm += amp;
        amp *= 0.5;
        f *= 2.0;
    }
    1.4 * s / norm
}

/// Cellular distances at `(x, y)` for jittered points, one per unit cell: the distances to
/// the nearest and second-nearest feature point (`F1`, `F2`). `F2 - F1` is zero on the
/// Voronoi edges, which trace closed polygonal loops like the areoles of a leaf's
/// higher-order veins. `jitter` in `[0, 1]` moves points off the lattice.
pub fn worley(x: f32, y: f32, seed: u32, jitter: f32) -> (f32, f32) {
    let (cx, cy) = (x.floor() as i32, y.floor() as i32);
    let (mut f1, mut f2) = (f32::MAX, f32::MAX);
    for dy in -1..=1 {
        for dx in -1..=1 {
            let (ix, iy) = (cx + dx, cy + dy);
            let h = hash2(ix, iy, seed);
            let px = ix as f32 + 0.5 + jitter * (unit(h) - 0.5);
            let py = iy as f32 + 0.5 + jitter * (unit(hash32(h)) - 0.5);
            let d = ((px - x) * (px - x) + (py - y) * (py - y)).sqrt();
            if d < f1 {
                f2 = f1;
                f1 = d;
            } else if d < f2 {
                f2 = d;
            }
        }
    }
    (f1, f2)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_bounded() {
        for i in 0..1000 {
            let x = i as f32 * 0.173;
            let y = i as f32 * 0.071;
            let n = fbm(x, y, 7, 5);
            assert!(n.is_finite() && n.abs() <= 1.5, "{n}");
            assert_eq!(n, fbm(x, y, 7, 5));
            let (a, b) = worley(x, y, 3, 0.9);
            assert!(a <= b);
        }
        let mut r = Rng::new(1, 2);
        let v: Vec<f32> = (0..100).map(|_| r.next_f32()).collect();
        assert!(v.iter().all(|x| (0.0..1.0).contains(x)));
        let mean = v.iter().sum::<f32>() / 100.0;
        assert!((mean - 0.5).abs() < 0.1);
    }
}
