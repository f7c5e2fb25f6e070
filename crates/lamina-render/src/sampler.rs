//! Low-discrepancy sample generation.
//!
//! Every pixel sample draws a sequence of 2D points, one *dimension pair* per decision
//! (pixel position, lens, light choice, light position, BSDF lobe and direction, Russian
//! roulette, ...). Each pair is the 2D Sobol (0,2)-sequence with Owen scrambling and an
//! Owen-scrambled ("shuffled") sample index, both seeded by a hash of the render seed, the
//! pixel and the dimension (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4)).
//! The points of one pair over the samples of a pixel are stratified in 2D (every prefix of
//! length `2^k` is a (0,2)-net), the pairs are mutually decorrelated, and the whole state is
//! a few integers: no tables, no shared state, so rendering is deterministic for a seed
//! whatever the thread count.

use glam::Vec2;

pub use lamina_leaf::sampling::hash_u32;

/// Hash of a seed and a value.
#[inline]
pub fn hash_combine(seed: u32, v: u32) -> u32 {
    hash_u32(seed ^ hash_u32(v).wrapping_add(0x9e37_79b9))
}

/// Laine-Karras style permutation with Burley's constants: each output bit depends only on
/// the input bits below it.
#[inline]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// 32-bit fixed point to a float in `[0, 1)`.
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The second Sobol dimension (generator: the Pascal matrix mod 2) of index `i`, bits
/// reversed: the Pascal matrix applied to `i` by five shift-and-XOR steps (each doubles
/// the span of the binomial recurrence), written in reversed bit order so that no bit
/// reversal is needed (each costs a dozen instructions on x86). The reference (the
/// generator's bit loop, and the sequences as first written) is in the tests.
#[inline]
fn sobol1_reversed(i: u32) -> u32 {
    let mut x = i;
    x ^= (x & 0xaaaa_aaaa) >> 1;
    x ^= (x & 0xcccc_cccc) >> 2;
    x ^= (x & 0xf0f0_f0f0) >> 4;
    x ^= (x & 0xff00_ff00) >> 8;
    x ^= (x & 0xffff_0000) >> 16;
    x
}

/// The shuffled sample index for dimension seed `seed`: the index Owen-scrambled (the
/// Laine-Karras permutation between two bit reversals), from `rindex`, the index with its
/// bits reversed.
#[inline]
fn shuffled(rindex: u32, seed: u32) -> u32 {
    laine_karras(rindex, seed).reverse_bits()
}

/// The 2D point of shuffled index `i` for dimension seed `seed`: the van der Corput radical
/// inverse of `i` and the second Sobol dimension, each Owen-scrambled with its own seed.
/// Both are computed in reversed bit order, where the radical inverse is `i` itself, so
/// one bit reversal per coordinate remains.
#[inline]
fn point_2d(i: u32, seed: u32) -> Vec2 {
    point_2d_seeded(i, point_seeds(seed))
}

/// The two coordinates' scrambling seeds of dimension seed `seed` (see [`point_2d`]).
#[inline]
fn point_seeds(seed: u32) -> [u32; 2] {
    [hash_u32(seed ^ 0x5bd1_e995), hash_u32(seed ^ 0x1b87_3593)]
}

/// [`point_2d`] with its coordinates' seeds ([`point_seeds`]) given.
#[inline]
fn point_2d_seeded(i: u32, [sx, sy]: [u32; 2]) -> Vec2 {
    let x = laine_karras(i, sx);
    let y = laine_karras(sobol1_reversed(i), sy);
    // Both reversed by one 64-bit reversal (`y` above `x`: the reversed `x` comes out on
    // top), about the cost of one 32-bit reversal on x86, which has no instruction for it.
    let xy = ((u64::from(y) << 32) | u64::from(x)).reverse_bits();
    Vec2::new(to_unit((xy >> 32) as u32), to_unit(xy as u32))
}

/// The 1D point of shuffled index `i` for dimension seed `seed`.
#[inline]
fn point_1d(i: u32, seed: u32) -> f32 {
    to_unit(laine_karras(i, hash_u32(seed ^ 0x5bd1_e995)).reverse_bits())
}

/// Sample `index` of the shuffled, Owen-scrambled 2D Sobol sequence for `seed`.
#[inline]
pub fn sobol_2d(index: u32, seed: u32) -> Vec2 {
    point_2d(shuffled(index.reverse_bits(), seed), seed)
}

/// Sample `index` of the shuffled, Owen-scrambled 1D van der Corput sequence for `seed`.
#[inline]
pub fn sobol_1d(index: u32, seed: u32) -> f32 {
    point_1d(shuffled(index.reverse_bits(), seed), seed)
}

/// `hash_u32(dim)` for the first dimensions, which every sample draws: a table instead
/// of a hash per draw.
const DIM_HASHES: [u32; 64] = {
    let mut t = [0u32; 64];
    let mut d = 0;
    while d < 64 {
        t[d] = hash_u32(d as u32);
        d += 1;
    }
    t
};

/// `hash_u32(dim)`, from the table for the first dimensions.
#[inline(always)]
fn dim_hash(dim: u32) -> u32 {
    match DIM_HASHES.get(dim as usize) {
        Some(&h) => h,
        None => hash_u32(dim),
    }
}

/// The seed of a pixel's dimension whose [`dim_hash`] is `h`: `hash_combine(pixel_seed, dim)`.
#[inline(always)]
fn dim_seed(pixel_seed: u32, h: u32) -> u32 {
    hash_u32(pixel_seed ^ h.wrapping_add(0x9e37_79b9))
}

/// Folds a 64-bit user seed to the 32-bit seed of the hashes.
#[inline]
pub fn fold_seed(seed: u64) -> u32 {
    hash_u32(seed as u32) ^ hash_u32((seed >> 32) as u32 ^ 0x68e3_1da4)
}

/// What every sample of one pixel shares: the pixel's seed and the seeds of its first
/// dimension pair (the film position), so that a pixel's samples hash them once
/// ([`PixelStream::film`]) rather than each sample again.
#[derive(Clone, Copy, Debug)]
pub struct PixelStream {
    pixel_seed: u32,
    /// The first dimension's seed.
    film_seed: u32,
    /// Its coordinates' scrambling seeds.
    film_points: [u32; 2],
}

impl PixelStream {
    /// The samples of pixel `(x, y)` for the folded render `seed`.
    #[inline]
    pub fn new(seed: u32, x: u32, y: u32) -> Self {
        let mut first = PixelSampler::new(seed, x, y, 0);
        let film_seed = first.next_seed();
        PixelStream {
            pixel_seed: first.pixel_seed,
            film_seed,
            film_points: point_seeds(film_seed),
        }
    }

    /// Sample `index`'s first draw (the film position, in `[0, 1)²`) and its stream after
    /// it: bit for bit `PixelSampler::new(seed, x, y, index)` and its `next_2d()`.
    #[inline]
    pub fn film(&self, index: u32) -> (PixelSampler, Vec2) {
        let rindex = index.reverse_bits();
        let u = point_2d_seeded(shuffled(rindex, self.film_seed), self.film_points);
        let sampler = PixelSampler {
            pixel_seed: self.pixel_seed,
            rindex,
            dim: 1,
        };
        (sampler, u)
    }
}

/// The sample stream of one pixel sample: call [`PixelSampler::next_2d`] /
/// [`PixelSampler::next_1d`] in the same order for every sample.
#[derive(Clone, Copy, Debug)]
pub struct PixelSampler {
    pixel_seed: u32,
    /// The sample index, bits reversed (what the index shuffle starts from).
    rindex: u32,
    dim: u32,
}

impl PixelSampler {
    /// The stream of sample `index` of pixel `(x, y)` for the folded render `seed`.
    #[inline]
    pub fn new(seed: u32, x: u32, y: u32, index: u32) -> Self {
        let pixel_seed = hash_combine(hash_combine(seed, x), y ^ 0xa511_e9b3);
        PixelSampler {
            pixel_seed,
            rindex: index.reverse_bits(),
            dim: 0,
        }
    }

    /// The next dimension's seed: `hash_combine(pixel_seed, dim)`.
    #[inline]
    fn next_seed(&mut self) -> u32 {
        let h = dim_hash(self.dim);
        self.dim += 1;
        dim_seed(self.pixel_seed, h)
    }

    /// The next dimension pair, in `[0, 1)²`.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let s = self.next_seed();
        point_2d(shuffled(self.rindex, s), s)
    }

    /// [`PixelSampler::next_2d`] where `used`, else that draw skipped (zero returned):
    /// for a consumer that reads its numbers only sometimes (a delta light), the stream
    /// advances the same either way, so the later draws do not change.
    #[inline]
    pub fn next_2d_if(&mut self, used: bool) -> Vec2 {
        if used {
            self.next_2d()
        } else {
            self.skip(1);
            Vec2::ZERO
        }
    }

    /// The next single dimension, in `[0, 1)`.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let s = self.next_seed();
        point_1d(shuffled(self.rindex, s), s)
    }

    /// This stream after `n` more draws, this one left as it is.
    #[inline]
    fn after(&self, n: u32) -> PixelSampler {
        PixelSampler {
            dim: self.dim + n,
            ..*self
        }
    }

    /// What [`PixelSampler::next_2d`] will return after `ahead` more draws, without
    /// drawing: so that a value needed later can be computed before work whose branches
    /// would otherwise hold it up. Take it with [`PixelSampler::skip`] when its turn comes.
    #[inline]
    pub fn peek_2d(&self, ahead: u32) -> Vec2 {
        self.after(ahead).next_2d()
    }

    /// What [`PixelSampler::next_1d`] will return after `ahead` more draws, without
    /// drawing.
    #[inline]
    pub fn peek_1d(&self, ahead: u32) -> f32 {
        self.after(ahead).next_1d()
    }

    /// Skips `n` draws (values taken earlier with [`PixelSampler::peek_1d`] or
    /// [`PixelSampler::peek_2d`]).
    #[inline]
    pub fn skip(&mut self, n: u32) {
        *self = self.after(n);
    }
}

/// Pixel samples drawn side by side, for the wavefront path tracer: lane `k` is sample
/// `index[k]` of some pixel, and every lane draws its dimensions in the same order, so at
/// each draw they share the dimension. Where all lanes are samples of one pixel (a pass of
/// 16 samples) they share its seed too, hashed once per wave rather than per sample, and
/// only the index shuffle and the point differ lane by lane; lanes of several pixels (the
/// first passes, of 1 to 8 samples) hash their own. Each lane's numbers are bit for bit
/// those [`PixelSampler`] draws for that sample.
#[derive(Clone, Copy, Debug)]
pub struct LaneSampler<const N: usize> {
    /// Per lane, its pixel's seed.
    pixel_seed: [u32; N],
    /// Whether every lane's pixel seed is the same (one pixel's samples).
    one_pixel: bool,
    /// Per lane, the sample index with its bits reversed.
    rindex: [u32; N],
    dim: u32,
}

impl<const N: usize> LaneSampler<N> {
    /// Lane `k`: sample `index[k]` of the pixel whose stream is `streams[k]`, past its film
    /// draw, which goes to `(x[k], y[k])` (in `[0, 1)²`: [`PixelStream::film`]'s).
    #[inline(always)]
    pub fn film(
        streams: &[PixelStream; N],
        index: &[u32; N],
        x: &mut [f32; N],
        y: &mut [f32; N],
    ) -> Self {
        let mut rindex = [0u32; N];
        let mut pixel_seed = [0u32; N];
        for k in 0..N {
            let s = &streams[k];
            rindex[k] = index[k].reverse_bits();
            pixel_seed[k] = s.pixel_seed;
            let i = shuffled(rindex[k], s.film_seed);
            x[k] = to_unit(laine_karras(i, s.film_points[0]).reverse_bits());
            y[k] = to_unit(laine_karras(sobol1_reversed(i), s.film_points[1]).reverse_bits());
        }
        LaneSampler {
            one_pixel: pixel_seed.iter().all(|&p| p == pixel_seed[0]),
            pixel_seed,
            rindex,
            dim: 1,
        }
    }

    /// Per lane, the seed of the dimension `ahead` draws on, and per lane `f` of it (the
    /// point's scrambling seeds, `M` of them), as `M` lane arrays: hashed once for all
    /// lanes where they are one pixel's, else lane by lane in plain loops over the lane
    /// arrays (which the compiler turns into vector code; a wave of the first passes draws
    /// every number with its own seeds).
    #[inline(always)]
    fn seeds<const M: usize>(
        &self,
        ahead: u32,
        f: impl Fn(u32) -> [u32; M],
    ) -> ([u32; N], [[u32; N]; M]) {
        let h = dim_hash(self.dim + ahead);
        if self.one_pixel {
            let s = dim_seed(self.pixel_seed[0], h);
            let p = f(s);
            ([s; N], std::array::from_fn(|m| [p[m]; N]))
        } else {
            let mut s = [0u32; N];
            for (s, &pixel) in s.iter_mut().zip(&self.pixel_seed) {
                *s = dim_seed(pixel, h);
            }
            let mut points = [[0u32; N]; M];
            for (k, &sk) in s.iter().enumerate() {
                for (lanes, q) in points.iter_mut().zip(f(sk)) {
                    lanes[k] = q;
                }
            }
            (s, points)
        }
    }

    /// Every lane's [`PixelSampler::peek_1d`]`(ahead)`.
    #[inline(always)]
    pub fn peek_1d(&self, ahead: u32, out: &mut [f32; N]) {
        let (seed, [ps]) = self.seeds(ahead, |s| [hash_u32(s ^ 0x5bd1_e995)]);
        for k in 0..N {
            out[k] = to_unit(laine_karras(shuffled(self.rindex[k], seed[k]), ps[k]).reverse_bits());
        }
    }

    /// Every lane's [`PixelSampler::peek_2d`]`(ahead)`, as `(x, y)`.
    #[inline(always)]
    pub fn peek_2d(&self, ahead: u32, x: &mut [f32; N], y: &mut [f32; N]) {
        let (seed, [sx, sy]) = self.seeds(ahead, point_seeds);
        for k in 0..N {
            let i = shuffled(self.rindex[k], seed[k]);
            x[k] = to_unit(laine_karras(i, sx[k]).reverse_bits());
            y[k] = to_unit(laine_karras(sobol1_reversed(i), sy[k]).reverse_bits());
        }
    }

    /// Skips `n` draws in every lane.
    #[inline(always)]
    pub fn skip(&mut self, n: u32) {
        self.dim += n;
    }
}

#[cfg(test)]
mod tests {
    /// Each lane of a [`LaneSampler`] draws its sample's numbers: lanes of one pixel
    /// (shared seeds) and lanes of several pixels (the first passes' waves), some pixels
    /// with several samples side by side.
    #[test]
    fn lane_sampler_draws_each_samples_numbers() {
        let one_pixel = |seed: u32, x: u32, y: u32, i0: u32| -> Vec<(u32, u32, u32, u32)> {
            (0..16).map(|k| (seed, x, y, i0 + k)).collect()
        };
        let cases = [
            one_pixel(7, 3, 5, 0),
            one_pixel(0xdead_beef, 511, 0, 16),
            one_pixel(1, 0, 9, 48),
            // 16 pixels of a row, one sample each (a pass of 1 sample).
            (0..16).map(|k| (7, 100 + k, 4, 1)).collect(),
            // 4 pixels of 4 samples (a pass of 4), another seed.
            (0..16).map(|k| (99, 8 + k / 4, 2, 4 + k % 4)).collect(),
            // 5 pixels of 3 samples and a sixth pixel's first, across rows.
            (0..16)
                .map(|k| (3, 31 + k / 3 % 2, 7 + k / 6, 5 + k % 3))
                .collect(),
        ];
        for lanes in cases {
            let streams: [PixelStream; 16] =
                std::array::from_fn(|k| PixelStream::new(lanes[k].0, lanes[k].1, lanes[k].2));
            let index: [u32; 16] = std::array::from_fn(|k| lanes[k].3);
            let (mut fx, mut fy) = ([0.0f32; 16], [0.0f32; 16]);
            let mut wave = LaneSampler::<16>::film(&streams, &index, &mut fx, &mut fy);
            let shared = lanes
                .iter()
                .all(|l| l.0 == lanes[0].0 && l.1 == lanes[0].1 && l.2 == lanes[0].2);
            assert_eq!(wave.one_pixel, shared);
            let mut singles: Vec<PixelSampler> = (0..16)
                .map(|k| {
                    let (s, u) = streams[k].film(index[k]);
                    assert_eq!(
                        (u.x.to_bits(), u.y.to_bits()),
                        (fx[k].to_bits(), fy[k].to_bits())
                    );
                    s
                })
                .collect();
            for step in 0..40u32 {
                let (mut a, mut b, mut c) = ([0.0f32; 16], [0.0f32; 16], [0.0f32; 16]);
                wave.peek_1d(step % 3, &mut a);
                wave.peek_2d(step % 3 + 1, &mut b, &mut c);
                for (k, s) in singles.iter_mut().enumerate() {
                    assert_eq!(a[k].to_bits(), s.peek_1d(step % 3).to_bits());
                    let u = s.peek_2d(step % 3 + 1);
                    assert_eq!(
                        (b[k].to_bits(), c[k].to_bits()),
                        (u.x.to_bits(), u.y.to_bits())
                    );
                    s.skip(1 + step % 2);
                }
                wave.skip(1 + step % 2);
            }
        }
    }

    /// Nested uniform (Owen) scrambling of a 32-bit fixed-point value in `[0, 1)`.
    fn owen_scramble(x: u32, seed: u32) -> u32 {
        laine_karras(x.reverse_bits(), seed).reverse_bits()
    }

    /// Second Sobol dimension (generator: the Pascal matrix mod 2), branch-free: the bit
    /// loop over the generator's columns (XOR of column `k` for every set bit `k` of `i`) is
    /// the Pascal matrix applied to the reversed index, which five shift-and-XOR steps compute
    /// (each doubles the span of the binomial recurrence). Equal to the loop for every `u32`
    /// (test `sobol1_matches_the_generator_loop`); the loop's branches cost 6 % of a render.
    fn sobol1(i: u32) -> u32 {
        let mut x = i.reverse_bits();
        x ^= (x & 0x5555_5555) << 1;
        x ^= (x & 0x3333_3333) << 2;
        x ^= (x & 0x0f0f_0f0f) << 4;
        x ^= (x & 0x00ff_00ff) << 8;
        x ^= (x & 0x0000_ffff) << 16;
        x
    }

    /// The generator loop `sobol1` replaced.
    fn sobol1_loop(mut i: u32) -> u32 {
        let mut v = 0x8000_0000u32;
        let mut r = 0u32;
        while i != 0 {
            if i & 1 != 0 {
                r ^= v;
            }
            i >>= 1;
            v ^= v >> 1;
        }
        r
    }

    #[test]
    fn sobol1_matches_the_generator_loop() {
        let mut h = 1u32;
        for i in 0..70_000u32 {
            assert_eq!(sobol1(i), sobol1_loop(i), "{i}");
            h = hash_u32(h ^ i);
            assert_eq!(sobol1(h), sobol1_loop(h), "{h}");
        }
        assert_eq!(sobol1(u32::MAX), sobol1_loop(u32::MAX));
    }

    use super::*;

    /// The sequences as first written (2026-11): each coordinate Owen-scrambled with its
    /// bits reversed around the permutation, `sobol1` from the shuffled index.
    fn sobol_2d_reference(index: u32, seed: u32) -> Vec2 {
        let i = owen_scramble(index, seed);
        let x = owen_scramble(i.reverse_bits(), hash_u32(seed ^ 0x5bd1_e995));
        let y = owen_scramble(sobol1(i), hash_u32(seed ^ 0x1b87_3593));
        Vec2::new(to_unit(x), to_unit(y))
    }

    fn sobol_1d_reference(index: u32, seed: u32) -> f32 {
        let i = owen_scramble(index, seed);
        to_unit(owen_scramble(
            i.reverse_bits(),
            hash_u32(seed ^ 0x5bd1_e995),
        ))
    }

    /// The reordered arithmetic gives the same bits as the reference, so renders are
    /// unchanged: every sample index and dimension a render uses, and hashed ones.
    #[test]
    fn sequences_match_the_reference_bit_for_bit() {
        let mut h = 3u32;
        for k in 0..200_000u32 {
            h = hash_u32(h ^ k);
            assert_eq!(sobol1_reversed(h), sobol1(h).reverse_bits(), "{h}");
            let (index, seed) = if k % 2 == 0 { (k, h) } else { (h, k) };
            let (a, b) = (sobol_2d(index, seed), sobol_2d_reference(index, seed));
            assert_eq!(
                (a.x.to_bits(), a.y.to_bits()),
                (b.x.to_bits(), b.y.to_bits())
            );
            assert_eq!(
                sobol_1d(index, seed).to_bits(),
                sobol_1d_reference(index, seed).to_bits()
            );
        }
        for (x, y, i) in [
            (0, 0, 0),
            (511, 7, 63),
            (1919, 1079, 4095),
            (3, 4, u32::MAX),
        ] {
            let mut s = PixelSampler::new(fold_seed(42), x, y, i);
            let pixel_seed = hash_combine(hash_combine(fold_seed(42), x), y ^ 0xa511_e9b3);
            for dim in 0..100u32 {
                let seed = hash_combine(pixel_seed, dim);
                if dim % 3 == 0 {
                    assert_eq!(s.next_1d().to_bits(), sobol_1d_reference(i, seed).to_bits());
                } else {
                    let (a, b) = (s.next_2d(), sobol_2d_reference(i, seed));
                    assert_eq!(
                        (a.x.to_bits(), a.y.to_bits()),
                        (b.x.to_bits(), b.y.to_bits())
                    );
                }
            }
        }
    }

    /// A pixel's stream gives each sample's film draw and the stream after it bit for bit
    /// as the sample's own sampler does.
    #[test]
    fn pixel_stream_is_the_pixel_sampler() {
        for seed in [0u32, 1, 0xdead_beef] {
            for (x, y) in [
                (0u32, 0u32),
                (1, 0),
                (0, 1),
                (511, 7),
                (1919, 1079),
                (u32::MAX, 3),
            ] {
                let stream = PixelStream::new(seed, x, y);
                for index in (0..300).chain([1 << 16, u32::MAX - 1, u32::MAX]) {
                    let mut want = PixelSampler::new(seed, x, y, index);
                    let want_u = want.next_2d();
                    let (mut got, got_u) = stream.film(index);
                    assert_eq!(got_u.x.to_bits(), want_u.x.to_bits());
                    assert_eq!(got_u.y.to_bits(), want_u.y.to_bits());
                    // The streams go on the same.
                    for _ in 0..5 {
                        assert_eq!(got.next_2d(), want.next_2d());
                        assert_eq!(got.next_1d(), want.next_1d());
                    }
                }
            }
        }
    }

    /// A value drawn ahead is the one the draw gives when its turn comes, and skipping it
    /// leaves the stream where drawing would.
    #[test]
    fn peeked_values_are_the_drawn_ones() {
        let start = PixelSampler::new(fold_seed(7), 12, 34, 5);
        let mut drawn = start;
        let seq: Vec<(f32, Vec2)> = (0..8).map(|_| (drawn.next_1d(), drawn.next_2d())).collect();
        for (k, &(a, b)) in seq.iter().enumerate() {
            let k = 2 * k as u32;
            assert_eq!(start.peek_1d(k).to_bits(), a.to_bits());
            assert_eq!(start.peek_2d(k + 1), b);
        }
        let mut skipped = start;
        skipped.skip(3);
        let mut s = start;
        for _ in 0..3 {
            s.next_2d();
        }
        assert_eq!(skipped.next_2d(), s.next_2d());
        // A draw made only where it is used: the same value, and the same stream after.
        let (mut used, mut unused, mut plain) = (start, start, start);
        assert_eq!(used.next_2d_if(true), plain.next_2d());
        assert_eq!(unused.next_2d_if(false), Vec2::ZERO);
        assert_eq!(used.next_1d().to_bits(), plain.next_1d().to_bits());
        assert_eq!(unused.next_1d().to_bits(), start.peek_1d(1).to_bits());
    }

    #[test]
    fn sobol_prefixes_are_stratified() {
        // The first 16 points of any pair put one point in each cell of a 4x4 grid.
        for seed in [1u32, 77, 12345] {
            let mut cells = [0u32; 16];
            for i in 0..16 {
                let p = sobol_2d(i, seed);
                assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
                cells[(p.y * 4.0) as usize * 4 + (p.x * 4.0) as usize] += 1;
            }
            assert!(cells.iter().all(|&c| c == 1), "{cells:?}");
            let mut strata = [0u32; 16];
            for i in 0..16 {
                strata[(sobol_1d(i, seed) * 16.0) as usize] += 1;
            }
            assert!(strata.iter().all(|&c| c == 1));
        }
    }

    #[test]
    fn dimensions_are_decorrelated() {
        // Mean of x_d * x_{d+1} over many pixels ≈ 1/4 for independent uniforms.
        let mut sum = 0.0f64;
        let n = 4096;
        for p in 0..n {
            let mut s = PixelSampler::new(9, p, 3, 5);
            let a = s.next_1d();
            let b = s.next_1d();
            sum += (a * b) as f64;
        }
        assert!((sum / n as f64 - 0.25).abs() < 0.02);
    }
}
