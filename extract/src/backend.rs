//! The backend seam: a [`Backend`] turns a frame into blobs. The CPU backend
//! is the reference; the GPU backend ([`crate::gpu`]) plugs in behind the same
//! trait and finds the same blobs with the same moments.

use std::path::{Path, PathBuf};

use formats::limits::{DEFAULT_MAX_PIXELS, check_image_size};
use serde::{Deserialize, Serialize};

use crate::background::BackgroundStats;
use crate::batch::{self, FrameBlobs};
use crate::blob::{self, Blob};
use crate::denoise::{self, Denoise};
use crate::frame::FrameView;
use crate::label::{self, Weighting};
use crate::threshold::{Level, Threshold};
use crate::{ParameterProblem, Result};

/// Default smallest blob kept (px): smaller ones are noise spikes.
pub const DEFAULT_MIN_AREA: u64 = 5;
/// Default limit on above-threshold runs per frame (guards against a threshold in the noise).
pub const DEFAULT_MAX_RUNS: usize = 2_000_000;

/// Everything that decides what is extracted from a frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ExtractParams {
    /// Threshold T: fixed or automatic.
    pub threshold: Threshold,
    /// Centroid weights: `F = f − T` or `F = f`.
    pub weighting: Weighting,
    /// Optional denoising before thresholding.
    pub denoise: Denoise,
    /// Smallest blob kept (px).
    pub min_area: u64,
    /// Largest blob kept (px).
    pub max_area: u64,
    /// Give up on a frame with more above-threshold runs than this.
    pub max_runs: usize,
    /// Refuse frames of more pixels than this (decoded or given), before
    /// anything is allocated for them.
    #[serde(default = "default_max_pixels")]
    pub max_pixels: u64,
}

fn default_max_pixels() -> u64 {
    DEFAULT_MAX_PIXELS
}

impl Default for ExtractParams {
    fn default() -> Self {
        Self {
            threshold: Threshold::default(),
            weighting: Weighting::Subtracted,
            denoise: Denoise::None,
            min_area: DEFAULT_MIN_AREA,
            max_area: u64::MAX,
            max_runs: DEFAULT_MAX_RUNS,
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}

impl ExtractParams {
    /// Check the parameters for `frame`: on their own ([`Self::validate`])
    /// and the frame's size (at most [`Self::max_pixels`] pixels and
    /// [`formats::limits::MAX_IMAGE_SIDE_PX`] a side, so that every sum stays exact).
    pub fn validate_for(&self, frame: &FrameView<'_>) -> Result<()> {
        self.validate()?;
        check_image_size(
            u64::from(frame.width),
            u64::from(frame.height),
            self.max_pixels,
        )
        .map_err(|e| ParameterProblem::Size(e).into())
    }

    /// Check the parameters on their own.
    pub fn validate(&self) -> Result<()> {
        self.threshold.validate()?;
        if self.max_pixels == 0 {
            return Err(ParameterProblem::ZeroMaxPixels.into());
        }
        if self.min_area > self.max_area {
            return Err(ParameterProblem::AreaRange {
                min_area: self.min_area,
                max_area: self.max_area,
            }
            .into());
        }
        if let Denoise::Gaussian { sigma } = self.denoise
            && !(sigma.is_finite() && sigma > 0.0)
        {
            return Err(ParameterProblem::GaussianSigma(sigma).into());
        }
        Ok(())
    }
}

/// What one frame gave.
#[derive(Debug, Clone, PartialEq)]
pub struct Extraction {
    /// Blobs in raster order of their first pixel, within the area limits.
    pub blobs: Vec<Blob>,
    /// The threshold used.
    pub level: Level,
    /// The background estimate, when the threshold was automatic and global.
    pub background: Option<BackgroundStats>,
    /// Blobs dropped for being smaller than `min_area`.
    pub too_small: usize,
    /// Blobs dropped for being larger than `max_area`.
    pub too_large: usize,
    /// Blobs dropped because every pixel is exactly at the threshold (no
    /// weight): saturated blobs when the threshold is the saturation level.
    pub weightless: usize,
    /// Of those, blobs at the frame's saturation level.
    pub weightless_saturated: usize,
}

impl Extraction {
    /// Blobs kept with pixels at the saturation level.
    pub fn saturated(&self) -> usize {
        self.blobs.iter().filter(|b| b.saturated()).count()
    }

    /// What the frame's saturated blobs are, for a problems list: `None`
    /// when none is saturated or dropped for want of weight.
    pub fn saturation_note(&self, saturation: u16) -> Option<String> {
        let kept = self.saturated();
        let mut parts = Vec::new();
        if kept > 0 {
            parts.push(format!(
                "{kept} of {} blobs saturated (pixels at {saturation} DN): their weights are \
                 clipped",
                self.blobs.len()
            ));
        }
        if self.weightless > 0 {
            parts.push(format!(
                "{} blobs dropped: every pixel at the threshold {}{}, so no weight and no centroid",
                self.weightless,
                self.level.describe(),
                if self.weightless_saturated > 0 {
                    format!(
                        ", the saturation level ({} of them saturated)",
                        self.weightless_saturated
                    )
                } else {
                    String::new()
                }
            ));
        }
        (!parts.is_empty()).then(|| format!("{}; lower the exposure", parts.join("; ")))
    }
}

/// A compute backend for extraction.
pub trait Backend: Send + Sync {
    /// Name for logs and benchmark output (for a GPU: the adapter).
    fn name(&self) -> String;
    /// Extract the blobs of one frame.
    fn extract(&self, frame: FrameView<'_>, params: &ExtractParams) -> Result<Extraction>;

    /// Decode and extract every file; `sink(index, path, result)` is called
    /// once per file, in input order, and a failed file does not stop the
    /// batch. `expected_depth` rejects frames of another bit depth. The default
    /// decodes and extracts frames in parallel on the rayon pool
    /// (`batch::extract_parallel`); the GPU backend pipelines instead.
    fn extract_batch(
        &self,
        paths: &[PathBuf],
        params: &ExtractParams,
        expected_depth: Option<u8>,
        sink: &mut dyn FnMut(usize, &Path, Result<FrameBlobs>),
    ) {
        batch::extract_parallel(paths, self, params, expected_depth, None, sink);
    }

    /// Extract frames held in memory; `sink(index, result)` is called once per
    /// frame, in order. The default extracts one frame after the other; the
    /// GPU backend pipelines (upload of frame n+1 overlaps the work on frame n).
    fn extract_frames(
        &self,
        frames: &[FrameView<'_>],
        params: &ExtractParams,
        sink: &mut dyn FnMut(usize, Result<Extraction>),
    ) {
        for (i, frame) in frames.iter().enumerate() {
            sink(i, self.extract(*frame, params));
        }
    }
}

/// The reference backend: rayon across row bands (and across frames in batches).
#[derive(Debug, Clone, Copy, Default)]
pub struct CpuBackend;

impl Backend for CpuBackend {
    fn name(&self) -> String {
        format!("cpu ({} threads)", rayon::current_num_threads())
    }

    fn extract(&self, frame: FrameView<'_>, params: &ExtractParams) -> Result<Extraction> {
        params.validate_for(&frame)?;
        let denoised = denoise::apply(&frame, params.denoise);
        let frame = denoised.as_ref().map_or(frame, |f| f.view());
        let (level, background) = params.threshold.resolve(&frame)?;
        let labelling = label::label(&frame, &level, params.weighting, params.max_runs)?;
        let all = blob::collect(&frame, labelling);
        Ok(filter_area(all, level, background, params))
    }
}

/// Apply the area limits and assemble the result (shared by every backend).
pub fn filter_area(
    collected: blob::Collected,
    level: Level,
    background: Option<BackgroundStats>,
    params: &ExtractParams,
) -> Extraction {
    let blob::Collected {
        blobs: all,
        weightless,
        weightless_saturated,
    } = collected;
    let total = all.len();
    let too_small = all.iter().filter(|b| b.area_px < params.min_area).count();
    let blobs: Vec<Blob> = all
        .into_iter()
        .filter(|b| (params.min_area..=params.max_area).contains(&b.area_px))
        .collect();
    Extraction {
        too_large: total - too_small - blobs.len(),
        too_small,
        blobs,
        level,
        background,
        weightless,
        weightless_saturated,
    }
}
