//! glTF accessors read with every count, offset, stride and type checked first.
//!
//! The gltf crate's own readers trust the file: a `byteStride` shorter than the element
//! panics inside its iterator, an accessor without a buffer view yields `count` zeros
//! whatever `count` is, and positions are read as `f32` whatever their component type. This
//! reader checks, before reading a byte:
//!
//! * the accessor's type (`VEC3`, ...) and component type / `normalized` flag against what
//!   the attribute allows (glTF 2.0 with `KHR_mesh_quantization`);
//! * `1 <= count <=` [`MAX_GLTF_ELEMENTS`];
//! * the buffer view within its buffer (`byteOffset + byteLength` within the buffer's
//!   `byteLength` and its data), its `byteStride` (when given) at least the element size,
//!   and `byteOffset + (count - 1) * stride + element size` within the view;
//! * for sparse accessors: `1 <= sparse.count <= count`, the indices and values views
//!   checked the same way, every index below `count`.
//!
//! Errors are messages (the caller adds the file and the mesh/primitive key) that name the
//! accessor and, where it is at fault, the buffer view.

use crate::limits::MAX_GLTF_ELEMENTS;
use gltf::accessor::{DataType, Dimensions};

/// A component type with its `normalized` flag.
pub(crate) type Component = (DataType, bool);

/// `POSITION`: float, or any 8/16-bit integer (`KHR_mesh_quantization`).
pub(crate) const POSITION: &[Component] = &[
    (DataType::F32, false),
    (DataType::I8, false),
    (DataType::I8, true),
    (DataType::U8, false),
    (DataType::U8, true),
    (DataType::I16, false),
    (DataType::I16, true),
    (DataType::U16, false),
    (DataType::U16, true),
];

/// `NORMAL` and `TANGENT`: float, or normalized signed 8/16-bit integers.
pub(crate) const DIRECTION: &[Component] = &[
    (DataType::F32, false),
    (DataType::I8, true),
    (DataType::I16, true),
];

/// `TEXCOORD_n`: float, normalized unsigned 8/16-bit (core), any 8/16-bit integer
/// (`KHR_mesh_quantization`).
pub(crate) const TEXCOORD: &[Component] = POSITION;

/// Indices: unsigned 8, 16 or 32-bit integers, not normalized.
pub(crate) const INDEX: &[Component] = &[
    (DataType::U8, false),
    (DataType::U16, false),
    (DataType::U32, false),
];

fn type_name(t: DataType) -> &'static str {
    match t {
        DataType::I8 => "BYTE (5120)",
        DataType::U8 => "UNSIGNED_BYTE (5121)",
        DataType::I16 => "SHORT (5122)",
        DataType::U16 => "UNSIGNED_SHORT (5123)",
        DataType::U32 => "UNSIGNED_INT (5125)",
        DataType::F32 => "FLOAT (5126)",
    }
}

fn dims_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

fn allowed_list(allowed: &[Component]) -> String {
    allowed
        .iter()
        .map(|&(t, n)| {
            if n {
                format!("{} normalized", type_name(t))
            } else {
                type_name(t).to_string()
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The bytes of buffer view `view`, checked to lie within its buffer.
fn view_bytes<'b>(
    view: &gltf::buffer::View,
    buffers: &'b [gltf::buffer::Data],
) -> Result<&'b [u8], String> {
    let b = view.buffer();
    let data = buffers.get(b.index()).ok_or_else(|| {
        format!(
            "bufferView {}: buffer {} is missing",
            view.index(),
            b.index()
        )
    })?;
    let (offset, length) = (view.offset() as u64, view.length() as u64);
    let end = offset.saturating_add(length);
    let available = (b.length() as u64).min(data.0.len() as u64);
    if end > available {
        return Err(format!(
            "bufferView {} (byteOffset {offset}, byteLength {length}) ends at byte {end}, beyond buffer {} ({available} bytes)",
            view.index(),
            b.index()
        ));
    }
    Ok(&data.0[offset as usize..end as usize])
}

/// Checks that `count` elements of `elem` bytes, `stride` apart from `offset`, lie within
/// `len` bytes of a view; `what` names them.
fn check_span(
    what: &str,
    view_index: usize,
    offset: usize,
    count: usize,
    stride: usize,
    elem: usize,
    len: usize,
) -> Result<(), String> {
    let end = (count as u64 - 1)
        .checked_mul(stride as u64)
        .and_then(|x| x.checked_add(offset as u64))
        .and_then(|x| x.checked_add(elem as u64))
        .unwrap_or(u64::MAX);
    if end > len as u64 {
        return Err(format!(
            "{what}: {count} elements of {elem} bytes, {stride} bytes apart from byteOffset {offset}, end at byte {end}, beyond bufferView {view_index} ({len} bytes)"
        ));
    }
    Ok(())
}

/// The stride of `view` for elements of `elem` bytes: its `byteStride`, which must be at
/// least `elem`, or `elem` (tightly packed).
fn stride_of(what: &str, view: &gltf::buffer::View, elem: usize) -> Result<usize, String> {
    match view.stride() {
        None => Ok(elem),
        Some(s) if s >= elem => Ok(s),
        Some(s) => Err(format!(
            "{what}: bufferView {} has byteStride {s}, less than the element size {elem} bytes",
            view.index()
        )),
    }
}

/// One component at the start of `b` as `f64` (normalized integers mapped to [0, 1] or
/// [-1, 1] as glTF specifies).
#[inline]
fn component(t: DataType, normalized: bool, b: &[u8]) -> f64 {
    match t {
        DataType::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
        DataType::U8 if normalized => b[0] as f64 / 255.0,
        DataType::U8 => b[0] as f64,
        DataType::I8 if normalized => (b[0] as i8 as f64 / 127.0).max(-1.0),
        DataType::I8 => b[0] as i8 as f64,
        DataType::U16 if normalized => u16::from_le_bytes([b[0], b[1]]) as f64 / 65535.0,
        DataType::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
        DataType::I16 if normalized => {
            (i16::from_le_bytes([b[0], b[1]]) as f64 / 32767.0).max(-1.0)
        }
        DataType::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
        DataType::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
    }
}

/// Checks an accessor's type, component type and count; its element size in bytes.
pub(crate) fn check_accessor(
    acc: &gltf::Accessor,
    dims: Dimensions,
    allowed: &[Component],
    what: &str,
) -> Result<usize, String> {
    let name = format!("{what} (accessor {})", acc.index());
    if acc.dimensions() != dims {
        return Err(format!(
            "{name}: type {} where {} is required",
            dims_name(acc.dimensions()),
            dims_name(dims)
        ));
    }
    let ct = (acc.data_type(), acc.normalized());
    if !allowed.contains(&ct) {
        return Err(format!(
            "{name}: component type {}{} is not allowed (allowed: {})",
            type_name(ct.0),
            if ct.1 { " normalized" } else { "" },
            allowed_list(allowed)
        ));
    }
    let count = acc.count();
    if count == 0 || count > MAX_GLTF_ELEMENTS {
        return Err(format!(
            "{name}: count {count} must be in [1, {MAX_GLTF_ELEMENTS}]"
        ));
    }
    Ok(acc.data_type().size() * dims.multiplicity())
}

/// Reads an accessor of `N` components per element as `f32`, after the checks of the
/// module docs. `what` names it in errors (`POSITION`).
pub(crate) fn read_f32<const N: usize>(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    dims: Dimensions,
    allowed: &[Component],
    what: &str,
) -> Result<Vec<[f32; N]>, String> {
    debug_assert_eq!(dims.multiplicity(), N);
    let (t, normalized) = (acc.data_type(), acc.normalized());
    let size = t.size();
    read(acc, buffers, dims, allowed, what, [0.0; N], |b| {
        std::array::from_fn(|c| component(t, normalized, &b[c * size..]) as f32)
    })
}

/// Reads an index accessor (`SCALAR`, unsigned 8/16/32-bit).
pub(crate) fn read_indices(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
) -> Result<Vec<u32>, String> {
    let t = acc.data_type();
    read(acc, buffers, Dimensions::Scalar, INDEX, "indices", 0, |b| {
        component(t, false, b) as u32
    })
}

fn read<T: Copy>(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    dims: Dimensions,
    allowed: &[Component],
    what: &str,
    zero: T,
    decode: impl Fn(&[u8]) -> T,
) -> Result<Vec<T>, String> {
    let elem = check_accessor(acc, dims, allowed, what)?;
    let name = format!("{what} (accessor {})", acc.index());
    let count = acc.count();
    // Check everything (base view and sparse views) before allocating or reading.
    let base = match acc.view() {
        Some(view) => {
            let bytes = view_bytes(&view, buffers).map_err(|e| format!("{name}: {e}"))?;
            let stride = stride_of(&name, &view, elem)?;
            check_span(
                &name,
                view.index(),
                acc.offset(),
                count,
                stride,
                elem,
                bytes.len(),
            )?;
            Some((&bytes[acc.offset()..], stride))
        }
        None => None,
    };
    let sparse = match acc.sparse() {
        Some(s) => {
            let n = s.count();
            if n == 0 || n > count {
                return Err(format!(
                    "{name}: sparse.count {n} must be in [1, count = {count}]"
                ));
            }
            let iv = s.indices().view();
            let isize = s.indices().index_type().size();
            let ibytes =
                view_bytes(&iv, buffers).map_err(|e| format!("{name}: sparse.indices: {e}"))?;
            let istride = stride_of(&format!("{name}: sparse.indices"), &iv, isize)?;
            let ioff = s.indices().offset();
            check_span(
                &format!("{name}: sparse.indices"),
                iv.index(),
                ioff,
                n,
                istride,
                isize,
                ibytes.len(),
            )?;
            let vv = s.values().view();
            let vbytes =
                view_bytes(&vv, buffers).map_err(|e| format!("{name}: sparse.values: {e}"))?;
            let vstride = stride_of(&format!("{name}: sparse.values"), &vv, elem)?;
            let voff = s.values().offset();
            check_span(
                &format!("{name}: sparse.values"),
                vv.index(),
                voff,
                n,
                vstride,
                elem,
                vbytes.len(),
            )?;
            let itype = match isize {
                1 => DataType::U8,
                2 => DataType::U16,
                _ => DataType::U32,
            };
            let mut indices = Vec::with_capacity(n);
            for k in 0..n {
                let i = component(itype, false, &ibytes[ioff + k * istride..]) as u64;
                if i >= count as u64 {
                    return Err(format!(
                        "{name}: sparse index {i} (entry {k}) is not below count = {count}"
                    ));
                }
                indices.push(i as usize);
            }
            Some((indices, &vbytes[voff..], vstride))
        }
        None => None,
    };
    if base.is_none() && sparse.is_none() {
        // Valid glTF (all zeros), but nothing a renderer can use; say so plainly.
        return Err(format!(
            "{name}: has neither a bufferView nor sparse values (all {count} elements would be zero)"
        ));
    }
    let mut out: Vec<T> = match base {
        Some((bytes, stride)) => (0..count)
            .map(|i| decode(&bytes[i * stride..i * stride + elem]))
            .collect(),
        None => vec![zero; count],
    };
    if let Some((indices, bytes, stride)) = sparse {
        for (k, i) in indices.into_iter().enumerate() {
            out[i] = decode(&bytes[k * stride..k * stride + elem]);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalized_components() {
        assert_eq!(component(DataType::U8, true, &[255]), 1.0);
        assert_eq!(component(DataType::I8, true, &[0x80]), -1.0);
        assert_eq!(
            component(DataType::I16, false, &(-5i16).to_le_bytes()),
            -5.0
        );
        assert_eq!(component(DataType::F32, false, &1.5f32.to_le_bytes()), 1.5);
        assert_eq!(component(DataType::U16, true, &[0xff, 0xff]), 1.0);
    }
}
