//! [`GpuBackend`]: the [`Backend`] on a wgpu device.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

use super::context::{self, Context};
use super::pass::{Found, Passes};
use super::{AdapterKind, AdapterSummary, GpuOptions, GpuStats, segments};
use crate::backend::{Backend, ExtractParams, Extraction, filter_area};
use crate::background::BackgroundStats;
use crate::batch::FrameBlobs;
use crate::blob;
use crate::denoise;
use crate::frame::{Frame, FrameView};
use crate::label;
use crate::threshold::Level;
use crate::{ExtractError, Result};

/// Extraction on a GPU through wgpu (Vulkan, WGSL): run segments with exact
/// integer sums on the GPU, joining and labelling on the host. Finds the same
/// blobs with the same moments as [`CpuBackend`](crate::CpuBackend).
pub struct GpuBackend {
    pub(super) ctx: Context,
    pub(super) passes: Mutex<Passes>,
}

impl std::fmt::Debug for GpuBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuBackend")
            .field("adapter", &self.ctx.adapter)
            .finish()
    }
}

/// Why the backend's buffers cannot be used any more.
pub(super) const POISONED: &str = "a previous frame panicked while holding the GPU buffers";

/// A frame prepared on the host for the kernel: denoised (if asked) and its threshold.
pub(super) struct Prepared {
    /// The denoised frame, when denoising was asked for.
    pub denoised: Option<Frame>,
    pub level: Level,
    pub background: Option<BackgroundStats>,
}

impl GpuBackend {
    /// Open the best Vulkan adapter, whatever its kind (a software adapter
    /// too); fails with the reason when there is none or it cannot run the kernel.
    pub fn new(options: &GpuOptions) -> Result<Self> {
        let probe = context::probe(options).map_err(|message| ExtractError::Backend {
            backend: "gpu".into(),
            message,
        })?;
        Self::open(probe, options)
    }

    pub(super) fn open(probe: context::Probe, options: &GpuOptions) -> Result<Self> {
        Ok(Self {
            ctx: Context::open(probe, options)?,
            passes: Mutex::new(Passes::default()),
        })
    }

    /// The adapter in use.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.ctx.adapter
    }

    /// Pixel bytes of one band at most: larger frames are cut into bands of rows.
    pub fn band_bytes(&self) -> u64 {
        self.ctx.band_bytes
    }

    /// What the backend has done so far.
    pub fn stats(&self) -> GpuStats {
        self.passes.lock().map(|p| p.stats).unwrap_or_default()
    }

    pub(super) fn lock(&self) -> Result<MutexGuard<'_, Passes>> {
        self.passes.lock().map_err(|_| self.ctx.error(POISONED))
    }

    /// Host side before the kernel: parameters, denoising, threshold.
    pub(super) fn prepare(frame: &FrameView<'_>, params: &ExtractParams) -> Result<Prepared> {
        params.validate_for(frame)?;
        let denoised = denoise::apply(frame, params.denoise);
        let view = denoised.as_ref().map_or(*frame, |f| f.view());
        let (level, background) = params.threshold.resolve(&view)?;
        Ok(Prepared {
            denoised,
            level,
            background,
        })
    }

    /// Host side after the kernel: runs, components, blobs, area limits.
    pub(super) fn complete(
        frame: &FrameView<'_>,
        prepared: Prepared,
        found: Found,
        params: &ExtractParams,
    ) -> Result<Extraction> {
        let Prepared {
            denoised,
            level,
            background,
        } = prepared;
        let frame = denoised.as_ref().map_or(*frame, |f| f.view());
        let labelling = match found {
            Found::Segments(s) => segments::label(segments::runs(s), &level, params.max_runs)?,
            // Far more segments than any sensible threshold gives: the CPU labeller decides (and
            // most likely reports too many runs).
            Found::TooMany => label::label(&frame, &level, params.weighting, params.max_runs)?,
        };
        let all = blob::collect(&frame, labelling);
        Ok(filter_area(all, level, background, params))
    }
}

impl Backend for GpuBackend {
    fn name(&self) -> String {
        let kind = match self.ctx.adapter.kind {
            AdapterKind::Discrete => "discrete GPU",
            AdapterKind::Integrated => "integrated GPU",
            AdapterKind::Virtual => "virtual GPU",
            AdapterKind::Cpu => "software Vulkan on the CPU",
            AdapterKind::Other => "GPU",
        };
        format!("gpu: {}, {kind}, Vulkan", self.ctx.adapter.describe())
    }

    fn extract(&self, frame: FrameView<'_>, params: &ExtractParams) -> Result<Extraction> {
        let prepared = Self::prepare(&frame, params)?;
        let view = prepared.denoised.as_ref().map_or(frame, |f| f.view());
        let found = {
            let mut passes = self.lock()?;
            let submitted =
                passes.submit(&self.ctx, 0, &view, &prepared.level, params.weighting)?;
            passes.finish(&self.ctx, submitted)?
        };
        Self::complete(&frame, prepared, found, params)
    }

    fn extract_batch(
        &self,
        paths: &[PathBuf],
        params: &ExtractParams,
        expected_depth: Option<u8>,
        sink: &mut dyn FnMut(usize, &Path, Result<FrameBlobs>),
    ) {
        super::sequence::files(self, paths, params, expected_depth, sink);
    }

    fn extract_frames(
        &self,
        frames: &[FrameView<'_>],
        params: &ExtractParams,
        sink: &mut dyn FnMut(usize, Result<Extraction>),
    ) {
        self.extract_sequence(frames.iter().copied(), params, sink);
    }
}
