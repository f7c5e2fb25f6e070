//! Reading frames back to the CPU: texture copies to a mapped buffer, and the box filter
//! from the supersampled RGBA16F target to linear radiance pixels.

use super::half::half_to_f32;
use crate::context::GpuContext;
use crate::error::GpuError;
use glam::Vec3;

/// Submits `encoder` plus a copy of `tex` (`width x height`, `bpp` bytes per texel) and
/// returns the tightly packed rows.
pub(super) fn read_texture(
    ctx: &GpuContext,
    mut encoder: wgpu::CommandEncoder,
    tex: &wgpu::Texture,
    width: u32,
    height: u32,
    bpp: u32,
) -> Result<Vec<u8>, GpuError> {
    let row = width * bpp;
    let padded = row.div_ceil(256) * 256;
    let buf = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: (padded * height) as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: tex,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buf,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
    );
    let scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
    ctx.queue.submit([encoder.finish()]);
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(GpuError::Validation {
            what: "rendering the frame".into(),
            message: e.to_string(),
        });
    }
    let data = map_and_wait(ctx, &buf)?;
    let mut out = Vec::with_capacity((row * height) as usize);
    for y in 0..height as usize {
        out.extend_from_slice(&data[y * padded as usize..y * padded as usize + row as usize]);
    }
    Ok(out)
}

/// The contents of `buf` (which has `COPY_SRC`), waiting for the GPU.
pub(super) fn read_buffer(ctx: &GpuContext, buf: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: buf.size(),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(buf, 0, &staging, 0, buf.size());
    ctx.queue.submit([encoder.finish()]);
    let data = map_and_wait(ctx, &staging)?;
    Ok(data.to_vec())
}

/// Maps `buf` for reading and waits for the GPU.
fn map_and_wait(ctx: &GpuContext, buf: &wgpu::Buffer) -> Result<wgpu::BufferView, GpuError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buf.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    buf.get_mapped_range(..)
        .map_err(|e| GpuError::Readback(format!("{e:?}")))
}

/// Linear RGB pixels of a `width x height` image from `raw`, the rows of an RGBA16F image
/// `ss` times larger per axis, each pixel the mean of its `ss x ss` block.
pub(super) fn box_downsample(raw: &[u8], ss: u32, width: u32, height: u32) -> Vec<Vec3> {
    let mut pixels = vec![Vec3::ZERO; (width * height) as usize];
    let row = (width * ss * 8) as usize;
    let norm = 1.0 / (ss * ss) as f32;
    for y in 0..height {
        for x in 0..width {
            let mut acc = Vec3::ZERO;
            for sy in 0..ss {
                for sx in 0..ss {
                    let o = ((y * ss + sy) as usize) * row + ((x * ss + sx) as usize) * 8;
                    let c = |k: usize| {
                        half_to_f32(u16::from_le_bytes([raw[o + 2 * k], raw[o + 2 * k + 1]]))
                    };
                    acc += Vec3::new(c(0), c(1), c(2));
                }
            }
            pixels[(y * width + x) as usize] = acc * norm;
        }
    }
    pixels
}
