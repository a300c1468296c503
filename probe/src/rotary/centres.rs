//! Ball centres from probed points: the geometric least-squares sphere
//! (`geom::fit::sphere`, minimising `Σ(|p − c| − r)²`) through the points of
//! one ball at one angle — the seed's five (the north pole and four on the
//! equator) or scanned tracks — with its residuals.

use geom::nalgebra::Point3;

use super::{Measurement, centre_label};
use crate::{ProbeError, Result, RotaryFault};

/// Fewest probed points that determine a sphere (centre and radius).
pub const MIN_POINTS: usize = 4;

/// A fit whose radius differs from the median radius of all fits by more
/// than this (mm) is named in the warnings: a sphere of 10 µm more or less
/// than the others means a wrong ball, a stylus not qualified, or dirt.
pub(crate) const RADIUS_WARNING_MM: f64 = 0.010;

/// A fit with a residual larger than this (mm) is named in the warnings:
/// the probed points are not on one sphere (dirt, a bad point).
pub(crate) const RESIDUAL_WARNING_MM: f64 = 0.005;

/// The sphere through the probed points of one ball at one angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentreFit {
    /// Centre (mm, table frame).
    pub centre: Point3<f64>,
    /// Radius (mm).
    pub radius: f64,
    /// RMS of the radial residuals `|p − c| − r` (mm).
    pub rms_residual: f64,
    /// Largest absolute radial residual (mm).
    pub max_residual: f64,
    /// Number of points.
    pub points: usize,
}

/// The geometric least-squares sphere through `points` (≥ [`MIN_POINTS`]).
/// With exactly 4 points the sphere passes through them (no residual).
pub fn fit_centre(points: &[Point3<f64>]) -> Result<CentreFit> {
    if points.len() < MIN_POINTS {
        return Err(ProbeError::Rotary(RotaryFault::TooFewPoints {
            count: points.len(),
        }));
    }
    let fit = geom::fit::sphere(points)?;
    let n = fit.residuals.len().max(1) as f64;
    Ok(CentreFit {
        centre: fit.centre,
        radius: fit.radius,
        rms_residual: (fit.residuals.iter().map(|r| r * r).sum::<f64>() / n).sqrt(),
        max_residual: fit.residuals.iter().fold(0.0, |m, r| m.max(r.abs())),
        points: points.len(),
    })
}

/// Warnings about the sphere fits of a measurement: radii far from the
/// median radius, residuals beyond [`RESIDUAL_WARNING_MM`].
pub(super) fn fit_warnings(m: &Measurement) -> Vec<String> {
    let mut radii: Vec<f64> = m
        .balls
        .iter()
        .flat_map(|b| b.fits.iter().map(|f| f.radius))
        .collect();
    if radii.is_empty() {
        return Vec::new();
    }
    radii.sort_by(f64::total_cmp);
    let median = radii[radii.len() / 2];
    let mut out = Vec::new();
    for b in &m.balls {
        for (f, a) in b.fits.iter().zip(&m.angles_deg) {
            if (f.radius - median).abs() > RADIUS_WARNING_MM {
                out.push(format!(
                    "{}: fitted radius {:.4} mm differs from the median {median:.4} mm of all fits by more than {} µm",
                    centre_label(&b.name, *a),
                    f.radius,
                    RADIUS_WARNING_MM * 1e3
                ));
            }
            if f.max_residual > RESIDUAL_WARNING_MM {
                out.push(format!(
                    "{}: a probed point lies {:.2} µm off the fitted sphere (more than {} µm)",
                    centre_label(&b.name, *a),
                    f.max_residual * 1e3,
                    RESIDUAL_WARNING_MM * 1e3
                ));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::nalgebra::Vector3;

    #[test]
    fn five_points_give_the_centre() {
        let c = Point3::new(150.0, 10.0, 60.0);
        let r = 12.7;
        let mut pts = vec![c + Vector3::z() * r];
        for k in 0..4 {
            let t = f64::from(k) * std::f64::consts::FRAC_PI_2 + 0.25;
            pts.push(c + Vector3::new(t.cos(), t.sin(), 0.0) * r);
        }
        let f = fit_centre(&pts).unwrap();
        assert!((f.centre - c).norm() < 1e-10);
        assert!((f.radius - r).abs() < 1e-10);
        assert!(f.max_residual < 1e-10 && f.points == 5);
    }

    #[test]
    fn too_few_or_coplanar_points_are_errors() {
        let pts: Vec<_> = (0..3)
            .map(|k| Point3::new(f64::from(k), 1.0, 0.0))
            .collect();
        assert!(
            fit_centre(&pts)
                .unwrap_err()
                .to_string()
                .contains("3 point(s)")
        );
        let ring: Vec<_> = (0..6)
            .map(|k| {
                let t = f64::from(k);
                Point3::new(t.cos(), t.sin(), 0.0)
            })
            .collect();
        assert!(fit_centre(&ring).is_err());
    }
}
