//! Brown–Conrady lens distortion on normalised image coordinates (OpenCV form).
//!
//! For a normalised point (x, y), r² = x² + y²:
//! `x_d = x·(1 + k1·r² + k2·r⁴ + k3·r⁶) + 2·p1·x·y + p2·(r² + 2x²)`
//! `y_d = y·(1 + k1·r² + k2·r⁴ + k3·r⁶) + p1·(r² + 2y²) + 2·p2·x·y`

use nalgebra::{Matrix2, Vector2};

use crate::{Degeneracy, GeomError, Result};

/// Maximum Newton iterations of [`Distortion::undistort`].
const MAX_UNDISTORT_ITERATIONS: usize = 100;
/// Newton aims this factor below the requested tolerance.
const AIM_BELOW_TOLERANCE: f64 = 10.0;
/// Smallest fraction of a Newton step tried before giving up.
const MIN_STEP_SCALE: f64 = 1e-6;

/// Brown distortion coefficients: radial k1, k2, k3 and tangential p1, p2.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Distortion {
    /// Radial coefficient of r².
    pub k1: f64,
    /// Radial coefficient of r⁴.
    pub k2: f64,
    /// Radial coefficient of r⁶.
    pub k3: f64,
    /// Tangential (decentring) coefficient p1.
    pub p1: f64,
    /// Tangential (decentring) coefficient p2.
    pub p2: f64,
}

impl Distortion {
    /// No distortion: the ideal pinhole.
    pub const NONE: Distortion = Distortion {
        k1: 0.0,
        k2: 0.0,
        k3: 0.0,
        p1: 0.0,
        p2: 0.0,
    };

    /// True when every coefficient is zero.
    pub fn is_none(&self) -> bool {
        *self == Self::NONE
    }

    /// Coefficients as `[k1, k2, p1, p2, k3]` (OpenCV's order).
    pub fn to_opencv(&self) -> [f64; 5] {
        [self.k1, self.k2, self.p1, self.p2, self.k3]
    }

    /// Apply the distortion to an ideal normalised point.
    pub fn distort(&self, p: Vector2<f64>) -> Vector2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        Vector2::new(
            x * radial + 2.0 * self.p1 * x * y + self.p2 * (r2 + 2.0 * x * x),
            y * radial + self.p1 * (r2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
        )
    }

    /// Jacobian ∂(x_d, y_d)/∂(x, y) of [`Distortion::distort`] at an ideal point.
    pub fn jacobian(&self, p: Vector2<f64>) -> Matrix2<f64> {
        let (x, y) = (p.x, p.y);
        let r2 = x * x + y * y;
        let radial = 1.0 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3));
        // d(radial)/d(r²)
        let dradial = self.k1 + r2 * (2.0 * self.k2 + 3.0 * self.k3 * r2);
        let cross = 2.0 * x * y * dradial + 2.0 * self.p1 * x + 2.0 * self.p2 * y;
        Matrix2::new(
            radial + 2.0 * x * x * dradial + 2.0 * self.p1 * y + 6.0 * self.p2 * x,
            cross,
            cross,
            radial + 2.0 * y * y * dradial + 6.0 * self.p1 * y + 2.0 * self.p2 * x,
        )
    }

    /// Invert the distortion by damped Newton iteration: find the ideal point
    /// whose distorted image is `distorted`, until `‖distort(x) − x_d‖ ≤ tolerance`
    /// (normalised units; the camera converts a pixel tolerance).
    pub fn undistort(&self, distorted: Vector2<f64>, tolerance: f64) -> Result<Vector2<f64>> {
        self.undistort_from(distorted, distorted, tolerance)
    }

    /// [`Distortion::undistort`] starting the iteration at `start` (e.g. the
    /// solution for a neighbouring point, which one or two Newton steps then
    /// refine); the result is converged to the same tolerance.
    pub fn undistort_from(
        &self,
        distorted: Vector2<f64>,
        start: Vector2<f64>,
        tolerance: f64,
    ) -> Result<Vector2<f64>> {
        if !(distorted.x.is_finite()
            && distorted.y.is_finite()
            && start.x.is_finite()
            && start.y.is_finite())
        {
            return Err(GeomError::NonFinite("undistort"));
        }
        if self.is_none() {
            return Ok(distorted);
        }
        // Newton aims a decade below the tolerance (margin for the rounding of
        // whoever re-distorts the result) and accepts anything within it once
        // no step can improve further (the floating-point floor).
        let aim = tolerance / AIM_BELOW_TOLERANCE;
        let mut x = start;
        let mut err = self.distort(x) - distorted;
        let mut norm = err.norm();
        for _ in 0..MAX_UNDISTORT_ITERATIONS {
            if norm <= aim {
                return Ok(x);
            }
            let step = self.jacobian(x).try_inverse().ok_or(GeomError::Degenerate(
                Degeneracy::Singular {
                    matrix: "distortion Jacobian",
                },
            ))? * err;
            // Halve the step until the residual decreases (globalises Newton
            // for strong distortion far from the centre).
            let mut scale = 1.0;
            loop {
                let candidate = x - step * scale;
                let cand_err = self.distort(candidate) - distorted;
                let cand_norm = cand_err.norm();
                if cand_norm < norm {
                    x = candidate;
                    err = cand_err;
                    norm = cand_norm;
                    break;
                }
                if norm <= tolerance {
                    return Ok(x);
                }
                scale *= 0.5;
                if scale < MIN_STEP_SCALE {
                    return Err(GeomError::NotConverged {
                        what: "undistortion",
                        iterations: MAX_UNDISTORT_ITERATIONS,
                        last_step: norm,
                    });
                }
            }
        }
        if norm <= tolerance {
            Ok(x)
        } else {
            Err(GeomError::NotConverged {
                what: "undistortion",
                iterations: MAX_UNDISTORT_ITERATIONS,
                last_step: norm,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LENS: Distortion = Distortion {
        k1: -0.21,
        k2: 0.21,
        k3: -0.02,
        p1: 1.2e-3,
        p2: -8e-4,
    };

    #[test]
    fn jacobian_matches_central_differences() {
        let h = 1e-7;
        for &(x, y) in &[(0.1, -0.2), (0.35, 0.27), (-0.4, 0.05), (0.0, 0.0)] {
            let p = Vector2::new(x, y);
            let j = LENS.jacobian(p);
            for c in 0..2 {
                let mut e = Vector2::zeros();
                e[c] = h;
                let d = (LENS.distort(p + e) - LENS.distort(p - e)) / (2.0 * h);
                assert!((j.column(c) - d).norm() < 1e-8, "column {c} at {p:?}");
            }
        }
    }

    #[test]
    fn undistort_inverts_distort() {
        for &(x, y) in &[(0.1, -0.2), (0.35, 0.27), (-0.45, -0.33), (0.0, 0.0)] {
            let p = Vector2::new(x, y);
            let back = LENS.undistort(LENS.distort(p), 1e-15).unwrap();
            assert!((back - p).norm() < 1e-14);
        }
    }

    #[test]
    fn undistort_rejects_nan() {
        assert!(LENS.undistort(Vector2::new(f64::NAN, 0.0), 1e-12).is_err());
    }
}
