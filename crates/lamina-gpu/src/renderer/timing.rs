//! GPU time per pass, from timestamp queries written at the beginning and end of the
//! passes (wgpu's `TIMESTAMP_QUERY`, requested by [`crate::GpuContext`] when the adapter has
//! it): the culling and level-of-detail compute pass (`cull`, where the device runs it), the
//! sun's two light-view passes together (`shadows`), the camera pass (`main`) and the
//! tone-map pass (`post`, when the frame has one).
//!
//! A frame is *armed* when the previous frame's values have been read: its passes write the
//! timestamps, [`Timer::resolve`] copies them to a mappable buffer, and once the frame
//! is submitted [`Timer::submitted`] maps that buffer. [`Timer::poll`] reads the values when
//! the GPU is done, without waiting (a window's frame loop), or [`Timer::wait`] blocks (the
//! benchmark). Frames drawn while a read is pending are not timed, so timing never stalls a
//! frame on the GPU.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// GPU time of one frame's passes, in milliseconds, from timestamp queries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassTimes {
    /// The culling and level-of-detail compute pass, where the device runs it.
    pub cull_ms: Option<f64>,
    /// The sun's two light-view passes (layer 1 and the peeled layer 2) together.
    pub shadows_ms: f64,
    /// The camera pass (with occlusion culling, from its first part's beginning to its
    /// second part's end: the depth pyramid and the late culling pass included).
    pub main_ms: f64,
    /// The tone-map and overlay pass, when the frame had one.
    pub post_ms: Option<f64>,
}

impl PassTimes {
    /// The sum of the passes' times (ms): the frame's GPU time, gaps between passes not
    /// counted.
    pub fn total_ms(&self) -> f64 {
        self.cull_ms.unwrap_or(0.0) + self.shadows_ms + self.main_ms + self.post_ms.unwrap_or(0.0)
    }
}

/// Which timestamp a pass writes.
#[derive(Clone, Copy, Debug)]
pub(super) enum Pass {
    /// The first light-view pass (its beginning) and the peel pass (its end).
    ShadowFirst,
    ShadowPeel,
    Main,
    /// With occlusion culling, the camera pass's first part (its beginning) and its
    /// second part (its end): `main` then spans the depth pyramid and the late culling.
    MainFirst,
    MainLate,
    Post,
}

/// Timestamps per frame: cull begin/end, shadows begin/end, main begin/end, post begin/end.
const SLOTS: u32 = 8;
/// Bytes of the resolved timestamps (`SLOTS` u64, a whole alignment unit).
const BYTES: u64 = wgpu::QUERY_RESOLVE_BUFFER_ALIGNMENT;

const IDLE: u8 = 0;
const TO_MAP: u8 = 1;
const MAPPING: u8 = 2;
const MAPPED: u8 = 3;
const FAILED: u8 = 4;

/// The query set and buffers of the frame timer, and where the current read stands.
pub(super) struct Timer {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    read: Arc<wgpu::Buffer>,
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
    state: Arc<AtomicU8>,
    /// The frame being encoded writes timestamps.
    armed: bool,
    /// The armed frame has a post pass.
    post: bool,
    /// The armed frame has a culling pass.
    cull: bool,
    /// The frame whose values are being read had one.
    cull_pending: bool,
    /// The frame whose values are being read had one.
    post_pending: bool,
    last: Option<PassTimes>,
}

impl Timer {
    /// A timer on `device`, or `None` when it lacks `TIMESTAMP_QUERY`.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Option<Timer> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: SLOTS,
        });
        let buffer = |label, usage| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: BYTES,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(Timer {
            set,
            resolve: buffer(
                "timestamps resolved",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            read: Arc::new(buffer(
                "timestamps read",
                wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            )),
            period_ns: queue.get_timestamp_period() as f64,
            state: Arc::new(AtomicU8::new(IDLE)),
            armed: false,
            post: false,
            cull: false,
            cull_pending: false,
            post_pending: false,
            last: None,
        })
    }

    /// Starts encoding a frame: armed when no read is pending.
    pub fn begin_frame(&mut self) {
        self.armed = self.state.load(Ordering::Acquire) == IDLE;
        self.post = false;
        self.cull = false;
    }

    /// The timestamp writes of the culling pass in an armed frame.
    pub fn compute_writes(&mut self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        if !self.armed {
            return None;
        }
        self.cull = true;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        })
    }

    /// The timestamp writes of `pass` in an armed frame.
    pub fn writes(&mut self, pass: Pass) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        if !self.armed {
            return None;
        }
        let (begin, end) = match pass {
            Pass::ShadowFirst => (Some(2), None),
            Pass::ShadowPeel => (None, Some(3)),
            Pass::Main => (Some(4), Some(5)),
            Pass::MainFirst => (Some(4), None),
            Pass::MainLate => (None, Some(5)),
            Pass::Post => {
                self.post = true;
                (Some(6), Some(7))
            }
        };
        Some(wgpu::RenderPassTimestampWrites {
            query_set: &self.set,
            beginning_of_pass_write_index: begin,
            end_of_pass_write_index: end,
        })
    }

    /// Records the copy of an armed frame's timestamps into the mappable buffer (after its
    /// last pass).
    pub fn resolve(&mut self, encoder: &mut wgpu::CommandEncoder) {
        if !self.armed {
            return;
        }
        // Slots 0-1 are resolved only when the culling pass wrote them; the rest in order.
        let first = if self.cull { 0 } else { 2 };
        let n = if self.post { SLOTS } else { 6 };
        encoder.resolve_query_set(&self.set, first..n, &self.resolve, 8 * first as u64);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.read, 0, BYTES);
        self.post_pending = self.post;
        self.cull_pending = self.cull;
        self.state.store(TO_MAP, Ordering::Release);
        self.armed = false;
    }

    /// Call after submitting the frame that [`Self::resolve`] recorded into: asks for its
    /// values.
    pub fn submitted(&mut self) {
        if self
            .state
            .compare_exchange(TO_MAP, MAPPING, Ordering::AcqRel, Ordering::Acquire)
            .is_err()
        {
            return;
        }
        let state = self.state.clone();
        self.read.map_async(wgpu::MapMode::Read, .., move |r| {
            state.store(if r.is_ok() { MAPPED } else { FAILED }, Ordering::Release);
        });
    }

    /// The latest frame's times: reads the pending values if the GPU has written them
    /// (`device` polled without waiting), else the last ones read.
    pub fn poll(&mut self, device: &wgpu::Device) -> Option<PassTimes> {
        if self.state.load(Ordering::Acquire) == MAPPING {
            let _ = device.poll(wgpu::PollType::Poll);
        }
        self.take();
        self.last
    }

    /// As [`Self::poll`], but waits for the GPU when a read is pending.
    pub fn wait(&mut self, device: &wgpu::Device) -> Option<PassTimes> {
        if self.state.load(Ordering::Acquire) == MAPPING {
            let _ = device.poll(wgpu::PollType::wait_indefinitely());
        }
        self.take();
        self.last
    }

    fn take(&mut self) {
        match self.state.load(Ordering::Acquire) {
            MAPPED => {
                let ticks: Option<[u64; SLOTS as usize]> =
                    self.read.get_mapped_range(..).ok().map(|data| {
                        std::array::from_fn(|i| {
                            u64::from_le_bytes(data[8 * i..8 * i + 8].try_into().expect("8 bytes"))
                        })
                    });
                self.read.unmap();
                self.last =
                    ticks.and_then(|t| self.times(&t, self.cull_pending, self.post_pending));
                self.state.store(IDLE, Ordering::Release);
            }
            FAILED => {
                self.read.unmap();
                self.state.store(IDLE, Ordering::Release);
            }
            _ => {}
        }
    }

    /// Milliseconds between a pair of ticks; `None` for a pair that was not written in
    /// order (a driver that reports zeros).
    fn ms(&self, begin: u64, end: u64) -> Option<f64> {
        (end > begin).then(|| (end - begin) as f64 * self.period_ns / 1e6)
    }

    fn times(&self, t: &[u64; SLOTS as usize], cull: bool, post: bool) -> Option<PassTimes> {
        Some(PassTimes {
            cull_ms: if cull { self.ms(t[0], t[1]) } else { None },
            shadows_ms: self.ms(t[2], t[3])?,
            main_ms: self.ms(t[4], t[5])?,
            post_ms: if post { self.ms(t[6], t[7]) } else { None },
        })
    }
}
