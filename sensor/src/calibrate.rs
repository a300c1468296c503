//! A camera's sensor calibration from a flat stack and a dark stack: the
//! refusals of issue 24 item 8, the masters, photon transfer, DSNU and PRNU,
//! the defect map, and the decisions which per-pixel maps correct a frame.
//!
//! The decision rule (METHODS §6): a map is used only where its own noise
//! is at most `useful_noise_ratio` (0.5) times the fixed pattern it
//! corrects; otherwise it would replace a pattern by one of its own noise.
//! A single flat at 30 000 DN (≈ 10⁴ e⁻) has ≈ 1 % shot noise per pixel,
//! as large as a 1 % PRNU: the smooth model is kept. The column/row pattern
//! of the dark is estimated from whole lines, so its noise is `√H` times
//! smaller than a pixel's and it is often worth correcting when the
//! per-pixel dark is not.

use crate::adc::{AdcDepth, adc_depth};
use crate::correct::SensorMaps;
use crate::defect_map::DefectMap;
use crate::detect::{Criteria, defect_codes};
use crate::frame::{Frame, StackKind, check_same_camera, check_stack, same_exposure};
use crate::gain::{StackNoise, gain_map, gain_variances};
use crate::master::{Master, master};
use crate::pattern::{
    DarkVariances, Lines, dark_variances, mean_lines, percentile1, residual_sigma, robust_lines,
};
use crate::transfer::{PhotonTransfer, TRANSFER_FRAMES, photon_transfer};
use crate::{Result, SensorError};

/// A flat with more pixels saturated than this fraction is refused.
const SATURATED_FLAT_LIMIT: f64 = 1e-4;
/// A flat's level above the dark must be at least this fraction of the full
/// scale (a gain map and photon transfer need signal).
const MIN_FLAT_FRACTION: f64 = 0.05;
/// … and at least this many times the dark's temporal noise (then the
/// shot noise dominates: EMVA 1288 asks for a level well above the dark).
const MIN_FLAT_DARK_NOISES: f64 = 100.0;
/// A dark whose mean is more than this fraction of the full scale above its
/// own 1st percentile has light in it (uneven light: a leak, an uncovered
/// lens in a dim room).
const DARK_LIGHT_SPREAD: f64 = 0.10;
/// A dark brighter than this fraction of the full scale has light in it
/// (no sensor offset is that high).
const DARK_LIGHT_LEVEL: f64 = 0.20;

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
/// [`check_stack`] on each stack and between them (size, bit depth); a
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

/// Both stacks checked, of one camera, and large enough.
fn check_stacks(flats: &[Frame<'_>], darks: &[Frame<'_>], options: &Options) -> Result<()> {
    check_stack(flats, StackKind::Flat)?;
    check_stack(darks, StackKind::Dark)?;
    if let (Some(f0), Some(d0)) = (flats.first(), darks.first()) {
        check_same_camera(d0, StackKind::Dark, 0, f0, StackKind::Flat)?;
    }
    for (kind, frames) in [(StackKind::Flat, flats), (StackKind::Dark, darks)] {
        if frames.len() < options.min_stack_frames {
            return Err(SensorError::StackTooSmall {
                kind,
                frames: frames.len(),
                needed: options.min_stack_frames,
                what: "a per-pixel map (its noise is judged from the temporal noise of a pair \
                       of frames)"
                    .into(),
            });
        }
    }
    Ok(())
}

/// A dark without light: its mean within 10 % of the full scale of its 1st
/// percentile and below 20 % of the full scale.
fn check_dark(dark: &Master, saturation: u16) -> Result<()> {
    let full = f64::from(saturation);
    let p1 = percentile1(&dark.mean);
    let above = dark.level_dn - p1;
    if above > DARK_LIGHT_SPREAD * full || dark.level_dn > DARK_LIGHT_LEVEL * full {
        return Err(SensorError::DarkWithLight {
            level_dn: dark.level_dn,
            percentile1_dn: p1,
            above_dn: above,
            above_limit_dn: DARK_LIGHT_SPREAD * full,
            bright_limit_dn: DARK_LIGHT_LEVEL * full,
            full_scale_dn: saturation,
        });
    }
    Ok(())
}

/// A flat brighter than its dark, not saturated and well exposed.
fn check_flat(flat: &Master, dark: &Master, saturation: u16) -> Result<()> {
    if flat.level_dn <= dark.level_dn {
        return Err(SensorError::FlatDarkerThanDark {
            flat_dn: flat.level_dn,
            dark_dn: dark.level_dn,
        });
    }
    if flat.saturated_fraction > SATURATED_FLAT_LIMIT {
        return Err(SensorError::SaturatedFlat {
            fraction: flat.saturated_fraction,
            limit: SATURATED_FLAT_LIMIT,
            saturation_dn: saturation,
        });
    }
    let signal = flat.level_dn - dark.level_dn;
    let by_scale = MIN_FLAT_FRACTION * f64::from(saturation);
    let by_noise = dark.temporal_dn().map(|s| MIN_FLAT_DARK_NOISES * s);
    let (needed, reason) = match by_noise {
        Some(n) if n > by_scale => (
            n,
            format!(
                "{MIN_FLAT_DARK_NOISES} × the dark's temporal noise {:.2} DN",
                n / MIN_FLAT_DARK_NOISES
            ),
        ),
        _ => (
            by_scale,
            format!(
                "{} % of the full scale {saturation} DN",
                MIN_FLAT_FRACTION * 100.0
            ),
        ),
    };
    if signal < needed {
        return Err(SensorError::UnderexposedFlat {
            signal_dn: signal,
            needed_dn: needed,
            reason,
        });
    }
    Ok(())
}

/// The dark's fixed pattern, noise shares removed (DN), and what judges
/// its maps.
struct DarkPattern {
    /// Total DSNU.
    total: f64,
    /// Column DSNU.
    columns: f64,
    /// Row DSNU.
    rows: f64,
    /// The pixel pattern beyond the lines (DSNU without its temporal share
    /// when that is known; with it for a single frame).
    pixel: f64,
    /// σ of the line pattern per pixel, `√(σ²_col + σ²_row)`.
    lines: f64,
    /// Noise of the line pattern's estimate per pixel.
    lines_noise: f64,
    /// Noise of the per-pixel master dark (`None` for one frame).
    pixel_noise: Option<f64>,
}

impl DarkPattern {
    fn new(v: &DarkVariances, noise_dn: Option<f64>, w: usize, h: usize) -> Self {
        let temporal = noise_dn.map_or(0.0, |n| n * n);
        let (wf, hf) = (w.max(1) as f64, h.max(1) as f64);
        // A column mean holds 1/H of the residual's variance (pixel pattern
        // and noise), a row mean 1/W.
        let columns = (v.columns - v.residual / hf).max(0.0);
        let rows = (v.rows - v.residual / wf).max(0.0);
        Self {
            total: (v.total - temporal).max(0.0).sqrt(),
            columns: columns.sqrt(),
            rows: rows.sqrt(),
            pixel: (v.residual - temporal).max(0.0).sqrt(),
            lines: (columns + rows).sqrt(),
            lines_noise: (v.residual / hf + v.residual / wf).sqrt(),
            pixel_noise: noise_dn,
        }
    }

    /// The dark model and why, with the numbers.
    fn decide(&self, ratio: f64, frames: usize, black_dn: f64) -> (DarkModel, String) {
        let pixel_useful = self.pixel_noise.is_some_and(|n| n <= ratio * self.pixel);
        let lines_useful = self.lines > 0.0 && self.lines_noise <= ratio * self.lines;
        let verdict = |used: bool| if used { "used" } else { "not used" };
        let why_not = if lines_useful {
            String::new()
        } else {
            format!(": not ≤ {ratio} × the pattern")
        };
        let lines_text = format!(
            "column/row pattern {} ({:.2} DN, estimated to {:.2} DN from whole lines{why_not})",
            verdict(lines_useful),
            self.lines,
            self.lines_noise,
        );
        let pixel_text = match self.pixel_noise {
            Some(n) => format!(
                "per-pixel master dark {}: its noise {n:.2} DN ({frames} frames) is {} {ratio} × \
                 the pixel DSNU {:.2} DN it corrects beyond the column/row pattern",
                verdict(pixel_useful),
                if pixel_useful { "≤" } else { "not ≤" },
                self.pixel
            ),
            None => format!(
                "per-pixel master dark not used: a single dark frame, whose temporal noise \
                 cannot be measured and is part of its pixel pattern of {:.2} DN",
                self.pixel
            ),
        };
        if pixel_useful {
            (DarkModel::PerPixel, pixel_text)
        } else if lines_useful {
            (DarkModel::Lines, format!("{lines_text}; {pixel_text}"))
        } else {
            (
                DarkModel::Scalar,
                format!("scalar black level {black_dn:.1} DN only: {lines_text}; {pixel_text}"),
            )
        }
    }
}

/// Whether the gain map is used, and why, with the numbers.
fn decide_gain(
    ratio: f64,
    prnu: f64,
    noise: Option<f64>,
    flats: usize,
    darks: usize,
    signal_dn: f64,
) -> (bool, String) {
    match noise {
        Some(n) if n <= ratio * prnu => (
            true,
            format!(
                "per-pixel gain map used: its noise {:.3} % ({flats} flats at {signal_dn:.0} DN \
                 above {darks} darks) is ≤ {ratio} × the PRNU {:.3} % it corrects",
                n * 100.0,
                prnu * 100.0
            ),
        ),
        Some(n) => (
            false,
            format!(
                "smooth model kept, gain map not used: its noise {:.3} % ({flats} flats at \
                 {signal_dn:.0} DN above {darks} darks) is not ≤ {ratio} × the PRNU {:.3} % it \
                 would correct (dividing by it would trade the PRNU for a pattern of its own \
                 noise; more flats lower the noise as 1/√N)",
                n * 100.0,
                prnu * 100.0
            ),
        ),
        None => (
            false,
            format!(
                "smooth model kept, gain map not used: the noise of a gain map from {flats} \
                 flat(s) and {darks} dark(s) cannot be measured (that needs ≥ 2 of each), and a \
                 single flat's shot noise per pixel, 1/√electrons (≈ 1 % at 10 000 e⁻, as in a \
                 flat at 30 000 DN at 3 DN/e⁻), is as large as a typical PRNU; this map's \
                 spread, PRNU and noise together, is {:.3} %",
                prnu * 100.0
            ),
        ),
    }
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
