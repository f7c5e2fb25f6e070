//! Branch meshes (generalized cylinders) and the procedural bark texture.
//!
//! The skeleton is cut into *chains*: from a stem base, or from a lateral child, follow the
//! thickest child to a tip. Each chain is one tube of rings sharing vertices (smooth along
//! the chain), with a ring frame carried by parallel transport (no twist), radii from the
//! pipe model, and the ring count of sides set by the chain's base radius. A lateral chain
//! starts with a ring at its mother node, inside the mother branch, so joints overlap and
//! show no gap. Normals are the ring's radial directions. Bark UVs: `u` once around
//! (0 to 1, the seam vertex duplicated), `v` the length along the chain divided by the local
//! circumference, so a square bark texture has square texels everywhere.

use crate::rng::{hash3, unit_f32};
use crate::skeleton::{NONE, Skeleton};
use glam::{Vec2, Vec3, Vec4};
use lamina_core::scene::Mesh;
use lamina_leaf::frame::Frame;
use lamina_leaf::{Texture, Wrap};
use rayon::prelude::*;
use std::f32::consts::TAU;

fn sides_for(radius: f32) -> u32 {
    match radius {
        r if r >= 0.08 => 16,
        r if r >= 0.025 => 12,
        r if r >= 0.008 => 8,
        r if r >= 0.003 => 6,
        _ => 4,
    }
}

/// The chains: lists of node indices, each starting at a stem base or a lateral child.
fn chains(sk: &Skeleton) -> Vec<Vec<u32>> {
    let n = sk.pos.len();
    // Main child: the thickest (first on ties).
    let main: Vec<u32> = (0..n)
        .map(|i| {
            sk.children(i).iter().copied().fold(NONE, |best, c| {
                if best == NONE || sk.radius[c as usize] > sk.radius[best as usize] {
                    c
                } else {
                    best
                }
            })
        })
        .collect();
    let mut out = Vec::new();
    for start in 0..n {
        let par = sk.parent[start];
        if par != NONE && main[par as usize] == start as u32 {
            continue;
        }
        let mut chain = vec![start as u32];
        let mut c = main[start];
        while c != NONE {
            chain.push(c);
            c = main[c as usize];
        }
        out.push(chain);
    }
    out
}

/// One tube: positions, normals, uvs and triangles with indices from 0.
fn tube(sk: &Skeleton, chain: &[u32]) -> Mesh {
    let mut pts: Vec<Vec3> = Vec::with_capacity(chain.len() + 1);
    let mut rad: Vec<f32> = Vec::with_capacity(chain.len() + 1);
    let first = chain[0] as usize;
    if sk.parent[first] != NONE {
        pts.push(sk.pos[sk.parent[first] as usize]);
        rad.push(sk.radius[first]);
    }
    for &c in chain {
        pts.push(sk.pos[c as usize]);
        rad.push(sk.radius[c as usize]);
    }
    let mut mesh = Mesh::default();
    if pts.len() < 2 {
        return mesh;
    }
    // The tip ring closes the tube to a narrow end just beyond the last node.
    let m = pts.len();
    let sides = sides_for(rad[0]);
    let ring = sides + 1;
    let mut normal_ref = Vec3::ZERO;
    let mut v = 0.0f32;
    for j in 0..m {
        let t = if j == 0 {
            pts[1] - pts[0]
        } else if j == m - 1 {
            pts[j] - pts[j - 1]
        } else {
            (pts[j + 1] - pts[j]).normalize_or_zero() + (pts[j] - pts[j - 1]).normalize_or_zero()
        }
        .normalize_or(Vec3::Y);
        if j == 0 {
            normal_ref = Frame::from_normal(t).s;
        } else {
            let seg = pts[j].distance(pts[j - 1]);
            v += seg / (TAU * 0.5 * (rad[j] + rad[j - 1]));
            let proj = normal_ref - t * t.dot(normal_ref);
            normal_ref = if proj.length_squared() > 1e-8 {
                proj.normalize()
            } else {
                Frame::from_normal(t).s
            };
        }
        let b = t.cross(normal_ref);
        for i in 0..ring {
            let phi = TAU * i as f32 / sides as f32;
            let d = normal_ref * phi.cos() + b * phi.sin();
            mesh.positions.push(pts[j] + d * rad[j]);
            mesh.normals.push(d);
            mesh.uvs.push(Vec2::new(i as f32 / sides as f32, v));
        }
    }
    for j in 0..m as u32 - 1 {
        for i in 0..sides {
            let a0 = j * ring + i;
            let a1 = a0 + 1;
            let b0 = a0 + ring;
            let b1 = b0 + 1;
            // Counter-clockwise seen from outside (normal = d, around the axis t).
            mesh.indices.push([a0, a1, b1]);
            mesh.indices.push([a0, b1, b0]);
        }
    }
    mesh
}

/// The branch mesh of a skeleton, material index 0.
pub fn branch_mesh(sk: &Skeleton) -> Mesh {
    let chains = chains(sk);
    let parts: Vec<Mesh> = chains.par_iter().map(|c| tube(sk, c)).collect();
    let nv: usize = parts.iter().map(|m| m.positions.len()).sum();
    let nt: usize = parts.iter().map(|m| m.indices.len()).sum();
    let mut mesh = Mesh {
        positions: Vec::with_capacity(nv),
        normals: Vec::with_capacity(nv),
        tangents: Vec::new(),
        uvs: Vec::with_capacity(nv),
        indices: Vec::with_capacity(nt),
        material: 0,
    };
    for part in parts {
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(part.positions);
        mesh.normals.extend(part.normals);
        mesh.uvs.extend(part.uvs);
        mesh.indices
            .extend(part.indices.iter().map(|t| t.map(|i| i + base)));
    }
    mesh
}

/// Periodic value noise on a `period × period` lattice (tiles seamlessly over `[0, period)`).
fn value_noise(x: f32, y: f32, period: (i64, i64), seed: u64) -> f32 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (sx, sy) = (fx * fx * (3.0 - 2.0 * fx), fy * fy * (3.0 - 2.0 * fy));
    let (ix, iy) = (x0 as i64, y0 as i64);
    let h = |i: i64, j: i64| {
        unit_f32(hash3(
            seed,
            i.rem_euclid(period.0) as u64,
            j.rem_euclid(period.1) as u64,
        ))
    };
    let a = h(ix, iy) + (h(ix + 1, iy) - h(ix, iy)) * sx;
    let b = h(ix, iy + 1) + (h(ix + 1, iy + 1) - h(ix, iy + 1)) * sx;
    a + (b - a) * sy
}

/// A tileable bark texture, `size × size` texels, linear RGB (brown-grey, furrowed).
///
/// Ridged noise stretched along the branch (`v`): vertical plates of grey-brown bark
/// separated by dark furrows, with finer cracks and lichen-grey mottling. Linear albedos
/// 0.03-0.25 (sRGB about 50-135 of 255), like dry bark.
pub fn bark_texture(size: u32, seed: u64) -> Texture {
    let size = size.max(8);
    let texels: Vec<Vec4> = (0..size * size)
        .into_par_iter()
        .map(|k| {
            let (px, py) = (k % size, k / size);
            let u = px as f32 / size as f32;
            let v = py as f32 / size as f32;
            // Ridges: stretched 3:1 along v, with a warp so the furrows meander.
            let warp = value_noise(u * 4.0, v * 4.0, (4, 4), seed ^ 7) - 0.5;
            let mut ridge = 0.0;
            let mut amp = 1.0;
            let mut norm = 0.0;
            for o in 0..4u32 {
                let f = 1u32 << o;
                let (pu, pv) = ((6 * f) as i64, (2 * f) as i64);
                let n = value_noise(
                    (u + 0.08 * warp) * pu as f32,
                    v * pv as f32,
                    (pu, pv),
                    seed.wrapping_add(o as u64),
                );
                ridge += amp * (1.0 - (2.0 * n - 1.0).abs());
                norm += amp;
                amp *= 0.5;
            }
            // Plates where the ridged value is high, narrow dark furrows where it is low.
            let r = ridge / norm;
            let x = ((r - 0.45) / 0.3).clamp(0.0, 1.0);
            let ridge = x * x * (3.0 - 2.0 * x);
            let mottle = value_noise(u * 8.0, v * 8.0, (8, 8), seed ^ 99);
            let grain = value_noise(u * 64.0, v * 64.0, (64, 64), seed ^ 5);
            let dark = Vec3::new(0.035, 0.027, 0.02);
            let plate = Vec3::new(0.16, 0.135, 0.11).lerp(Vec3::new(0.21, 0.2, 0.18), mottle);
            let c = dark.lerp(plate, ridge.clamp(0.0, 1.0)) * (0.85 + 0.3 * grain);
            c.extend(1.0)
        })
        .collect();
    Texture::from_texels(size, size, texels, Wrap::Repeat)
}
