//! VDI/DGQ 3441 (1977), "Statistische Prüfung der Arbeits- und
//! Positionsgenauigkeit von Werkzeugmaschinen", from the same per-target
//! statistics as ISO 230-2 (both directions needed).
//!
//! Per position j, with `x̄ⱼ↑, x̄ⱼ↓` the mean deviations and `sⱼ↑, sⱼ↓` the
//! standard deviations of the approaches from each side:
//! - mean position deviation `x̄ⱼ = (x̄ⱼ↑ + x̄ⱼ↓)/2`;
//! - reversal span (Umkehrspanne) `Uⱼ = |x̄ⱼ↑ − x̄ⱼ↓|`, `U = max Uⱼ`, `Ū = mean Uⱼ`;
//! - positional scatter (Positionsstreubreite) `Psⱼ = 6·s̄ⱼ`, `s̄ⱼ = (sⱼ↑ + sⱼ↓)/2`,
//!   `Ps = max Psⱼ`;
//! - position deviation (Positionsabweichung) `Pa = max x̄ⱼ − min x̄ⱼ`;
//! - positional uncertainty (Positionsunsicherheit)
//!   `P = max(x̄ⱼ + (Uⱼ + Psⱼ)/2) − min(x̄ⱼ − (Uⱼ + Psⱼ)/2)`.
//!
//! The guideline estimates s from the range of five approaches; here the
//! sample standard deviation (n − 1 divisor) of any n ≥ 2 is used, as in
//! ISO 230-2.

use crate::iso230_2::Iso230_2;

/// The VDI/DGQ 3441 figures, in the unit of the deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vdi3441 {
    /// Positional uncertainty `P`.
    pub p: f64,
    /// Largest positional scatter `Ps = max 6·s̄ⱼ`.
    pub ps: f64,
    /// Largest reversal span `U = max |x̄ⱼ↑ − x̄ⱼ↓|`.
    pub u: f64,
    /// Mean reversal span `Ū`.
    pub u_mean: f64,
    /// Position deviation `Pa = max x̄ⱼ − min x̄ⱼ`.
    pub pa: f64,
}

/// VDI/DGQ 3441 from ISO 230-2 per-target statistics; `None` unless every
/// target has both directions.
pub fn vdi3441(iso: &Iso230_2) -> Option<Vdi3441> {
    let mut per_target = Vec::with_capacity(iso.targets.len());
    for t in &iso.targets {
        let (up, down) = (t.up?, t.down?);
        let mean = (up.mean + down.mean) / 2.0;
        let u = (up.mean - down.mean).abs();
        let ps = 6.0 * (up.s + down.s) / 2.0;
        per_target.push((mean, u, ps));
    }
    if per_target.is_empty() {
        return None;
    }
    let n = per_target.len() as f64;
    let (mut p_hi, mut p_lo) = (f64::NEG_INFINITY, f64::INFINITY);
    let (mut pa_hi, mut pa_lo) = (f64::NEG_INFINITY, f64::INFINITY);
    for &(mean, u, ps) in &per_target {
        p_hi = p_hi.max(mean + (u + ps) / 2.0);
        p_lo = p_lo.min(mean - (u + ps) / 2.0);
        pa_hi = pa_hi.max(mean);
        pa_lo = pa_lo.min(mean);
    }
    Some(Vdi3441 {
        p: p_hi - p_lo,
        ps: per_target.iter().map(|t| t.2).fold(0.0, f64::max),
        u: per_target.iter().map(|t| t.1).fold(0.0, f64::max),
        u_mean: per_target.iter().map(|t| t.1).sum::<f64>() / n,
        pa: pa_hi - pa_lo,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::iso230_2::{TargetDeviations, iso230_2};

    #[test]
    fn two_targets_by_hand() {
        // Target 0: ↑ {0, 2} (x̄ 1, s √2), ↓ {−1, −1} (x̄ −1, s 0): x̄ 0, U 2, Ps 3√2.
        // Target 1: ↑ {4, 4}, ↓ {3, 5} (s √2): x̄ 4, U 0, Ps 3√2.
        let iso = iso230_2(&[
            TargetDeviations {
                up: vec![0.0, 2.0],
                down: vec![-1.0, -1.0],
            },
            TargetDeviations {
                up: vec![4.0, 4.0],
                down: vec![3.0, 5.0],
            },
        ])
        .unwrap();
        let v = vdi3441(&iso).unwrap();
        let ps = 3.0 * 2.0_f64.sqrt();
        assert!((v.ps - ps).abs() < 1e-15);
        assert_eq!((v.u, v.u_mean, v.pa), (2.0, 1.0, 4.0));
        // max(4 + Ps/2) − min(0 − (2 + Ps)/2) = 4 + Ps + 1.
        assert!((v.p - (5.0 + ps)).abs() < 1e-14, "{}", v.p);
    }

    #[test]
    fn one_direction_has_no_vdi_figures() {
        let iso = iso230_2(&[TargetDeviations {
            up: vec![0.0, 2.0],
            down: vec![],
        }])
        .unwrap();
        assert!(vdi3441(&iso).is_none());
    }
}
