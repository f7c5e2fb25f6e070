//! Micro-benchmark of the leaf BSDF: evaluations and samples per second on one core, for the
//! closed-form single scattering (the default), the paper's ray march, and the Eq. (1) mode,
//! plus the per-texel `LeafMaterial::bsdf` query.
//!
//! `cargo bench -p lamina-leaf --bench bsdf`

use divan::Bencher;
use divan::counter::ItemsCount;
use glam::{Vec2, Vec3, Vec4};
use lamina_leaf::march::Pcg32;
use lamina_leaf::sampling::uniform_sphere;
use lamina_leaf::*;

const N: usize = 1024;

fn main() {
    divan::main();
}

fn directions() -> Vec<(Vec3, Vec3, Vec3)> {
    let mut rng = Pcg32::new(1);
    (0..N)
        .map(|_| {
            let wo = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let wi = uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            (wo, wi, u)
        })
        .collect()
}

fn bsdf(mode: LeafMode) -> LeafBsdf {
    let params = LeafParams {
        mode,
        ..Default::default()
    };
    LeafMaterial::new(LeafMaps::default(), params)
        .unwrap()
        .bsdf(Vec2::splat(0.5))
}

#[divan::bench(args = [LeafMode::Layered, LeafMode::Eq1, LeafMode::Diffuse])]
fn eval(bencher: Bencher, mode: LeafMode) {
    let b = bsdf(mode);
    let d = directions();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = Vec3::ZERO;
        for &(wo, wi, _) in &d {
            acc += b.eval(divan::black_box(wo), divan::black_box(wi));
        }
        acc
    });
}

/// The paper's ray march in place of the closed form, with `samples` steps per layer.
#[divan::bench(args = [1, 16, 256])]
fn eval_marched(bencher: Bencher, samples: u32) {
    let b = bsdf(LeafMode::Layered);
    let d = directions();
    let mut rng = Pcg32::new(7);
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = Vec3::ZERO;
        for &(wo, wi, _) in &d {
            acc += b.eval_marched(
                divan::black_box(wo),
                divan::black_box(wi),
                samples,
                &mut rng,
            );
        }
        acc
    });
}

#[divan::bench(args = [LeafMode::Layered, LeafMode::Eq1, LeafMode::Diffuse])]
fn sample(bencher: Bencher, mode: LeafMode) {
    let b = bsdf(mode);
    let d = directions();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = 0.0f32;
        for &(wo, _, u) in &d {
            if let Some(s) = b.sample(divan::black_box(wo), divan::black_box(u)) {
                acc += s.pdf;
            }
        }
        acc
    });
}

#[divan::bench(args = [LeafMode::Layered, LeafMode::Eq1])]
fn pdf(bencher: Bencher, mode: LeafMode) {
    let b = bsdf(mode);
    let d = directions();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = 0.0f32;
        for &(wo, wi, _) in &d {
            acc += b.pdf(divan::black_box(wo), divan::black_box(wi));
        }
        acc
    });
}

/// Building the texel BSDF from seven 256x256 maps (bilinear lookups, Kubelka-Munk of the
/// texel's layers, energy bound, bump gradient).
#[divan::bench]
fn texel_query(bencher: Bencher) {
    let w = 256u32;
    let map = |f: &dyn Fn(f32, f32) -> Vec4| {
        let texels = (0..w * w)
            .map(|i| f((i % w) as f32 / w as f32, (i / w) as f32 / w as f32))
            .collect();
        Some(Texture::from_texels(w, w, texels, Wrap::Repeat))
    };
    let maps = LeafMaps {
        front: map(&|u, v| Vec4::new(0.05 + 0.1 * u, 0.2, 0.03 + 0.05 * v, 1.0)),
        back: map(&|u, _| Vec4::new(0.1, 0.25 + 0.1 * u, 0.08, 1.0)),
        translucency: map(&|_, v| Vec4::new(0.1, 0.3, 0.02 + 0.02 * v, 1.0)),
        alpha: map(&|u, _| Vec4::splat(if u < 0.9 { 1.0 } else { 0.0 })),
        thickness: map(&|u, v| Vec4::splat(0.5 + 0.4 * (20.0 * u).sin() * v)),
        extinction: map(&|u, v| Vec4::splat(0.5 + 0.4 * (20.0 * v).sin() * u)),
        bump: map(&|u, v| Vec4::splat(0.01 * (30.0 * u).sin() * (30.0 * v).cos())),
    };
    let m = LeafMaterial::new(maps, LeafParams::default()).unwrap();
    let mut rng = Pcg32::new(3);
    let uvs: Vec<Vec2> = (0..N)
        .map(|_| Vec2::new(rng.next_f32(), rng.next_f32()))
        .collect();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = 0.0f32;
        for &uv in &uvs {
            acc += m.bsdf(divan::black_box(uv)).diffuse_albedo().0.y;
        }
        acc
    });
}

/// The glTF metallic-roughness surface: a rough dielectric with diffuse transmission, and a
/// half-metallic mix (the most lobes at once).
fn pbr(metallic: f32) -> PbrBsdf {
    PbrBsdf {
        base_color: Vec3::new(0.6, 0.4, 0.2),
        metallic,
        roughness: 0.4,
        ior: 1.5,
        transmission: 0.3,
        transmission_color: Vec3::new(0.5, 0.8, 0.3),
    }
}

#[divan::bench(args = [0.0, 0.5])]
fn pbr_eval(bencher: Bencher, metallic: f32) {
    let b = pbr(metallic);
    let d = directions();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = Vec3::ZERO;
        for &(wo, wi, _) in &d {
            acc += b.eval(divan::black_box(wo), divan::black_box(wi));
        }
        acc
    });
}

#[divan::bench(args = [0.0, 0.5])]
fn pbr_sample(bencher: Bencher, metallic: f32) {
    let b = pbr(metallic);
    let d = directions();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = 0.0f32;
        for &(wo, _, u) in &d {
            if let Some(s) = b.sample(divan::black_box(wo), divan::black_box(u)) {
                acc += s.pdf;
            }
        }
        acc
    });
}

#[divan::bench(args = [0.0, 0.5])]
fn pbr_pdf(bencher: Bencher, metallic: f32) {
    let b = pbr(metallic);
    let d = directions();
    bencher.counter(ItemsCount::new(N)).bench_local(|| {
        let mut acc = 0.0f32;
        for &(wo, wi, _) in &d {
            acc += b.pdf(divan::black_box(wo), divan::black_box(wi));
        }
        acc
    });
}

/// A pigment leaf's materials at 16 wavelength triples (a visible render's channel sets),
/// with thickness and extinction maps: one by one, and together (the albedo quadratures'
/// slab geometry shared).
#[divan::bench(args = [false, true], sample_count = 3)]
fn pigment_materials_16(bencher: Bencher, together: bool) {
    let ramp = |f: fn(f32, f32) -> f32| {
        let (w, h) = (64u32, 64u32);
        Some(Texture::from_fn(w, h, Wrap::Repeat, |x, y| {
            Vec4::splat(f(x as f32 / w as f32, y as f32 / h as f32)).with_w(1.0)
        }))
    };
    let maps = LeafMaps {
        thickness: ramp(|x, y| 0.3 + 0.4 * x * y),
        extinction: ramp(|x, y| 0.2 + 0.7 * (1.0 - x) * y),
        ..LeafMaps::default()
    };
    let leaf = PigmentLeaf::new(Pigments::default(), LeafParams::default(), maps).unwrap();
    let like = leaf.material([550.0, 560.0, 570.0]).unwrap();
    let nms: Vec<[f32; 3]> = (0..16)
        .map(|j| [0, 1, 2].map(|c| 400.0 + 10.0 * (j + 16 * c) as f32))
        .collect();
    bencher.counter(ItemsCount::new(nms.len())).bench_local(|| {
        if together {
            leaf.materials_like(&nms, &like).unwrap()
        } else {
            nms.iter()
                .map(|nm| leaf.material_like(*nm, &like).unwrap())
                .collect()
        }
    });
}
