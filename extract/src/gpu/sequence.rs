//! Sequences of frames through the GPU, pipelined.
//!
//! For frame n the calling thread copies the frame into the staging buffers of
//! slot n mod 2 and submits upload + kernel + readback — while the GPU is
//! still busy with frame n − 1 — and only then waits for frame n − 1, joins
//! and labels its runs on the host (while the GPU works on frame n) and hands
//! its result on. For files, a decoder thread reads, decodes, denoises and
//! thresholds the frames ahead (in parallel chunks on the rayon pool, pixel
//! buffers recycled). Results come out in input order and equal the CPU
//! backend's.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::mpsc::{Receiver, SyncSender, channel, sync_channel};

use rayon::prelude::*;

use super::backend::{GpuBackend, Prepared};
use super::pass::{Passes, Submitted};
use crate::Result;
use crate::backend::{ExtractParams, Extraction};
use crate::batch::{self, FrameBlobs};
use crate::decode::FrameReader;
use crate::frame::{Frame, FrameView};
use crate::metadata::FrameMetadata;

/// A frame, owned (decoded from a file) or borrowed (in memory).
enum Pixels<'a> {
    Owned(Frame),
    Borrowed(FrameView<'a>),
}

impl Pixels<'_> {
    fn view(&self) -> FrameView<'_> {
        match self {
            Pixels::Owned(f) => f.view(),
            Pixels::Borrowed(v) => *v,
        }
    }
}

/// A frame ready for the kernel, with what the caller wants back (`tag`).
struct Job<'a, T> {
    pixels: Pixels<'a>,
    prepared: Prepared,
    tag: T,
}

/// A job whose kernel has been submitted.
struct InFlight<'a, T> {
    index: usize,
    job: Job<'a, T>,
    submitted: Submitted,
}

/// Wait for a job in flight and complete it on the host.
fn finish<'a, T>(
    f: InFlight<'a, T>,
    backend: &GpuBackend,
    passes: &mut Passes,
    params: &ExtractParams,
) -> (usize, Result<(Pixels<'a>, T, Extraction)>) {
    let InFlight {
        index,
        job,
        submitted,
    } = f;
    let Job {
        pixels,
        prepared,
        tag,
    } = job;
    let result = passes
        .finish(&backend.ctx, submitted)
        .and_then(|found| GpuBackend::complete(&pixels.view(), prepared, found, params))
        .map(|extraction| (pixels, tag, extraction));
    (index, result)
}

/// The pipeline over `jobs` (index, and the job or the error that stopped it
/// before the GPU); `done(index, result)` is called in input order, with the
/// frame and tag back on success.
fn pipeline<'a, T>(
    backend: &GpuBackend,
    passes: &mut Passes,
    params: &ExtractParams,
    jobs: impl Iterator<Item = (usize, Result<Job<'a, T>>)>,
    mut done: impl FnMut(usize, Result<(Pixels<'a>, T, Extraction)>),
) {
    let mut in_flight: Option<InFlight<'a, T>> = None;
    let mut slot = 0usize;
    for (index, job) in jobs {
        let submitted = job.and_then(|job| {
            let view = job
                .prepared
                .denoised
                .as_ref()
                .map_or(job.pixels.view(), |f| f.view());
            let submitted = passes.submit(
                &backend.ctx,
                slot,
                &view,
                &job.prepared.level,
                params.weighting,
            )?;
            Ok((job, submitted))
        });
        match submitted {
            Ok((job, submitted)) => {
                slot ^= 1;
                if let Some(previous) = in_flight.replace(InFlight {
                    index,
                    job,
                    submitted,
                }) {
                    let (i, r) = finish(previous, backend, passes, params);
                    done(i, r);
                }
            }
            Err(e) => {
                if let Some(previous) = in_flight.take() {
                    let (i, r) = finish(previous, backend, passes, params);
                    done(i, r);
                }
                done(index, Err(e));
            }
        }
    }
    if let Some(previous) = in_flight.take() {
        let (i, r) = finish(previous, backend, passes, params);
        done(i, r);
    }
}

impl GpuBackend {
    /// Extract frames held in memory, pipelined (upload of frame n+1 overlaps
    /// the GPU work on frame n); `sink(index, result)` is called in input order.
    pub fn extract_sequence<'a>(
        &self,
        frames: impl IntoIterator<Item = FrameView<'a>>,
        params: &ExtractParams,
        mut sink: impl FnMut(usize, Result<Extraction>),
    ) {
        let mut passes = match self.lock() {
            Ok(p) => p,
            Err(_) => {
                for (i, _) in frames.into_iter().enumerate() {
                    sink(i, Err(self.ctx.error(super::backend::POISONED)));
                }
                return;
            }
        };
        let jobs = frames.into_iter().enumerate().map(|(i, frame)| {
            let job = GpuBackend::prepare(&frame, params).map(|prepared| Job {
                pixels: Pixels::Borrowed(frame),
                prepared,
                tag: (),
            });
            (i, job)
        });
        pipeline(self, &mut passes, params, jobs, |i, r| {
            sink(i, r.map(|(_, _, extraction)| extraction))
        });
    }
}

/// Decode `paths` in chunks of `ahead` on the rayon pool and send them in order.
fn decode_ahead<'a>(
    paths: &[PathBuf],
    params: &ExtractParams,
    expected_depth: Option<u8>,
    ahead: usize,
    recycled: &Mutex<Receiver<Vec<u16>>>,
    out: SyncSender<(usize, Result<Job<'a, FrameMetadata>>)>,
) {
    let readers: Mutex<Vec<FrameReader>> = Mutex::new(Vec::new());
    for (c, chunk) in paths.chunks(ahead).enumerate() {
        let decoded: Vec<Result<Job<'a, FrameMetadata>>> = chunk
            .par_iter()
            .map(|path| {
                let mut reader = readers
                    .lock()
                    .ok()
                    .and_then(|mut r| r.pop())
                    .unwrap_or_else(|| {
                        FrameReader::new()
                            .expect_bit_depth(expected_depth)
                            .limit_pixels(params.max_pixels)
                    });
                let mut pixels = recycled
                    .lock()
                    .ok()
                    .and_then(|r| r.try_recv().ok())
                    .unwrap_or_default();
                let result = reader.read(path).and_then(|(view, metadata)| {
                    let prepared =
                        GpuBackend::prepare(&view, params).map_err(|e| e.in_file(path))?;
                    pixels.clear();
                    pixels.extend_from_slice(view.pixels);
                    Ok(Job {
                        pixels: Pixels::Owned(Frame {
                            width: view.width,
                            height: view.height,
                            bit_depth: view.bit_depth,
                            pixels,
                        }),
                        prepared,
                        tag: metadata,
                    })
                });
                if let Ok(mut r) = readers.lock() {
                    r.push(reader);
                }
                result
            })
            .collect();
        for (i, d) in decoded.into_iter().enumerate() {
            if out.send((c * ahead + i, d)).is_err() {
                return;
            }
        }
    }
}

/// Decode and extract every file through the GPU; see the module documentation.
pub(super) fn files(
    backend: &GpuBackend,
    paths: &[PathBuf],
    params: &ExtractParams,
    expected_depth: Option<u8>,
    sink: &mut dyn FnMut(usize, &Path, Result<FrameBlobs>),
) {
    let mut passes = match backend.lock() {
        Ok(p) => p,
        Err(_) => {
            for (i, path) in paths.iter().enumerate() {
                sink(i, path, Err(backend.ctx.error(super::backend::POISONED)));
            }
            return;
        }
    };
    let ahead = rayon::current_num_threads().max(2);
    let (recycle, recycled) = channel::<Vec<u16>>();
    let recycled = Mutex::new(recycled);
    std::thread::scope(|scope| {
        let (tx, rx) = sync_channel(ahead);
        let recycled = &recycled;
        scope.spawn(move || decode_ahead(paths, params, expected_depth, ahead, recycled, tx));
        pipeline(
            backend,
            &mut passes,
            params,
            rx.into_iter(),
            |index, result| {
                let path = &paths[index];
                let result = result.map(|(pixels, metadata, extraction)| {
                    let blobs = batch::frame_blobs(
                        &pixels.view(),
                        metadata,
                        extraction,
                        params.weighting,
                        None,
                        params.denoise,
                    );
                    if let Pixels::Owned(frame) = pixels {
                        // The decoder may be gone already; the buffer is then dropped.
                        let _ = recycle.send(frame.pixels);
                    }
                    blobs
                });
                sink(index, path, result.map_err(|e| e.in_file(path)));
            },
        );
    });
}
