//! Leaves along the twigs.
//!
//! *Twigs* are the skeleton segments within a few growth steps of a tip (the outer shell of
//! the crown). The target leaf count is spread over them in proportion to their length,
//! exactly (cumulative rounding). Along each twig the leaves follow a phyllotactic spiral:
//! leaf `k` sits at azimuth `φ₀ + k·divergence` around the twig axis, the counter carried on
//! from the mother segment. Each leaf:
//! 1. leaves the twig on a short petiole, its blade inclined ~50° forward from the axis;
//! 2. its natural adaxial normal faces the twig's apex side; phototropism blends it toward
//!    the light (`normal = nlerp(natural, light, phototropism)`), and the blade axis is made
//!    perpendicular to it;
//! 3. is twisted and yawed at random (less with strong phototropism);
//! 4. droops: blade and normal rotate together about the horizontal axis across the blade,
//!    its tip toward the ground, by up to `gravitropism × 60°`;
//! 5. gets a size `species size × leaf_scale × (1 ± variation)` and one of the variants.
//!
//! Everything per leaf comes from a hash of (seed, leaf index), so the result does not
//! depend on the number of threads.

use crate::params::Resolved;
use crate::rng::{hash3, unit_f32};
use crate::skeleton::{NONE, Skeleton};
use glam::{Quat, Vec2, Vec3};
use lamina_core::cards::LeafCard;
use rayon::prelude::*;

/// Leaf cards per variant.
pub fn place_leaves(p: &Resolved, sk: &Skeleton, sizes: &[Vec2]) -> Vec<Vec<LeafCard>> {
    let n = sk.pos.len();
    let zone = (6.0 * sk.step).max(0.05 * p.crown_radius);
    // Leafy segments and their lengths.
    let segs: Vec<u32> = (0..n as u32)
        .filter(|&i| sk.parent[i as usize] != NONE && sk.tip_distance[i as usize] <= zone)
        .collect();
    let mut variants: Vec<Vec<LeafCard>> = vec![Vec::new(); sizes.len()];
    if segs.is_empty() {
        return variants;
    }
    let lengths: Vec<f64> = segs
        .iter()
        .map(|&i| {
            let i = i as usize;
            sk.pos[i].distance(sk.pos[sk.parent[i] as usize]) as f64 + 1e-9
        })
        .collect();
    let total: f64 = lengths.iter().sum();
    let target = p.leaf_count as f64;
    // Exact cumulative rounding: counts sum to the target.
    let mut counts = vec![0u32; n];
    let mut first = vec![0u64; segs.len()];
    let mut cum = 0.0f64;
    let mut placed = 0u64;
    for (k, (&i, &l)) in segs.iter().zip(&lengths).enumerate() {
        cum += l;
        let upto = ((cum / total) * target).round() as u64;
        first[k] = placed;
        counts[i as usize] = (upto - placed) as u32;
        placed = upto;
    }
    // Phyllotactic counter carried along the branches (parents come first).
    let mut phyllo = vec![0u32; n];
    for i in 0..n {
        let par = sk.parent[i];
        if par != NONE {
            phyllo[i] = phyllo[par as usize].wrapping_add(counts[par as usize]);
        }
    }
    let light = p.light_direction;
    let leaves: Vec<(u8, LeafCard)> = segs
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, &i)| {
            let i = i as usize;
            let a = sk.pos[sk.parent[i] as usize];
            let b = sk.pos[i];
            let count = counts[i];
            let t = (b - a).normalize_or(Vec3::Y);
            let reference = if t.y.abs() < 0.95 { Vec3::Y } else { Vec3::X };
            let s = t.cross(reference).normalize();
            let w = t.cross(s);
            let r_node = sk.radius[i];
            let base_index = first[k];
            let phase = phyllo[i];
            (0..count).map(move |j| {
                let h = hash3(p.seed, 0x1EAF, base_index + j as u64);
                let h2 = hash3(p.seed, 0x1EAF2, base_index + j as u64);
                let r = |shift: u32| unit_f32(h >> shift);
                let r2 = |shift: u32| unit_f32(h2 >> shift);
                let h3 = hash3(p.seed, 0x1EAF3, base_index + j as u64);
                let variant = ((h3 >> 32) % sizes.len() as u64) as usize;
                let f = (j as f32 + 0.5 + 0.6 * (r(0) - 0.5)) / count as f32;
                let at = a.lerp(b, f);
                let phi = (phase.wrapping_add(j)) as f32 * p.phyllotaxis + 0.15 * (r(21) - 0.5);
                let out = s * phi.cos() + w * phi.sin();
                let incline = (40.0 + 25.0 * r(42)).to_radians();
                let tip0 = (t * incline.cos() + out * incline.sin()).normalize();
                // Natural adaxial side: toward the twig's apex.
                let mut n0 = t - tip0 * t.dot(tip0);
                if n0.length_squared() < 1e-8 {
                    n0 = Vec3::Y - tip0 * tip0.y;
                }
                let n0 = n0.normalize_or(Vec3::Y);
                // Phototropism.
                let mut normal = n0.lerp(light, p.phototropism);
                if normal.length_squared() < 1e-6 {
                    normal = light;
                }
                let normal = normal.normalize();
                let mut tip = tip0 - normal * tip0.dot(normal);
                if tip.length_squared() < 1e-8 {
                    tip = out - normal * out.dot(normal);
                }
                let mut tip = tip.normalize_or(normal.any_orthonormal_vector());
                let mut normal = normal;
                // Twist about the blade axis and yaw about the normal.
                let freedom = 1.0 - 0.6 * p.phototropism;
                let twist = Quat::from_axis_angle(tip, (r2(0) - 0.5) * 0.9 * freedom);
                normal = twist * normal;
                let yaw = Quat::from_axis_angle(normal, (r2(21) - 0.5) * 0.6);
                tip = yaw * tip;
                // Droop under gravity.
                let axis = tip.cross(Vec3::NEG_Y);
                if axis.length_squared() > 1e-8 && p.gravitropism > 0.0 {
                    let room = tip.dot(Vec3::NEG_Y).clamp(-1.0, 1.0).acos();
                    let angle = (p.gravitropism * 60f32.to_radians() * (0.6 + 0.8 * r2(42)))
                        .min(room * 0.9);
                    let q = Quat::from_axis_angle(axis.normalize(), angle);
                    tip = q * tip;
                    normal = q * normal;
                }
                // Re-orthonormalise.
                let normal = normal.normalize();
                let up =
                    (tip - normal * tip.dot(normal)).normalize_or(normal.any_orthonormal_vector());
                let size = sizes[variant]
                    * p.leaf_scale
                    * (1.0 + p.leaf_size_variation * (2.0 * unit_f32(h3) - 1.0)).max(0.05);
                let petiole = 0.12 * size.y;
                let mut center = at + out * (r_node + petiole) + up * (0.5 * size.y);
                let right = up.cross(normal);
                let low = center.y - 0.5 * size.y * up.y.abs() - 0.5 * size.x * right.y.abs();
                if low < 0.005 {
                    center.y += 0.005 - low;
                }
                (
                    variant as u8,
                    LeafCard {
                        center,
                        normal,
                        up,
                        width: size.x,
                        height: size.y,
                    },
                )
            })
        })
        .collect();
    for v in variants.iter_mut() {
        v.reserve(leaves.len() / sizes.len() + 16);
    }
    for (v, card) in leaves {
        variants[v as usize].push(card);
    }
    variants
}
