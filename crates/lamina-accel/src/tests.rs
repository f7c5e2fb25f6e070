//! The engine against a brute-force reference over the same [`SceneDesc`], for every
//! kernel this CPU runs: random triangles and cards with mattes and masks, instances with
//! rotation, non-uniform scale and mirroring, spheres, skips, `-0` directions, `tmax`.
//! (lamina-render's backend suite checks the renderer's whole path the same way.)

#![allow(clippy::nonminimal_bool)]

use crate::mask::{MaskWrap, OpacityMask};
use crate::*;
use glam::{Affine3A, DVec3, Quat, Vec2, Vec3};

fn rng(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn unit(r: &mut impl FnMut() -> f32) -> Vec3 {
    let z = 2.0 * r() - 1.0;
    let phi = std::f32::consts::TAU * r();
    let s = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// A 16x16 matte: a disc of radius 0.4 around (0.5, 0.5) in texel space, bilinear.
const MW: i64 = 16;
fn matte_texel(x: i64, y: i64) -> f32 {
    let (x, y) = (x.clamp(0, MW - 1), y.clamp(0, MW - 1));
    let (u, v) = ((x as f32 + 0.5) / MW as f32, (y as f32 + 0.5) / MW as f32);
    if (u - 0.5).powi(2) + (v - 0.5).powi(2) < 0.16 {
        1.0
    } else {
        0.0
    }
}
fn matte(uv: Vec2) -> bool {
    bilinear(matte_texel, uv)
}

/// Whether the `MW x MW` matte with texels `texel` is opaque at `uv` (bilinear, cutoff 0.5).
fn bilinear(texel: fn(i64, i64) -> f32, uv: Vec2) -> bool {
    let x = uv.x * MW as f32 - 0.5;
    let y = (1.0 - uv.y) * MW as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let a = texel(x0, y0) * (1.0 - fx) + texel(x0 + 1, y0) * fx;
    let b = texel(x0, y0 + 1) * (1.0 - fx) + texel(x0 + 1, y0 + 1) * fx;
    a * (1.0 - fy) + b * fy >= 0.5
}

fn random_geometry(r: &mut impl FnMut() -> f32, n: usize, side: f32, alpha: bool) -> Geometry {
    let prims = (0..n)
        .map(|i| {
            let c = Vec3::new(r(), r(), r()) * side;
            let (a, b) = (unit(r) * side * 0.08, unit(r) * side * 0.05);
            let mut p = if i % 3 == 0 {
                Prim::triangle([c, c + a, c + b])
            } else {
                Prim::parallelogram(c, a, b)
            };
            if alpha && i % 2 == 0 {
                p.alpha = Some(PrimAlpha {
                    id: 0,
                    uv: [Vec2::ZERO, Vec2::X, Vec2::Y],
                });
            }
            if i % 17 == 5 {
                p.v[2] = p.v[0] + (p.v[1] - p.v[0]) * 2.0; // degenerate: never hit
            }
            p
        })
        .collect();
    Geometry { prims }
}

fn scene(seed: u64, instances: bool) -> SceneDesc {
    let mut r = rng(seed);
    let mask = OpacityMask::from_texels(MW as u32, MW as u32, MaskWrap::Clamp, 0.5, matte_texel);
    let mut desc = SceneDesc {
        world: random_geometry(&mut r, 300, 4.0, true),
        masks: vec![mask],
        spheres: vec![Sphere {
            center: Vec3::splat(2.0),
            radius: 0.3,
        }],
        ..Default::default()
    };
    if instances {
        desc.prototypes = vec![
            random_geometry(&mut r, 40, 1.0, true),
            random_geometry(&mut r, 1, 1.0, true), // a card: no tree
            Geometry::default(),                   // empty: dropped from the top level
        ];
        for i in 0..60 {
            let scale =
                Vec3::new(0.5 + r(), 0.5 + r(), 0.5 + r()) * if i % 4 == 0 { -1.0 } else { 1.0 };
            desc.instances.push(Instance {
                object_to_world: Affine3A::from_scale_rotation_translation(
                    scale,
                    Quat::from_axis_angle(unit(&mut r), 6.0 * r()),
                    Vec3::new(r(), r(), r()) * 4.0,
                ),
                prototype: i % 3,
            });
        }
    }
    desc
}

/// The reference: every primitive (world and every instance, moved to world space in
/// `f64`), every sphere.
fn brute(desc: &SceneDesc, ray: &Ray, skip: PrimRef) -> Option<(f64, PrimRef)> {
    let o = ray.origin.as_dvec3();
    let d = ray.dir.as_dvec3();
    let mut best: Option<(f64, PrimRef)> = None;
    let mut test = |g: &Geometry, m: Option<&Affine3A>, inst: u32| {
        for (i, p) in g.prims.iter().enumerate() {
            let here = PrimRef {
                inst,
                prim: i as u32,
            };
            if !p.is_valid() || here == skip {
                continue;
            }
            let v = p.v.map(|v| match m {
                Some(m) => m.transform_point3(v).as_dvec3(),
                None => v.as_dvec3(),
            });
            let (e1, e2) = (v[1] - v[0], v[2] - v[0]);
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det == 0.0 {
                continue;
            }
            let tv = o - v[0];
            let b1 = tv.dot(pv) / det;
            let q = tv.cross(e1);
            let b2 = d.dot(q) / det;
            let t = e2.dot(q) / det;
            let inside = b1 >= 0.0
                && b2 >= 0.0
                && if p.quad {
                    b1 <= 1.0 && b2 <= 1.0
                } else {
                    b1 + b2 <= 1.0
                };
            if !inside || !(t > 0.0 && t < ray.tmax as f64) || best.is_some_and(|b| b.0 <= t) {
                continue;
            }
            if let Some(a) = p.alpha {
                let (b1, b2) = (b1 as f32, b2 as f32);
                let uv = a.uv[0] * (1.0 - b1 - b2) + a.uv[1] * b1 + a.uv[2] * b2;
                if !matte(uv) {
                    continue;
                }
            }
            best = Some((t, here));
        }
    };
    test(&desc.world, None, NO_INSTANCE);
    for (k, inst) in desc.instances.iter().enumerate() {
        test(
            &desc.prototypes[inst.prototype as usize],
            Some(&inst.object_to_world),
            k as u32,
        );
    }
    for (k, s) in desc.spheres.iter().enumerate() {
        let oc = o - s.center.as_dvec3();
        let b = oc.dot(d) / d.length_squared();
        let disc = b * b - (oc.length_squared() - (s.radius as f64).powi(2)) / d.length_squared();
        if disc >= 0.0 {
            for t in [-b - disc.sqrt(), -b + disc.sqrt()] {
                if t > 0.0 && t < ray.tmax as f64 && best.is_none_or(|b| t < b.0) {
                    best = Some((
                        t,
                        PrimRef {
                            inst: SPHERE,
                            prim: k as u32,
                        },
                    ));
                    break;
                }
            }
        }
    }
    best
}

fn kernels() -> Vec<Kernel> {
    [Kernel::Avx2, Kernel::Sse, Kernel::Scalar]
        .into_iter()
        .filter(|k| k.available())
        .collect()
}

/// The builders this build has: lamina's, and with the `embree` feature Embree's (its
/// spatial splits put a primitive in several leaves).
fn builders() -> Vec<crate::Builder> {
    vec![
        crate::Builder::Lamina,
        #[cfg(feature = "embree")]
        crate::Builder::EmbreeHigh,
    ]
}

/// Closest hits and occlusion equal brute force on thousands of random rays (a handful of
/// rays grazing an edge may differ by rounding: at most 0.2 %, and a different hit must be
/// at the same distance), for every kernel and builder.
fn check(desc: &SceneDesc, seed: u64) {
    let f = |id: u32, uv: Vec2| {
        assert_eq!(id, 0);
        matte(uv)
    };
    let runs = kernels()
        .into_iter()
        .flat_map(|k| builders().into_iter().map(move |b| (k, b)));
    for (kernel, builder) in runs {
        let a = Accel::build_with(
            desc,
            BuildOptions {
                kernel,
                builder,
                ..Default::default()
            },
        )
        .unwrap();
        // Hits name instances in the top level's order; brute force in the scene's.
        let order = a.scene_instances(desc);
        let scene = |p: PrimRef| match p.inst {
            NO_INSTANCE | SPHERE => p,
            k => PrimRef {
                inst: order[k as usize],
                prim: p.prim,
            },
        };
        let mut r = rng(seed);
        let (mut n, mut off) = (0, 0);
        for i in 0..4000 {
            let mut dir = unit(&mut r);
            if i % 50 == 0 {
                // Negative-zero components: along an axis, and in an axis plane.
                dir = if i % 100 == 0 {
                    Vec3::new(-0.0, -0.0, -1.0)
                } else {
                    Vec3::new(dir.x, -0.0, dir.z).normalize()
                };
                assert!(dir.y.is_sign_negative() && dir.y == 0.0);
            }
            let ray = Ray {
                origin: Vec3::new(r(), r(), r()) * 5.0 - 0.5,
                dir: dir * if i % 7 == 0 { 2.5 } else { 1.0 },
                tmax: if i % 3 == 0 {
                    0.5 + 3.0 * r()
                } else {
                    f32::INFINITY
                },
            };
            let want = brute(desc, &ray, PrimRef::NONE);
            let got = a.intersect(&ray, PrimRef::NONE, &f);
            n += 1;
            match (want, got) {
                (None, None) => {}
                (Some((t, p)), Some(h)) => {
                    assert!(
                        (h.t as f64 - t).abs() <= 1e-4 * t.max(1.0),
                        "{kernel:?} {builder:?} ray {i}: t {} vs {t}",
                        h.t
                    );
                    if scene(h.prim) != p {
                        off += 1;
                    }
                }
                _ => off += 1,
            }
            if a.occluded(&ray, PrimRef::NONE, &f) != want.is_some() {
                off += 1;
            }
            // Continuing from the hit, skipping it, sees what brute force sees past it.
            if let Some(h) = got.filter(|h| h.prim.inst != SPHERE) {
                let cont = Ray {
                    origin: ray.origin + ray.dir * h.t,
                    ..ray
                };
                let cont = Ray {
                    tmax: f32::INFINITY,
                    ..cont
                };
                let want = brute(desc, &cont, scene(h.prim));
                let got = a.intersect(&cont, h.prim, &f);
                n += 1;
                if want.map(|w| w.1) != got.map(|g| scene(g.prim)) {
                    off += 1;
                }
            }
        }
        assert!(
            off * 500 <= n,
            "{kernel:?} {builder:?}: {off} of {n} rays disagree with brute force"
        );
    }
}

#[test]
fn world_geometry_matches_brute_force() {
    check(&scene(1, false), 11);
}

#[test]
fn instances_match_brute_force() {
    check(&scene(2, true), 12);
}

/// Long, thin primitives across the scene (where Embree's builder splits references, so a
/// primitive sits in several leaves: `embree_build`'s `long_slivers_are_split`) among
/// small ones: the answers stay brute force's.
#[test]
fn long_primitives_match_brute_force() {
    let mut desc = scene(3, false);
    let mut r = rng(33);
    for i in 0..120 {
        let c = Vec3::new(r(), r(), r()) * 4.0;
        let (a, b) = (unit(&mut r) * 3.5, unit(&mut r) * 0.05);
        desc.world.prims.push(if i % 2 == 0 {
            Prim::triangle([c - a * 0.5, c + a * 0.5, c + b])
        } else {
            Prim::parallelogram(c - a * 0.5, a, b)
        });
    }
    check(&desc, 13);
}

/// Every kernel gives bit-identical leaf results, so the same hits.
#[test]
fn kernels_agree_exactly() {
    let desc = scene(3, true);
    let f = |_: u32, uv: Vec2| matte(uv);
    let accels: Vec<Accel> = kernels()
        .into_iter()
        .map(|kernel| {
            Accel::build_with(
                &desc,
                BuildOptions {
                    kernel,
                    ..Default::default()
                },
            )
            .unwrap()
        })
        .collect();
    let mut r = rng(5);
    let mut same = 0;
    for _ in 0..5000 {
        let ray = Ray {
            origin: Vec3::new(r(), r(), r()) * 5.0 - 0.5,
            dir: unit(&mut r),
            tmax: f32::INFINITY,
        };
        let hits: Vec<_> = accels
            .iter()
            .map(|a| a.intersect(&ray, PrimRef::NONE, &f))
            .collect();
        same += hits.windows(2).all(|w| w[0] == w[1]) as u32;
    }
    assert!(same >= 4995, "{same} of 5000 rays identical across kernels");
}

/// The masks decide most candidates; only unknown cells ask the filter, and its answers
/// are the ones that count.
#[test]
fn masks_skip_most_alpha_lookups() {
    let desc = scene(4, true);
    let f = |_: u32, uv: Vec2| matte(uv);
    let a = Accel::build(&desc).unwrap();
    let st = TraversalStats::default();
    let mut r = rng(9);
    for _ in 0..4000 {
        let ray = Ray {
            origin: Vec3::new(r(), r(), r()) * 5.0 - 0.5,
            dir: unit(&mut r),
            tmax: f32::INFINITY,
        };
        a.intersect_counted(&ray, PrimRef::NONE, &f, &st);
    }
    let decided = st.mask_opaque.get() + st.mask_transparent.get();
    let asked = st.alpha_lookups.get();
    assert!(
        decided > 0 && decided > 2 * asked,
        "decided {decided}, asked {asked}"
    );
    // A filter that says "transparent" everywhere only changes unknown cells.
    let none = |_: u32, _: Vec2| false;
    let opaque_cells = (0..2000).filter(|i| {
        let ray = Ray {
            origin: Vec3::new(2.0, 2.0, -1.0),
            dir: (Vec3::new((i % 40) as f32 * 0.1, (i / 40) as f32 * 0.1, 5.0)
                - Vec3::new(2.0, 2.0, -1.0))
            .normalize(),
            tmax: f32::INFINITY,
        };
        a.intersect(&ray, PrimRef::NONE, &none).is_some()
    });
    assert!(
        opaque_cells.count() > 0,
        "opaque cells hit without asking the filter"
    );
}

/// Instances are bounded by their placed vertices ([`hull_points`]), not by their placed
/// box: a right triangle turned 45° about its normal gets a box half the area of its turned
/// box's box. Rays aimed at points 1 % inside the corners of turned, scaled and mirrored
/// cards and triangles (what a box that left out a vertex would cut off) hit them, as brute
/// force does. (At 1e-4 inside, 9 of 1120 such rays miss with these boxes and with the
/// placed-box boxes alike: the f32 instance transform at 30 m from the origin.)
#[test]
fn instance_boxes_are_tight_and_keep_the_corners() {
    let card = Prim::parallelogram(Vec3::ZERO, Vec3::X, Vec3::Y);
    let tri = Prim::triangle([
        Vec3::new(0.0, 0.0, 0.5),
        Vec3::new(1.0, 0.2, 0.5),
        Vec3::new(0.3, 1.0, 0.7),
    ]);
    let geom = Geometry {
        prims: vec![card, tri],
    };
    let b = Aabb::of_points(&[Vec3::ZERO, Vec3::ONE]);
    assert_eq!(hull_points(&geom, b).len(), 4 + 3);
    // More distinct vertices than MAX_HULL_POINTS: the box's corners.
    let mut r = rng(3);
    let many = random_geometry(&mut r, MAX_HULL_POINTS, 1.0, false);
    assert_eq!(hull_points(&many, b).len(), 8);

    // A right triangle turned 45° about its normal: its box is half its box's turned box.
    let right = Geometry {
        prims: vec![Prim::triangle([Vec3::ZERO, Vec3::X, Vec3::Y])],
    };
    let mut desc = SceneDesc {
        prototypes: vec![right],
        ..Default::default()
    };
    let turn = Affine3A::from_rotation_z(std::f32::consts::FRAC_PI_4);
    desc.instances.push(Instance {
        object_to_world: turn,
        prototype: 0,
    });
    let a = Accel::build(&desc).unwrap();
    let blas_box = |a: &Accel| match &a.engine {
        Engine::W8(l) => l.protos[0].bounds.unwrap(),
        Engine::W4(l) => l.protos[0].bounds.unwrap(),
    };
    let (_, boxes) = match &a.engine {
        Engine::W8(l) => top_boxes(&desc, &l.protos),
        Engine::W4(l) => top_boxes(&desc, &l.protos),
    };
    let corner_box = (0..8).fold(Aabb::EMPTY, |acc, k| {
        let pb = blas_box(&a);
        let c = Vec3::new(
            if k & 1 == 0 { pb.min.x } else { pb.max.x },
            if k & 2 == 0 { pb.min.y } else { pb.max.y },
            if k & 4 == 0 { pb.min.z } else { pb.max.z },
        );
        acc.grow(turn.transform_point3(c))
    });
    let area = |b: &Aabb| {
        let e = b.max - b.min;
        e.x * e.y
    };
    assert!(
        area(&boxes[0]) < 0.6 * area(&corner_box),
        "{:?} vs {:?}",
        boxes[0],
        corner_box
    );

    // Many placements; rays toward points 1 % inside each corner, from random origins.
    let mut r = rng(17);
    desc.prototypes = vec![geom.clone()];
    desc.instances.clear();
    for i in 0..40 {
        let scale =
            Vec3::new(0.2 + r(), 0.2 + r(), 0.2 + r()) * if i % 3 == 0 { -1.0 } else { 1.0 };
        desc.instances.push(Instance {
            object_to_world: Affine3A::from_scale_rotation_translation(
                scale,
                Quat::from_axis_angle(unit(&mut r), 6.0 * r()),
                Vec3::new(r(), r(), r()) * 30.0,
            ),
            prototype: 0,
        });
    }
    let f = |_: u32, _: Vec2| true;
    for kernel in kernels() {
        let a = Accel::build_with(
            &desc,
            BuildOptions {
                kernel,
                ..Default::default()
            },
        )
        .unwrap();
        let mut missed = 0;
        let mut n = 0;
        for inst in &desc.instances {
            let m = inst.object_to_world;
            for p in &geom.prims {
                let corners: Vec<Vec3> = if p.quad {
                    vec![p.v[0], p.v[1], p.v[2], p.v[1] + p.v[2] - p.v[0]]
                } else {
                    p.v.to_vec()
                };
                let centre = corners.iter().copied().sum::<Vec3>() / corners.len() as f32;
                for &c in &corners {
                    let target = m.transform_point3(c + (centre - c) * 1e-2);
                    for _ in 0..4 {
                        let origin = target + unit(&mut r) * 5.0;
                        let ray = Ray {
                            origin,
                            dir: (target - origin).normalize(),
                            tmax: f32::INFINITY,
                        };
                        n += 1;
                        let want = brute(&desc, &ray, PrimRef::NONE).is_some();
                        let got = a.intersect(&ray, PrimRef::NONE, &f).is_some();
                        missed += (want && !got) as u32;
                        assert_eq!(
                            a.occluded(&ray, PrimRef::NONE, &f),
                            got,
                            "{kernel:?}: occluded and intersect disagree"
                        );
                    }
                }
            }
        }
        assert_eq!(missed, 0, "{kernel:?}: {missed} of {n} corner rays missed");
    }
}

#[test]
fn build_errors_name_the_instance() {
    let mut desc = scene(5, true);
    desc.instances[7].prototype = 9;
    assert_eq!(
        Accel::build(&desc).unwrap_err(),
        AccelError::Prototype {
            instance: 7,
            prototype: 9,
            count: 3
        }
    );
    let mut desc = scene(5, true);
    desc.instances[3].object_to_world = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    assert_eq!(Accel::build(&desc).unwrap_err(), AccelError::Transform(3));
}

#[test]
fn empty_scenes_hit_nothing() {
    let a = Accel::build(&SceneDesc::default()).unwrap();
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::Z,
        tmax: f32::INFINITY,
    };
    assert_eq!(a.intersect(&ray, PrimRef::NONE, &|_, _| true), None);
    assert!(!a.occluded(&ray, PrimRef::NONE, &|_, _| true));
    let _ = DVec3::ZERO;
}

/// A sphere is named by its index in `SceneDesc::spheres`, also after invalid ones (which
/// are never hit).
#[test]
fn sphere_ids_are_scene_indices() {
    let desc = SceneDesc {
        spheres: vec![
            Sphere {
                center: Vec3::ZERO,
                radius: 0.0,
            },
            Sphere {
                center: Vec3::new(0.0, 0.0, -5.0),
                radius: 1.0,
            },
        ],
        ..Default::default()
    };
    let a = Accel::build(&desc).unwrap();
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: -Vec3::Z,
        tmax: f32::INFINITY,
    };
    let h = a.intersect(&ray, PrimRef::NONE, &|_, _| true).unwrap();
    assert_eq!(
        h.prim,
        PrimRef {
            inst: SPHERE,
            prim: 1
        }
    );
    assert!((h.t - 4.0).abs() < 1e-5);
}

#[test]
fn kernel_choice_names_a_bad_override() {
    let (fastest, none) = Kernel::chosen(None);
    assert!(fastest.available() && none.is_none());
    assert_eq!(Kernel::chosen(Some("  ")), (fastest, None));
    assert_eq!(Kernel::chosen(Some("Scalar")), (Kernel::Scalar, None));
    let (k, w) = Kernel::chosen(Some("avx512"));
    assert_eq!(k, fastest);
    let w = w.expect("a warning");
    assert!(w.contains("avx512") && w.contains("not a kernel"), "{w}");
    if !Kernel::Avx2.available() {
        let (k, w) = Kernel::chosen(Some("avx2"));
        assert_eq!(k, fastest);
        assert!(w.expect("a warning").contains("cannot run"));
    }
}

/// [`scene`], with (`ground`) a ground far larger than everything else and a column of
/// 400 cards stacked along `stack`, too crowded for one cell's list of a grid looking
/// along it.
fn grid_scene(s: u64, instances: bool, ground: bool, stack: Vec3) -> SceneDesc {
    let mut desc = scene(s, instances);
    if ground {
        desc.world.prims.push(Prim::parallelogram(
            Vec3::new(-100.0, -0.3, 100.0),
            Vec3::new(200.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -200.0),
        ));
        let (a, b) = stack.any_orthonormal_pair();
        for k in 0..400 {
            let c = Vec3::new(1.5, 1.5, 1.5) + stack * (0.01 * k as f32);
            desc.world
                .prims
                .push(Prim::parallelogram(c, a * 0.1, b * 0.1));
        }
    }
    desc
}

/// `desc` built for every kernel this CPU runs (no grids: the tree walk's answers).
fn walks(desc: &SceneDesc) -> Vec<(Kernel, Accel)> {
    kernels()
        .into_iter()
        .map(|kernel| {
            let opts = BuildOptions {
                kernel,
                ..Default::default()
            };
            (kernel, Accel::build_with(desc, opts).unwrap())
        })
        .collect()
}

/// The grid along a sun's axis ([`Accel::index_direction`]) answers occlusion exactly as
/// the tree walk does, for every kernel: rays along the axis, in narrow and wide cones
/// around it and in any direction, from free space and from surfaces (skipping the one
/// they leave), with and without `tmax`, on the world level and through instances; with a
/// ground far larger than the grid's cells (listed apart for rays that leave the grid) and
/// a column of cards too crowded for a cell's list (its rays take the walk).
#[test]
fn direction_grid_answers_as_the_walk() {
    let f = |_: u32, uv: Vec2| matte(uv);
    for (s, instances, ground) in [(3, false, false), (4, true, false), (6, true, true)] {
        let desc = grid_scene(s, instances, ground, Vec3::Y);
        for (kernel, walk) in walks(&desc) {
            let mut r = rng(s * 31 + 7);
            let axes = [
                unit(&mut r),
                Vec3::Y,
                Vec3::new(-0.0, 1.0, -0.0),
                Vec3::new(0.3, -0.8, 0.2),
            ];
            for axis in axes {
                let mut grid = walk.clone();
                let st = grid.index_direction(axis).expect("a grid");
                assert!(st.entries >= st.packs && st.bytes > 0, "{st:?}");
                assert_eq!(grid.directions(), vec![st]);
                assert_eq!(
                    grid.memory().total(),
                    walk.memory().total() + st.bytes,
                    "the grid's bytes are counted"
                );
                let a = axis.normalize();
                let (u, v) = a.any_orthonormal_pair();
                let (mut served, mut along) = (0, 0);
                for i in 0..3000 {
                    // Directions: the axis itself (half of them exactly as the grid was
                    // asked for, which its short plan serves), a sun of 0.5° and of 10°,
                    // anything.
                    let dir = match i % 4 {
                        0 if i % 8 == 0 => axis,
                        0 => a,
                        1 | 2 => {
                            let w = if i % 4 == 1 { 0.0046 } else { 0.18 };
                            let phi = std::f32::consts::TAU * r();
                            let rad = w * r().sqrt();
                            (a + (u * phi.cos() + v * phi.sin()) * rad).normalize()
                        }
                        _ => unit(&mut r),
                    };
                    let spread = if ground && i % 8 == 4 { 60.0 } else { 5.0 };
                    // Some far below the scene along the axis, where the short plan's drift
                    // bound does not reach (the general plan serves them).
                    let below = if i % 24 == 16 { a * -3.0e5 } else { Vec3::ZERO };
                    let mut ray = Ray {
                        origin: Vec3::new(r(), r(), r()) * spread - 0.1 * spread + below,
                        dir: dir * if i % 5 == 0 { 3.0 } else { 1.0 },
                        tmax: if i % 3 == 0 {
                            0.2 + 2.0 * r()
                        } else {
                            f32::INFINITY
                        },
                    };
                    let mut skip = PrimRef::NONE;
                    if i % 2 == 1 {
                        // From a surface: where a random ray lands, leaving that primitive.
                        let probe = Ray {
                            dir: unit(&mut r),
                            tmax: f32::INFINITY,
                            ..ray
                        };
                        if let Some(h) = walk
                            .intersect(&probe, PrimRef::NONE, &f)
                            .filter(|h| h.prim.inst != SPHERE)
                        {
                            ray.origin = probe.origin + probe.dir * h.t;
                            skip = h.prim;
                        }
                    }
                    let stats = TraversalStats::default();
                    let want = walk.occluded(&ray, skip, &f);
                    let got = grid.occluded_counted(&ray, skip, &f, &stats);
                    assert_eq!(
                        got, want,
                        "{kernel:?} axis {axis} ray {i}: {ray:?} skip {skip:?}"
                    );
                    if i % 4 == 0 {
                        along += 1;
                        // A ray the grid serves walks no tree node.
                        if stats.nodes.get() == 0 {
                            served += 1;
                        }
                    }
                }
                // All but the few that start in the crowded column.
                assert!(
                    served * 50 >= along * 49,
                    "{kernel:?} axis {axis}: {served} of {along} served"
                );
            }
        }
    }
}

/// Rays along exactly the direction a sun's grid was asked for take its short plan (their
/// cells under the origin, no drift computed) from anywhere in the scene, and the general
/// one from far enough below it that the direction's rounding across the axis could carry
/// them more than the rounding margin; either way the answers are the tree walk's, and the
/// short plan's cells hold the general plan's, also for origins at cells' edges.
#[test]
fn rays_along_the_grids_own_direction_take_the_short_plan() {
    let f = |_: u32, uv: Vec2| matte(uv);
    let desc = grid_scene(5, false, true, Vec3::Y);
    for (kernel, walk) in walks(&desc) {
        let mut r = rng(77);
        for axis in [Vec3::new(0.3, 0.8, 0.2), Vec3::Y, unit(&mut r)] {
            let mut grid = walk.clone();
            grid.index_direction(axis).expect("a grid");
            let ix = match &grid.engine {
                Engine::W8(l) => l.dirs[0].clone(),
                Engine::W4(l) => l.dirs[0].clone(),
            };
            let lowest = ix
                .along_lowest()
                .expect("a short plan for its own direction");
            let a = axis.normalize();
            let (mut short, mut blocked) = (0, 0);
            for i in 0..4000 {
                let mut origin = Vec3::new(r(), r(), r()) * 6.0 - 1.0;
                let far = i % 10 == 0 && lowest.is_finite();
                if far {
                    origin -= a * (2.0 * (origin.dot(a) - lowest).abs() + 10.0);
                }
                let ray = Ray {
                    origin,
                    dir: axis,
                    tmax: if i % 3 == 0 { 0.5 + r() } else { f32::INFINITY },
                };
                let takes_short = ix.takes_short_plan(&ray);
                assert_eq!(
                    takes_short,
                    !far && origin.dot(a) < ix.top(),
                    "{kernel:?} {ray:?}"
                );
                short += takes_short as u32;
                let want = walk.occluded(&ray, PrimRef::NONE, &f);
                assert_eq!(
                    grid.occluded(&ray, PrimRef::NONE, &f),
                    want,
                    "{kernel:?} {ray:?}"
                );
                blocked += want as u32;
            }
            assert!(
                short > 2000 && blocked > 200,
                "{kernel:?} {axis}: {short} short, {blocked} blocked"
            );
            // The short plan's cells hold the general plan's, also for origins within a
            // few units in the last place of a cell's edge, where the general plan's
            // margin takes in the next cell.
            let (lo, cell, n) = ix.layout();
            let mut checked = 0;
            for i in 0..4000 {
                let (kx, ky) = ((r() * n[0] as f32) as i32, (r() * n[1] as f32) as i32);
                let nudge = |k: i32| (k as f32 * 2.0 - 1.0) * 1e-6 * (i % 7) as f32;
                let s0 = lo[0] + kx as f32 * cell + nudge(i % 3 - 1);
                let q0 = lo[1] + ky as f32 * cell + nudge(i % 5 - 2);
                let depth = ix.top() - 0.1 - 4.0 * r();
                let ray = Ray {
                    origin: ix.point(s0, q0, depth),
                    dir: axis,
                    tmax: f32::INFINITY,
                };
                let (Some(short), Some(general)) =
                    (ix.cells_of(&ray, true), ix.cells_of(&ray, false))
                else {
                    continue;
                };
                assert!(
                    short.1 || !general.1,
                    "{ray:?}: apart {short:?} {general:?}"
                );
                if let Some((gx, gy)) = general.0 {
                    let (sx, sy) = short.0.expect("cells where the general plan has some");
                    assert!(
                        sx[0] <= gx[0] && gx[1] <= sx[1] && sy[0] <= gy[0] && gy[1] <= sy[1],
                        "{kernel:?} {ray:?}: short {short:?} general {general:?}"
                    );
                    checked += 1;
                }
            }
            assert!(checked > 3000, "{checked}");
            // A direction one unit in the last place away is not the grid's own.
            let off = Vec3::from_array(axis.to_array().map(|c| f32::from_bits(c.to_bits() + 1)));
            let ray = Ray {
                origin: Vec3::splat(1.0),
                dir: off,
                tmax: f32::INFINITY,
            };
            assert!(!ix.takes_short_plan(&ray));
        }
    }
}

/// A close-up under a sun's disc (a few cards a hand wide over a ground to the horizon,
/// as `examples/pigment_leaves.toml`): a shadow ray from the ground drifts across several
/// cells that list the same packs, and the ground is listed in its cells and apart; each
/// pack is tested at most once per ray, alone and eight at a time, and the answers stay
/// the tree walk's.
#[test]
fn sun_grid_tests_each_pack_once_per_ray() {
    let f = |_: u32, uv: Vec2| matte(uv);
    let mut desc = SceneDesc::default();
    desc.world.prims.push(Prim::parallelogram(
        Vec3::new(-500.0, 0.0, 500.0),
        Vec3::new(1000.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -1000.0),
    ));
    for k in 0..3 {
        desc.world.prims.push(Prim::parallelogram(
            Vec3::new(-0.17 + 0.12 * k as f32, 0.02, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.0, 0.1, -0.03),
        ));
    }
    let ground = PrimRef {
        inst: NO_INSTANCE,
        prim: 0,
    };
    let axis = Vec3::new(0.3, 0.8, 0.45).normalize();
    let (u, v) = axis.any_orthonormal_pair();
    for (kernel, walk) in walks(&desc) {
        let mut grid = walk.clone();
        let packs = grid.index_direction(axis).expect("a grid").packs as u64;
        let mut r = rng(77);
        let (mut blocked, mut total) = (0, 0);
        for bundle in 0..400 {
            // A pixel's ground points under and around the cards, toward a 0.53° disc.
            let at = Vec3::new(r() * 0.6 - 0.35, 0.0, r() * 0.3 - 0.25);
            let mut rays = Vec::new();
            for _ in 0..8 {
                let phi = std::f32::consts::TAU * r();
                let rad = 0.0046 * r().sqrt();
                rays.push(Ray {
                    origin: at + Vec3::new(r(), 0.0, r()) * 2e-3,
                    dir: (axis + (u * phi.cos() + v * phi.sin()) * rad).normalize(),
                    tmax: f32::INFINITY,
                });
            }
            let skips = vec![ground; rays.len()];
            let many = TraversalStats::default();
            let mut got = vec![false; rays.len()];
            grid.occluded_many_counted(&rays, &skips, &f, &many, &mut got);
            assert!(
                many.packs.get() <= packs * rays.len() as u64,
                "{kernel:?} bundle {bundle}: {} pack tests for {} rays, {packs} packs",
                many.packs.get(),
                rays.len()
            );
            for (i, (ray, got)) in rays.iter().zip(&got).enumerate() {
                let one = TraversalStats::default();
                let want = walk.occluded(ray, ground, &f);
                assert_eq!(grid.occluded_counted(ray, ground, &f, &one), want);
                assert_eq!(*got, want, "{kernel:?} bundle {bundle} ray {i}: {ray:?}");
                assert!(
                    one.packs.get() <= packs && one.nodes.get() == 0,
                    "{kernel:?} bundle {bundle} ray {i}: {} packs, {} nodes of {packs}",
                    one.packs.get(),
                    one.nodes.get()
                );
                blocked += u32::from(want);
                total += 1;
            }
        }
        assert!(
            blocked * 20 > total && blocked * 2 < total,
            "{kernel:?}: {blocked} blocked of {total}"
        );
    }
}

/// [`Accel::occluded_many`] answers each ray exactly as [`Accel::occluded`] and the tree
/// walk do, for every kernel: bundles of shadow rays along a sun's axis (and in a 0.5°
/// cone around it) from points a pixel apart on one surface (tested together where they
/// run the same cells), from points spread over the scene (several groups), from free
/// space, some in any direction or with a `tmax`, each leaving its own primitive, in slices
/// of 1 to 13 rays; on the world level with and without a ground (listed apart) and a
/// crowded column (its cells keep the walk), and through instances (one by one).
#[test]
fn occluded_many_answers_as_occluded() {
    let f = |_: u32, uv: Vec2| matte(uv);
    // Spheres leave every ray to the one-ray query: the third scene keeps its sphere.
    for (s, instances, ground, sphere) in [
        (21, false, false, false),
        (22, false, true, false),
        (23, true, true, true),
    ] {
        let mut desc = grid_scene(s, instances, ground, Vec3::Y);
        if !sphere {
            desc.spheres.clear();
        }
        for (kernel, walk) in walks(&desc) {
            let mut r = rng(s * 7 + 3);
            let axis = Vec3::new(0.35, 0.85, 0.25).normalize();
            let (u, v) = axis.any_orthonormal_pair();
            let mut grid = walk.clone();
            grid.index_direction(axis).expect("a grid");
            let stats = TraversalStats::default();
            let (mut blocked, mut total, mut from_surfaces) = (0, 0, 0);
            for bundle in 0..300 {
                let n = 1 + bundle % 13;
                // A pixel's points on one surface, or points spread over the scene: where
                // probes from one point in nearly the same or in any direction land.
                let spread = if bundle % 4 == 3 { 1.0 } else { 2e-3 };
                let mut aim = || (Vec3::new(r(), r(), r()) * 5.0 - 0.5, unit(&mut r));
                let (mut eye, mut look) = aim();
                for _ in 0..100 {
                    let probe = Ray {
                        origin: eye,
                        dir: look,
                        tmax: f32::INFINITY,
                    };
                    if walk.intersect(&probe, PrimRef::NONE, &f).is_some() {
                        break;
                    }
                    (eye, look) = aim();
                }
                let mut rays = Vec::with_capacity(n);
                let mut skips = Vec::with_capacity(n);
                for i in 0..n {
                    let jitter = Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * spread;
                    let probe = Ray {
                        origin: eye,
                        dir: (look + jitter).normalize(),
                        tmax: f32::INFINITY,
                    };
                    let (mut origin, mut skip) = (eye + jitter, PrimRef::NONE);
                    if (bundle + i) % 11 != 7
                        && let Some(h) = walk
                            .intersect(&probe, PrimRef::NONE, &f)
                            .filter(|h| h.prim.inst != SPHERE)
                    {
                        origin = probe.origin + probe.dir * h.t;
                        skip = h.prim;
                        from_surfaces += 1;
                    }
                    let dir = match (bundle + 3 * i) % 9 {
                        0 => unit(&mut r),
                        1 | 2 => {
                            let phi = std::f32::consts::TAU * r();
                            let rad = 0.0046 * r().sqrt();
                            (axis + (u * phi.cos() + v * phi.sin()) * rad).normalize()
                        }
                        _ => axis,
                    };
                    let tmax = if (bundle + i) % 5 == 0 {
                        0.3 + 3.0 * r()
                    } else {
                        f32::INFINITY
                    };
                    rays.push(Ray { origin, dir, tmax });
                    skips.push(skip);
                }
                let mut got = vec![false; n];
                grid.occluded_many(&rays, &skips, &f, &mut got);
                let mut counted = vec![false; n];
                grid.occluded_many_counted(&rays, &skips, &f, &stats, &mut counted);
                assert_eq!(counted, got);
                for (i, ((ray, skip), got)) in rays.iter().zip(&skips).zip(&got).enumerate() {
                    let want = walk.occluded(ray, *skip, &f);
                    assert_eq!(
                        *got, want,
                        "{kernel:?} bundle {bundle} ray {i}: {ray:?} skip {skip:?}"
                    );
                    assert_eq!(*got, grid.occluded(ray, *skip, &f));
                    blocked += u32::from(want);
                    total += 1;
                }
            }
            assert!(
                blocked * 20 > total && blocked * 5 < total * 4 && from_surfaces * 2 > total,
                "{kernel:?}: {blocked} blocked of {total}, {from_surfaces} from surfaces"
            );
            // The masks decided hits both ways and left some to the exact matte.
            let (o, t, a) = (
                stats.mask_opaque.get(),
                stats.mask_transparent.get(),
                stats.alpha_lookups.get(),
            );
            assert!(
                o > 0 && t > 0 && a > 0,
                "{kernel:?}: {o} opaque, {t} transparent, {a} exact"
            );
        }
    }
}

#[test]
fn direction_grid_is_refused_without_a_direction_or_geometry() {
    let mut a = Accel::build(&scene(5, true)).unwrap();
    assert!(a.index_direction(Vec3::ZERO).is_none());
    assert!(a.index_direction(Vec3::new(f32::NAN, 1.0, 0.0)).is_none());
    assert!(a.directions().is_empty());
    let mut empty = Accel::build(&SceneDesc::default()).unwrap();
    assert!(empty.index_direction(Vec3::Y).is_none());
    // Spheres only: no packs, no grid, and occlusion still sees the sphere.
    let mut spheres = Accel::build(&SceneDesc {
        spheres: vec![Sphere {
            center: Vec3::new(0.0, 2.0, 0.0),
            radius: 0.5,
        }],
        ..Default::default()
    })
    .unwrap();
    assert!(spheres.index_direction(Vec3::Y).is_none());
    let up = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::Y,
        tmax: f32::INFINITY,
    };
    assert!(spheres.occluded(&up, PrimRef::NONE, &|_, _| true));
}

/// The grid from a camera's eye ([`Accel::index_view`]) finds the walk's closest hit for
/// every kernel: rays from the eye inside and outside the picture window, with and
/// without `tmax`, on the world level and through instances, with a ground crossing the
/// eye's plane and a column of cards too crowded for a cell's list; rays from elsewhere
/// keep the walk.
#[test]
fn view_grid_finds_the_walks_hits() {
    let f = |_: u32, uv: Vec2| matte(uv);
    for (s, instances, ground) in [(7, false, false), (8, true, false), (9, true, true)] {
        let desc = grid_scene(s, instances, ground, Vec3::Z);
        for (kernel, walk) in walks(&desc) {
            let mut r = rng(s * 17 + 3);
            // Eyes outside the scene looking in, and inside it.
            let eyes = [
                (Vec3::new(2.0, 2.0, 9.0), Vec3::new(-0.1, -0.1, -1.0)),
                (Vec3::new(1.6, 1.55, 6.0), Vec3::new(0.0, 0.0, -1.0)),
                (Vec3::new(2.0, 1.0, 2.0), unit(&mut r)),
            ];
            let window = [-0.6, 0.6, -0.45, 0.45];
            for (eye, fwd) in eyes {
                let mut grid = walk.clone();
                // An eye inside the geometry may cut too many primitives with its plane
                // for a grid; then queries keep the walk.
                let st = grid.index_view(eye, fwd, Vec3::Y, window);
                assert!(st.is_some() || eye == eyes[2].0, "a grid for eyes outside");
                assert_eq!(grid.view_grid(), st);
                let bytes = st.map_or(0, |st| st.bytes);
                assert_eq!(grid.memory().total(), walk.memory().total() + bytes);
                let f3 = fwd.normalize();
                let right = f3.cross(Vec3::Y).normalize();
                let up = right.cross(f3);
                let (mut served, mut inside, mut hits) = (0, 0, 0);
                for i in 0..3000 {
                    // Mostly inside the window, some just outside it.
                    let (x, y) = (1.3 * r() - 0.65, 1.0 * r() - 0.5);
                    let ray = Ray {
                        origin: if i % 10 == 9 {
                            eye + Vec3::X * 1e-3
                        } else {
                            eye
                        },
                        dir: (f3 + right * x + up * y) * if i % 5 == 0 { 2.0 } else { 1.0 },
                        tmax: if i % 3 == 0 {
                            1.0 + 6.0 * r()
                        } else {
                            f32::INFINITY
                        },
                    };
                    let stats = TraversalStats::default();
                    let want = walk.intersect(&ray, PrimRef::NONE, &f);
                    let got = grid.intersect_counted(&ray, PrimRef::NONE, &f, &stats);
                    assert_eq!(got, want, "{kernel:?} eye {eye} ray {i}: {ray:?}");
                    hits += want.is_some() as u32;
                    let in_window = x.abs() < 0.59 && y.abs() < 0.44 && i % 10 != 9;
                    if in_window {
                        inside += 1;
                        // A ray the grid serves walks no tree node.
                        if stats.nodes.get() == 0 && stats.instances.get() == 0 {
                            served += 1;
                        }
                    }
                }
                assert!(hits > 100, "{kernel:?} eye {eye}: {hits} hits");
                // All but the few under the crowded column.
                assert!(
                    st.is_none() || served * 50 >= inside * 49,
                    "{kernel:?} eye {eye}: {served} of {inside} served"
                );
            }
        }
    }
}

/// The frame of an eye looking along `fwd` (up +y): unit forward, right and up.
fn eye_frame(fwd: Vec3) -> (Vec3, Vec3, Vec3) {
    let f3 = fwd.normalize();
    let right = f3.cross(Vec3::Y).normalize();
    (f3, right, right.cross(f3))
}

/// Where bundle `bundle` of camera rays points in the picture (tangents right and up) and
/// how far its rays spread: mostly over the scene, one in ten past the window's edge; a
/// pixel's spread, one in four a wide one.
fn bundle_spot(bundle: usize, r: &mut impl FnMut() -> f32) -> (f32, f32, f32) {
    let (cx, cy) = if bundle % 10 == 9 {
        (1.3 * r() - 0.65, 1.0 * r() - 0.5)
    } else {
        (0.5 * r() - 0.25, 0.5 * r() - 0.25)
    };
    (cx, cy, if bundle % 4 == 3 { 0.2 } else { 2e-3 })
}

/// [`Accel::intersect_eye`] answers each ray from the eye exactly as [`Accel::intersect`]
/// does, for every kernel: lane arrays of 1 to 16 directions (one or two groups of eight,
/// the second partial) through one small patch of the picture or spread over it, some
/// past the window's edge; with the grid at that eye, with a grid at another eye (never
/// used), and without a grid; on the world level with and without a ground crossing the
/// eye's plane and a crowded column, with a sphere in view, and through instances.
#[test]
fn intersect_eye_answers_as_intersect() {
    let f = |_: u32, uv: Vec2| matte(uv);
    let (eye, fwd) = (Vec3::new(1.6, 1.55, 6.0), Vec3::new(0.02, -0.01, -1.0));
    let window = [-0.6, 0.6, -0.45, 0.45];
    for (s, instances, ground, sphere) in [
        (21, false, false, false),
        (22, false, true, false),
        (23, false, false, true),
        (24, true, false, false),
    ] {
        let mut desc = grid_scene(s, instances, ground, Vec3::Z);
        if sphere {
            desc.spheres.push(Sphere {
                center: Vec3::new(1.2, 1.2, 2.0),
                radius: 0.4,
            });
        }
        for (kernel, walk) in walks(&desc) {
            let mut here = walk.clone();
            assert!(here.index_view(eye, fwd, Vec3::Y, window).is_some());
            let mut elsewhere = walk.clone();
            assert!(
                elsewhere
                    .index_view(eye + Vec3::X * 1e-3, fwd, Vec3::Y, window)
                    .is_some()
            );
            let mut r = rng(s * 7 + 3);
            let (f3, right, up) = eye_frame(fwd);
            let (mut hits, mut total) = (0, 0);
            for bundle in 0..300 {
                let (cx, cy, spread) = bundle_spot(bundle, &mut r);
                let n = 1 + bundle % 16;
                let mut d = [vec![0.0f32; n], vec![0.0f32; n], vec![0.0f32; n]];
                for k in 0..n {
                    let (x, y) = (cx + spread * (r() - 0.5), cy + spread * (r() - 0.5));
                    let v = (f3 + right * x + up * y).normalize();
                    for a in 0..3 {
                        d[a][k] = v[a];
                    }
                }
                let lanes = [&d[0][..], &d[1][..], &d[2][..]];
                for (which, accel) in [("grid", &here), ("other eye", &elsewhere), ("walk", &walk)]
                {
                    let mut got = vec![None; n];
                    accel.intersect_eye(eye, lanes, &f, &mut got);
                    for (k, got) in got.iter().enumerate() {
                        let ray = Ray::from_eye_lane(eye, lanes, k);
                        let want = walk.intersect(&ray, PrimRef::NONE, &f);
                        assert_eq!(*got, want, "{kernel:?} {which} bundle {bundle} ray {k}");
                        hits += want.is_some() as u32;
                        total += 1;
                    }
                }
            }
            assert!(hits * 5 > total, "{kernel:?}: {hits} hits of {total}");
        }
    }
}

/// [`Accel::intersect_many`] answers each ray exactly as [`Accel::intersect`] does, for
/// every kernel: bundles of rays from a pinhole's eye through one small patch of the
/// picture (tested together where they cross the same cells), spread over it (several
/// groups), some from just off the eye or outside the window, with and without `tmax`,
/// in slices of 1 to 13 rays; on the world level with and without a ground crossing the
/// eye's plane (tested by every ray) and a crowded column (its cells keep the walk), and
/// through instances (no packets: one by one).
#[test]
fn intersect_many_answers_as_intersect() {
    let f = |_: u32, uv: Vec2| matte(uv);
    for (s, instances, ground) in [(11, false, false), (12, false, true), (13, true, false)] {
        let desc = grid_scene(s, instances, ground, Vec3::Z);
        for (kernel, walk) in walks(&desc) {
            let mut r = rng(s * 13 + 1);
            let (eye, fwd) = (Vec3::new(1.6, 1.55, 6.0), Vec3::new(0.02, -0.01, -1.0));
            let mut grid = walk.clone();
            assert!(
                grid.index_view(eye, fwd, Vec3::Y, [-0.6, 0.6, -0.45, 0.45])
                    .is_some()
            );
            let (f3, right, up) = eye_frame(fwd);
            let (mut hits, mut rays_total) = (0, 0);
            let stats = TraversalStats::default();
            for bundle in 0..400 {
                let (cx, cy, spread) = bundle_spot(bundle, &mut r);
                let n = 1 + bundle % 13;
                let rays: Vec<Ray> = (0..n)
                    .map(|i| {
                        let (x, y) = (cx + spread * (r() - 0.5), cy + spread * (r() - 0.5));
                        Ray {
                            origin: if (bundle + i) % 17 == 5 {
                                eye + Vec3::X * 1e-3
                            } else {
                                eye
                            },
                            dir: f3 + right * x + up * y,
                            tmax: if bundle % 3 == 0 {
                                1.0 + 8.0 * r()
                            } else {
                                f32::INFINITY
                            },
                        }
                    })
                    .collect();
                let mut got = vec![None; n];
                grid.intersect_many(&rays, &f, &mut got);
                let mut counted = vec![None; n];
                grid.intersect_many_counted(&rays, &f, &stats, &mut counted);
                assert_eq!(counted, got);
                for (i, (ray, got)) in rays.iter().zip(&got).enumerate() {
                    let want = walk.intersect(ray, PrimRef::NONE, &f);
                    assert_eq!(*got, want, "{kernel:?} bundle {bundle} ray {i}: {ray:?}");
                    assert_eq!(*got, grid.intersect(ray, PrimRef::NONE, &f));
                    hits += want.is_some() as u32;
                    rays_total += 1;
                }
            }
            assert!(
                hits * 5 > rays_total,
                "{kernel:?}: {hits} hits of {rays_total}"
            );
            // The masks decided hits both ways and left some to the exact matte (the rays
            // that one answers ray by ray).
            let (o, t, a) = (
                stats.mask_opaque.get(),
                stats.mask_transparent.get(),
                stats.alpha_lookups.get(),
            );
            assert!(
                o > 0 && t > 0 && a > 0,
                "{kernel:?}: {o} opaque, {t} transparent, {a} exact"
            );
        }
    }
}

/// A `MW x MW` matte opaque in texels 6..=9 across and 3..=12 down: a narrow leaf with
/// wide transparent margins, for the trimmed boxes (`trim.rs`).
fn narrow_texel(x: i64, y: i64) -> f32 {
    let (x, y) = (x.clamp(0, MW - 1), y.clamp(0, MW - 1));
    f32::from((6..=9).contains(&x) && (3..=12).contains(&y))
}

/// Adds the narrow matte (id 1) to `desc` and gives it to every other masked primitive,
/// and every fifth masked primitive texture coordinates turned and scaled.
fn narrow_mattes(desc: &mut SceneDesc) {
    desc.masks.push(OpacityMask::from_texels(
        MW as u32,
        MW as u32,
        MaskWrap::Clamp,
        0.5,
        narrow_texel,
    ));
    let geoms = std::iter::once(&mut desc.world).chain(desc.prototypes.iter_mut());
    let alphas = geoms.flat_map(|g| g.prims.iter_mut().filter_map(|p| p.alpha.as_mut()));
    for (k, al) in alphas.enumerate() {
        if k % 2 == 1 {
            al.id = 1;
        }
        if k % 5 == 4 {
            al.uv = [
                Vec2::new(1.0, 0.2),
                Vec2::new(0.1, 0.1),
                Vec2::new(0.9, 1.0),
            ];
        }
    }
}

/// Boxes and grids over only the live part of masked primitives (`trim_masked`, the
/// default) answer every query exactly as boxes over whole primitives do, for every
/// kernel, with the sun's and the eye's grids: rays aimed at random points of random cards
/// and triangles (margins, live parts and the edges between), grazing ones nearly in a
/// card's plane, and rays in any direction; closest hits (distance, primitive, instance,
/// barycentrics) and occlusion, on the world level and through instances. And the trimmed
/// tree is smaller: fewer pack tests per ray.
#[test]
fn trimmed_boxes_answer_as_whole_ones() {
    let f = |id: u32, uv: Vec2| {
        if id == 0 {
            matte(uv)
        } else {
            bilinear(narrow_texel, uv)
        }
    };
    for (s, instances) in [(21, false), (22, true)] {
        let mut desc = scene(s, instances);
        narrow_mattes(&mut desc);
        let targets: Vec<(Vec3, Vec3, Vec3)> = desc
            .world
            .prims
            .iter()
            .filter(|p| p.is_valid())
            .map(|p| (p.v[0], p.v[1] - p.v[0], p.v[2] - p.v[0]))
            .collect();
        for kernel in kernels() {
            let build = |trim_masked| {
                let opts = BuildOptions {
                    kernel,
                    trim_masked,
                    ..Default::default()
                };
                let mut a = Accel::build_with(&desc, opts).unwrap();
                a.index_direction(Vec3::new(0.3, 0.8, 0.2));
                a.index_view(
                    Vec3::new(2.0, 2.0, 9.0),
                    Vec3::new(-0.1, -0.1, -1.0),
                    Vec3::Y,
                    [-0.6, 0.6, -0.45, 0.45],
                );
                a
            };
            let (trim, whole) = (build(true), build(false));
            // Hits name instances in each top level's order: compare scene instances.
            let (ot, ow) = (trim.scene_instances(&desc), whole.scene_instances(&desc));
            let named = |h: Option<Hit>, order: &[u32]| {
                h.map(|mut h| {
                    if h.prim.inst != NO_INSTANCE && h.prim.inst != SPHERE {
                        h.prim.inst = order[h.prim.inst as usize];
                    }
                    h
                })
            };
            let mut r = rng(s * 7 + 1);
            let (st_trim, st_whole) = (TraversalStats::default(), TraversalStats::default());
            let mut hits = 0;
            for i in 0..6000 {
                let (v0, e1, e2) = targets[(r() * targets.len() as f32) as usize % targets.len()];
                let at = v0 + e1 * (1.1 * r() - 0.05) + e2 * (1.1 * r() - 0.05);
                let n = e1.cross(e2).normalize();
                let ray = match i % 4 {
                    // Toward the sun, from the eye, from anywhere, grazing.
                    0 => {
                        // Toward the sun through the target: what its grid answers.
                        let d = Vec3::new(0.3, 0.8, 0.2) + unit(&mut r) * 0.01;
                        Ray {
                            origin: at - d * 3.0,
                            dir: d,
                            tmax: f32::INFINITY,
                        }
                    }
                    1 => {
                        let eye = Vec3::new(2.0, 2.0, 9.0);
                        Ray {
                            origin: eye,
                            dir: at - eye,
                            tmax: f32::INFINITY,
                        }
                    }
                    2 => {
                        let o = Vec3::new(r(), r(), r()) * 5.0 - 0.5;
                        Ray {
                            origin: o,
                            dir: (at - o) * 0.5,
                            tmax: if i % 3 == 0 { 1.0 + r() } else { f32::INFINITY },
                        }
                    }
                    _ => {
                        let along = (e1 * (r() - 0.5) + e2 * (r() - 0.5)).normalize();
                        let d = along + n * (r() - 0.5) * 1e-3;
                        Ray {
                            origin: at - d * 0.3,
                            dir: d,
                            tmax: f32::INFINITY,
                        }
                    }
                };
                let want = named(
                    whole.intersect_counted(&ray, PrimRef::NONE, &f, &st_whole),
                    &ow,
                );
                let got = named(
                    trim.intersect_counted(&ray, PrimRef::NONE, &f, &st_trim),
                    &ot,
                );
                assert_eq!(got, want, "{kernel:?} scene {s} ray {i}: {ray:?}");
                hits += want.is_some() as u32;
                assert_eq!(
                    trim.occluded(&ray, PrimRef::NONE, &f),
                    whole.occluded(&ray, PrimRef::NONE, &f),
                    "{kernel:?} scene {s} ray {i}: {ray:?}"
                );
                let mut many = [None; 1];
                trim.intersect_many(&[ray], &f, &mut many);
                assert_eq!(
                    named(many[0], &ot),
                    want,
                    "{kernel:?} scene {s} ray {i} (many)"
                );
                // Skipping the hit, from it (each named in its own structure's order).
                let (ht, hw) = (
                    trim.intersect(&ray, PrimRef::NONE, &f),
                    whole.intersect(&ray, PrimRef::NONE, &f),
                );
                let off_sphere = |h: &Hit| h.prim.inst != SPHERE;
                if let (Some(ht), Some(hw)) = (ht.filter(off_sphere), hw.filter(off_sphere)) {
                    let cont = Ray {
                        origin: ray.origin + ray.dir * hw.t,
                        tmax: f32::INFINITY,
                        ..ray
                    };
                    assert_eq!(
                        named(trim.intersect(&cont, ht.prim, &f), &ot),
                        named(whole.intersect(&cont, hw.prim, &f), &ow),
                        "{kernel:?} scene {s} ray {i} (continued)"
                    );
                    assert_eq!(
                        trim.occluded(&cont, ht.prim, &f),
                        whole.occluded(&cont, hw.prim, &f)
                    );
                }
            }
            assert!(hits > 1000, "{kernel:?} scene {s}: {hits} hits");
            assert!(
                st_trim.packs.get() < st_whole.packs.get(),
                "{kernel:?} scene {s}: {} pack tests trimmed vs {} whole",
                st_trim.packs.get(),
                st_whole.packs.get()
            );
        }
    }
}

/// The grids' outline of a masked card (`grid::placed_corners` with trimming) is a
/// sub-card holding every point of the card whose mask cell is not transparent: over a
/// fine lattice of each card of the world level (identity and turned uv, both mattes), the
/// points the mask does not reject lie inside; and the outlines are cut (the grids gain).
#[test]
fn grid_outlines_of_masked_cards_hold_their_live_points() {
    fn check<const W: usize>(lv: &crate::traverse::Levels<W>) -> (usize, usize) {
        let (mut cut, mut checked) = (0, 0);
        for pack in 0..lv.world.packs.len() as u32 {
            let r = crate::grid::PackRef {
                inst: NO_INSTANCE,
                pack,
            };
            let p = &lv.world.packs[pack as usize];
            let corners = crate::grid::placed_corners(lv, &[], r);
            let used = (0..4).filter(|&l| p.id[l] != u32::MAX);
            for (l, (n, c)) in used.zip(corners) {
                if n != 4 || p.flags[l] & crate::layout::ALPHA == 0 {
                    continue;
                }
                let g =
                    |a: &[[f32; 4]; 3]| DVec3::new(a[0][l] as f64, a[1][l] as f64, a[2][l] as f64);
                let (v0, e1, e2) = (g(&p.v0), g(&p.e1), g(&p.e2));
                // The outline's corners in the card's own (b1, b2), by least squares.
                let (a, b, d) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
                let coords = |q: DVec3| {
                    let (x, y) = ((q - v0).dot(e1), (q - v0).dot(e2));
                    let det = a * d - b * b;
                    ((x * d - y * b) / det, (y * a - x * b) / det)
                };
                let (lo, hi) = (coords(c[0].as_dvec3()), coords(c[2].as_dvec3()));
                if lo.0 > 1e-3 || lo.1 > 1e-3 || hi.0 < 1.0 - 1e-3 || hi.1 < 1.0 - 1e-3 {
                    cut += 1;
                }
                for i in 0..=64 {
                    for j in 0..=64 {
                        let (b1, b2) = (i as f32 / 64.0, j as f32 / 64.0);
                        let state =
                            crate::traverse::mask_state(&lv.world, &lv.masks, p.flags[l], b1, b2).2;
                        if state == crate::mask::TRANSPARENT {
                            continue;
                        }
                        checked += 1;
                        let (b1, b2) = (b1 as f64, b2 as f64);
                        assert!(
                            b1 >= lo.0 - 1e-5
                                && b1 <= hi.0 + 1e-5
                                && b2 >= lo.1 - 1e-5
                                && b2 <= hi.1 + 1e-5,
                            "pack {pack} lane {l}: live point ({b1}, {b2}) outside {lo:?}-{hi:?}"
                        );
                    }
                }
            }
        }
        (cut, checked)
    }
    let mut desc = scene(23, false);
    narrow_mattes(&mut desc);
    for (kernel, a) in walks(&desc) {
        let (cut, checked) = match &a.engine {
            Engine::W8(l) => check(l),
            Engine::W4(l) => check(l),
        };
        assert!(
            cut > 50 && checked > 10000,
            "{kernel:?}: {cut} cut, {checked} points"
        );
    }
}

/// A masked primitive's box in the tree (`trim::live_bounds`) holds every point of it the
/// mask does not reject: over a fine lattice of each card and triangle of the world level
/// and the prototypes (identity and turned uv, both mattes); and the boxes are cut.
#[test]
fn tree_boxes_of_masked_primitives_hold_their_live_points() {
    let mut desc = scene(24, true);
    narrow_mattes(&mut desc);
    let live = crate::trim::live_uvs(&desc.masks);
    let f = |id: u32, uv: Vec2| {
        if id == 0 {
            matte(uv)
        } else {
            bilinear(narrow_texel, uv)
        }
    };
    let (mut cut, mut checked) = (0, 0);
    let geoms = std::iter::once(&desc.world).chain(&desc.prototypes);
    for p in geoms.flat_map(|g| &g.prims).filter(|p| p.is_valid()) {
        let Some(al) = p.alpha else { continue };
        let mask = desc.masks[al.id as usize].as_ref().unwrap();
        let b = crate::trim::live_bounds(p, &live);
        let whole = crate::layout::prim_bounds(p);
        if b.min != whole.min || b.max != whole.max {
            cut += 1;
        }
        for i in 0..=64 {
            for j in 0..=64 {
                let (b1, b2) = (i as f32 / 64.0, j as f32 / 64.0);
                if !p.quad && b1 + b2 > 1.0 {
                    continue;
                }
                let uv = al.uv[0] * (1.0 - b1 - b2) + al.uv[1] * b1 + al.uv[2] * b2;
                if mask.classify(uv) == crate::mask::TRANSPARENT {
                    continue;
                }
                // The exact matte agrees with the mask where the mask decides.
                assert!(mask.classify(uv) != crate::mask::OPAQUE || f(al.id, uv));
                checked += 1;
                let q = p.v[0] + (p.v[1] - p.v[0]) * b1 + (p.v[2] - p.v[0]) * b2;
                let slack = (p.v[1] - p.v[0]).length().max((p.v[2] - p.v[0]).length()) * 1e-5;
                assert!(
                    q.cmpge(b.min - slack).all() && q.cmple(b.max + slack).all(),
                    "live point {q} (b {b1}, {b2}, uv {uv}) outside {b:?}"
                );
            }
        }
    }
    assert!(cut > 100 && checked > 50000, "{cut} cut, {checked} points");
}
