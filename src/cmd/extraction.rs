//! The extraction options every command that extracts blobs (`extract`,
//! `calibrate`, `measure`) flattens into its own: threshold, weighting,
//! denoising, blob sizes, backend and the largest frame decoded.

use anyhow::{Context, Result};
use clap::ValueEnum;
use extract::{Backend, Denoise, ExtractParams, Threshold, Weighting};

use crate::cmd::OrUsage;
use crate::cmd::backend::{BackendChoice, select_backend};

/// Centroid weighting.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum WeightingArg {
    /// F = f − T (the seed's formula).
    Subtracted,
    /// F = f.
    Raw,
}

/// Denoising filter.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DenoiseArg {
    /// None.
    None,
    /// 3×3 median.
    Median,
    /// Gaussian (see --sigma).
    Gaussian,
}

/// Options shared by every command that extracts blobs.
#[derive(Debug, Clone, clap::Args)]
pub struct ExtractOptions {
    /// Threshold T in DN (e.g. 6000 on 16-bit frames), `auto` (global
    /// background + k·σ) or `local` (background mesh + k·σ).
    #[arg(long, default_value = "auto", value_parser = threshold_arg)]
    threshold: String,
    /// k of the automatic thresholds.
    #[arg(long, default_value_t = extract::DEFAULT_K, value_parser = crate::cmd::values::positive)]
    k: f64,
    /// Box size of the local background mesh (px).
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(
        i64::from(extract::MIN_MESH_PX)..=i64::from(formats::limits::MAX_IMAGE_SIDE_PX)))]
    mesh: u32,
    /// Centroid weights.
    #[arg(long, value_enum, default_value_t = WeightingArg::Subtracted)]
    weighting: WeightingArg,
    /// Denoising before thresholding.
    #[arg(long, value_enum, default_value_t = DenoiseArg::None)]
    denoise: DenoiseArg,
    /// σ of the Gaussian denoising (px).
    #[arg(long, default_value_t = 1.0, value_parser = crate::cmd::values::positive_f32)]
    sigma: f32,
    /// Smallest blob kept (px).
    #[arg(long, default_value_t = extract::DEFAULT_MIN_AREA)]
    min_area: u64,
    /// Largest blob kept (px).
    #[arg(long)]
    max_area: Option<u64>,
    /// Compute backend.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// Largest frame decoded (pixels): an image whose header claims more is
    /// refused before anything is allocated for it (default 2²⁸; each side
    /// is at most 65536 px whatever the limit).
    #[arg(long, default_value_t = formats::limits::DEFAULT_MAX_PIXELS,
        value_parser = clap::value_parser!(u64).range(1..))]
    max_pixels: u64,
}

/// `--threshold`: `auto`, `local` or a level of at least 1 DN.
fn threshold_arg(text: &str) -> std::result::Result<String, String> {
    match text {
        "auto" | "local" => Ok(text.to_string()),
        t => match t.parse::<u16>() {
            Ok(level) if level >= 1 => Ok(text.to_string()),
            _ => Err(format!(
                "expected a level of 1..={} DN, 'auto' or 'local', got '{t}'",
                u16::MAX
            )),
        },
    }
}

impl ExtractOptions {
    /// The extraction parameters these flags describe.
    pub fn params(&self) -> Result<ExtractParams> {
        let threshold = match self.threshold.as_str() {
            "auto" => Threshold::Auto { k: self.k },
            "local" => Threshold::Local {
                k: self.k,
                mesh: self.mesh,
            },
            t => Threshold::Fixed(
                t.parse()
                    .with_context(|| {
                        format!("--threshold {t}: expected a level in DN, 'auto' or 'local'")
                    })
                    .or_usage()?,
            ),
        };
        let params = ExtractParams {
            threshold,
            weighting: match self.weighting {
                WeightingArg::Subtracted => Weighting::Subtracted,
                WeightingArg::Raw => Weighting::Raw,
            },
            denoise: match self.denoise {
                DenoiseArg::None => Denoise::None,
                DenoiseArg::Median => Denoise::Median3,
                DenoiseArg::Gaussian => Denoise::Gaussian { sigma: self.sigma },
            },
            min_area: self.min_area,
            max_area: self.max_area.unwrap_or(u64::MAX),
            max_pixels: self.max_pixels,
            ..ExtractParams::default()
        };
        params.validate().or_usage()?;
        Ok(params)
    }

    /// The backend these flags choose.
    pub fn backend(&self) -> Result<std::sync::Arc<dyn Backend>> {
        select_backend(self.backend)
    }
}
