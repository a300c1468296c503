//! A camera's sensor calibration from a flat stack and a dark stack: the
//! refusals ([`crate::refusal`]), the masters, photon transfer, DSNU and
//! PRNU, the defect map, and the maps chosen to correct a frame
//! ([`crate::decision`]).

use crate::Result;
use crate::adc::{AdcDepth, adc_depth};
use crate::correct::SensorMaps;
use crate::decision::{DarkPattern, decide_gain};
use crate::defect_map::DefectMap;
use crate::detect::{Criteria, defect_codes};
use crate::frame::{Frame, same_exposure};
use crate::gain::{StackNoise, gain_map, gain_variances};
use crate::master::{Master, master};
use crate::pattern::{Lines, dark_variances, mean_lines, residual_sigma, robust_lines};
use crate::refusal::{check_dark, check_flat, check_stacks};
use crate::transfer::{PhotonTransfer, TRANSFER_FRAMES, photon_transfer};

/// Thresholds of the calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    /// Hot: master dark above its column/row pattern by more than this many
    /// σ of its robust spatial noise (default 6).
    pub hot_sigmas: f64,
    /// A threshold in DN above the pattern instead of `hot_sigmas`.
    pub hot_threshold_dn: Option<f64>,
    /// Weak below `1 − tolerance`, strong above `1 + tolerance` in the gain
    /// map (default 0.30).
    pub gain_tolerance: f64,
    /// Dead: gain map below this (default 0.10: no response).
    pub dead_below: f64,
    /// A per-pixel map is used only if its noise ≤ this × the pattern it
    /// corrects (default 0.5).
    pub useful_noise_ratio: f64,
    /// Frames each stack must hold (default 2: a per-pixel map needs the
    /// temporal noise of a pair to be judged; 1 accepts single frames, whose
    /// per-pixel maps are then never used).
    pub min_stack_frames: usize,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            hot_sigmas: 6.0,
            hot_threshold_dn: None,
            gain_tolerance: 0.30,
            dead_below: 0.10,
            useful_noise_ratio: 0.5,
            min_stack_frames: TRANSFER_FRAMES,
        }
    }
}

/// Which dark correction a frame gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DarkModel {
    /// The scalar black level only.
    Scalar,
    /// The black level plus the column and row offsets.
    Lines,
    /// The per-pixel master dark.
    PerPixel,
}

/// Every result of a camera's sensor calibration and the decisions made.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorCalibration {
    /// The ADC behind the files.
    pub adc: AdcDepth,
    /// Frames in the flat stack.
    pub flats: usize,
    /// Frames in the dark stack.
    pub darks: usize,
    /// Per-pixel noise of the master flat, `σ_y.flat/√N` (DN).
    pub flat_noise_dn: Option<f64>,
    /// Per-pixel noise of the master dark, `σ_y.dark/√N` (DN).
    pub dark_noise_dn: Option<f64>,
    /// Spatial σ of the master dark (defects out), its temporal share
    /// `σ²_y.dark/N` removed (DN).
    pub dsnu_dn: f64,
    /// Spatial σ of the column means of the master dark, the share of the
    /// pixel pattern and noise in a column mean removed (DN).
    pub column_dsnu_dn: f64,
    /// Spatial σ of the row means of the master dark, likewise (DN).
    pub row_dsnu_dn: f64,
    /// Spatial σ of the gain map (defects out), the stacks' noise removed in
    /// quadrature, relative (no noise removed from a single flat).
    pub prnu: f64,
    /// Relative per-pixel noise of the gain map from the stacks; `None`
    /// without photon transfer.
    pub gain_noise: Option<f64>,
    /// Photon transfer; `None` with a stack of 1 (`transfer_note` says why).
    pub transfer: Option<PhotonTransfer>,
    /// Why there is no photon transfer, or what limits it.
    pub transfer_note: Option<String>,
    /// The maps that correct a frame.
    pub maps: SensorMaps,
    /// Which dark correction `maps` holds.
    pub dark_model: DarkModel,
    /// Why the per-pixel dark is used or not (with numbers).
    pub dark_note: String,
    /// Why the gain map is used or not (with numbers).
    pub gain_note: String,
}

/// From a flat stack and a dark stack of one camera and the smooth model of
/// `(flat − dark)` (`smooth(u, v)` at pixel centres, any scale: the gain map
/// is normalised to median 1): masters, ADC depth, photon transfer,
/// DSNU/PRNU, defect map, and the maps with the use decisions.
///
/// Refusals, each naming the stack or frame and the numbers: the checks of
/// [`crate::check_stack`] on each stack and between them (size, bit depth); a
/// stack of fewer than `min_stack_frames`; a dark with light in it (its mean
/// more than 10 % of the full scale above its own 1st percentile, or above
/// 20 % of the full scale); a flat not brighter than its dark; a saturated
/// flat (more than 10⁻⁴ of its pixels at saturation); an under-exposed flat
/// (less than 5 % of the full scale or 100 × the dark's temporal noise above
/// the dark); a flat without shot noise (photon transfer).
pub fn calibrate(
    flats: &[Frame<'_>],
    darks: &[Frame<'_>],
    smooth: &dyn Fn(f64, f64) -> f64,
    options: &Options,
) -> Result<SensorCalibration> {
    check_stacks(flats, darks, options)?;
    let all: Vec<Frame<'_>> = flats.iter().chain(darks).copied().collect();
    let adc = adc_depth(&all);
    let saturation = adc.saturation_dn();
    let dark = master(darks, saturation)?;
    check_dark(&dark, saturation)?;
    let flat = master(flats, saturation)?;
    check_flat(&flat, &dark, saturation)?;
    let transfer = match (flat.frames, dark.frames) {
        (f, d) if f >= TRANSFER_FRAMES && d >= TRANSFER_FRAMES => {
            Some(photon_transfer(&flat, &dark, adc)?)
        }
        _ => None,
    };
    let (width, height) = (dark.width, dark.height);
    let (w, h) = (width as usize, height as usize);

    let robust = robust_lines(&dark.mean, w, h);
    let sigma = residual_sigma(&dark.mean, w, &robust).max(adc.quantisation_var_dn2().sqrt());
    let gain = gain_map(&flat.mean, &dark.mean, w, smooth)?;
    let criteria = Criteria {
        hot_above_dn: options
            .hot_threshold_dn
            .unwrap_or(options.hot_sigmas * sigma),
        dead_below: options.dead_below,
        gain_tolerance: options.gain_tolerance,
    };
    let codes = defect_codes(&dark.mean, &gain, w, &robust, &criteria);
    let defects = DefectMap::from_codes(width, height, &codes)?;
    let good = |i: usize| codes[i] == 0;

    let lines = mean_lines(&dark.mean, w, h, robust.black, &good);
    let dsnu = DarkPattern::new(
        &dark_variances(&dark.mean, w, &lines, &good),
        dark.noise_dn(),
        w,
        h,
    );
    let noise = transfer.as_ref().map(|t| StackNoise {
        dark_var_dn2: t.dark_temporal_dn.powi(2),
        gain_dn_per_e: t.gain_dn_per_e,
        flats: flat.frames,
        darks: dark.frames,
    });
    let (gain_var, noise_var) =
        gain_variances(&gain, &flat.mean, &dark.mean, w, noise.as_ref(), &good);
    let prnu = (gain_var - noise_var).max(0.0).sqrt();
    let gain_noise = noise.map(|_| noise_var.sqrt());

    let ratio = options.useful_noise_ratio;
    let (dark_model, dark_note) = dsnu.decide(ratio, dark.frames, lines.black);
    let signal_dn = flat.level_dn - dark.level_dn;
    let (use_gain, gain_note) =
        decide_gain(ratio, prnu, gain_noise, flat.frames, dark.frames, signal_dn);
    let maps = SensorMaps {
        width,
        height,
        black_level_dn: lines.black as f32,
        dark: dark_map(dark_model, &dark.mean, &lines, w),
        gain: use_gain.then(|| neutral_at_defects(gain, &codes)),
        defects,
        saturation,
    };
    Ok(SensorCalibration {
        adc,
        flats: flat.frames,
        darks: dark.frames,
        flat_noise_dn: flat.noise_dn(),
        dark_noise_dn: dark.noise_dn(),
        dsnu_dn: dsnu.total,
        column_dsnu_dn: dsnu.columns,
        row_dsnu_dn: dsnu.rows,
        prnu,
        gain_noise,
        transfer_note: transfer_note(
            transfer.as_ref(),
            &flat,
            &dark,
            adc,
            exposures(flats, darks),
        ),
        transfer,
        maps,
        dark_model,
        dark_note,
        gain_note,
    })
}

/// The dark map for the chosen model.
fn dark_map(model: DarkModel, dark: &[f32], lines: &Lines, w: usize) -> Option<Vec<f32>> {
    let w = w.max(1);
    match model {
        DarkModel::Scalar => None,
        DarkModel::PerPixel => Some(dark.to_vec()),
        DarkModel::Lines => Some(
            (0..dark.len())
                .map(|i| lines.at(i % w, i / w) as f32)
                .collect(),
        ),
    }
}

/// The gain map with 1 at defective pixels (they are replaced, and a dead
/// pixel's gain would be 0).
fn neutral_at_defects(mut gain: Vec<f32>, codes: &[u8]) -> Vec<f32> {
    for (g, &c) in gain.iter_mut().zip(codes) {
        if c != 0 {
            *g = 1.0;
        }
    }
    gain
}

/// The exposure times (s) of the flats and the darks when both are known
/// and differ.
fn exposures(flats: &[Frame<'_>], darks: &[Frame<'_>]) -> Option<(f64, f64)> {
    let flat = flats.first()?.exposure_s?;
    let dark = darks.first()?.exposure_s?;
    (!same_exposure(Some(flat), Some(dark))).then_some((flat, dark))
}

/// Why photon transfer is missing, or what limits it: the read noise below
/// the quantisation noise, darks of another exposure than the flats.
fn transfer_note(
    transfer: Option<&PhotonTransfer>,
    flat: &Master,
    dark: &Master,
    adc: AdcDepth,
    exposures: Option<(f64, f64)>,
) -> Option<String> {
    let mut notes = Vec::new();
    match transfer {
        None => notes.push(format!(
            "no photon transfer: it needs ≥ {TRANSFER_FRAMES} flats and ≥ {TRANSFER_FRAMES} \
             darks (the temporal noise is ½·var(A − B) of a pair), the stacks hold {} flat(s) \
             and {} dark(s)",
            flat.frames, dark.frames
        )),
        Some(t) if t.read_noise_e == 0.0 => notes.push(format!(
            "the dark's temporal noise {:.3} DN is not above the quantisation noise {:.3} DN \
             (step {} DN/√12): the read noise is at most {:.3} e⁻",
            t.dark_temporal_dn,
            adc.quantisation_var_dn2().sqrt(),
            adc.step_dn(),
            t.dark_temporal_dn / t.gain_dn_per_e
        )),
        Some(_) => {}
    }
    if let Some((flat_s, dark_s)) = exposures.filter(|_| transfer.is_some()) {
        notes.push(format!(
            "the darks were exposed {dark_s} s and the flats {flat_s} s: photon transfer takes \
             the darks' level and noise for those of the flats' exposure (true where the dark \
             current is negligible)"
        ));
    }
    (!notes.is_empty()).then(|| notes.join("; "))
}
