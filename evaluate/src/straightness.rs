//! Straightness of a line in one perpendicular direction (docs/methods.md,
//! ISO 230-1 §3.4.8): the profile is the per-target mean points in the plane
//! spanned by the axis direction and that perpendicular direction; the
//! least-squares figure is the range of the orthogonal residuals from the
//! orthogonal least-squares line, the minimum zone (ISO 12780) the distance
//! between the two closest parallel lines enclosing the profile. Both are
//! invariant to a rotation of the profile, so a small error of the fitted
//! axis direction does not change them.

use geom::Point2;

/// Targets a straightness figure needs: a line through two points passes
/// through both, so their deviations are zero by construction and say
/// nothing of the axis (ISO 230-1 §3.4.8 takes the reference line from the
/// profile itself).
pub const MIN_TARGETS: usize = 3;

/// Why a line of `targets` targets has no straightness, as the report says
/// it; `None` with [`MIN_TARGETS`] or more.
pub fn left_out(targets: usize) -> Option<String> {
    (targets < MIN_TARGETS).then(|| {
        format!(
            "straightness left out: the line has {targets} targets, and a reference line through \
             {targets} points passes through them (0 µm by construction); it needs at least \
             {MIN_TARGETS}"
        )
    })
}
use geom::fit::line_2d;
use geom::min_zone;

/// Straightness figures and profile of one direction (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Straightness {
    /// Range of the residuals from the least-squares line.
    pub lsq: f64,
    /// Minimum-zone width.
    pub min_zone: f64,
    /// Signed residual of each point from the least-squares line.
    pub deviations: Vec<f64>,
    /// Lower boundary of the minimum zone at each point, measured like `deviations`.
    pub zone_low: Vec<f64>,
    /// Upper boundary of the minimum zone at each point.
    pub zone_high: Vec<f64>,
}

/// Straightness of a profile: `(t, h)` per target, `t` along the axis, `h`
/// across it (mm); at least two points.
pub fn straightness(profile: &[Point2<f64>]) -> geom::Result<Straightness> {
    let ls = line_2d(profile)?;
    let zone = min_zone::straightness(profile)?;
    let (lo, hi) = geom::stats::min_max(&ls.residuals)?;
    // Residuals about the zone's centre line, signed like the least-squares ones.
    let sign = if ls.normal.dot(&zone.normal) < 0.0 {
        -1.0
    } else {
        1.0
    };
    let half = zone.width / 2.0;
    let centre: Vec<f64> = ls
        .residuals
        .iter()
        .zip(&zone.residuals)
        .map(|(r, z)| r - sign * z)
        .collect();
    Ok(Straightness {
        lsq: hi - lo,
        min_zone: zone.width,
        zone_low: centre.iter().map(|c| c - half).collect(),
        zone_high: centre.iter().map(|c| c + half).collect(),
        deviations: ls.residuals,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bow_profile() {
        // h = 4 µm·(t/100)² on 0..100 mm: the minimum zone of a convex arc is
        // its largest distance from the chord, 4 µm/4 = 1 µm.
        let pts: Vec<Point2<f64>> = (0..=10)
            .map(|k| {
                let t = 10.0 * k as f64;
                Point2::new(t, 4e-3 * (t / 100.0).powi(2))
            })
            .collect();
        let s = straightness(&pts).unwrap();
        assert!((s.min_zone - 1e-3).abs() < 1e-12, "{}", s.min_zone);
        assert!(s.min_zone <= s.lsq);
        for ((d, lo), hi) in s.deviations.iter().zip(&s.zone_low).zip(&s.zone_high) {
            assert!(*lo <= d + 1e-15 && *d <= hi + 1e-15);
        }
    }
}
