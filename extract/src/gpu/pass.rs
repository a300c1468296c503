//! One frame on the GPU: upload into reused buffers, dispatch the kernel band
//! by band, read back the segment count and the segments.
//!
//! Two slots of buffers let frame n+1 be uploaded while frame n is computed:
//! a slot's staging buffers are mapped again as soon as the GPU is done with
//! them, and its readback buffer is mapped with the submission. The readback
//! copies the counter and as many segments as the previous frames suggest
//! (5/4 of the last count plus a margin); a frame with more segments is read
//! again, and one with more than the segment buffer holds is dispatched again
//! with a larger buffer. The data read back scales with the signal.

use std::sync::mpsc::{Receiver, TryRecvError, channel};

use bytemuck::{Pod, Zeroable};

use super::GpuStats;
use super::context::{CHUNK, Context, WORKGROUP};
use super::segments::{SEGMENT_BYTES, Segment};
use crate::Result;
use crate::frame::FrameView;
use crate::label::Weighting;
use crate::threshold::Level;

/// Segment records of a fresh slot.
const INITIAL_SEGMENTS: u64 = 1 << 16;
/// Segments read back beyond 5/4 of the last frame's count.
const READBACK_MARGIN: u64 = 1024;
/// Bytes before the first segment in the readback buffer (the counter, padded).
const COUNT_BYTES: u64 = 8;

/// `Params` of runs.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Params {
    width: u32,
    rows: u32,
    first_row: u32,
    threshold: u32,
    use_map: u32,
    raw: u32,
    saturation: u32,
    chunks: u32,
}

/// Rows `first_row..first_row + rows` of a frame, one storage binding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Band {
    first_row: u32,
    rows: u32,
}

/// Cut a `width × height` frame into bands of rows whose `u16` pixels (padded
/// to whole words) fit in `binding_bytes`, each at most `max_rows` rows.
fn bands(
    width: u32,
    height: u32,
    binding_bytes: u64,
    max_rows: u32,
) -> std::result::Result<Vec<Band>, String> {
    let row_bytes = 2 * u64::from(width);
    let fit = (binding_bytes.saturating_sub(4) / row_bytes).min(u64::from(max_rows)) as u32;
    if fit == 0 {
        return Err(format!(
            "a row of {width} px ({row_bytes} bytes) does not fit in a storage binding of {binding_bytes} bytes"
        ));
    }
    Ok((0..height)
        .step_by(fit as usize)
        .map(|first_row| Band {
            first_row,
            rows: fit.min(height - first_row),
        })
        .collect())
}

/// Whether a mapping is ready for the host.
enum MapState {
    Mapped,
    Pending(
        Receiver<std::result::Result<(), wgpu::BufferAsyncError>>,
        wgpu::SubmissionIndex,
    ),
    Unmapped,
}

impl MapState {
    /// Ask for `buffer` to be mapped once submission `index` is done with it.
    fn request(
        buffer: &wgpu::Buffer,
        mode: wgpu::MapMode,
        bytes: u64,
        index: &wgpu::SubmissionIndex,
    ) -> Self {
        let (tx, rx) = channel();
        buffer.map_async(mode, 0..bytes, move |r| {
            // The receiver is gone only when the slot was dropped.
            let _ = tx.send(r);
        });
        MapState::Pending(rx, index.clone())
    }

    /// Block until mapped.
    fn ready(&mut self, ctx: &Context) -> Result<()> {
        if let MapState::Pending(rx, index) = self {
            let r = match rx.try_recv() {
                Ok(r) => r,
                Err(TryRecvError::Empty) => {
                    ctx.wait(Some(index.clone()))?;
                    rx.try_recv()
                        .map_err(|_| ctx.error("a buffer mapping never completed"))?
                }
                Err(TryRecvError::Disconnected) => {
                    return Err(ctx.error("a buffer mapping was dropped"));
                }
            };
            r.map_err(|e| ctx.error(format!("mapping a buffer: {e}")))?;
            *self = MapState::Mapped;
        }
        match self {
            MapState::Mapped => Ok(()),
            _ => Err(ctx.error("a buffer is not mapped")),
        }
    }
}

/// A host-visible staging buffer and the storage buffer it is copied into.
struct Upload {
    staging: wgpu::Buffer,
    storage: wgpu::Buffer,
    bytes: u64,
    map: MapState,
}

impl Upload {
    fn new(ctx: &Context, bytes: u64, label: &str) -> Self {
        let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_WRITE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: true,
        });
        let storage = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            staging,
            storage,
            bytes,
            map: MapState::Mapped,
        }
    }

    /// Write `data` (u16 values) into the staging buffer; returns the bytes to copy (whole words).
    fn write(&mut self, ctx: &Context, data: &[u16]) -> Result<u64> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        self.map.ready(ctx)?;
        {
            let mut view = self
                .staging
                .get_mapped_range_mut(..)
                .map_err(|e| ctx.error(format!("staging buffer: {e}")))?;
            view.slice(..bytes.len()).copy_from_slice(bytes);
        }
        self.staging.unmap();
        self.map = MapState::Unmapped;
        Ok((bytes.len() as u64).next_multiple_of(4))
    }
}

/// The buffers of one band.
struct BandBuffers {
    pixels: Upload,
    levels: Option<Upload>,
    params: wgpu::Buffer,
    /// Bytes to copy from staging this frame.
    used: u64,
    band: Band,
}

/// One set of buffers for one frame in flight.
struct Slot {
    bands: Vec<BandBuffers>,
    /// How many of `bands` the current frame uses.
    active: usize,
    width: u32,
    use_map: bool,
    count: wgpu::Buffer,
    segments: wgpu::Buffer,
    /// Segment records `segments` holds.
    capacity: u64,
    readback: wgpu::Buffer,
    readback_map: MapState,
}

/// A frame submitted to the GPU, to be finished with [`Passes::finish`].
pub(crate) struct Submitted {
    slot: usize,
    index: wgpu::SubmissionIndex,
    /// Segment records copied into the readback buffer.
    copied: u64,
}

/// What the GPU found in a frame.
pub(crate) enum Found {
    /// Every run segment, in no particular order.
    Segments(Vec<Segment>),
    /// More segments than one storage binding holds (a threshold in the noise):
    /// the frame must be labelled on the CPU.
    TooMany,
}

/// Two slots of reused buffers and the readback size estimate.
#[derive(Default)]
pub(crate) struct Passes {
    slots: [Option<Slot>; 2],
    /// Segments of the last frame.
    last_count: u64,
    /// Counters since the backend was opened.
    pub stats: GpuStats,
}

fn segment_buffers(ctx: &Context, capacity: u64) -> (wgpu::Buffer, wgpu::Buffer) {
    let segments = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("segments"),
        size: capacity * SEGMENT_BYTES,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: COUNT_BYTES + capacity * SEGMENT_BYTES,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    (segments, readback)
}

impl Slot {
    fn new(ctx: &Context) -> Self {
        let count = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("segment count"),
            size: 4,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let capacity = INITIAL_SEGMENTS.min(ctx.max_segments);
        let (segments, readback) = segment_buffers(ctx, capacity);
        Self {
            bands: Vec::new(),
            active: 0,
            width: 0,
            use_map: false,
            count,
            segments,
            capacity,
            readback,
            readback_map: MapState::Unmapped,
        }
    }

    /// Clear the counter, run the kernel over the active bands, copy the
    /// counter and the first `copy` segments into the readback buffer.
    fn encode(&self, ctx: &Context, encoder: &mut wgpu::CommandEncoder, copy: u64) {
        encoder.clear_buffer(&self.count, 0, None);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("runs"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&ctx.pipeline);
            let chunks = self.width.div_ceil(CHUNK);
            for b in &self.bands[..self.active] {
                let levels = match (&b.levels, self.use_map) {
                    (Some(l), true) => &l.storage,
                    _ => &ctx.no_levels,
                };
                let group = ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("runs"),
                    layout: &ctx.layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: b.params.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: b.pixels.storage.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: levels.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 3,
                            resource: self.count.as_entire_binding(),
                        },
                        wgpu::BindGroupEntry {
                            binding: 4,
                            resource: self.segments.as_entire_binding(),
                        },
                    ],
                });
                pass.set_bind_group(0, &group, &[]);
                pass.dispatch_workgroups(chunks.div_ceil(WORKGROUP), b.band.rows, 1);
            }
        }
        encoder.copy_buffer_to_buffer(&self.count, 0, &self.readback, 0, 4);
        if copy > 0 {
            encoder.copy_buffer_to_buffer(
                &self.segments,
                0,
                &self.readback,
                COUNT_BYTES,
                copy * SEGMENT_BYTES,
            );
        }
    }

    /// Submit `encode` with `copy` segments and ask for the readback mapping.
    fn dispatch(&mut self, ctx: &Context, copy: u64) -> Result<wgpu::SubmissionIndex> {
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("runs"),
            });
        self.encode(ctx, &mut encoder, copy);
        let index = ctx.queue.submit([encoder.finish()]);
        self.readback_map = MapState::request(
            &self.readback,
            wgpu::MapMode::Read,
            COUNT_BYTES + copy * SEGMENT_BYTES,
            &index,
        );
        ctx.check()?;
        Ok(index)
    }

    /// Wait for the readback of `copied` segments; returns the counter and the segments read.
    fn read(&mut self, ctx: &Context, copied: u64) -> Result<(u64, Vec<Segment>)> {
        self.readback_map.ready(ctx)?;
        let (count, segments) = {
            let view = self
                .readback
                .get_mapped_range(0..COUNT_BYTES + copied * SEGMENT_BYTES)
                .map_err(|e| ctx.error(format!("readback buffer: {e}")))?;
            let count = u64::from(u32::from_le_bytes([view[0], view[1], view[2], view[3]]));
            let n = count.min(copied);
            let bytes = &view[COUNT_BYTES as usize..(COUNT_BYTES + n * SEGMENT_BYTES) as usize];
            (count, bytemuck::pod_collect_to_vec::<u8, Segment>(bytes))
        };
        self.readback.unmap();
        self.readback_map = MapState::Unmapped;
        Ok((count, segments))
    }
}

impl Passes {
    /// Upload `frame` (and a threshold map) into slot `slot` and start the kernel.
    pub fn submit(
        &mut self,
        ctx: &Context,
        slot: usize,
        frame: &FrameView<'_>,
        level: &Level,
        weighting: Weighting,
    ) -> Result<Submitted> {
        let plan = bands(
            frame.width,
            frame.height,
            ctx.band_bytes,
            ctx.max_workgroups,
        )
        .map_err(|m| ctx.error(m))?;
        let copy_estimate = self.last_count + self.last_count / 4 + READBACK_MARGIN;
        let s = self.slots[slot % 2].get_or_insert_with(|| Slot::new(ctx));
        let w = frame.width as usize;
        let (threshold, map) = match level {
            Level::Constant(t) => (u32::from(*t), None),
            Level::Map(m) => (0, Some(m.as_slice())),
        };
        for (i, band) in plan.iter().enumerate() {
            let range = band.first_row as usize * w..(band.first_row + band.rows) as usize * w;
            let need = (range.len() as u64 * 2).next_multiple_of(4);
            if s.bands.get(i).is_none_or(|b| b.pixels.bytes < need) {
                let b = BandBuffers {
                    pixels: Upload::new(ctx, need, "pixels"),
                    levels: None,
                    params: ctx.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("params"),
                        size: std::mem::size_of::<Params>() as u64,
                        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    }),
                    used: 0,
                    band: *band,
                };
                if i < s.bands.len() {
                    s.bands[i] = b;
                } else {
                    s.bands.push(b);
                }
            }
            let b = &mut s.bands[i];
            b.band = *band;
            b.used = b.pixels.write(ctx, &frame.pixels[range.clone()])?;
            if let Some(m) = map {
                if b.levels.as_ref().is_none_or(|l| l.bytes < need) {
                    b.levels = Some(Upload::new(ctx, need, "threshold map"));
                }
                if let Some(l) = b.levels.as_mut() {
                    l.write(ctx, &m[range])?;
                }
            }
            let params = Params {
                width: frame.width,
                rows: band.rows,
                first_row: band.first_row,
                threshold,
                use_map: u32::from(map.is_some()),
                raw: u32::from(weighting == Weighting::Raw),
                saturation: u32::from(frame.max_value()),
                chunks: frame.width.div_ceil(CHUNK),
            };
            ctx.queue
                .write_buffer(&b.params, 0, bytemuck::bytes_of(&params));
        }
        s.active = plan.len();
        s.width = frame.width;
        s.use_map = map.is_some();

        let copy = copy_estimate.min(s.capacity);
        let mut encoder = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("upload"),
            });
        for b in &s.bands[..s.active] {
            encoder.copy_buffer_to_buffer(&b.pixels.staging, 0, &b.pixels.storage, 0, b.used);
            if let (Some(l), true) = (&b.levels, s.use_map) {
                encoder.copy_buffer_to_buffer(&l.staging, 0, &l.storage, 0, b.used);
            }
        }
        s.encode(ctx, &mut encoder, copy);
        let index = ctx.queue.submit([encoder.finish()]);
        for b in &mut s.bands[..s.active] {
            b.pixels.map = MapState::request(
                &b.pixels.staging,
                wgpu::MapMode::Write,
                b.pixels.bytes,
                &index,
            );
            if let (Some(l), true) = (b.levels.as_mut(), map.is_some()) {
                l.map = MapState::request(&l.staging, wgpu::MapMode::Write, l.bytes, &index);
            }
        }
        s.readback_map = MapState::request(
            &s.readback,
            wgpu::MapMode::Read,
            COUNT_BYTES + copy * SEGMENT_BYTES,
            &index,
        );
        ctx.check()?;
        Ok(Submitted {
            slot: slot % 2,
            index,
            copied: copy,
        })
    }

    /// Wait for a submitted frame and read its segments back.
    pub fn finish(&mut self, ctx: &Context, submitted: Submitted) -> Result<Found> {
        let Submitted {
            slot,
            index,
            copied,
        } = submitted;
        let s = self.slots[slot]
            .as_mut()
            .ok_or_else(|| ctx.error("finishing a frame that was never submitted"))?;
        ctx.wait(Some(index))?;
        let (count, mut segments) = s.read(ctx, copied)?;
        self.stats.frames += 1;
        self.stats.bands += s.active as u64;
        self.stats.segments += count;
        self.stats.bytes_read += COUNT_BYTES + copied * SEGMENT_BYTES;
        if count > copied {
            if count > s.capacity {
                // The segment buffer overflowed: run the kernel again with room for all.
                let capacity = count.next_power_of_two().min(ctx.max_segments);
                if count > capacity {
                    self.last_count = 0;
                    self.stats.cpu_labelled += 1;
                    return Ok(Found::TooMany);
                }
                (s.segments, s.readback) = segment_buffers(ctx, capacity);
                s.capacity = capacity;
            }
            // Read everything again (rare: sequences change slowly).
            s.dispatch(ctx, count)?;
            let (again, all) = s.read(ctx, count)?;
            self.stats.rereads += 1;
            self.stats.bytes_read += COUNT_BYTES + count * SEGMENT_BYTES;
            if again != count {
                return Err(ctx.error(format!(
                    "segment count changed from {count} to {again} between two runs"
                )));
            }
            segments = all;
        }
        self.last_count = count;
        Ok(Found::Segments(segments))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_the_frame_within_the_binding() {
        // 3 rows of 2000 bytes (+ padding) fit in 8000 bytes.
        let b = bands(1000, 46, 8000, 65535).unwrap();
        assert_eq!(b.len(), 16);
        assert_eq!(b.iter().map(|b| b.rows).sum::<u32>(), 46);
        assert!(b.iter().all(|b| u64::from(b.rows) * 2000 + 4 <= 8000));
        assert_eq!(
            b[15],
            Band {
                first_row: 45,
                rows: 1
            }
        );
        assert_eq!(bands(7, 3, 1 << 20, 2).unwrap().len(), 2);
        assert!(bands(5000, 2, 8000, 65535).is_err());
    }
}
