//! Placements of an object that becomes a [`crate::Prototype`]: inline
//! `instances = [{ translate = [..], rotate_y = .., scale = .. }, ...]` and/or an
//! `instances_file` (CSV), and the size limits every transform must respect.

use crate::error::SceneError;
use crate::transform::Transform;
use glam::{Affine3A, Vec3};
use std::path::Path;

/// Smallest and largest absolute scale factor per axis accepted in a transform. Outside this
/// range a transform is singular or a units mistake (1e30 metres).
pub const SCALE_RANGE: (f32, f32) = (1e-6, 1e6);

/// Largest distance from the origin (m, per coordinate) of a translation or of any vertex
/// after it is placed: 10,000 km. Anything farther is a units mistake and would wreck
/// single-precision ray tracing.
pub const MAX_COORD: f32 = 1e7;

/// Most instances one object, and the whole scene over all objects, may have.
pub const MAX_INSTANCES: usize = 1 << 27;

/// Columns an instances CSV file may have.
pub const CSV_COLUMNS: &[&str] = &["tx", "ty", "tz", "rx", "ry", "rz", "sx", "sy", "sz", "s"];

/// A transform from its parts (scale, rotations about x, y, z in degrees, translation in
/// m), validated: finite, every scale factor's magnitude in [`SCALE_RANGE`], translation
/// within [`MAX_COORD`]. The error is `(sub-key, message)`.
pub fn checked_transform(
    scale: Vec3,
    rotate_deg: Vec3,
    translate: Vec3,
) -> Result<Transform, (&'static str, String)> {
    if !scale.is_finite() {
        return Err((
            "scale",
            format!("must be finite, got {:?}", scale.to_array()),
        ));
    }
    let (lo, hi) = SCALE_RANGE;
    let a = scale.abs();
    if a.min_element() < lo || a.max_element() > hi {
        return Err((
            "scale",
            format!(
                "each factor must be in [{lo:e}, {hi:e}] in magnitude (zero is singular, huge is a units mistake), got {:?}",
                scale.to_array()
            ),
        ));
    }
    if !rotate_deg.is_finite() {
        return Err((
            "rotate",
            format!("angles must be finite, got {:?}", rotate_deg.to_array()),
        ));
    }
    if !translate.is_finite() || translate.abs().max_element() > MAX_COORD {
        return Err((
            "translate",
            format!(
                "must be finite and within ±{MAX_COORD:e} m, got {:?}",
                translate.to_array()
            ),
        ));
    }
    Ok(Transform::from_parts(scale, rotate_deg, translate))
}

/// The transform as an instance's affine matrix.
pub fn affine(t: &Transform) -> Affine3A {
    Affine3A::from_mat4(t.m)
}

/// Reads an instances CSV file: a header naming any of [`CSV_COLUMNS`] (any order; `tx ty
/// tz` translation in m, `rx ry rz` rotation in degrees about x then y then z, `sx sy sz`
/// per-axis scale or `s` uniform scale), then one placement per row. Missing columns take
/// 0 (translation, rotation) or 1 (scale). `#` starts a comment line. Errors name the file,
/// the line and the column.
///
/// At most [`crate::limits::MAX_TEXT_FILE_BYTES`] and [`MAX_INSTANCES`] rows; a panic in
/// the reader is an error naming the file.
pub fn read_instances_csv(path: &Path) -> Result<Vec<Transform>, SceneError> {
    read_instances_csv_capped(path, MAX_INSTANCES)
}

/// [`read_instances_csv`] that stops with an error after `max` placements.
pub(crate) fn read_instances_csv_capped(
    path: &Path,
    max: usize,
) -> Result<Vec<Transform>, SceneError> {
    crate::error::guarded(path, || {
        crate::error::fault_point("instances");
        let text =
            crate::error::read_text(path, "instances file", crate::limits::MAX_TEXT_FILE_BYTES)?;
        parse_capped(&text, path, max)
    })
}

/// Parses the text of an instances CSV file (see [`read_instances_csv`]); `path` names it
/// in errors. The entry point for fuzzing.
pub fn parse_instances_csv(text: &str, path: &Path) -> Result<Vec<Transform>, SceneError> {
    crate::error::guarded(path, || parse_capped(text, path, MAX_INSTANCES))
}

fn parse_capped(text: &str, path: &Path, max: usize) -> Result<Vec<Transform>, SceneError> {
    // Plain comma-separated numbers: read by hand so that every line number is exact
    // (blank lines and `#` comments included).
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let Some((header_line, header)) = lines.next() else {
        return Err(SceneError::new(
            path,
            None,
            "",
            "the instances file is empty (it needs a header such as 'tx,ty,tz')",
        ));
    };
    let header_line = Some(header_line);
    let mut cols: Vec<usize> = Vec::new();
    for h in header.split(',').map(str::trim) {
        let Some(c) = CSV_COLUMNS.iter().position(|&c| c == h) else {
            return Err(SceneError::new(
                path,
                header_line,
                h,
                format!(
                    "unknown column (the header names any of: {})",
                    CSV_COLUMNS.join(", ")
                ),
            ));
        };
        if cols.contains(&c) {
            return Err(SceneError::new(path, header_line, h, "column given twice"));
        }
        cols.push(c);
    }
    if cols.contains(&9) && cols.iter().any(|&c| (6..9).contains(&c)) {
        return Err(SceneError::new(
            path,
            header_line,
            "s",
            "give either 's' (uniform scale) or 'sx', 'sy', 'sz', not both",
        ));
    }
    let mut out = Vec::new();
    for (line, row) in lines {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        let line = Some(line);
        if fields.len() != cols.len() {
            return Err(SceneError::new(
                path,
                line,
                "",
                format!(
                    "bad CSV row: {} fields, the header has {}",
                    fields.len(),
                    cols.len()
                ),
            ));
        }
        let mut v = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0f32];
        for (field, &c) in fields.iter().zip(&cols) {
            v[c] = field.parse::<f32>().map_err(|_| {
                SceneError::new(
                    path,
                    line,
                    CSV_COLUMNS[c],
                    format!("not a number: '{field}'"),
                )
            })?;
        }
        let scale = if cols.contains(&9) {
            Vec3::splat(v[9])
        } else {
            Vec3::new(v[6], v[7], v[8])
        };
        let t = checked_transform(
            scale,
            Vec3::new(v[3], v[4], v[5]),
            Vec3::new(v[0], v[1], v[2]),
        )
        .map_err(|(k, m)| SceneError::new(path, line, k, m))?;
        if out.len() >= max {
            return Err(SceneError::new(
                path,
                line,
                "",
                format!(
                    "more than {max} instances (at most {MAX_INSTANCES} in a scene, over all objects)"
                ),
            ));
        }
        out.push(t);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn absurd_and_singular_scales_are_rejected() {
        assert!(checked_transform(Vec3::ONE, Vec3::ZERO, Vec3::ZERO).is_ok());
        assert!(checked_transform(Vec3::new(-2.0, 1.0, 1.0), Vec3::ZERO, Vec3::ZERO).is_ok());
        for s in [0.0, 1e30, f32::NAN, 1e-9] {
            let (k, m) = checked_transform(Vec3::splat(s), Vec3::ZERO, Vec3::ZERO).unwrap_err();
            assert_eq!(k, "scale", "{m}");
        }
        let (k, _) = checked_transform(Vec3::ONE, Vec3::ZERO, Vec3::splat(1e9)).unwrap_err();
        assert_eq!(k, "translate");
    }
}
