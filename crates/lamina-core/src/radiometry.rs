//! What a scene measures besides its picture (canopy radiative transfer, RAMI-style): a
//! periodic domain, radiometric sensors, and which `[[object]]` every mesh and instance came
//! from (so absorbed power can be told per object).
//!
//! Conventions: `+y` is up; horizontal positions are `(x, z)` pairs; angles are degrees as
//! a user types them; a view direction's **zenith** is measured from `+y` and its
//! **relative azimuth** from the sun's azimuth (`0` = the sun's side: the hotspot is at
//! view zenith = sun zenith, relative azimuth 0). Values are per film channel: linear
//! Rec.709 R, G, B, or the bands of `[film] bands` when a render runs per band.

use crate::{Instance, Mesh};
use glam::{Vec2, Vec3};
use std::ops::Range;
use std::path::PathBuf;

/// The measurement side of a scene: periodic domain, sensors, object provenance.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Radiometry {
    /// The scene is one cell of an infinite periodic repetition (RAMI's infinite canopy).
    pub periodic: Option<Periodic>,
    /// Sensors, in file order.
    pub sensors: Vec<Sensor>,
    /// The `[[object]]` tables, in file order, and what each one added to the scene.
    pub objects: Vec<ObjectRecord>,
}

/// A horizontal rectangle `[min.x, max.x] × [min.y, max.y]` of world `(x, z)` (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    /// Smallest `(x, z)`.
    pub min: Vec2,
    /// Largest `(x, z)`.
    pub max: Vec2,
}

impl Rect {
    /// Area (m²).
    pub fn area(&self) -> f32 {
        let d = self.max - self.min;
        d.x * d.y
    }

    /// Size along x and z (m).
    pub fn size(&self) -> Vec2 {
        self.max - self.min
    }

    /// Whether `other` lies inside this rectangle (borders included).
    pub fn contains_rect(&self, other: &Rect) -> bool {
        other.min.cmpge(self.min).all() && other.max.cmple(self.max).all()
    }
}

/// A periodic domain: the scene's content over the cell `cell` (x, z) repeats without end
/// in both horizontal directions; rays that leave a side re-enter through the opposite one.
/// Objects that cross the cell's border are copied one cell over on the other side (so the
/// cell holds the whole periodic pattern); an object that spans the whole cell along an axis
/// (a ground plane) is cut at the cell's sides on that axis instead.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Periodic {
    /// The cell.
    pub cell: Rect,
}

/// Which meshes and instances one `[[object]]` table added.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectRecord {
    /// The object's `name` (or `object[i]`).
    pub name: String,
    /// Indices into `Scene::meshes`.
    pub meshes: Range<u32>,
    /// Indices into `Scene::instances`.
    pub instances: Range<u32>,
}

/// One sensor of `[[sensor]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Sensor {
    /// The sensor's `name` (or `sensor[i]`), for messages and progress.
    pub name: String,
    /// Monte Carlo samples: per view direction (`brf`), per grid cell and hemisphere
    /// (`irradiance`), photons in all (`absorbed`), per pixel (`fisheye`).
    pub samples: u32,
    /// Report only this film channel (index), in the single-value layout (RAMI's
    /// `brf std`); `None`: every channel.
    pub channel: Option<usize>,
    /// What it measures and where it writes.
    pub kind: SensorKind,
}

/// The sensor types.
#[derive(Clone, Debug, PartialEq)]
pub enum SensorKind {
    /// Bidirectional reflectance factor `BRF = π L / E` of the area `target` (HDRF when a sky
    /// lights the scene too), `L` the radiance leaving the area toward each view direction
    /// averaged over it, `E` the downwelling irradiance on it from the sun and sky.
    Brf {
        /// The area (default: the periodic cell).
        target: Option<Rect>,
        /// Each list of view directions and the CSV file it is written to.
        sweeps: Vec<BrfSweep>,
        /// A plot of every sweep with error bars, if wanted (PNG).
        plot: Option<PathBuf>,
    },
    /// Up- and downwelling irradiance (W m⁻²) on the horizontal plane `y = height` over
    /// `area` (default: the periodic cell), per cell of a `grid` over it.
    Irradiance {
        /// Height of the plane (m).
        height: f32,
        /// The area (default: the periodic cell).
        area: Option<Rect>,
        /// Cells along x and z.
        grid: [u32; 2],
        /// Output CSV file.
        file: PathBuf,
    },
    /// Power absorbed per material and per object, as fractions of the power the sun and sky
    /// bring onto `area` (default: the periodic cell; required without one): `albedo`,
    /// `fabs` (absorbed by everything but the ground), `ftran` (arriving at the ground,
    /// every order of scattering).
    Absorbed {
        /// The area photons enter through, at the top of the scene.
        area: Option<Rect>,
        /// Materials (indices into `Scene::materials`) that are the ground.
        ground: Vec<u32>,
        /// Output CSV file.
        file: PathBuf,
    },
    /// A hemispherical camera: an image of the hemisphere above (`up`) or below a point.
    Fisheye {
        /// The lens centre (m).
        position: Vec3,
        /// Looking up (`+y`) or down.
        up: bool,
        /// The lens projection.
        projection: FisheyeProjection,
        /// Image width and height (pixels; the hemisphere is the inscribed circle).
        resolution: u32,
        /// Output image (EXR or PNG).
        file: PathBuf,
        /// Gap fraction per 5° zenith ring (CSV), if wanted.
        gap_file: Option<PathBuf>,
    },
}

/// One list of BRF view directions.
#[derive(Clone, Debug, PartialEq)]
pub struct BrfSweep {
    /// A label for the plot (`principal plane`, `orthogonal plane`, `directions`).
    pub label: String,
    /// `(view zenith, relative azimuth)` in degrees, zenith in `[0, 90)`, as written to the
    /// CSV; `signed_zenith` is what the plot's axis shows.
    pub directions: Vec<BrfDirection>,
    /// Output CSV file.
    pub file: PathBuf,
}

/// One BRF view direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrfDirection {
    /// View zenith angle (degrees, 0 to < 90).
    pub zenith: f32,
    /// View azimuth relative to the sun's (degrees, [0, 360)).
    pub relative_azimuth: f32,
    /// The zenith signed as in a plane sweep (negative: the opposite half-plane).
    pub signed_zenith: f32,
}

/// How a fisheye lens maps zenith angle `θ` to image radius `r` (1 at the horizon).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FisheyeProjection {
    /// `r = θ / 90°`: equal zenith steps are equal radii (hemispherical photographs).
    Equidistant,
    /// `r = √2 sin(θ / 2)`: equal solid angles are equal areas.
    Equisolid,
}

impl FisheyeProjection {
    /// Image radius (0 at the axis, 1 at 90°) of zenith angle `theta` (radians).
    pub fn radius(self, theta: f32) -> f32 {
        match self {
            Self::Equidistant => theta / std::f32::consts::FRAC_PI_2,
            Self::Equisolid => std::f32::consts::SQRT_2 * (0.5 * theta).sin(),
        }
    }

    /// Zenith angle (radians) of image radius `r` in `[0, 1]`.
    pub fn theta(self, r: f32) -> f32 {
        match self {
            Self::Equidistant => r * std::f32::consts::FRAC_PI_2,
            Self::Equisolid => 2.0 * (r / std::f32::consts::SQRT_2).clamp(-1.0, 1.0).asin(),
        }
    }
}

/// The unit direction toward a viewer at `zenith` and azimuth `azimuth` (degrees; azimuth
/// measured as [`sun_azimuth_deg`] measures it).
pub fn direction_from_angles(zenith_deg: f32, azimuth_deg: f32) -> Vec3 {
    let (t, p) = (zenith_deg.to_radians(), azimuth_deg.to_radians());
    Vec3::new(t.sin() * p.sin(), t.cos(), t.sin() * p.cos())
}

/// The azimuth (degrees, `atan2(x, z)`) of a direction.
pub fn sun_azimuth_deg(dir: Vec3) -> f32 {
    dir.x.atan2(dir.z).to_degrees()
}

/// What a periodic domain adds to the scene so that the cell holds the whole pattern:
/// copies of the world-mesh triangles and of the instances that cross the cell's border
/// (or lie outside it), shifted by whole cells, and the height range of all geometry.
#[derive(Clone, Debug, Default)]
pub struct PeriodicCopies {
    /// Extra world meshes (the copied triangles of one scene mesh each) ...
    pub meshes: Vec<Mesh>,
    /// ... and the index of the scene mesh each copies from.
    pub mesh_origins: Vec<u32>,
    /// Extra instances, each with the index of the scene instance it copies.
    pub instances: Vec<(u32, Instance)>,
    /// Lowest and highest `y` of any geometry (m); `(0, 0)` for an empty scene.
    pub y_range: (f32, f32),
}

/// Why a scene cannot be made periodic.
#[derive(Clone, Debug, PartialEq)]
pub struct PeriodicError {
    /// The world mesh (index into `Scene::meshes`) or ...
    pub mesh: Option<u32>,
    /// ... the instance (index into `Scene::instances`) at fault.
    pub instance: Option<u32>,
    /// What is wrong.
    pub message: String,
}

/// The whole-cell shifts along one axis that put copies of an item spanning `[lo, hi]`
/// into the cell `[c0, c1]`, the first one bringing the item itself in (0 when its centre
/// is inside). One shift (0) for an item that covers the whole cell: it is cut at the
/// sides instead. An error for an item wider than the cell that does not cover it.
fn axis_shifts(lo: f32, hi: f32, c0: f32, c1: f32) -> Result<Vec<f32>, f32> {
    let l = c1 - c0;
    if lo <= c0 && hi >= c1 {
        return Ok(vec![0.0]);
    }
    if hi - lo > l {
        return Err(hi - lo);
    }
    let k = ((0.5 * (lo + hi) - c0) / l).floor();
    let base = -k * l;
    let mut v = vec![base];
    if lo + base < c0 {
        v.push(base + l);
    }
    if hi + base > c1 {
        v.push(base - l);
    }
    Ok(v)
}

/// Every `(dx, dz)` shift of an item with bounds `lo..hi` other than `(0, 0)`.
fn shifts(lo: Vec3, hi: Vec3, cell: &Rect) -> Result<Vec<Vec3>, (char, f32)> {
    let xs = axis_shifts(lo.x, hi.x, cell.min.x, cell.max.x).map_err(|w| ('x', w))?;
    let zs = axis_shifts(lo.z, hi.z, cell.min.y, cell.max.y).map_err(|w| ('z', w))?;
    let mut out = Vec::new();
    for &dx in &xs {
        for &dz in &zs {
            if dx != 0.0 || dz != 0.0 {
                out.push(Vec3::new(dx, 0.0, dz));
            }
        }
    }
    Ok(out)
}

fn too_wide(cell: &Rect, axis: char, width: f32) -> String {
    let size = cell.size();
    let cell_w = if axis == 'x' { size.x } else { size.y };
    format!(
        "is {width:.4} m wide along {axis}, more than the periodic cell ({cell_w:.4} m), without \
         spanning the whole cell: make the cell larger than every object (objects that span the \
         whole cell, such as a ground plane, are cut at its sides)"
    )
}

/// The lowest and highest `y` (m) of the scene's geometry (world meshes and placed
/// prototypes' bounding boxes); `(0, 0)` for an empty scene.
pub fn height_range(scene: &crate::Scene) -> (f32, f32) {
    let everything = Rect {
        min: Vec2::splat(-1e30),
        max: Vec2::splat(1e30),
    };
    periodic_copies(scene, &everything).map_or((0.0, 0.0), |c| c.y_range)
}

/// The copies a periodic `cell` needs in `scene` (see [`PeriodicCopies`]); an error names
/// the first mesh triangle or instance wider than the cell that does not span it.
pub fn periodic_copies(scene: &crate::Scene, cell: &Rect) -> Result<PeriodicCopies, PeriodicError> {
    let mut out = PeriodicCopies::default();
    let (mut ylo, mut yhi) = (f32::INFINITY, f32::NEG_INFINITY);
    for (mi, mesh) in scene.meshes.iter().enumerate() {
        let mut copy = Mesh {
            material: mesh.material,
            ..Mesh::default()
        };
        let copies_of = |idx: &[u32; 3], d: Vec3, copy: &mut Mesh| {
            let base = copy.positions.len() as u32;
            for &i in idx {
                let i = i as usize;
                copy.positions
                    .push(mesh.positions.get(i).copied().unwrap_or(Vec3::NAN) + d);
                if !mesh.normals.is_empty() {
                    copy.normals
                        .push(mesh.normals.get(i).copied().unwrap_or(Vec3::Z));
                }
                if mesh.tangents.len() == mesh.positions.len() && !mesh.normals.is_empty() {
                    copy.tangents.push(mesh.tangents[i]);
                }
                if !mesh.uvs.is_empty() {
                    copy.uvs
                        .push(mesh.uvs.get(i).copied().unwrap_or(Vec2::ZERO));
                }
            }
            copy.indices.push([base, base + 1, base + 2]);
        };
        for (ti, idx) in mesh.indices.iter().enumerate() {
            let p = idx.map(|i| mesh.positions.get(i as usize).copied());
            let [Some(a), Some(b), Some(c)] = p else {
                continue;
            };
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                continue;
            }
            let (lo, hi) = (a.min(b).min(c), a.max(b).max(c));
            ylo = ylo.min(lo.y);
            yhi = yhi.max(hi.y);
            let ds = shifts(lo, hi, cell).map_err(|(axis, w)| PeriodicError {
                mesh: Some(mi as u32),
                instance: None,
                message: format!("triangle {ti} {}", too_wide(cell, axis, w)),
            })?;
            for d in ds {
                copies_of(idx, d, &mut copy);
            }
        }
        if !copy.indices.is_empty() {
            out.meshes.push(copy);
            out.mesh_origins.push(mi as u32);
        }
    }
    let bounds: Vec<Option<(Vec3, Vec3)>> = scene
        .prototypes
        .iter()
        .map(|p| {
            let pts = p.meshes.iter().flat_map(|m| m.positions.iter());
            let (lo, hi) = pts
                .filter(|v| v.is_finite())
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| {
                    (lo.min(*v), hi.max(*v))
                });
            (lo.x <= hi.x).then_some((lo, hi))
        })
        .collect();
    for (ii, inst) in scene.instances.iter().enumerate() {
        let Some(Some((plo, phi))) = bounds.get(inst.prototype as usize) else {
            continue;
        };
        let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { plo.x } else { phi.x },
                if k & 2 == 0 { plo.y } else { phi.y },
                if k & 4 == 0 { plo.z } else { phi.z },
            );
            let w = inst.transform.transform_point3(c);
            lo = lo.min(w);
            hi = hi.max(w);
        }
        ylo = ylo.min(lo.y);
        yhi = yhi.max(hi.y);
        let ds = shifts(lo, hi, cell).map_err(|(axis, w)| PeriodicError {
            mesh: None,
            instance: Some(ii as u32),
            message: format!("its placement {}", too_wide(cell, axis, w)),
        })?;
        for d in ds {
            let mut copy = *inst;
            copy.transform.translation += glam::Vec3A::from(d);
            out.instances.push((ii as u32, copy));
        }
    }
    out.y_range = if ylo <= yhi { (ylo, yhi) } else { (0.0, 0.0) };
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shifts_copy_what_crosses_and_wrap_what_is_outside() {
        assert_eq!(axis_shifts(2.0, 3.0, 0.0, 10.0), Ok(vec![0.0]));
        assert_eq!(axis_shifts(-0.5, 0.5, 0.0, 10.0), Ok(vec![0.0, 10.0]));
        assert_eq!(axis_shifts(9.4, 10.4, 0.0, 10.0), Ok(vec![0.0, -10.0]));
        assert_eq!(axis_shifts(9.5, 10.5, 0.0, 10.0), Ok(vec![-10.0, 0.0]));
        assert_eq!(axis_shifts(12.0, 13.0, 0.0, 10.0), Ok(vec![-10.0]));
        assert_eq!(axis_shifts(-1.0, 11.0, 0.0, 10.0), Ok(vec![0.0]));
        assert_eq!(axis_shifts(0.5, 12.0, 0.0, 10.0), Err(11.5));
    }

    #[test]
    fn projections_invert() {
        for p in [FisheyeProjection::Equidistant, FisheyeProjection::Equisolid] {
            assert!((p.radius(std::f32::consts::FRAC_PI_2) - 1.0).abs() < 1e-6);
            for i in 0..=10 {
                let t = i as f32 * 0.15;
                assert!((p.theta(p.radius(t)) - t).abs() < 1e-5, "{p:?} {t}");
            }
        }
    }

    #[test]
    fn angles_round_trip() {
        let d = direction_from_angles(30.0, 120.0);
        assert!((d.length() - 1.0).abs() < 1e-6);
        assert!((d.y.acos().to_degrees() - 30.0).abs() < 1e-4);
        assert!((sun_azimuth_deg(d) - 120.0).abs() < 1e-4);
    }
}
