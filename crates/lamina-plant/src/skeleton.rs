//! The branching skeleton by space colonisation (Runions, Lane & Prusinkiewicz 2007,
//! "Modeling Trees with a Space Colonization Algorithm").
//!
//! * Attraction points fill the crown envelope (biased toward its surface, where a real
//!   crown carries its foliage).
//! * Each iteration, every live point is associated with its nearest node within the
//!   *influence distance* `di`; each node with points grows a new node one step `D` along
//!   the mean unit direction to its points (plus a weak tropism and a little jitter);
//!   points with a node closer than the *kill distance* `dk` are removed.
//! * Scaling: points are bucketed once in a uniform grid of cell `di`. A point caches its
//!   nearest node; only the nodes created in the last iteration are tested against the
//!   points around them, so an iteration costs O(new nodes × points within `di`) plus a
//!   pass over the live points, and the whole growth is O(N) in the number of points.
//! * Lateral branches are bent into `[0.6, 1] × branch_angle` from their mother branch;
//!   continuations bend at most 25° per step.
//! * Radii follow the pipe model: `r^a = Σ r_child^a` with every tip one unit pipe, scaled so
//!   the thickest stem has the trunk radius, floored at the twig radius.

use crate::params::{CrownShape, PlantKind, Resolved};
use crate::rng::{Rng, hash3, unit_f32};
use glam::{IVec3, Vec3};
use std::f32::consts::TAU;

/// No node.
pub const NONE: u32 = u32::MAX;

/// The grown skeleton: nodes in creation order (every parent before its children).
#[derive(Clone, Debug, Default)]
pub struct Skeleton {
    /// Node positions (m).
    pub pos: Vec<Vec3>,
    /// Parent of each node, [`NONE`] for the base of a stem.
    pub parent: Vec<u32>,
    /// Radius of the segment from the parent to the node (m); at the node for a stem base.
    pub radius: Vec<f32>,
    /// Children of node `i` are `child_list[child_start[i]..child_start[i + 1]]`.
    pub child_start: Vec<u32>,
    /// See [`Skeleton::child_start`].
    pub child_list: Vec<u32>,
    /// Longest distance (m) from the node to a tip of its subtree.
    pub tip_distance: Vec<f32>,
    /// Growth step `D` (m).
    pub step: f32,
}

impl Skeleton {
    /// The children of node `i`.
    pub fn children(&self, i: usize) -> &[u32] {
        &self.child_list[self.child_start[i] as usize..self.child_start[i + 1] as usize]
    }
}

/// The crown envelope.
struct Envelope {
    shape: CrownShape,
    center: Vec3,
    /// Horizontal radius, vertical half-height (ellipsoid), base y and top y.
    radius: f32,
    half_h: f32,
    y0: f32,
    y1: f32,
    /// Directions of the crown's lobes (an irregular, lumpy outline).
    lobes: Vec<Vec3>,
}

impl Envelope {
    fn new(p: &Resolved) -> Self {
        let y0 = p.height * p.crown_base;
        let y1 = p.height;
        let (center_y, half_h) = match p.crown_shape {
            CrownShape::Dome => (y0, y1 - y0),
            _ => (0.5 * (y0 + y1), 0.5 * (y1 - y0)),
        };
        let mut rng = Rng::new(p.seed, 2);
        let lobes = (0..12)
            .map(|_| {
                let z = 2.0 * rng.f32() - 1.0;
                let phi = TAU * rng.f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                Vec3::new(r * phi.cos(), z.abs() * 0.8 + 0.2, r * phi.sin()).normalize()
            })
            .collect();
        Envelope {
            lobes,
            shape: p.crown_shape,
            center: Vec3::new(0.0, center_y, 0.0),
            radius: p.crown_radius,
            half_h,
            y0,
            y1,
        }
    }

    fn volume(&self) -> f32 {
        let h = self.y1 - self.y0;
        let r2 = self.radius * self.radius;
        match self.shape {
            CrownShape::Ellipsoid => 4.0 / 3.0 * std::f32::consts::PI * r2 * self.half_h,
            CrownShape::Dome => 2.0 / 3.0 * std::f32::consts::PI * r2 * self.half_h,
            CrownShape::Cone => std::f32::consts::PI * r2 * h / 3.0,
        }
    }

    /// A point in the envelope, biased toward its surface: a direction and a relative
    /// radius `s = u^(1/5)` (uniform in volume would be `u^(1/3)`).
    fn sample(&self, rng: &mut Rng) -> Vec3 {
        let s = rng.f32().powf(0.2);
        match self.shape {
            CrownShape::Ellipsoid | CrownShape::Dome => {
                let z = if self.shape == CrownShape::Dome {
                    rng.f32()
                } else {
                    2.0 * rng.f32() - 1.0
                };
                let phi = TAU * rng.f32();
                let rxy = (1.0 - z * z).max(0.0).sqrt();
                let dir = Vec3::new(rxy * phi.cos(), z, rxy * phi.sin());
                let lump = self
                    .lobes
                    .iter()
                    .map(|c| dir.dot(*c).max(0.0).powi(4))
                    .fold(0.0f32, f32::max);
                let d = dir * (s * (0.68 + 0.32 * lump));
                self.center + Vec3::new(d.x * self.radius, d.y * self.half_h, d.z * self.radius)
            }
            CrownShape::Cone => {
                // Height fraction t with density ∝ (1 - t)² (cone cross-section), radius
                // biased outward.
                let t = 1.0 - rng.f32().cbrt();
                let r = self.radius * (1.0 - t) * s;
                let phi = TAU * rng.f32();
                Vec3::new(
                    r * phi.cos(),
                    self.y0 + t * (self.y1 - self.y0),
                    r * phi.sin(),
                )
            }
        }
    }
}

/// Uniform grid over the attraction points (CSR buckets).
struct PointGrid {
    origin: Vec3,
    inv_cell: f32,
    dims: IVec3,
    start: Vec<u32>,
    items: Vec<u32>,
}

impl PointGrid {
    fn new(points: &[Vec3], cell: f32) -> Self {
        let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
        for p in points {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        // Cap the grid at 2^21 cells: cells grow if the points are spread very thinly.
        let mut cell = cell.max(1e-4);
        let extent = (hi - lo).max(Vec3::splat(1e-3));
        while ((extent / cell).ceil() + 1.0).element_product() > (1u32 << 21) as f32 {
            cell *= 1.25;
        }
        let dims = ((extent / cell).ceil().as_ivec3() + IVec3::ONE).max(IVec3::ONE);
        let mut grid = PointGrid {
            origin: lo,
            inv_cell: 1.0 / cell,
            dims,
            start: vec![0; (dims.x * dims.y * dims.z) as usize + 1],
            items: vec![0; points.len()],
        };
        for p in points {
            let c = grid.cell_index(grid.cell_of(*p));
            grid.start[c + 1] += 1;
        }
        for i in 1..grid.start.len() {
            grid.start[i] += grid.start[i - 1];
        }
        let mut fill = grid.start.clone();
        for (i, p) in points.iter().enumerate() {
            let c = grid.cell_index(grid.cell_of(*p));
            grid.items[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        grid
    }

    fn cell_of(&self, p: Vec3) -> IVec3 {
        ((p - self.origin) * self.inv_cell)
            .floor()
            .as_ivec3()
            .clamp(IVec3::ZERO, self.dims - 1)
    }

    fn cell_index(&self, c: IVec3) -> usize {
        ((c.z * self.dims.y + c.y) * self.dims.x + c.x) as usize
    }

    /// Calls `f` with every point index in the cells overlapping the ball (`p`, `r`).
    fn for_each_near(&self, p: Vec3, r: f32, mut f: impl FnMut(u32)) {
        let a = ((p - r - self.origin) * self.inv_cell).floor().as_ivec3();
        let b = ((p + r - self.origin) * self.inv_cell).floor().as_ivec3();
        if b.x < 0
            || b.y < 0
            || b.z < 0
            || a.x >= self.dims.x
            || a.y >= self.dims.y
            || a.z >= self.dims.z
        {
            return;
        }
        let a = a.max(IVec3::ZERO);
        let b = b.min(self.dims - 1);
        for z in a.z..=b.z {
            for y in a.y..=b.y {
                let row = self.cell_index(IVec3::new(a.x, y, z));
                let end = self.cell_index(IVec3::new(b.x, y, z));
                for &i in &self.items[self.start[row] as usize..self.start[end + 1] as usize] {
                    f(i);
                }
            }
        }
    }
}

/// Rotates `d` so that its angle to unit `axis` lies in `[lo, hi]` (radians).
fn clamp_angle(d: Vec3, axis: Vec3, lo: f32, hi: f32, fallback: Vec3) -> Vec3 {
    let c = d.dot(axis).clamp(-1.0, 1.0);
    let angle = c.acos();
    if angle >= lo && angle <= hi {
        return d;
    }
    let mut perp = d - axis * c;
    if perp.length_squared() < 1e-10 {
        perp = fallback - axis * fallback.dot(axis);
        if perp.length_squared() < 1e-10 {
            perp = lamina_leaf::frame::Frame::from_normal(axis).s;
        }
    }
    let perp = perp.normalize();
    let a = angle.clamp(lo, hi);
    (axis * a.cos() + perp * a.sin()).normalize()
}

/// Grows the skeleton for the resolved parameters.
pub fn grow(p: &Resolved) -> Skeleton {
    let mut rng = Rng::new(p.seed, 1);
    let env = Envelope::new(p);
    let n_points = p.attraction_points as usize;
    let points: Vec<Vec3> = (0..n_points).map(|_| env.sample(&mut rng)).collect();
    // Mean spacing of the points sets the step, kill and influence distances.
    let spacing = (env.volume() / n_points as f32).cbrt();
    let step = 0.45 * spacing;
    let kill = 1.0 * spacing;
    let influence = (4.0 * spacing).max(0.04 * p.height);
    let grid = PointGrid::new(&points, influence);

    let mut pos: Vec<Vec3> = Vec::new();
    let mut parent: Vec<u32> = Vec::new();
    let tropism = match p.kind {
        PlantKind::Tree => Vec3::Y * 0.12,
        PlantKind::Bush => Vec3::Y * 0.08,
    } - Vec3::Y * (0.1 * p.gravitropism);

    // Stems: straight (slightly leaning) chains up to where the crown takes over.
    let stem_top = match p.kind {
        PlantKind::Tree => (env.y0 + 0.08 * (env.y1 - env.y0)).min(env.y1 - 2.0 * step),
        PlantKind::Bush => (0.18 * p.height).max(env.y0),
    };
    for s in 0..p.stems {
        let (base, dir) = if p.stems == 1 {
            let lean = 0.04 * rng.f32();
            let phi = TAU * rng.f32();
            (
                Vec3::ZERO,
                Vec3::new(lean * phi.cos(), 1.0, lean * phi.sin()).normalize(),
            )
        } else {
            let phi = TAU * (s as f32 + 0.35 * rng.f32()) / p.stems as f32;
            let tilt = (12.0 + 22.0 * rng.f32()).to_radians();
            let out = Vec3::new(phi.cos(), 0.0, phi.sin());
            (
                out * (0.015 * p.height * rng.f32()),
                (Vec3::Y * tilt.cos() + out * tilt.sin()).normalize(),
            )
        };
        let len = (stem_top - base.y) / dir.y.max(0.2) * (0.8 + 0.2 * rng.f32());
        let n = (len / step).ceil().max(1.0) as usize;
        let seg = len / n as f32;
        pos.push(base);
        parent.push(NONE);
        for k in 1..=n {
            let wobble = Vec3::new(rng.f32() - 0.5, 0.0, rng.f32() - 0.5) * (0.15 * seg);
            let prev = *pos.last().unwrap_or(&base);
            pos.push(prev + dir * seg + wobble * (k as f32 / n as f32));
            parent.push((pos.len() - 2) as u32);
        }
    }

    // Space colonisation.
    let mut alive = vec![true; n_points];
    let mut live: Vec<u32> = (0..n_points as u32).collect();
    let mut nearest = vec![NONE; n_points];
    let mut nearest_d2 = vec![f32::MAX; n_points];
    let mut first_child: Vec<u32> = vec![NONE; pos.len()];
    let mut next_sibling: Vec<u32> = vec![NONE; pos.len()];
    for i in 0..pos.len() {
        if parent[i] != NONE {
            first_child[parent[i] as usize] = i as u32;
        }
    }
    let mut acc: Vec<Vec3> = vec![Vec3::ZERO; pos.len()];
    let mut touched: Vec<u32> = Vec::new();
    let (kill2, infl2) = (kill * kill, influence * influence);
    let extent = 2.0 * env.radius.max(env.y1);
    let max_iter = (4.0 * extent / step) as usize + 100;
    let mut new_from = 0usize;
    let mut reached = false;
    for iter in 0..max_iter {
        // Update the nearest-node cache with the nodes made last iteration; kill points.
        for (n, &q) in pos.iter().enumerate().skip(new_from) {
            grid.for_each_near(q, influence, |i| {
                let i = i as usize;
                if !alive[i] {
                    return;
                }
                let d2 = points[i].distance_squared(q);
                if d2 < kill2 {
                    alive[i] = false;
                } else if d2 < infl2 && d2 < nearest_d2[i] {
                    nearest_d2[i] = d2;
                    nearest[i] = n as u32;
                }
            });
        }
        new_from = pos.len();
        live.retain(|&i| alive[i as usize]);
        if live.is_empty() {
            break;
        }
        for &i in &live {
            let n = nearest[i as usize];
            if n == NONE {
                continue;
            }
            let d = (points[i as usize] - pos[n as usize]).normalize_or_zero();
            if acc[n as usize] == Vec3::ZERO {
                touched.push(n);
            }
            acc[n as usize] += d + Vec3::splat(1e-7);
        }
        if touched.is_empty() {
            // Nothing in reach: extend the tips of the stems upward (a tree's trunk before
            // its crown) until some point is within the influence distance.
            if reached {
                break;
            }
            let tips: Vec<u32> = (0..pos.len() as u32)
                .filter(|&i| first_child[i as usize] == NONE)
                .collect();
            let mut grew = false;
            for t in tips {
                if pos[t as usize].y < env.y1 {
                    let dir = if parent[t as usize] != NONE {
                        (pos[t as usize] - pos[parent[t as usize] as usize]).normalize()
                    } else {
                        Vec3::Y
                    };
                    let dir = (dir + Vec3::Y).normalize();
                    let q = pos[t as usize] + dir * step;
                    add_node(
                        &mut pos,
                        &mut parent,
                        &mut first_child,
                        &mut next_sibling,
                        &mut acc,
                        t,
                        q,
                    );
                    grew = true;
                }
            }
            if !grew {
                break;
            }
            continue;
        }
        reached = true;
        touched.sort_unstable();
        for &n in &touched {
            let nu = n as usize;
            let sum = acc[nu];
            acc[nu] = Vec3::ZERO;
            let h = hash3(p.seed, n as u64, iter as u64);
            let jitter = Vec3::new(
                unit_f32(h) - 0.5,
                unit_f32(h >> 21) - 0.5,
                unit_f32(h >> 42) - 0.5,
            );
            let mut dir = (sum.normalize_or_zero() + tropism + jitter * 0.12).normalize_or_zero();
            if dir == Vec3::ZERO {
                continue;
            }
            let par = parent[nu];
            if par != NONE {
                let axis = (pos[nu] - pos[par as usize]).normalize_or_zero();
                if axis != Vec3::ZERO {
                    dir = if first_child[nu] == NONE {
                        clamp_angle(dir, axis, 0.0, 25f32.to_radians(), jitter)
                    } else {
                        clamp_angle(dir, axis, 0.6 * p.branch_angle, p.branch_angle, jitter)
                    };
                }
            }
            // Do not grow a twin of an existing child (points symmetric about the node).
            let mut c = first_child[nu];
            let mut twin = false;
            while c != NONE {
                if (pos[c as usize] - pos[nu]).normalize_or_zero().dot(dir) > 0.985 {
                    twin = true;
                    break;
                }
                c = next_sibling[c as usize];
            }
            if twin {
                continue;
            }
            let q = pos[nu] + dir * step;
            add_node(
                &mut pos,
                &mut parent,
                &mut first_child,
                &mut next_sibling,
                &mut acc,
                n,
                q,
            );
        }
        touched.clear();
        if pos.len() == new_from {
            break;
        }
    }

    finish(p, pos, parent, step)
}

fn add_node(
    pos: &mut Vec<Vec3>,
    parent: &mut Vec<u32>,
    first_child: &mut Vec<u32>,
    next_sibling: &mut Vec<u32>,
    acc: &mut Vec<Vec3>,
    par: u32,
    q: Vec3,
) {
    let id = pos.len() as u32;
    pos.push(q);
    parent.push(par);
    next_sibling.push(first_child[par as usize]);
    first_child[par as usize] = id;
    first_child.push(NONE);
    acc.push(Vec3::ZERO);
}

/// Smoothing, children lists, pipe-model radii and tip distances.
fn finish(p: &Resolved, mut pos: Vec<Vec3>, parent: Vec<u32>, step: f32) -> Skeleton {
    let n = pos.len();
    let mut child_start = vec![0u32; n + 1];
    for &par in &parent {
        if par != NONE {
            child_start[par as usize + 1] += 1;
        }
    }
    for i in 1..=n {
        child_start[i] += child_start[i - 1];
    }
    let mut fill = child_start.clone();
    let mut child_list = vec![0u32; child_start[n] as usize];
    for (i, &par) in parent.iter().enumerate() {
        if par != NONE {
            child_list[fill[par as usize] as usize] = i as u32;
            fill[par as usize] += 1;
        }
    }
    let children = |i: usize| &child_list[child_start[i] as usize..child_start[i + 1] as usize];

    // Two passes of Laplacian smoothing along the branches (stem bases stay put).
    for _ in 0..2 {
        let prev = pos.clone();
        for i in 0..n {
            let par = parent[i];
            if par == NONE {
                continue;
            }
            let ch = children(i);
            if ch.is_empty() {
                continue;
            }
            let mean_child = ch.iter().map(|&c| prev[c as usize]).sum::<Vec3>() / ch.len() as f32;
            let target = 0.5 * (prev[par as usize] + mean_child);
            pos[i] = prev[i].lerp(target, 0.5);
        }
    }

    // Pipe model, tips one unit: u^a = Σ u_child^a, i.e. u = (tips below)^(1/a).
    let a = p.pipe_exponent;
    let mut pipe = vec![0.0f32; n]; // Σ of r^a
    let mut tip_distance = vec![0.0f32; n];
    for i in (0..n).rev() {
        if pipe[i] == 0.0 {
            pipe[i] = 1.0;
        }
        let par = parent[i];
        if par != NONE {
            let pu = par as usize;
            pipe[pu] += pipe[i];
            let d = tip_distance[i] + pos[i].distance(pos[pu]);
            tip_distance[pu] = tip_distance[pu].max(d);
        }
    }
    let max_root = (0..n)
        .filter(|&i| parent[i] == NONE)
        .map(|i| pipe[i])
        .fold(1.0f32, f32::max);
    let scale = p.trunk_radius / max_root.powf(1.0 / a);
    let radius = pipe
        .iter()
        .map(|&u| (scale * u.powf(1.0 / a)).max(p.twig_radius))
        .collect();
    Skeleton {
        pos,
        parent,
        radius,
        child_start,
        child_list,
        tip_distance,
        step,
    }
}
