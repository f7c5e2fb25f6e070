//! Where an object goes: its transform (`transform = { ... }` or the same keys on the
//! object), its placements (`instances`, `instances_file`), and the checks that keep every
//! placed vertex within the size limits.

use super::Geometry;
use crate::dict::{Dict, Keys, Kind, S, Value};
use crate::error::SceneError;
use crate::scene::{Instance, Prototype};
use crate::transform::Transform;
use glam::Vec3;
use std::ops::Range;

/// The keys of a transform table (`transform = { ... }`, each entry of `instances`).
pub(crate) const TRANSFORM: Keys = Keys::plain(&[
    ("scale", Kind::Color),
    ("rotate_x", Kind::Num),
    ("rotate_y", Kind::Num),
    ("rotate_z", Kind::Num),
    ("translate", Kind::Vec3),
]);

/// The transform parts as given: scale, rotations about x, y, z (degrees), translation (m).
type Parts = (Option<S<Vec3>>, Vec3, Option<S<Vec3>>);

/// The transform parts in dictionary `d`, as given.
fn parts(d: &Dict) -> Result<Parts, SceneError> {
    let scale = d.raw_scale("scale")?;
    let angle = |k: &str| Ok::<_, SceneError>(d.raw_float(k)?.map_or(0.0, |v| v.into_inner()));
    let rot = Vec3::new(angle("rotate_x")?, angle("rotate_y")?, angle("rotate_z")?);
    let translate = d.raw_vec3("translate")?;
    Ok((scale, rot, translate))
}

/// A transform table (`transform = { ... }` or one placement) named `at`.
fn table_transform(d: &Dict, v: &S<Value>, at: String) -> Result<Transform, SceneError> {
    let Value::Table(t) = v.get_ref() else {
        return Err(d.ld.err(
            v.span(),
            at,
            format!(
                "must be a table of transform keys, got {}",
                v.get_ref().type_name()
            ),
        ));
    };
    let td = Dict::open(d.ld, at.clone(), None, v.span(), t, TRANSFORM)?;
    let (scale, rot, tr) = parts(&td)?;
    td.finish()?;
    let scale = scale.map_or(Vec3::ONE, |s| s.into_inner());
    let tr = tr.map_or(Vec3::ZERO, |t| t.into_inner());
    d.ld.transform_parts(scale, rot, tr, v.span(), &at)
}

/// The object's transform: `transform = { ... }` or the same keys on the object itself.
pub(crate) fn object_transform(d: &Dict) -> Result<Transform, SceneError> {
    let inline: Vec<Range<usize>> = TRANSFORM
        .own
        .iter()
        .filter_map(|(k, _)| d.get(k).map(|v| v.span()))
        .collect();
    let transform = d.get("transform");
    let Some(first) = inline.first().cloned() else {
        return match transform {
            None => Ok(Transform::default()),
            Some(t) => table_transform(d, t, d.key("transform")),
        };
    };
    if let Some(t) = transform {
        return Err(d.err(
            t.span(),
            "transform",
            "give the transform either as 'transform = { ... }' or as scale/rotate_x/rotate_y/rotate_z/translate keys on the object, not both",
        ));
    }
    let (scale, rot, tr) = parts(d)?;
    let scale_span = scale.as_ref().map(|s| s.span());
    let tr_span = tr.as_ref().map(|s| s.span());
    let scale = scale.map_or(Vec3::ONE, |s| s.into_inner());
    let tr = tr.map_or(Vec3::ZERO, |t| t.into_inner());
    crate::instances::checked_transform(scale, rot, tr).map_err(|(k, m)| {
        let span = match k {
            "scale" => scale_span,
            "translate" => tr_span,
            _ => None,
        };
        d.err(span.unwrap_or(first), k, m)
    })
}

/// The object's placements when it has `instances` and/or `instances_file`.
pub(crate) fn placements(d: &Dict) -> Result<Option<Vec<glam::Affine3A>>, SceneError> {
    let rows = d.array("instances")?;
    let file = d.string("instances_file")?;
    if rows.is_none() && file.is_none() {
        return Ok(None);
    }
    let mut out = Vec::new();
    if let Some(rows) = &rows {
        for (j, row) in rows.get_ref().iter().enumerate() {
            let t = table_transform(d, row, d.key(&format!("instances[{j}]")))?;
            out.push(crate::instances::affine(&t));
        }
    }
    if let Some(f) = &file {
        let left =
            d.ld.budgets
                .instances
                .saturating_sub(d.ld.instances.get())
                .saturating_sub(out.len());
        let rows = crate::instances::read_instances_csv_capped(&d.ld.path(f.get_ref()), left)?;
        out.extend(rows.iter().map(crate::instances::affine));
    }
    if out.is_empty() {
        return Err(d.err(
            d.span.clone(),
            "instances",
            "no placements: give at least one (or drop 'instances' to place the object once)",
        ));
    }
    if out.len() > crate::instances::MAX_INSTANCES {
        return Err(d.err(
            d.span.clone(),
            "instances",
            format!(
                "{} instances is more than the {} supported",
                out.len(),
                crate::instances::MAX_INSTANCES
            ),
        ));
    }
    Ok(Some(out))
}

/// Places an object's geometry at every placement. Its world-space meshes become one
/// prototype `name`, placed once per placement. Its own prototypes (glTF meshes used by
/// several nodes, curved leaves of a plant) stay prototypes, and every one of their
/// instances is composed with every placement: the renderers' instancing stays two
/// levels deep (a placement × inner instance pair costs one instance record), while the
/// geometry still exists once.
pub(crate) fn place(
    d: &Dict,
    name: String,
    geometry: Geometry,
    placements: &[glam::Affine3A],
) -> Result<Geometry, SceneError> {
    let per_placement = geometry.instances.len() + usize::from(!geometry.meshes.is_empty());
    let total = per_placement.saturating_mul(placements.len());
    if total > crate::instances::MAX_INSTANCES {
        return Err(d.err(
            d.span.clone(),
            "instances",
            format!(
                "{} placements x {per_placement} instances each = {total} instances, more \
                 than the {} supported",
                placements.len(),
                crate::instances::MAX_INSTANCES
            ),
        ));
    }
    // The scene-wide total, before the allocation.
    d.ld.check_instances(d.span.clone(), &d.key("instances"), total)?;
    let mut prototypes = geometry.prototypes;
    let outer = (!geometry.meshes.is_empty()).then(|| {
        prototypes.push(Prototype {
            name,
            meshes: geometry.meshes,
        });
        prototypes.len() as u32 - 1
    });
    let mut instances = Vec::with_capacity(total);
    for place in placements {
        if let Some(prototype) = outer {
            instances.push(Instance {
                prototype,
                transform: *place,
            });
        }
        instances.extend(geometry.instances.iter().map(|i| Instance {
            prototype: i.prototype,
            transform: *place * i.transform,
        }));
    }
    Ok(Geometry {
        meshes: Vec::new(),
        prototypes,
        instances,
    })
}

/// Rejects geometry that, once placed, lies beyond ±[`crate::instances::MAX_COORD`] m
/// or has a non-finite vertex.
pub(crate) fn check_extent(d: &Dict, g: &Geometry, user_placed: bool) -> Result<(), SceneError> {
    let max = crate::instances::MAX_COORD;
    let bad = |v: Vec3| !v.is_finite() || v.abs().max_element() > max;
    let p = &d.at;
    for m in &g.meshes {
        if let Some(v) = m.positions.iter().find(|&&v| bad(v)) {
            return Err(d.ld.err(
                d.span.clone(),
                p.clone(),
                format!(
                    "a vertex lands at {:?}, beyond ±{max:e} m (absurd size, or wrong units?)",
                    v.to_array()
                ),
            ));
        }
    }
    let bounds: Vec<Option<(Vec3, Vec3)>> = g
        .prototypes
        .iter()
        .map(|pr| {
            let mut it = pr.meshes.iter().flat_map(|m| m.positions.iter().copied());
            let first = it.next()?;
            Some(it.fold((first, first), |(lo, hi), v| (lo.min(v), hi.max(v))))
        })
        .collect();
    for (j, inst) in g.instances.iter().enumerate() {
        let Some(Some((lo, hi))) = bounds.get(inst.prototype as usize) else {
            continue;
        };
        for c in 0..8 {
            let corner = Vec3::new(
                if c & 1 == 0 { lo.x } else { hi.x },
                if c & 2 == 0 { lo.y } else { hi.y },
                if c & 4 == 0 { lo.z } else { hi.z },
            );
            let w: Vec3 = inst.transform.transform_point3(corner);
            if bad(w) {
                let (key, what) = if user_placed {
                    (format!("{p}.instances[{j}]"), "places".to_string())
                } else {
                    let name = &g.prototypes[inst.prototype as usize].name;
                    (p.to_string(), format!("a node using mesh '{name}' places"))
                };
                return Err(d.ld.err(
                    d.span.clone(),
                    key,
                    format!(
                        "{what} the geometry at {:?}, beyond ±{max:e} m (absurd size, or wrong units?)",
                        w.to_array()
                    ),
                ));
            }
        }
    }
    Ok(())
}
