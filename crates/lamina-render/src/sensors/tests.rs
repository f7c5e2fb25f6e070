//! The sensors and the periodic domain against what they must agree with: an explicitly
//! tiled scene, the energy budget, the Boolean-model gap fraction, each other.

use super::*;
use crate::tests::scenes::{camera_at, diffuse, diffuse_transmission, film};
use glam::{Affine3A, Quat, Vec2, Vec3};
use lamina_core::radiometry::{
    BrfDirection, BrfSweep, FisheyeProjection, Periodic, Rect, Sensor, SensorKind,
};
use lamina_core::{Instance, Integrator, Light, Mesh, Prototype, Radiometry, Sky};
use std::f64::consts::PI;

const R: f32 = 0.05;

/// A disc leaf of radius [`R`] (32-gon of the same area) in the x-z plane, normal `+y`.
fn disc() -> Mesh {
    let n = 32;
    let r = R
        * (std::f32::consts::PI / (0.5 * n as f32 * (2.0 * std::f32::consts::PI / n as f32).sin()))
            .sqrt();
    let mut positions = vec![Vec3::ZERO];
    for k in 0..n {
        let a = -2.0 * std::f32::consts::PI * k as f32 / n as f32;
        positions.push(Vec3::new(r * a.cos(), 0.0, r * a.sin()));
    }
    let indices = (0..n).map(|k| [0, k + 1, (k + 1) % n + 1]).collect();
    Mesh {
        positions,
        indices,
        material: 0,
        ..Mesh::default()
    }
}

/// splitmix64 in [0, 1).
struct Rng(u64);
impl Rng {
    fn f(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A RAMI-like layer: `lai` of disc leaves (material 0, bi-Lambertian `r`, `t`) with
/// uniformly distributed inclination in `[R, h − R]` over a periodic `cell`-sided square, a
/// soil of reflectance `soil` (material 1) spanning the cell, a delta sun at `sza` degrees
/// in the x-y plane with irradiance 1.
fn canopy(lai: f32, h: f32, cell: f32, band: (f32, f32, f32), sza: f32, seed: u64) -> Scene {
    let (r, t, soil) = band;
    let mut rng = Rng(seed);
    let n = (lai * cell * cell / (std::f32::consts::PI * R * R)).round() as usize;
    let instances = (0..n)
        .map(|_| {
            let c = Vec3::new(rng.f() * cell, R + rng.f() * (h - 2.0 * R), rng.f() * cell);
            let incl = rng.f() * std::f32::consts::FRAC_PI_2;
            let az = rng.f() * std::f32::consts::TAU;
            Instance {
                prototype: 0,
                transform: Affine3A::from_rotation_translation(
                    Quat::from_rotation_y(az) * Quat::from_rotation_x(incl),
                    c,
                ),
            }
        })
        .collect();
    let mut ground = Mesh::quad(
        Vec3::new(0.0, 0.0, cell),
        Vec3::new(cell, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -cell),
        1,
    );
    ground.uvs.clear();
    let s = sza.to_radians();
    Scene {
        radiometry: Radiometry {
            periodic: Some(Periodic {
                cell: Rect {
                    min: Vec2::ZERO,
                    max: Vec2::splat(cell),
                },
            }),
            sensors: Vec::new(),
            objects: vec![
                lamina_core::radiometry::ObjectRecord {
                    name: "soil".into(),
                    meshes: 0..1,
                    instances: 0..0,
                },
                lamina_core::radiometry::ObjectRecord {
                    name: "leaves".into(),
                    meshes: 1..1,
                    instances: 0..n as u32,
                },
            ],
        },
        camera: camera_at(5.0, 40.0),
        film: film(8, 8, 1),
        integrator: Integrator::Path {
            max_depth: 1024,
            rr_depth: 8,
            light_sampling: Default::default(),
            sky_sampling: Default::default(),
        },
        lights: vec![Light::Sun {
            direction: Vec3::new(s.sin(), s.cos(), 0.0),
            irradiance: Vec3::ONE,
            angular_diameter_deg: 0.0,
        }],
        sky: None,
        materials: vec![
            diffuse_transmission(Vec3::splat(r), Vec3::splat(t)),
            diffuse(soil),
        ],
        meshes: vec![ground],
        prototypes: vec![Prototype {
            name: "disc".into(),
            meshes: vec![disc()],
        }],
        instances,
    }
}

fn absorbed_sensor(samples: u32) -> Sensor {
    Sensor {
        name: "fluxes".into(),
        samples,
        channel: Some(0),
        kind: SensorKind::Absorbed {
            area: None,
            ground: vec![1],
            file: "fluxes.csv".into(),
        },
    }
}

fn run(scene: &Scene, sensors: Vec<Sensor>, threads: usize) -> Vec<SensorOutput> {
    let mut s = scene.clone();
    s.radiometry.sensors = sensors;
    measure(
        &s,
        &MeasureOptions {
            seed: 3,
            threads: Some(threads),
            ..Default::default()
        },
    )
    .unwrap()
}

fn fluxes(scene: &Scene, photons: u32) -> absorbed::AbsorbedResult {
    match run(scene, vec![absorbed_sensor(photons)], 2)
        .remove(0)
        .measurement
    {
        Measurement::Absorbed(r) => *r,
        _ => unreachable!(),
    }
}

#[test]
fn periodic_rays_match_an_explicitly_tiled_scene() {
    // Leaves crossing the border (instances) and loose triangles crossing it (world mesh).
    let cell = 1.0;
    let mut scene = canopy(2.0, 0.6, cell, (0.1, 0.1, 0.2), 30.0, 5);
    let mut rng = Rng(9);
    let mut loose = Mesh {
        material: 0,
        ..Mesh::default()
    };
    for k in 0..40u32 {
        let c = Vec3::new(rng.f(), 0.1 + 0.4 * rng.f(), rng.f());
        let a = Vec3::new(rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5) * 0.3;
        let b = Vec3::new(rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5) * 0.3;
        loose.positions.extend([c, c + a, c + b]);
        loose.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
    }
    scene.meshes.push(loose.clone());
    // The same world tiled 7 x 7 times, without a periodic domain.
    let mut tiled = scene.clone();
    tiled.radiometry = Radiometry::default();
    tiled.instances.clear();
    tiled.meshes.truncate(1);
    for i in -3..=3 {
        for j in -3..=3 {
            let d = Vec3::new(i as f32 * cell, 0.0, j as f32 * cell);
            for inst in &scene.instances {
                let mut m = *inst;
                m.transform.translation += glam::Vec3A::from(d);
                tiled.instances.push(m);
            }
            let mut l = loose.clone();
            l.positions.iter_mut().for_each(|p| *p += d);
            tiled.meshes.push(l);
        }
    }
    // The ground spans the tiled world too.
    tiled.meshes[0] = Mesh::quad(
        Vec3::new(-3.0, 0.0, 4.0),
        Vec3::new(7.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -7.0),
        1,
    );
    let a = crate::Accel::build(&scene).unwrap();
    let b = crate::Accel::build(&tiled).unwrap();
    assert_eq!(a.periodic(), Some((Vec2::ZERO, Vec2::ONE)));
    let mut rng = Rng(17);
    let (mut hits, mut checked, mut grazing) = (0, 0, 0);
    for _ in 0..20000 {
        // From inside the cell's column, above the canopy or inside it, any direction that
        // stays within the tiled world (at most 2 m sideways).
        let o = Vec3::new(rng.f(), 0.05 + 0.9 * rng.f(), rng.f());
        let th = rng.f() * 1.3;
        let ph = rng.f() * std::f32::consts::TAU;
        let up = rng.f() < 0.3;
        let d = Vec3::new(
            th.sin() * ph.cos(),
            if up { th.cos() } else { -th.cos() },
            th.sin() * ph.sin(),
        );
        let ray = crate::Ray {
            origin: o,
            dir: d,
            tmax: 2.0,
        };
        let (ha, hb) = (a.intersect(&ray), b.intersect(&ray));
        checked += 1;
        // A ray that grazes a leaf's rim may hit it from one origin and miss it from the
        // same origin moved by whole cells (rounding); anything else is a bug.
        match (ha, hb) {
            (None, None) => {}
            (Some(x), Some(y)) if (x.t - y.t).abs() < 1e-4 => {
                hits += 1;
                let mat = |acc: &crate::Accel, h: crate::Hit| match h.kind {
                    crate::accel::HitKind::Triangle { prim, .. } => {
                        acc.flags(prim) & crate::accel::ID_MASK
                    }
                    _ => u32::MAX,
                };
                assert_eq!(mat(&a, x), mat(&b, y));
            }
            _ => grazing += 1,
        }
        if a.occluded(&ray) != b.occluded(&ray) {
            grazing += 1;
        }
    }
    eprintln!("{hits} hits of {checked} rays, {grazing} differ (rim grazing)");
    assert!(hits > checked / 4, "{hits} of {checked}");
    assert!(
        grazing <= checked / 2000,
        "{grazing} of {checked} rays differ"
    );
}

#[test]
fn a_ray_crossing_the_cell_border_keeps_its_distance_and_escapes_above() {
    let scene = canopy(1.0, 1.0, 2.0, (0.1, 0.1, 0.2), 0.0, 1);
    let a = crate::Accel::build(&scene).unwrap();
    // Straight down far outside the cell: moved in by whole cells, hits the ground at t = 100.
    let ray = crate::Ray {
        origin: Vec3::new(1001.3, 100.0, -57.7),
        dir: -Vec3::Y,
        tmax: f32::INFINITY,
    };
    let h = a.intersect(&ray).unwrap();
    assert!(h.t <= 100.0 + 1e-3, "{}", h.t);
    // Upward rays above the geometry meet nothing.
    let up = crate::Ray {
        origin: Vec3::new(0.5, 1.5, 0.5),
        dir: Vec3::new(0.7, 0.1, 0.7).normalize(),
        tmax: f32::INFINITY,
    };
    assert!(a.intersect(&up).is_none());
    // A horizontal ray inside the canopy layer meets a leaf within a few cells (one along
    // an axis would retrace the same line in every cell).
    let side = crate::Ray {
        origin: Vec3::new(0.5, 0.5, 0.5),
        dir: Vec3::new(1.0, 0.0, 0.37).normalize(),
        tmax: f32::INFINITY,
    };
    let h = a.intersect(&side).unwrap();
    assert!(h.t > 0.0 && h.t < 100.0, "{}", h.t);
}

#[test]
fn energy_closes_in_red_and_nir_and_the_conservative_case_reflects_everything() {
    // RAMI's bands: (leaf R, T, soil).
    for (name, r, t, soil) in [
        ("red", 0.0546, 0.0149, 0.127),
        ("nir", 0.4957, 0.4409, 0.159),
        ("nr1", 0.5, 0.5, 1.0),
    ] {
        let scene = canopy(2.0, 1.0, 3.0, (r, t, soil), 20.0, 2);
        let f = fluxes(&scene, 200_000);
        let (a, fa, ft) = (f.albedo.value.x, f.fabs.value.x, f.ftran.value.x);
        let sum = a + fa + ft * (1.0 - soil as f64);
        eprintln!("{name}: albedo {a:.5} fabs {fa:.5} ftran {ft:.5}: budget {sum:.5}");
        assert!((sum - 1.0).abs() < 0.01, "{name}: {sum}");
        assert_eq!(f.escaped.value.x, 0.0);
        if name == "nr1" {
            assert!((a - 1.0).abs() < 0.005, "{a}");
            assert!(fa.abs() < 1e-9, "{fa}");
        }
        // Leaves and soil per material and per object add up to fabs and the soil's share.
        let soil_abs = f.materials[1].1.value.x;
        assert!(
            (soil_abs - ft * (1.0 - soil as f64)).abs() < 0.01,
            "{soil_abs}"
        );
        assert!((f.objects[1].1.value.x - fa).abs() < 1e-9);
        assert!((f.objects[0].1.value.x - soil_abs).abs() < 1e-9);
    }
}

/// `G(μ)` of the uniform leaf inclination distribution (`g = 2/π`), numerically.
fn g_uniform(mu: f64) -> f64 {
    let th = mu.acos();
    let n = 4000;
    (0..n)
        .map(|i| {
            let tl = (i as f64 + 0.5) / n as f64 * PI / 2.0;
            let ct = tl.cos();
            let c = 1.0 / (th.tan() * tl.tan());
            let v = if th < 1e-9 || c.abs() >= 1.0 {
                mu * ct
            } else {
                let p = c.acos();
                mu * ct * (1.0 + 2.0 / PI * (p.tan() - p))
            };
            2.0 / PI * v * (PI / 2.0 / n as f64)
        })
        .sum()
}

#[test]
fn uncollided_transmission_is_geometric_and_follows_the_boolean_model() {
    for sza in [0.0f32, 50.0] {
        let mut seen = Vec::new();
        for (r, t, soil) in [
            (0.0546, 0.0149, 0.127),
            (0.4957, 0.4409, 0.159),
            (0.5, 0.5, 1.0),
        ] {
            // Averaged over three leaf placements: one placement's gaps vary by ~1 %.
            let mut u = 0.0;
            for seed in 0..3 {
                let scene = canopy(1.0, 1.0, 5.0, (r, t, soil), sza, 40 + seed);
                u += fluxes(&scene, 100_000).ftran_uncollided.value.x / 3.0;
            }
            seen.push(u);
        }
        assert!(seen.iter().all(|u| *u == seen[0]), "{seen:?}");
        let mu = (sza as f64).to_radians().cos();
        let expected = (-g_uniform(mu) / mu).exp();
        eprintln!(
            "sun zenith {sza}: uncollided {:.4}, Boolean model {expected:.4}",
            seen[0]
        );
        assert!(
            (seen[0] - expected).abs() < 0.012,
            "{} vs {expected}",
            seen[0]
        );
    }
}

fn brf_sensor(directions: Vec<BrfDirection>, samples: u32) -> Sensor {
    Sensor {
        name: "brf".into(),
        samples,
        channel: Some(0),
        kind: SensorKind::Brf {
            target: None,
            sweeps: vec![BrfSweep {
                label: "directions".into(),
                directions,
                file: "brf.csv".into(),
            }],
            plot: None,
        },
    }
}

#[test]
fn brf_integrates_to_the_albedo() {
    let scene = canopy(2.0, 1.0, 3.0, (0.4957, 0.4409, 0.159), 30.0, 7);
    // Midpoint rule in μ (16) and azimuth (16): albedo = (1/π) ∫∫ BRF μ dμ dφ.
    let (nm, na) = (16usize, 16usize);
    let mut dirs = Vec::new();
    for i in 0..nm {
        let mu = (i as f32 + 0.5) / nm as f32;
        for j in 0..na {
            dirs.push(BrfDirection {
                zenith: mu.acos().to_degrees(),
                relative_azimuth: (j as f32 + 0.5) * 360.0 / na as f32,
                signed_zenith: mu.acos().to_degrees(),
            });
        }
    }
    let out = run(
        &scene,
        vec![brf_sensor(dirs.clone(), 2048), absorbed_sensor(200_000)],
        2,
    );
    let Measurement::Brf(b) = &out[0].measurement else {
        unreachable!()
    };
    let Measurement::Absorbed(f) = &out[1].measurement else {
        unreachable!()
    };
    let mut albedo = 0.0;
    for (d, e) in dirs.iter().zip(&b.sweeps[0]) {
        let mu = d.zenith.to_radians().cos() as f64;
        albedo += e.value.x * mu / (nm as f64) * (2.0 * PI / na as f64) / PI;
    }
    eprintln!(
        "albedo from the BRF {albedo:.4}, from the photons {:.4}",
        f.albedo.value.x
    );
    assert!(
        (albedo - f.albedo.value.x).abs() < 0.01,
        "{albedo} vs {}",
        f.albedo.value.x
    );
    assert!((b.irradiance.x - 30f64.to_radians().cos()).abs() < 1e-6);
}

/// An irradiance sensor over the whole cell at `height`, one grid cell, `samples` rays per
/// hemisphere.
fn irradiance_plane(height: f32, samples: u32) -> Sensor {
    Sensor {
        name: format!("plane {height}"),
        samples,
        channel: None,
        kind: SensorKind::Irradiance {
            height,
            area: None,
            grid: [1, 1],
            file: "e.csv".into(),
        },
    }
}

#[test]
fn irradiance_sensor_agrees_with_the_flux_budget() {
    let scene = canopy(2.0, 1.0, 3.0, (0.4957, 0.4409, 0.159), 20.0, 4);
    let plane = |height: f32| irradiance_plane(height, 8192);
    let out = run(
        &scene,
        vec![plane(1.2), plane(0.001), absorbed_sensor(200_000)],
        2,
    );
    let cell = |i: usize| match &out[i].measurement {
        Measurement::Irradiance(r) => r.cells[0],
        _ => unreachable!(),
    };
    let Measurement::Absorbed(f) = &out[2].measurement else {
        unreachable!()
    };
    let e = 20f64.to_radians().cos();
    let (top, bottom) = (cell(0), cell(1));
    let close = |a: f64, b: f64, sigma: f64, what: &str| {
        eprintln!("{what}: {a:.4} vs {b:.4} (σ {sigma:.4})");
        assert!((a - b).abs() < 4.0 * sigma + 0.004, "{what}: {a} vs {b}");
    };
    close(
        top.down.value.x,
        e,
        top.down.std.x,
        "downwelling above the canopy",
    );
    close(
        top.up.value.x,
        f.albedo.value.x * e,
        top.up.std.x + f.albedo.std.x,
        "upwelling above",
    );
    close(
        bottom.down.value.x,
        f.ftran.value.x * e,
        bottom.down.std.x + f.ftran.std.x,
        "down at the soil",
    );
    close(
        bottom.up.value.x,
        0.159 * f.ftran.value.x * e,
        bottom.up.std.x + f.ftran.std.x,
        "up at the soil",
    );
}

/// The irradiance sensor's receiver picks lights as a path vertex does: with
/// `light_sampling = "one"` its shadow rays go to one light, weighted by the probability of
/// drawing it, and the MIS weights of its traced ray assume the same; a sky left to BSDF
/// samples gets no shadow ray and counts in full along the traced ray. Above the canopy the
/// downwelling irradiance of a sun and a constant sky is `E cos θ + π L` in each mode,
/// and below it the modes agree.
#[test]
fn irradiance_is_the_same_however_the_lights_are_sampled() {
    let mut scene = canopy(2.0, 1.0, 3.0, (0.4957, 0.4409, 0.159), 20.0, 4);
    scene.sky = Some(Sky::Constant(Vec3::splat(0.1)));
    let plane = |height: f32| irradiance_plane(height, 16384);
    let measure_with = |ls, sky| {
        let mut s = scene.clone();
        let Integrator::Path {
            light_sampling,
            sky_sampling,
            ..
        } = &mut s.integrator
        else {
            unreachable!()
        };
        *light_sampling = ls;
        *sky_sampling = sky;
        let out = run(&s, vec![plane(1.2), plane(0.001)], 2);
        out.iter()
            .map(|o| match &o.measurement {
                Measurement::Irradiance(r) => r.cells[0],
                _ => unreachable!(),
            })
            .collect::<Vec<_>>()
    };
    use lamina_core::{LightSampling, SkySampling};
    // The sky light-sampled, so that "one" draws between sun and sky; and left to the
    // receiver's cosine-distributed ray (the default for a constant sky).
    let all = measure_with(LightSampling::All, SkySampling::Light);
    let one = measure_with(LightSampling::One, SkySampling::Light);
    let bsdf = measure_with(LightSampling::All, SkySampling::Auto);
    let expect = 20f64.to_radians().cos() + std::f64::consts::PI * 0.1;
    for (name, m) in [
        ("all", &all),
        ("one", &one),
        ("sky by the traced ray", &bsdf),
    ] {
        let (v, sd) = (m[0].down.value.x, m[0].down.std.x);
        eprintln!("{name}: downwelling above {v:.4} ± {sd:.4} (expected {expect:.4})");
        assert!(
            (v - expect).abs() < 4.0 * sd + 0.002,
            "{name}: {v} vs {expect}"
        );
    }
    let (a, o) = (all[1].down, one[1].down);
    eprintln!(
        "down at the soil: all {:.4} ± {:.4}, one {:.4} ± {:.4}",
        a.value.x, a.std.x, o.value.x, o.std.x
    );
    for o in [one[1].down, bsdf[1].down] {
        let sd = (a.std.x.powi(2) + o.std.x.powi(2)).sqrt();
        assert!((a.value.x - o.value.x).abs() < 4.0 * sd + 0.002);
    }
}

#[test]
fn fisheye_sees_the_sky_through_the_gaps() {
    let mut scene = canopy(1.0, 1.0, 3.0, (0.1, 0.1, 0.2), 30.0, 8);
    scene.sky = Some(Sky::Constant(Vec3::splat(0.5)));
    scene.lights.clear();
    let eye = |position: Vec3| Sensor {
        name: "eye".into(),
        samples: 16,
        channel: None,
        kind: SensorKind::Fisheye {
            position,
            up: true,
            projection: FisheyeProjection::Equidistant,
            resolution: 64,
            file: "eye.exr".into(),
            gap_file: None,
        },
    };
    // Above the canopy: nothing in the way, the sky everywhere inside the circle.
    let out = run(
        &scene,
        vec![
            eye(Vec3::new(1.5, 1.5, 1.5)),
            eye(Vec3::new(1.5, 0.01, 1.5)),
        ],
        2,
    );
    let Measurement::Fisheye(above) = &out[0].measurement else {
        unreachable!()
    };
    assert!(above.gap.iter().all(|g| g.0 == 1.0), "{:?}", above.gap);
    let centre = above.image.pixels[(32 * 64 + 32) as usize];
    assert!(
        (centre - Vec3::splat(0.5)).abs().max_element() < 1e-6,
        "{centre}"
    );
    assert_eq!(above.image.pixels[0], Vec3::ZERO, "outside the circle");
    // Under it: the gap fraction of the rings near the zenith follows the Boolean model.
    let Measurement::Fisheye(below) = &out[1].measurement else {
        unreachable!()
    };
    let mut got = 0.0;
    let mut want = 0.0;
    for (k, g) in below.gap.iter().take(12).enumerate() {
        let mu = ((k as f64 + 0.5) * 5.0).to_radians().cos();
        got += g.0 / 12.0;
        want += (-g_uniform(mu) / mu).exp() / 12.0;
    }
    eprintln!("gap fraction 0-60°: {got:.3}, Boolean model {want:.3}");
    assert!((got - want).abs() < 0.1, "{got} vs {want}");
}

#[test]
fn sensors_are_deterministic_whatever_the_threads() {
    let scene = canopy(1.0, 1.0, 2.0, (0.3, 0.2, 0.2), 40.0, 11);
    let dirs = vec![BrfDirection {
        zenith: 30.0,
        relative_azimuth: 0.0,
        signed_zenith: 30.0,
    }];
    let a = run(
        &scene,
        vec![brf_sensor(dirs.clone(), 512), absorbed_sensor(20_000)],
        1,
    );
    let b = run(
        &scene,
        vec![brf_sensor(dirs, 512), absorbed_sensor(20_000)],
        2,
    );
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(
            format!("{:?}", x.measurement),
            format!("{:?}", y.measurement)
        );
    }
}

#[test]
fn an_object_wider_than_the_cell_is_an_error() {
    let mut scene = canopy(0.5, 1.0, 1.0, (0.1, 0.1, 0.2), 0.0, 1);
    // A leaf 1.2 m across on the border of a 1 m cell: wider than the cell, not spanning
    // it (one that spans the whole cell would be cut at its sides instead).
    scene.instances[0].transform = Affine3A::from_scale_rotation_translation(
        Vec3::splat(12.0),
        Quat::IDENTITY,
        Vec3::new(1.0, 0.5, 1.0),
    );
    let e = crate::Accel::build(&scene).unwrap_err().to_string();
    assert!(e.contains("wider") || e.contains("wide along"), "{e}");
}
