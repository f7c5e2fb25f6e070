//! Tests of [`Accel`]'s own API beyond the [`super::Backend`] trait, each kept as it was
//! written: card merging, the matte's cell table, negative-zero directions, instanced
//! against flattened geometry (closest hit, any hit, surface frames, shading normals, UV
//! tangents, continuation rays) and build errors and memory.

use super::super::alpha::AlphaTest;
use super::super::prims::parallelogram;
use crate::accel::{Accel, Hit, HitKind, Ray};
use crate::tests::scenes::*;
use glam::{Affine3A, Vec2, Vec3, Vec4};
use lamina_core::{AlphaMask, ColorInput, Instance, Material, Mesh, Prototype};
use lamina_leaf::{Texture, Wrap};

#[test]
fn cards_become_parallelograms() {
    let p = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 2.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
        Vec3::new(1.5, 2.0, 0.0), // makes a trapezoid with 0, 1, 2
    ];
    let uv = [Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y, Vec2::ONE];
    let pos = |i: u32| p[i as usize];
    let tex = |i: u32| uv[i as usize];
    // Diagonal 0-2, both rotations of the second triangle.
    assert_eq!(
        parallelogram([0, 1, 2], [0, 2, 3], &pos, &tex),
        Some([0, 1, 3])
    );
    assert_eq!(
        parallelogram([0, 1, 2], [2, 3, 0], &pos, &tex),
        Some([0, 1, 3])
    );
    // Diagonal 1-3.
    assert_eq!(
        parallelogram([0, 1, 3], [1, 2, 3], &pos, &tex),
        Some([0, 1, 3])
    );
    // Not a parallelogram, opposite winding, unrelated triangles.
    assert_eq!(parallelogram([0, 1, 4], [0, 4, 3], &pos, &tex), None);
    assert_eq!(parallelogram([0, 1, 2], [0, 3, 2], &pos, &tex), None);
    assert_eq!(parallelogram([0, 1, 2], [1, 2, 4], &pos, &tex), None);
    // Non-affine texture coordinates.
    let bent = |i: u32| {
        if i == 3 {
            Vec2::new(0.2, 1.0)
        } else {
            uv[i as usize]
        }
    };
    assert_eq!(parallelogram([0, 1, 2], [0, 2, 3], &pos, &bent), None);
}

/// The opacity mask built from a matte agrees with the filtered lookup wherever it decides
/// (opaque or transparent cells), for both wrap modes, both channels, inside and outside
/// `[0, 1]`, and decides most of them.
#[test]
fn mask_cells_agree_with_filtered_lookup() {
    let (w, h) = (7u32, 5u32);
    let texels: Vec<Vec4> = (0..w * h)
        .map(|i| {
            let v = ((i * 37 + 11) % 10) as f32 / 9.0;
            Vec4::new(v, 0.0, 0.0, 1.0 - v)
        })
        .collect();
    for wrap in [Wrap::Repeat, Wrap::Clamp] {
        for use_alpha_channel in [false, true] {
            let mask = AlphaMask {
                map: Texture::from_texels(w, h, texels.clone(), wrap),
                use_alpha_channel,
                cutoff: 0.5,
            };
            let test = AlphaTest::of_mask(&mask);
            // A matte too large for its channel's copy reads the texture: the same test.
            let uncopied = AlphaTest::matte(&mask.map, use_alpha_channel, mask.cutoff, 0);
            let cells = test.mask().unwrap();
            let mut decided = 0;
            for i in 0..4000 {
                let uv = Vec2::new(
                    i as f32 / 4000.0 * 1.6 - 0.3,
                    ((i * 7919) % 4000) as f32 / 4000.0 * 1.6 - 0.3,
                );
                assert_eq!(test.opaque(uv), mask.opaque(uv), "{wrap:?} {uv}");
                assert_eq!(uncopied.opaque(uv), mask.opaque(uv), "{wrap:?} {uv}");
                match cells.classify(uv) {
                    lamina_accel::mask::OPAQUE => assert!(mask.opaque(uv), "{wrap:?} {uv}"),
                    lamina_accel::mask::TRANSPARENT => assert!(!mask.opaque(uv), "{wrap:?} {uv}"),
                    _ => continue,
                }
                decided += 1;
            }
            assert!(decided > 200, "{decided} of 4000 decided by the mask");
        }
    }
}

/// A leaf's alpha test is [`lamina_leaf::LeafMaterial::opaque`] bit for bit (its matte's
/// alpha channel where the map has one, else the grey value, at 0.5), through the
/// channel the test keeps on its own and, for a matte too large for that copy, through
/// the texture, for both wrap modes, inside and outside `[0, 1]`; a leaf without an
/// alpha map has no test.
#[test]
fn a_leaf_alpha_test_is_the_leaf_material_own() {
    use lamina_leaf::{LeafMaps, LeafMaterial, LeafParams};
    let (w, h) = (9u32, 6u32);
    for (wrap, with_alpha) in [
        (Wrap::Repeat, false),
        (Wrap::Clamp, true),
        (Wrap::Clamp, false),
    ] {
        let texels: Vec<Vec4> = (0..w * h)
            .map(|i| {
                let v = ((i * 37 + 11) % 10) as f32 / 9.0;
                let a = ((i * 13 + 5) % 10) as f32 / 9.0;
                Vec4::new(v, v, v, if with_alpha { a } else { 1.0 })
            })
            .collect();
        let maps = LeafMaps {
            alpha: Some(Texture::from_texels(w, h, texels, wrap)),
            ..Default::default()
        };
        let leaf = LeafMaterial::new(maps, LeafParams::default()).unwrap();
        let test = AlphaTest::of_leaf(&leaf);
        assert!(test.is_some());
        let (map, alpha) = leaf.matte().unwrap();
        let uncopied = AlphaTest::matte(map, alpha, 0.5, 0);
        let (mut opaque, n) = (0, 4000);
        for i in 0..n {
            let uv = Vec2::new(
                i as f32 / n as f32 * 1.6 - 0.3,
                ((i * 7919) % n) as f32 / n as f32 * 1.6 - 0.3,
            );
            let want = leaf.opaque(uv);
            assert_eq!(test.opaque(uv), want, "{wrap:?} {with_alpha} {uv}");
            assert_eq!(uncopied.opaque(uv), want, "{wrap:?} {with_alpha} {uv}");
            opaque += leaf.opaque(uv) as usize;
        }
        assert!(
            (n / 5..n * 4 / 5).contains(&opaque),
            "{opaque} of {n} opaque"
        );
    }
    let bare = LeafMaterial::new(LeafMaps::default(), LeafParams::default()).unwrap();
    assert!(!AlphaTest::of_leaf(&bare).is_some());
}

/// Directions with negative zeros (`-Vec3::Z` is `(-0, -0, -1)`) hit what the same
/// direction with positive zeros hits (obvhs, the engine before lamina-accel, derived the octant and the inverse direction
/// differently for `-0`, which made such rays miss half of a sphere.
#[test]
fn negative_zero_directions_hit() {
    let scene = sphere_scene(uv_sphere(Vec3::ZERO, 1.0, 12, 24, true, 0), vec![], None);
    let a = Accel::build(&scene).unwrap();
    for x in [-0.9f32, -0.5, 0.0, 0.5] {
        for (o, d, plus) in [
            (Vec3::new(x, 0.13, 5.0), -Vec3::Z, Vec3::new(0.0, 0.0, -1.0)),
            (Vec3::new(5.0, 0.13, x), -Vec3::X, Vec3::new(-1.0, 0.0, 0.0)),
        ] {
            let ray = |dir| Ray {
                origin: o,
                dir,
                tmax: f32::INFINITY,
            };
            let (h, h_plus) = (a.intersect(&ray(d)), a.intersect(&ray(plus)));
            let (h, h_plus) = (
                h.expect("the -0 ray hits"),
                h_plus.expect("the +0 ray hits"),
            );
            // The same point: on an edge the two may name either of its triangles.
            assert!(
                (h.t - h_plus.t).abs() <= 1e-5 * h.t,
                "{o} {d}: {h:?} {h_plus:?}"
            );
            let point = |h: Hit| match h.kind {
                HitKind::Triangle { prim, bary } => a.surface(prim, bary).0,
                HitKind::Sphere { .. } => unreachable!(),
            };
            assert!(
                point(h).distance(point(h_plus)) < 1e-5,
                "{o} {d}: {h:?} {h_plus:?}"
            );
            assert!(a.occluded(&ray(d)));
        }
    }
}

/// Instanced geometry answers every query like the same geometry flattened into world
/// space: closest hit (distance, position, adaxial normal, dP/du, uv, material) and any-hit,
/// through rotations, non-uniform scale and a mirror. Rays that graze an edge may differ by
/// rounding, so a few disagreements (< 1 %) are allowed, never a wrong frame.
#[test]
fn instanced_queries_match_flattened_geometry() {
    let (inst, flat) = instanced_and_flat(&test_transforms());
    let (a, b) = (Accel::build(&inst).unwrap(), Accel::build(&flat).unwrap());
    assert_eq!(a.instance_count(), 3);
    let (mut n, mut hits, mut disagree) = (0, 0, 0);
    for i in 0..4000u32 {
        let s = crate::sampler::sobol_2d(i, 3);
        let q = crate::sampler::sobol_2d(i, 4);
        let origin = Vec3::new(s.x * 4.0 - 2.0, s.y * 4.0 - 2.0, 3.0);
        let target = Vec3::new(q.x * 3.0 - 1.5, q.y * 3.0 - 1.5, (q.x - q.y) * 2.0 - 1.0);
        let ray = Ray {
            origin,
            dir: (target - origin).normalize(),
            tmax: f32::INFINITY,
        };
        n += 1;
        let (ha, hb) = (a.intersect(&ray), b.intersect(&ray));
        assert_eq!(a.occluded(&ray), ha.is_some());
        match (ha, hb) {
            (None, None) => {}
            (Some(ha), Some(hb)) if (ha.t - hb.t).abs() < 1e-4 * hb.t => {
                hits += 1;
                let (
                    HitKind::Triangle { prim: pa, bary: ba },
                    HitKind::Triangle { prim: pb, bary: bb },
                ) = (ha.kind, hb.kind)
                else {
                    assert_eq!(ha.kind, hb.kind, "both hit the same sphere light");
                    continue;
                };
                let (xa, ia) = a.surface(pa, ba);
                let (xb, ib) = b.surface(pb, bb);
                assert!((xa - xb).length() < 1e-4, "position {xa} vs {xb}");
                assert!(ia.n.dot(ib.n) > 0.9999, "normal {} vs {}", ia.n, ib.n);
                assert!(ia.s.dot(ib.s) > 0.999, "dP/du {} vs {}", ia.s, ib.s);
                assert!(ia.s.dot(ia.n).abs() < 1e-4);
                assert!((ia.uv_at(ba) - ib.uv_at(bb)).length() < 1e-4);
                // Material (and alpha flag); a mirrored card may be stored as a
                // parallelogram on one side and as two triangles on the other.
                // The UV-mirror flag is relative to each BLAS's own winding: compare the
                // normal-map frames it gives instead.
                let q = crate::accel::FLAG_QUAD | crate::accel::FLAG_UV_MIRRORED;
                assert_eq!(ia.flags & !q, ib.flags & !q);
                let (ta, sa) = a.uv_tangent(pa, ba);
                let (tb, sb) = b.uv_tangent(pb, bb);
                let (ta, tb) = (ta.normalize(), tb.normalize());
                assert!(ta.dot(tb) > 0.999, "tangent {ta} vs {tb}");
                let (ba_, bb_) = (ia.n.cross(ta) * sa, ib.n.cross(tb) * sb);
                assert!(ba_.dot(bb_) > 0.999, "bitangent {ba_} vs {bb_}");
            }
            _ => disagree += 1,
        }
    }
    assert!(hits > n / 4, "{hits} of {n} rays hit");
    assert!(disagree * 100 < n, "{disagree} of {n} rays disagree");
}

/// Bad instances are errors, not panics; memory is counted per level.
#[test]
fn instance_errors_and_memory() {
    let (mut inst, _) = instanced_and_flat(&test_transforms());
    let mem = Accel::build(&inst).unwrap().memory();
    assert_eq!(mem.instance_count, 3);
    assert!(mem.prototypes > 0 && mem.world > 0 && mem.instances >= 3 * 52);
    assert!(mem.bytes_per_instance() >= 52.0);
    inst.instances[1].transform = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
    assert!(Accel::build(&inst).is_err(), "singular transform");
    inst.instances[1].transform = Affine3A::IDENTITY;
    inst.instances[2].prototype = 5;
    assert!(Accel::build(&inst).is_err(), "prototype out of range");
}

/// Instances carry vertex normals through the inverse transpose: the shading normal of an
/// instanced smooth sphere equals that of the same sphere flattened into world space with
/// its normals transformed, through rotation, non-uniform scale and a mirror.
#[test]
fn instanced_shading_normals_match_flattened() {
    let sphere = uv_sphere(Vec3::ZERO, 0.5, 8, 16, true, 0);
    let transforms = test_transforms();
    let mut inst = sphere_scene(sphere.clone(), vec![], None);
    inst.meshes = Vec::new();
    inst.prototypes = vec![Prototype {
        name: "sphere".into(),
        meshes: vec![sphere.clone()],
    }];
    inst.instances = transforms
        .iter()
        .map(|&transform| Instance {
            prototype: 0,
            transform,
        })
        .collect();
    let mut flat = inst.clone();
    flat.prototypes = Vec::new();
    flat.instances = Vec::new();
    flat.meshes = transforms
        .iter()
        .map(|&m| {
            let mut out = flatten(&sphere, m);
            let it = m.matrix3.inverse().transpose();
            for n in &mut out.normals {
                *n = (it * glam::Vec3A::from(*n)).into();
            }
            out
        })
        .collect();
    let (a, b) = (Accel::build(&inst).unwrap(), Accel::build(&flat).unwrap());
    let mut hits = 0;
    for i in 0..2000u32 {
        let s = crate::sampler::sobol_2d(i, 5);
        let origin = Vec3::new(s.x * 4.0 - 2.0, s.y * 4.0 - 2.0, 3.0);
        let ray = Ray {
            origin,
            dir: (Vec3::new(s.y - 0.5, s.x - 0.5, 0.0) - origin).normalize(),
            tmax: f32::INFINITY,
        };
        let (Some(ha), Some(hb)) = (a.intersect(&ray), b.intersect(&ray)) else {
            continue;
        };
        let (HitKind::Triangle { prim: pa, bary: ba }, HitKind::Triangle { prim: pb, bary: bb }) =
            (ha.kind, hb.kind)
        else {
            continue;
        };
        if (ha.t - hb.t).abs() > 1e-4 * hb.t {
            continue; // grazing an edge: different triangles
        }
        let (na, nb) = (
            a.shading_normal(pa, ba).unwrap(),
            b.shading_normal(pb, bb).unwrap(),
        );
        assert!(na.dot(nb) > 0.9999, "shading normal {na} vs {nb}");
        // And it is the smooth one: on the outside of the (mirrored or not) sphere.
        let (_, info) = a.surface(pa, ba);
        assert!(na.dot(info.n) > 0.5, "{na} vs geometric {}", info.n);
        hits += 1;
    }
    assert!(hits > 200, "{hits} hits");
}

/// Tiny prototypes (at most `SMALL_BLAS` primitives, tested without a BVH) answer like
/// the flattened geometry: three crossing cards (two with a half-transparent matte) and
/// one triangle, placed rotated, non-uniformly scaled and mirrored. Closest hit, any hit,
/// and the continuation of every hit ray from its exact hit point skipping the primitive it
/// left (which must find the next surface, never the same one).
#[test]
fn tiny_instanced_prototypes_match_flattened_geometry() {
    let matte = Texture::from_texels(2, 1, vec![Vec4::ZERO, Vec4::ONE], Wrap::Clamp);
    let base = small_canopy_scene();
    let mut meshes: Vec<Mesh> = base.meshes[..3].to_vec();
    meshes[0].material = 2;
    meshes[2].material = 2;
    meshes.push(Mesh {
        positions: vec![
            Vec3::new(-0.5, -0.4, 0.1),
            Vec3::new(0.6, -0.2, -0.1),
            Vec3::new(0.0, 0.7, 0.2),
        ],
        indices: vec![[0, 1, 2]],
        material: 1,
        ..Default::default()
    });
    let mut inst = base.clone();
    inst.materials.push(Material::Diffuse {
        name: "matte".into(),
        reflectance: ColorInput::Constant(Vec3::splat(0.5)),
        alpha: Some(AlphaMask {
            map: matte,
            use_alpha_channel: false,
            cutoff: 0.5,
        }),
    });
    inst.prototypes = vec![Prototype {
        name: "tiny".into(),
        meshes: meshes.clone(),
    }];
    inst.meshes = Vec::new();
    let transforms = test_transforms();
    inst.instances = transforms
        .iter()
        .map(|&transform| Instance {
            prototype: 0,
            transform,
        })
        .collect();
    let mut flat = inst.clone();
    flat.prototypes = Vec::new();
    flat.instances = Vec::new();
    flat.meshes = transforms
        .iter()
        .flat_map(|&m| meshes.iter().map(move |mesh| flatten(mesh, m)))
        .collect();
    let (a, b) = (Accel::build(&inst).unwrap(), Accel::build(&flat).unwrap());
    assert_eq!(a.instance_count(), 3);
    assert_eq!(
        a.primitive_count(),
        4 + 1,
        "3 cards + 1 triangle + the quad light"
    );
    let prim = |h: &crate::Hit| match h.kind {
        HitKind::Triangle { prim, .. } => prim,
        HitKind::Sphere { .. } => crate::accel::PrimRef::NONE,
    };
    let (mut n, mut hits, mut second, mut disagree) = (0, 0, 0, 0);
    for i in 0..4000u32 {
        let s = crate::sampler::sobol_2d(i, 5);
        let q = crate::sampler::sobol_2d(i, 6);
        let origin = Vec3::new(s.x * 4.0 - 2.0, s.y * 4.0 - 2.0, 3.0 - 6.0 * (i % 2) as f32);
        let target = Vec3::new(q.x * 3.0 - 1.5, q.y * 3.0 - 1.5, (q.x - q.y) * 2.0 - 1.0);
        let ray = Ray {
            origin,
            dir: (target - origin).normalize(),
            tmax: f32::INFINITY,
        };
        n += 1;
        let (ha, hb) = (a.intersect(&ray), b.intersect(&ray));
        assert_eq!(a.occluded(&ray), ha.is_some());
        let (Some(ha), Some(hb)) = (ha, hb) else {
            disagree += (ha.is_some() != hb.is_some()) as u32;
            continue;
        };
        if (ha.t - hb.t).abs() >= 1e-4 * hb.t {
            disagree += 1;
            continue;
        }
        hits += 1;
        let (pa, pb) = (prim(&ha), prim(&hb));
        if pa == crate::accel::PrimRef::NONE {
            continue;
        }
        let HitKind::Triangle { bary, .. } = ha.kind else {
            unreachable!()
        };
        let (xa, ia) = a.surface(pa, bary);
        let HitKind::Triangle { bary: bb, .. } = hb.kind else {
            unreachable!()
        };
        let (xb, ib) = b.surface(pb, bb);
        assert!((xa - xb).length() < 1e-4, "position {xa} vs {xb}");
        assert!(ia.n.dot(ib.n) > 0.9999, "normal {} vs {}", ia.n, ib.n);
        // Continue from the exact hit point, skipping the primitive just hit.
        let next = |p: Vec3| Ray {
            origin: p,
            dir: ray.dir,
            tmax: 100.0,
        };
        let (na, nb) = (
            a.intersect_skip(&next(xa), pa),
            b.intersect_skip(&next(xb), pb),
        );
        assert_eq!(a.occluded_skip(&next(xa), pa), na.is_some());
        if let Some(h) = na {
            assert_ne!(prim(&h), pa, "the skipped primitive was hit again");
        }
        match (na, nb) {
            (None, None) => {}
            (Some(na), Some(nb)) if (na.t - nb.t).abs() < 1e-4 * nb.t.max(1e-2) => second += 1,
            _ => disagree += 1,
        }
    }
    eprintln!("{hits} hits, {second} second hits, {disagree} disagree of {n}");
    assert!(hits > n / 8, "{hits} of {n} rays hit");
    assert!(second > n / 40, "{second} of {n} rays hit twice");
    assert!(disagree * 100 < n, "{disagree} of {n} rays disagree");
}

/// A scene with a sun gets lamina-accel's grid along it (counted in `memory`), and shadow
/// rays toward the sun (from free space and from surfaces) are answered as without it.
#[test]
fn sun_shadow_rays_take_the_grid_with_the_same_answers() {
    let (mut scene, _) = instanced_and_flat(&test_transforms());
    scene
        .lights
        .retain(|l| !matches!(l, lamina_core::Light::Sun { .. }));
    let plain = Accel::build(&scene).unwrap();
    let sun = Vec3::new(0.3, 0.5, 0.8).normalize();
    scene.lights.push(lamina_core::Light::Sun {
        direction: sun,
        irradiance: Vec3::ONE,
        angular_diameter_deg: 0.53,
    });
    let grid = Accel::build(&scene).unwrap();
    assert!(
        grid.memory().grids > plain.memory().grids,
        "a grid along the sun"
    );
    let (mut blocked, mut n) = (0, 0);
    for i in 0..4000u32 {
        let s = crate::sampler::sobol_2d(i, 5);
        let q = crate::sampler::sobol_2d(i, 6);
        let origin = Vec3::new(s.x * 4.0 - 2.0, s.y * 4.0 - 2.0, q.x * 4.0 - 2.0);
        // The sun's axis and directions within its disc.
        let tilt = Vec3::new(q.y - 0.5, s.x - 0.5, 0.0) * if i % 2 == 0 { 0.0 } else { 0.009 };
        let ray = Ray {
            origin,
            dir: (sun + tilt).normalize(),
            tmax: f32::INFINITY,
        };
        let want = plain.occluded(&ray);
        assert_eq!(grid.occluded(&ray), want, "ray {i}: {ray:?}");
        blocked += want as u32;
        // From the surface a probe ray lands on, leaving it.
        let probe = Ray {
            dir: -ray.dir,
            ..ray
        };
        if let Some(Hit {
            t,
            kind: HitKind::Triangle { prim, .. },
        }) = plain.intersect(&probe)
        {
            let from = Ray {
                origin: probe.origin + probe.dir * t,
                ..ray
            };
            n += 1;
            assert_eq!(
                grid.occluded_skip(&from, prim),
                plain.occluded_skip(&from, prim),
                "ray {i} from {prim:?}"
            );
        }
    }
    assert!(
        blocked > 200 && n > 200,
        "{blocked} blocked, {n} from surfaces"
    );
}

/// A pinhole camera gets lamina-accel's grid from its eye (counted in `memory`), a thin
/// lens none; camera rays find the same hits either way.
#[test]
fn camera_rays_take_the_grid_with_the_same_hits() {
    let (mut scene, _) = instanced_and_flat(&test_transforms());
    scene.camera = crate::tests::scenes::camera_at(4.0, 60.0);
    scene.camera.aperture_radius = 0.0;
    let grid = Accel::build(&scene).unwrap();
    let cam = crate::camera::CameraModel::new(&scene.camera, &scene.film).unwrap();
    let mut lens = scene.clone();
    lens.camera.aperture_radius = 0.05;
    let plain = Accel::build(&lens).unwrap();
    assert!(
        grid.memory().grids > plain.memory().grids,
        "a grid for the pinhole, none for the lens"
    );
    let (w, h) = (scene.film.width as f32, scene.film.height as f32);
    let mut hits = 0;
    for i in 0..4000u32 {
        // Across the film and a little past its edges (the pixel filter's reach).
        let s = crate::sampler::sobol_2d(i, 7);
        let pos = glam::Vec2::new(s.x * (w + 4.0) - 2.0, s.y * (h + 4.0) - 2.0);
        let (origin, dir) = cam.generate_ray(pos, glam::Vec2::splat(0.5));
        let ray = Ray {
            origin,
            dir,
            tmax: f32::INFINITY,
        };
        let want = plain.intersect(&ray);
        assert_eq!(grid.intersect(&ray), want, "ray {i}: {ray:?}");
        hits += want.is_some() as u32;
    }
    assert!(hits > 400, "{hits} of 4000 camera rays hit");
}

/// A pixel's camera rays found together ([`Accel::intersect_many`], lamina-accel's packets
/// over the eye's grid) hit what each finds alone, on a scene of world cards with quad
/// and sphere lights, for groups of 1 to 8 rays per pixel across the film and past its
/// edges.
#[test]
fn camera_rays_found_together_hit_as_alone() {
    let scene = crate::tests::scenes::small_canopy_scene();
    assert_eq!(scene.camera.aperture_radius, 0.0);
    let accel = Accel::build(&scene).unwrap();
    assert!(accel.memory().grids > 0, "a grid for the pinhole");
    let cam = crate::camera::CameraModel::new(&scene.camera, &scene.film).unwrap();
    let (w, h) = (scene.film.width, scene.film.height);
    let (mut hits, mut total) = (0, 0);
    for y in 0..h + 2 {
        for x in 0..w + 2 {
            let n = 1 + ((x + y) as usize % Accel::MANY);
            let rays: Vec<Ray> = (0..n as u32)
                .map(|i| {
                    let s = crate::sampler::sobol_2d(i, x * 977 + y);
                    let pos = glam::Vec2::new(x as f32 - 1.0, y as f32 - 1.0) + s;
                    let (origin, dir) = cam.generate_ray(pos, glam::Vec2::ZERO);
                    Ray {
                        origin,
                        dir,
                        tmax: f32::INFINITY,
                    }
                })
                .collect();
            let mut got = vec![None; n];
            accel.intersect_many(&rays, &mut got);
            for (ray, got) in rays.iter().zip(&got) {
                let want = accel.intersect(ray);
                assert_eq!(*got, want, "pixel ({x}, {y}): {ray:?}");
                hits += want.is_some() as u32;
                total += 1;
            }
        }
    }
    assert!(hits * 10 > total, "{hits} of {total} camera rays hit");
}

/// A pixel's shadow rays toward a sun tested together ([`Accel::occluded_many`],
/// lamina-accel's eight-ray queries over the sun's grid) are blocked exactly when each is
/// alone, each leaving the surface its camera ray hit: on world cards with a matte under a
/// delta sun and a sun's disc, for groups of 1 to 16 rays per pixel across the film.
#[test]
fn sun_rays_tested_together_are_blocked_as_alone() {
    let mut scene = small_canopy_scene();
    scene.lights = vec![
        sun(Vec3::new(0.3, 1.0, 0.5), 400.0),
        lamina_core::Light::Sun {
            direction: Vec3::new(-0.4, 0.8, 0.3),
            irradiance: Vec3::splat(200.0),
            angular_diameter_deg: 2.0,
        },
    ];
    // Half of each card's matte cut away: blocked and unblocked rays through the cards.
    if let Material::DiffuseTransmission { alpha, .. } = &mut scene.materials[0] {
        *alpha = Some(AlphaMask {
            map: Texture::from_texels(
                2,
                2,
                vec![Vec4::ZERO, Vec4::ONE, Vec4::ONE, Vec4::ONE],
                Wrap::Clamp,
            ),
            use_alpha_channel: false,
            cutoff: 0.5,
        });
    }
    let accel = Accel::build(&scene).unwrap();
    assert!(accel.memory().grids > 0, "grids along the suns");
    let cam = crate::camera::CameraModel::new(&scene.camera, &scene.film).unwrap();
    let suns: Vec<crate::lights::SunLight> = scene
        .lights
        .iter()
        .filter_map(|l| match l {
            lamina_core::Light::Sun {
                direction,
                angular_diameter_deg,
                ..
            } => crate::lights::SunLight::new(*direction, Vec3::ONE, *angular_diameter_deg),
            _ => None,
        })
        .collect();
    let (w, h) = (scene.film.width, scene.film.height);
    let (mut blocked, mut total) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let n = 1 + ((x * 7 + y) as usize % 16);
            let (mut rays, mut skips) = (Vec::new(), Vec::new());
            for i in 0..n as u32 {
                let s = crate::sampler::sobol_2d(i, x * 977 + y);
                let (origin, dir) =
                    cam.generate_ray(glam::Vec2::new(x as f32, y as f32) + s, glam::Vec2::ZERO);
                let camera_ray = Ray {
                    origin,
                    dir,
                    tmax: f32::INFINITY,
                };
                let Some(Hit {
                    kind: HitKind::Triangle { prim, bary },
                    ..
                }) = accel.intersect(&camera_ray)
                else {
                    continue;
                };
                let (p, info) = accel.surface(prim, bary);
                let sun = &suns[(i as usize + x as usize) % suns.len()];
                let u = crate::sampler::sobol_2d(i, x * 31 + y * 7 + 1);
                let wi = sun.sample(u).wi;
                rays.push(Ray {
                    origin: crate::accel::spawn_origin(p, info.n, wi),
                    dir: wi,
                    tmax: f32::INFINITY,
                });
                skips.push(prim);
            }
            let mut got = vec![false; rays.len()];
            accel.occluded_many(&rays, &skips, &mut got);
            for ((ray, skip), got) in rays.iter().zip(&skips).zip(&got) {
                let want = accel.occluded_skip(ray, *skip);
                assert_eq!(*got, want, "pixel ({x}, {y}): {ray:?} leaving {skip:?}");
                blocked += u32::from(want);
                total += 1;
            }
        }
    }
    assert!(
        blocked * 20 > total && blocked * 20 < total * 19,
        "{blocked} of {total} sun rays blocked"
    );
}
