//! The covariance of a calibrated camera's parameters (docs/methods.md,
//! Calibration uncertainty), in the parametrisation of
//! [`geom::Camera::perturbed`]: the Jacobian J of the reprojection residuals
//! is taken at the solution with R₀ = R̂ and ω = 0, so `rx, ry, rz` are a
//! small rotation about the camera's own axes, `R = exp([ω]×)·R̂`.
//!
//! Two sources: the image noise, independent per coordinate with variance
//! σ², and the target's marker coordinates, independent per coordinate with
//! standard uncertainty `u_i` (mm). A marker error `e_i` moves its predicted
//! pixel by `J_t,i·e_i`, `J_t,i = ∂(u,v)/∂X = ∂(u,v)/∂t·R`, so the residuals'
//! covariance is `C = σ²·I + J_t·Σ_t·J_tᵀ` and that of the least-squares
//! estimate the sandwich `A·C·Aᵀ`, `A = (JᵀJ)⁻¹·Jᵀ`:
//! `Σ_p = σ²·(JᵀJ)⁻¹ + Σ_i u_i²·(A_i·D_i)(A_i·D_i)ᵀ` (`D_i = ∂(u,v)/∂t` of
//! point i, `A_i` its two columns of A; R drops out for an isotropic Σ_t).
//!
//! Random marker errors show in the residuals like image noise, so σ² is not
//! the residuals' `s² = Σr²/(m − n)`: that would count the target twice. It
//! is the residuals' variance less the target's expected share,
//! `σ² = max(0, Σr² − tr((I − H)·J_t·Σ_t·J_tᵀ))/(m − n)` with
//! `H = J·(JᵀJ)⁻¹·Jᵀ` (E[Σr²] = tr((I − H)·C)). Where the stated target
//! uncertainty explains more than the residuals show, σ² is 0 and the
//! covariance rests on the stated figure alone.

use std::collections::HashMap;

use formats::{CameraCovariance, TargetRow};
use geom::lm::Residuals;
use geom::nalgebra::{DMatrix, Matrix2};

use crate::refine::Reprojection;
use crate::{CalibError, Calibration, Observation, OptionProblem, Result};

/// Standard uncertainty (µm) of each coordinate of a marker when neither
/// `target.csv u_mm` nor `--target-uncertainty-um` gives one: a target of
/// ≈ 100–300 mm measured on a good CMM (MPE_E ≈ 2 µm, read as a rectangular
/// distribution: u ≈ 2/√3 ≈ 1 µm).
pub const DEFAULT_TARGET_UNCERTAINTY_UM: f64 = 1.0;

/// The standard uncertainty of every marker's coordinates and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct TargetUncertainty {
    /// Per marker id (µm).
    per_marker_um: HashMap<u32, f64>,
    /// For markers without a figure of their own (µm).
    otherwise_um: f64,
    /// Where the figures came from (`target_uncertainty_source` of `rig.json`).
    pub source: String,
}

impl TargetUncertainty {
    /// The figures for `target`: `option_um` (`--target-uncertainty-um`) for
    /// every marker when given; else each row's `u_mm`, with
    /// [`DEFAULT_TARGET_UNCERTAINTY_UM`] for rows without one.
    pub fn resolve(target: &[TargetRow], option_um: Option<f64>) -> Result<Self> {
        if let Some(um) = option_um {
            if !(um.is_finite() && um >= 0.0) {
                return Err(CalibError::Option(OptionProblem::TargetUncertainty(um)));
            }
            return Ok(Self {
                per_marker_um: HashMap::new(),
                otherwise_um: um,
                source: format!("--target-uncertainty-um {um}"),
            });
        }
        let per_marker_um: HashMap<u32, f64> = target
            .iter()
            .filter_map(|r| r.u_mm.map(|u| (r.id, 1000.0 * u)))
            .collect();
        let default = format!(
            "default {DEFAULT_TARGET_UNCERTAINTY_UM} µm; give target.csv u_mm or --target-uncertainty-um"
        );
        let source = if per_marker_um.is_empty() {
            default
        } else if per_marker_um.len() == target.len() {
            "target.csv u_mm".to_string()
        } else {
            format!(
                "target.csv u_mm ({} of {} markers), {default} for the others",
                per_marker_um.len(),
                target.len()
            )
        };
        Ok(Self {
            per_marker_um,
            otherwise_um: DEFAULT_TARGET_UNCERTAINTY_UM,
            source,
        })
    }

    /// The same figure `um` (µm) for every marker, with its source.
    pub fn uniform(um: f64, source: impl Into<String>) -> Self {
        Self {
            per_marker_um: HashMap::new(),
            otherwise_um: um,
            source: source.into(),
        }
    }

    /// Standard uncertainty of each coordinate of marker `id` (µm).
    pub fn of_um(&self, id: u32) -> f64 {
        self.per_marker_um
            .get(&id)
            .copied()
            .unwrap_or(self.otherwise_um)
    }
}

/// The covariance of one camera's calibrated parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterCovariance {
    /// Parameter names in the matrices' order ([`geom::Camera::PARAMETERS`] names).
    pub names: Vec<&'static str>,
    /// The full covariance `σ²·(JᵀJ)⁻¹ + A·J_t·Σ_t·J_tᵀ·Aᵀ`.
    pub total: DMatrix<f64>,
    /// Of it, the part due to the target's marker coordinates.
    pub target: DMatrix<f64>,
    /// The image noise σ left when the target's share of the residuals is removed (px).
    pub image_sigma_px: f64,
    /// The residuals' `s = √(Σr²/(m − n))` (px).
    pub residual_sigma_px: f64,
    /// RMS of the markers' coordinate uncertainties over the points used (µm).
    pub target_uncertainty_um: f64,
    /// Where they came from.
    pub target_uncertainty_source: String,
}

impl ParameterCovariance {
    /// Standard uncertainty of each parameter (square roots of the diagonal).
    pub fn std_devs(&self) -> Vec<f64> {
        self.total.diagonal().iter().map(|v| v.sqrt()).collect()
    }

    /// The stated target uncertainty explains more than the residuals show
    /// (σ² clamped at 0): the figure stated is probably too large.
    pub fn target_exceeds_residuals(&self) -> bool {
        self.image_sigma_px == 0.0 && self.residual_sigma_px > 0.0
    }

    /// As recorded in `rig.json`.
    pub fn record(&self) -> CameraCovariance {
        let rows = |m: &DMatrix<f64>| {
            (0..m.nrows())
                .map(|i| m.row(i).iter().copied().collect())
                .collect()
        };
        CameraCovariance {
            parameters: self.names.iter().map(|n| n.to_string()).collect(),
            matrix: rows(&self.total),
            target: Some(rows(&self.target)),
            target_uncertainty_um: self.target_uncertainty_um,
            target_uncertainty_source: self.target_uncertainty_source.clone(),
        }
    }
}

/// The covariance of `calibration`'s parameters from the `observations` it
/// was fitted to (same order; its outliers left out) and the target's
/// coordinate uncertainty; `None` when the parameters are not determined
/// (no redundancy, or a rank-deficient Jacobian). Fails when the
/// observations are not those of the calibration.
pub fn parameter_covariance(
    calibration: &Calibration,
    observations: &[Observation],
    target: &TargetUncertainty,
) -> Result<Option<ParameterCovariance>> {
    let residuals = &calibration.residuals;
    if observations.len() != residuals.len()
        || observations
            .iter()
            .zip(residuals)
            .any(|(o, r)| o.id != r.id)
    {
        return Err(CalibError::Option(OptionProblem::ObservationsDiffer {
            observations: observations.len(),
            residuals: residuals.len(),
        }));
    }
    let used: Vec<&Observation> = observations
        .iter()
        .zip(residuals)
        .filter(|(_, r)| !r.outlier)
        .map(|(o, _)| o)
        .collect();
    Ok(sandwich(calibration, &used, target))
}

/// [`parameter_covariance`] over the points used.
fn sandwich(
    calibration: &Calibration,
    used: &[&Observation],
    target: &TargetUncertainty,
) -> Option<ParameterCovariance> {
    let (world, image, radius) = crate::calibration::split(used.iter().copied());
    let u_um: Vec<f64> = used.iter().map(|o| target.of_um(o.id)).collect();
    let layout = calibration.options.layout();
    let camera = &calibration.camera;
    let problem = Reprojection {
        layout,
        r0: camera.rotation(),
        world: &world,
        image: &image,
        radius: &radius,
    };
    let p = layout.pack(camera);
    let j = problem.jacobian(&p);
    let ssr = problem.residuals(&p).norm_squared();
    let (m, n) = (j.nrows(), j.ncols());
    let dof = m.checked_sub(n).filter(|&d| d > 0)? as f64;
    // (JᵀJ)⁻¹ from the SVD of J (s² = 1 when the "ssr" is the dof).
    let normal_inverse = geom::lm::covariance(&j, dof, m, n)?;
    let a = &normal_inverse * j.transpose();
    let t = layout.translation_index();
    let mut target_cov = DMatrix::zeros(n, n);
    let mut explained = 0.0;
    for (i, u) in u_um.iter().map(|u| u / 1000.0).enumerate() {
        let rows = j.fixed_rows::<2>(2 * i);
        // D_i = ∂(u,v)/∂t = ∂(u,v)/∂X·Rᵀ; C_t,i = u²·D_i·D_iᵀ.
        let d = rows.fixed_columns::<3>(t);
        let c_i: Matrix2<f64> = (d * d.transpose()) * (u * u);
        let a_i = a.fixed_columns::<2>(2 * i);
        let h_ii: Matrix2<f64> = rows * a_i;
        explained += (c_i - h_ii * c_i).trace();
        let ad = a_i * d * u;
        target_cov += &ad * ad.transpose();
    }
    let image_var = ((ssr - explained) / dof).max(0.0);
    let total = &normal_inverse * image_var + &target_cov;
    let rms_um = (u_um.iter().map(|u| u * u).sum::<f64>() / u_um.len() as f64).sqrt();
    Some(ParameterCovariance {
        names: layout.names(),
        total,
        target: target_cov,
        image_sigma_px: image_var.sqrt(),
        residual_sigma_px: (ssr / dof).sqrt(),
        target_uncertainty_um: rms_um,
        target_uncertainty_source: target.source.clone(),
    })
}
