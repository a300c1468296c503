//! Helpers shared by calib's tests.

use geom::Camera;
use geom::nalgebra::{DMatrix, DVector};

/// A deterministic stream of numbers uniform in [0, 1) from `seed` (Knuth's
/// MMIX linear congruential generator, top 53 bits): the same spurious blobs
/// and noise on every machine.
pub fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut x = seed;
    move || {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The deviation δ with `estimate.perturbed(names, δ) = truth` (to first order).
#[allow(dead_code)]
pub fn parameter_error(names: &[&str], estimate: &Camera, truth: &Camera) -> DVector<f64> {
    let omega = (truth.rotation() * estimate.rotation().inverse()).scaled_axis();
    let dt = truth.translation() - estimate.translation();
    let (ki, ke) = (truth.intrinsics, estimate.intrinsics);
    let (di, de) = (truth.distortion, estimate.distortion);
    DVector::from_iterator(
        names.len(),
        names.iter().map(|n| match *n {
            "fx" => ki.fx - ke.fx,
            "fy" => ki.fy - ke.fy,
            "cx" => ki.cx - ke.cx,
            "cy" => ki.cy - ke.cy,
            "skew" => ki.skew - ke.skew,
            "rx" => omega.x,
            "ry" => omega.y,
            "rz" => omega.z,
            "tx" => dt.x,
            "ty" => dt.y,
            "tz" => dt.z,
            "k1" => di.k1 - de.k1,
            "k2" => di.k2 - de.k2,
            "p1" => di.p1 - de.p1,
            "p2" => di.p2 - de.p2,
            "k3" => di.k3 - de.k3,
            other => panic!("{other}"),
        }),
    )
}

/// `δᵀ·Σ⁻¹·δ`, solved on the correlation matrix (the parameters' units differ by 10⁸).
#[allow(dead_code)]
pub fn mahalanobis(sigma: &DMatrix<f64>, delta: &DVector<f64>) -> f64 {
    let s: DVector<f64> = sigma.diagonal().map(f64::sqrt);
    let corr = DMatrix::from_fn(sigma.nrows(), sigma.ncols(), |i, j| {
        sigma[(i, j)] / (s[i] * s[j])
    });
    let z = delta.component_div(&s);
    let chol = corr.cholesky().expect("a covariance");
    z.dot(&chol.solve(&z))
}
