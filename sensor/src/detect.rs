//! Finding defective pixels (EMVA 1288 defect pixels, METHODS §6): hot
//! pixels from the master dark, dead / weak / strong pixels from the gain
//! map.
//!
//! A hot pixel stands out from its own column and row: the master dark less
//! its line pattern ([`crate::pattern::robust_lines`]) exceeds the threshold,
//! so a bright column is a column offset, not a column of hot pixels.

use rayon::prelude::*;

use crate::defect_map::DefectKind;
use crate::pattern::Lines;

/// Thresholds of the defect criteria.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Criteria {
    /// Hot: master dark above its line pattern by more than this (DN).
    pub(crate) hot_above_dn: f64,
    /// Dead: gain below this.
    pub(crate) dead_below: f64,
    /// Weak: gain below `1 − tolerance`; strong: above `1 + tolerance`.
    pub(crate) gain_tolerance: f64,
}

/// The code of each pixel (0 good, else [`DefectKind::code`]); a pixel hot
/// in the dark is hot whatever its gain.
pub(crate) fn defect_codes(
    dark: &[f32],
    gain: &[f32],
    width: usize,
    lines: &Lines,
    criteria: &Criteria,
) -> Vec<u8> {
    let mut codes = vec![0u8; dark.len()];
    codes
        .par_chunks_mut(width.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, code) in row.iter_mut().enumerate() {
                let i = y * width + x;
                let above = f64::from(dark[i]) - lines.at(x, y);
                *code = classify(above, f64::from(gain[i]), criteria).map_or(0, DefectKind::code);
            }
        });
    codes
}

/// The kind of a pixel `above_dn` above its dark pattern with relative
/// gain `gain`.
fn classify(above_dn: f64, gain: f64, c: &Criteria) -> Option<DefectKind> {
    if above_dn > c.hot_above_dn {
        Some(DefectKind::Hot)
    } else if gain.is_nan() || gain < c.dead_below {
        Some(DefectKind::Dead)
    } else if gain < 1.0 - c.gain_tolerance {
        Some(DefectKind::Weak)
    } else if gain > 1.0 + c.gain_tolerance {
        Some(DefectKind::Strong)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_by_their_criteria() {
        let c = Criteria {
            hot_above_dn: 100.0,
            dead_below: 0.1,
            gain_tolerance: 0.3,
        };
        assert_eq!(classify(150.0, 1.0, &c), Some(DefectKind::Hot));
        assert_eq!(classify(0.0, 0.05, &c), Some(DefectKind::Dead));
        assert_eq!(classify(0.0, f64::NAN, &c), Some(DefectKind::Dead));
        assert_eq!(classify(0.0, 0.6, &c), Some(DefectKind::Weak));
        assert_eq!(classify(0.0, 1.4, &c), Some(DefectKind::Strong));
        assert_eq!(classify(99.0, 1.2, &c), None);
    }
}
