//! The refusals of bad calibration stacks (issue 24 item 8) beyond
//! [`crate::check_stack`]: stacks of two cameras, too few frames, a dark
//! with light in it, a flat darker than its dark, saturated or under-exposed.

use crate::calibrate::Options;
use crate::frame::{Frame, StackKind, check_same_camera, check_stack};
use crate::master::Master;
use crate::pattern::percentile1;
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

/// Both stacks checked, of one camera, and large enough.
pub(crate) fn check_stacks(
    flats: &[Frame<'_>],
    darks: &[Frame<'_>],
    options: &Options,
) -> Result<()> {
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
pub(crate) fn check_dark(dark: &Master, saturation: u16) -> Result<()> {
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
pub(crate) fn check_flat(flat: &Master, dark: &Master, saturation: u16) -> Result<()> {
    if flat.level_dn <= dark.level_dn {
        return Err(SensorError::FlatDarkerThanDark {
            flat_dn: flat.level_dn,
            dark_dn: dark.level_dn,
        });
    }
    // Hot pixels whose dark signal alone brings the flat to saturation are
    // defects the dark stack finds, not an over-exposed flat: left out.
    let headroom = f64::from(saturation) - flat.level_dn;
    let hot = dark
        .mean
        .iter()
        .filter(|&&d| f64::from(d) - dark.level_dn > headroom)
        .count();
    let fraction = (flat.saturated_fraction - hot as f64 / dark.mean.len().max(1) as f64).max(0.0);
    if fraction > SATURATED_FLAT_LIMIT {
        return Err(SensorError::SaturatedFlat {
            fraction,
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
