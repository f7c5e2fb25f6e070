//! The checks of the backend suite, generic over [`Backend`]. Each builds a backend and the
//! [`BruteForce`] reference for the same scene and holds the backend's answers to the
//! reference's:
//!
//! * a closest hit must be an opaque hit the reference finds too (same surface and
//!   instance, distance to 1e-4 relative, point, normal and texture coordinates), and no
//!   farther than the reference's closest (two surfaces at the same distance may go
//!   either way);
//! * a miss must be a miss of the reference;
//! * `occluded` must equal "closest is some", exactly, for every ray.
//!
//! The reference computes in `f64`, so rays within rounding of an outline (an edge nobody
//! shares, the cutoff of a matte) may legitimately differ: at most one ray in a thousand
//! may disagree. The known-answer checks (grid edges, back faces, grazing rays,
//! degenerate and empty scenes, build errors) allow none.

use super::random_scenes::{
    Rng, alpha_cards, instanced, plain, random_rays, scene, triangle_soup, without_mattes,
};
use super::reference::BruteForce;
use super::{Backend, SuiteHit, Surface};
use crate::accel::Ray;
use glam::{Affine3A, Vec2, Vec3};
use lamina_core::{Instance, Mesh, Prototype, Scene};

/// Rays per random check.
const RAYS: usize = 4000;

/// Whether `a` and `b` are the same hit up to rounding.
fn same_hit<P, Q>(a: &SuiteHit<P>, b: &SuiteHit<Q>) -> bool {
    a.what == b.what
        && (a.t - b.t).abs() <= 1e-4 * b.t.max(1e-2)
        && (a.point - b.point).length() <= 1e-4 * (1.0 + b.point.abs().max_element())
        && (a.normal - b.normal).length() <= 1e-2
        && (a.uv - b.uv).length() <= 1e-3
}

/// Counts of one check: rays cast, hits agreed on, disagreements (with the first few).
struct Tally {
    what: String,
    rays: usize,
    hits: usize,
    wrong: usize,
    examples: Vec<String>,
}

impl Tally {
    fn new<B: Backend>(what: &str) -> Self {
        Tally {
            what: format!("{}: {what}", B::NAME),
            rays: 0,
            hits: 0,
            wrong: 0,
            examples: Vec::new(),
        }
    }

    /// Casts `ray` (skipping `skip` in the backend and `ref_skip` in the reference) and
    /// judges the answer; returns the backend's hit and the reference's hit it matched.
    fn cast<B: Backend>(
        &mut self,
        b: &B,
        r: &BruteForce,
        ray: &Ray,
        skip: Option<B::Prim>,
        ref_skip: Option<usize>,
    ) -> Option<(SuiteHit<B::Prim>, SuiteHit<usize>)> {
        self.rays += 1;
        let hit = b.closest(ray, skip);
        assert_eq!(
            b.occluded(ray, skip),
            hit.is_some(),
            "{}: occluded disagrees with closest for {ray:?}",
            self.what
        );
        let all = r.all_hits(ray, ref_skip);
        let first = all.iter().min_by(|a, b| a.t.total_cmp(&b.t));
        let verdict = match (&hit, first) {
            (None, None) => Ok(None),
            (None, Some(f)) => Err(format!("missed {f:?}")),
            (Some(h), first) => match all.iter().find(|m| same_hit(h, m)) {
                None => Err(format!(
                    "hit {h:?}, which the reference has not (closest {first:?})"
                )),
                Some(m) => {
                    let f = first.expect("a matched hit");
                    if m.t > f.t + 1e-4 * f.t.max(1e-2) {
                        Err(format!("hit {h:?} behind the closest {f:?}"))
                    } else {
                        Ok(Some((*h, *m)))
                    }
                }
            },
        };
        match verdict {
            Ok(found) => {
                self.hits += found.is_some() as usize;
                found
            }
            Err(e) => {
                self.wrong += 1;
                if self.examples.len() < 5 {
                    self.examples.push(format!("{ray:?}: {e}"));
                }
                None
            }
        }
    }

    /// Asserts at most one ray in a thousand disagreed and at least `min_hits` hit.
    fn finish(&self, min_hits: usize) {
        eprintln!(
            "{}: {} rays, {} hits, {} disagree",
            self.what, self.rays, self.hits, self.wrong
        );
        assert!(
            self.wrong * 1000 <= self.rays,
            "{}: {} of {} rays disagree with the reference, e.g.\n{}",
            self.what,
            self.wrong,
            self.rays,
            self.examples.join("\n")
        );
        assert!(
            self.hits >= min_hits,
            "{}: only {} of {} rays hit",
            self.what,
            self.hits,
            self.rays
        );
    }

    /// Asserts no ray disagreed.
    fn finish_exact(&self) {
        assert!(
            self.wrong == 0,
            "{}: {} of {} rays disagree with the reference:\n{}",
            self.what,
            self.wrong,
            self.rays,
            self.examples.join("\n")
        );
    }
}

/// `B` and the reference for `scene`.
fn both<B: Backend>(scene: &Scene) -> (B, BruteForce) {
    (
        B::build(scene).expect("the backend builds"),
        BruteForce::build(scene).expect("the reference builds"),
    )
}

/// A ray, the backend's hit and the reference's hit it matched.
type Agreed<B> = (Ray, SuiteHit<<B as Backend>::Prim>, SuiteHit<usize>);

/// Random rays through `scene`, judged; returns the tally and the agreed hits.
fn random_check<B: Backend>(what: &str, scene: &Scene, seed: u64) -> (Tally, Vec<Agreed<B>>) {
    let (b, r) = both::<B>(scene);
    let mut tally = Tally::new::<B>(what);
    let mut hits = Vec::new();
    for ray in random_rays(&mut Rng::new(seed), RAYS) {
        if let Some((h, m)) = tally.cast(&b, &r, &ray, None, None) {
            hits.push((ray, h, m));
        }
    }
    (tally, hits)
}

/// Random triangles of three sizes (one mesh with vertex normals), quad lights (one
/// two-sided) and sphere lights, in world space.
pub(super) fn triangles_match_reference<B: Backend>() {
    let scene = triangle_soup(&mut Rng::new(1));
    let (tally, hits) = random_check::<B>("triangles", &scene, 11);
    tally.finish(RAYS / 5);
    let on = |f: fn(&Surface) -> bool| hits.iter().filter(|(_, h, _)| f(&h.what)).count();
    assert!(
        on(|w| matches!(w, Surface::QuadLight(_))) > 10,
        "quad lights"
    );
    assert!(
        on(|w| matches!(w, Surface::SphereLight(_))) > 10,
        "sphere lights"
    );
}

/// Leaf cards with every alpha test lamina has (none, repeating matte, clamped matte on
/// the alpha channel, a leaf's alpha map), split along either diagonal, in either order.
/// The mattes must matter: without them a good share of the rays hits something else.
pub(super) fn alpha_masked_cards_match_reference<B: Backend>() {
    let scene = alpha_cards(&mut Rng::new(2));
    let (tally, _) = random_check::<B>("alpha-masked cards", &scene, 12);
    tally.finish(RAYS / 5);
    let (masked, solid) = (
        BruteForce::build(&scene).unwrap(),
        BruteForce::build(&without_mattes(&scene)).unwrap(),
    );
    let changed = random_rays(&mut Rng::new(12), RAYS)
        .iter()
        .filter(|ray| {
            let (a, b) = (masked.closest(ray, None), solid.closest(ray, None));
            a.map(|h| (h.what, h.t)) != b.map(|h| (h.what, h.t))
        })
        .count();
    assert!(changed > RAYS / 20, "the mattes change only {changed} rays");
}

/// Two levels: instances of a cluster prototype (a BVH) and of a tiny one (no BVH),
/// rotated, non-uniformly scaled and mirrored, instances of an empty prototype, world
/// cards and triangles, a quad and a sphere light.
pub(super) fn instances_match_reference<B: Backend>() {
    let scene = instanced(&mut Rng::new(3));
    let (tally, hits) = random_check::<B>("instances", &scene, 13);
    tally.finish(RAYS / 5);
    let on_instance = |want: &dyn Fn(&Instance) -> bool| {
        hits.iter()
            .filter(|(_, h, _)| match h.what {
                Surface::Mesh {
                    instance: Some(i), ..
                } => want(&scene.instances[i as usize]),
                _ => false,
            })
            .count()
    };
    assert!(on_instance(&|i| i.prototype == 0) > 50, "cluster instances");
    assert!(on_instance(&|i| i.prototype == 1) > 20, "tiny instances");
    assert!(
        on_instance(&|i| i.transform.matrix3.determinant() < 0.0) > 20,
        "mirrored instances"
    );
}

/// Every agreed hit continued from its exact point, skipping the primitive it left: the
/// next hit must agree too and never be the skipped primitive (a planar primitive cannot
/// be hit again by a ray leaving it).
pub(super) fn continuation_rays_match_reference<B: Backend>() {
    for (what, scene, seed) in [
        ("continued rays, instances", instanced(&mut Rng::new(3)), 14),
        ("continued rays, cards", alpha_cards(&mut Rng::new(2)), 15),
    ] {
        let (b, r) = both::<B>(&scene);
        let (_, hits) = random_check::<B>(what, &scene, seed);
        let mut tally = Tally::new::<B>(what);
        for (ray, h, m) in hits {
            if matches!(h.what, Surface::SphereLight(_)) {
                continue;
            }
            let next = Ray {
                origin: h.point,
                dir: ray.dir,
                tmax: 100.0,
            };
            if let Some((h2, _)) = tally.cast(&b, &r, &next, Some(h.prim), Some(m.prim)) {
                assert_ne!(
                    h2.prim, h.prim,
                    "{what}: the skipped primitive was hit again"
                );
            }
        }
        tally.finish(tally.rays / 20);
    }
}

/// `tmax` cuts: every agreed hit at `t` is gone with `tmax = 0.999 t` and found again with
/// `tmax = 1.001 t`; `tmax = 0` hits nothing.
pub(super) fn tmax_limits_match_reference<B: Backend>() {
    let scene = instanced(&mut Rng::new(3));
    let (b, r) = both::<B>(&scene);
    let (_, hits) = random_check::<B>("tmax", &scene, 16);
    let mut tally = Tally::new::<B>("tmax limits");
    for (ray, h, _) in &hits {
        let short = Ray {
            tmax: 0.999 * h.t,
            ..*ray
        };
        if let Some((h2, _)) = tally.cast(&b, &r, &short, None, None) {
            assert!(h2.t < short.tmax, "hit beyond tmax: {h2:?} for {short:?}");
        }
        let long = Ray {
            tmax: 1.001 * h.t,
            ..*ray
        };
        if let Some((h2, _)) = tally.cast(&b, &r, &long, None, None) {
            assert!(same_hit(&h2, h), "{h2:?} instead of {h:?}");
        }
        let none = Ray { tmax: 0.0, ..*ray };
        assert!(b.closest(&none, None).is_none() && !b.occluded(&none, None));
    }
    tally.finish(hits.len() / 2);
}

/// A flat grid mesh at `z = 0` over `[-2, 2]²`: 8 x 8 cells of two triangles, diagonals
/// alternating (so some pairs merge into parallelograms and some do not), UVs over
/// `[0, 1]²`, wound to face `+z`.
fn grid() -> Mesh {
    let mut m = Mesh {
        material: 0,
        ..Default::default()
    };
    let at = |i: u32, j: u32| i * 9 + j;
    for i in 0..9 {
        for j in 0..9 {
            let (x, y) = (-2.0 + 0.5 * j as f32, -2.0 + 0.5 * i as f32);
            m.positions.push(Vec3::new(x, y, 0.0));
            m.uvs.push(Vec2::new((x + 2.0) / 4.0, (y + 2.0) / 4.0));
        }
    }
    for i in 0..8 {
        for j in 0..8 {
            let [a, b, c, d] = [at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j)];
            if (i + j) % 2 == 0 {
                m.indices.extend([[a, b, c], [a, c, d]]);
            } else {
                m.indices.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    m
}

/// Known answers on [`grid`]: rays straight down (a direction with negative zeros) or up
/// (onto the back faces) through every vertex, edge midpoint and quarter point of the
/// grid hit at exactly the right distance with the `+z` normal (never flipped toward the
/// ray) and the right UVs: no cracks between triangles. Rays in the grid's plane (along
/// its edges or across them) and rays starting on it hit nothing; `tmax` just short of the
/// surface hits nothing, just past it hits.
pub(super) fn edges_back_faces_and_grazing_rays<B: Backend>() {
    let scene = scene(vec![plain()], vec![grid()]);
    let (b, r) = both::<B>(&scene);
    let mut tally = Tally::new::<B>("grid");
    let grid_surface = Surface::Mesh {
        instance: None,
        material: 0,
    };
    for i in 1..16 {
        for j in 1..16 {
            let (x, y) = (-2.0 + 0.25 * j as f32, -2.0 + 0.25 * i as f32);
            for (z, dir) in [(1.0, -Vec3::Z), (-1.0, Vec3::Z)] {
                let ray = Ray {
                    origin: Vec3::new(x, y, z),
                    dir,
                    tmax: f32::INFINITY,
                };
                let h = b.closest(&ray, None);
                let h = h.unwrap_or_else(|| panic!("{}: crack at {x}, {y} ({dir})", B::NAME));
                assert_eq!(h.what, grid_surface);
                assert!((h.t - 1.0).abs() < 1e-6, "t = {}", h.t);
                assert!(h.normal.dot(Vec3::Z) > 0.9999, "normal {}", h.normal);
                let uv = Vec2::new((x + 2.0) / 4.0, (y + 2.0) / 4.0);
                assert!((h.uv - uv).length() < 1e-5, "uv {} vs {uv}", h.uv);
                tally.cast(&b, &r, &ray, None, None);
                for (tmax, hits) in [(0.999, false), (1.001, true)] {
                    let cut = Ray { tmax, ..ray };
                    assert_eq!(b.closest(&cut, None).is_some(), hits, "{cut:?}");
                    tally.cast(&b, &r, &cut, None, None);
                }
            }
        }
    }
    let mut rng = Rng::new(4);
    for k in 0..200 {
        // In the plane: along a grid line, or across the grid in any direction.
        let origin = if k % 2 == 0 {
            Vec3::new(-3.0, -2.0 + 0.5 * (k / 2 % 9) as f32, 0.0)
        } else {
            Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), 0.0)
        };
        let a = rng.range(0.0, std::f32::consts::TAU);
        let dir = if k % 2 == 0 {
            Vec3::X
        } else {
            Vec3::new(a.cos(), a.sin(), 0.0)
        };
        // And leaving the surface from a point on it, either way.
        let on = Vec3::new(rng.range(-1.9, 1.9), rng.range(-1.9, 1.9), 0.0);
        let away = (rng.unit() * Vec3::new(1.0, 1.0, 0.0) + Vec3::Z * rng.range(0.1, 1.0))
            .normalize()
            * if k % 3 == 0 { -1.0 } else { 1.0 };
        for ray in [(origin, dir), (on, away)].map(|(origin, dir)| Ray {
            origin,
            dir,
            tmax: f32::INFINITY,
        }) {
            assert_eq!(b.closest(&ray, None), None, "{}: {ray:?}", B::NAME);
            assert!(!b.occluded(&ray, None), "{}: {ray:?}", B::NAME);
            tally.cast(&b, &r, &ray, None, None);
        }
    }
    tally.finish_exact();
}

/// Scenes with nothing to hit (no geometry; only instances of an empty prototype) answer
/// every ray with a miss. Zero-area triangles (a repeated vertex, collinear vertices) and
/// triangles with a NaN or infinite vertex are never hit, and leave the good triangle of
/// the same mesh (which has no UVs: they read zero) hit as before.
pub(super) fn degenerate_and_empty_scenes<B: Backend>() {
    let empty = scene(vec![plain()], Vec::new());
    let mut only_empty = empty.clone();
    only_empty.prototypes = vec![Prototype {
        name: "empty".into(),
        meshes: vec![Mesh::default()],
    }];
    only_empty.instances = vec![Instance {
        prototype: 0,
        transform: Affine3A::from_translation(Vec3::X),
    }];
    for s in [&empty, &only_empty] {
        let b = B::build(s).unwrap();
        for ray in random_rays(&mut Rng::new(5), 200) {
            assert_eq!(b.closest(&ray, None), None);
            assert!(!b.occluded(&ray, None));
        }
    }
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let bad = Mesh {
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(2.0, 1.0, 0.0),
            Vec3::new(nan, 0.5, 0.0),
            Vec3::new(inf, 0.5, 0.0),
            Vec3::new(-1.0, -1.0, 0.5),
            Vec3::new(-1.0, 1.0, 0.5),
            Vec3::new(1.0, 1.0, 0.5),
            Vec3::new(1.0, 0.5, 0.0),
        ],
        // Good (z = 0.5, above y = x), repeated vertex, collinear, NaN, infinite.
        indices: vec![[6, 8, 7], [0, 1, 1], [0, 9, 3], [0, 1, 4], [1, 2, 5]],
        ..Default::default()
    };
    let s = scene(vec![plain()], vec![bad]);
    let (b, r) = both::<B>(&s);
    let mut tally = Tally::new::<B>("degenerate triangles");
    for ray in random_rays(&mut Rng::new(6), RAYS) {
        if let Some((h, _)) = tally.cast(&b, &r, &ray, None, None) {
            assert!(h.t.is_finite() && (h.point.z - 0.5).abs() < 1e-4, "{h:?}");
            assert_eq!(h.uv, Vec2::ZERO);
        }
    }
    let down = |x: f32, y: f32| Ray {
        origin: Vec3::new(x, y, 2.0),
        dir: -Vec3::Z,
        tmax: f32::INFINITY,
    };
    // Inside the good triangle; on or inside the span of the degenerate ones only.
    assert!(b.closest(&down(-0.5, 0.6), None).is_some());
    for (x, y) in [(0.5, 0.0), (0.6, 0.3), (0.5, 0.2), (0.8, 0.1)] {
        assert_eq!(
            b.closest(&down(x, y), None).map(|h| h.point.z),
            None,
            "{x} {y}"
        );
    }
    tally.finish_exact();
    assert!(tally.hits > 0);
}

/// Out-of-range indices (material, vertex, UV, prototype) and transforms that are not
/// finite and invertible are build errors, not panics; a broken prototype no instance uses
/// is not looked at.
pub(super) fn build_errors<B: Backend>() {
    let base = instanced(&mut Rng::new(7));
    B::build(&base).expect("the base scene builds");
    type Break = fn(&mut Scene);
    let broken: [(&str, Break); 7] = [
        ("world material", |s| s.meshes[0].material = 99),
        ("vertex index", |s| s.meshes[1].indices[0][2] = 9999),
        ("uv index", |s| {
            s.meshes[0].uvs.pop();
        }),
        ("prototype material", |s| {
            s.prototypes[0].meshes[1].material = 99
        }),
        ("prototype index", |s| s.instances[3].prototype = 9),
        ("singular transform", |s| {
            s.instances[4].transform = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0))
        }),
        ("non-finite transform", |s| {
            s.instances[5].transform.translation.x = f32::NAN
        }),
    ];
    for (what, f) in broken {
        let mut s = base.clone();
        f(&mut s);
        assert!(B::build(&s).is_err(), "{}: {what} builds", B::NAME);
    }
    let mut unused = base.clone();
    unused.prototypes[2].meshes[0].material = 99;
    unused.prototypes[2].meshes[0].indices[0][0] = 9999;
    assert!(
        B::build(&unused).is_ok(),
        "{}: an unused prototype",
        B::NAME
    );
}
