//! Rotary-table error identification with a standard ball (docs/probe-rotary.md,
//! seed 000): the six error motions of a C axis per measured angle, from
//! the centres of a ball mounted at three (or more) places on the table and
//! measured through a turn; their standard uncertainties; interpolation at
//! any angle; and, beyond the seed, the axis average line (ISO 230-7
//! location errors X0C, Y0C, A0C, B0C) separated from the component errors.
//!
//! - [`fit_centre`]: a ball centre from probed points (geometric
//!   least-squares sphere, ≥ [`MIN_POINTS`] points) with its residuals.
//! - [`layout`]: the layout check (condition number); [`AngleErrors`]: the
//!   per-angle least squares `X = (AᵀA)⁻¹Aᵀb` with uncertainties from the
//!   residuals.
//! - [`AxisLine`], [`Location`]: the axis average line and the component
//!   errors.
//! - [`report`], [`html`]: `report.json` types and `report.html`.
//!
//! [`solve`] runs the method on a [`Measurement`]; [`Solution::at`]
//! interpolates at any angle.
//!
//! # Conventions
//! - Table frame OXYZ: Z on the nominal rotation axis, origin on it at the
//!   table surface, right-handed; angles θ in degrees, counter-clockwise
//!   seen from +Z. Lengths in millimetres, error rotations in radians.
//! - The reference of each ball is its measured centre P0 at θ = 0; its
//!   ideal position at θ is `Pᵢ = Rz(θ)·P0`; the measured centre differs by
//!   `ΔP = δ + ε × Pᵢ` (first order). The six errors are, in this order,
//!   EXC, EYC, EZC, EAC, EBC, ECC = δx, δy, δz, εx, εy, εz (ISO 230-7 names
//!   for a C axis). All six are zero at θ = 0 by construction.
//! - Location errors of the axis average line: X0C, Y0C where it crosses
//!   Z = 0; A0C, B0C the right-hand rotations about X and Y that turn +Z
//!   onto its direction, which is ≈ (B0C, −A0C, 1). A fixed axis so placed
//!   makes `δ = (I − Rz(θ))·(X0C, Y0C, 0)` and `ε = (I − Rz(θ))·(A0C, B0C, 0)`.
//! - Interpolation between measured angles is linear, wrapping from the last
//!   measured angle to 360° (= 0°).

mod centres;
mod html;
mod identify;
mod location;
mod plot;
pub mod report;
pub mod uncertainty;

use geom::nalgebra::{Point3, Rotation3, Vector3, Vector6};

use crate::{CentreFault, Conditioning, ProbeError, Result, RotaryFault, Unsolvable};

pub use centres::{CentreFit, MIN_POINTS, fit_centre};
pub use html::render as html;
pub use identify::{AngleErrors, CONDITION_LIMIT, Layout, MAX_DISPLACEMENT_MM, layout};
pub use location::{AxisLine, LOCATION_CONDITION_LIMIT, Location};

/// One turn (degrees): angles are reduced to `[0, 360)`.
pub const FULL_TURN_DEG: f64 = 360.0;

/// Names of the six errors in the order of every six-vector of this module.
pub const NAMES: [&str; 6] = ["EXC", "EYC", "EZC", "EAC", "EBC", "ECC"];

/// The six errors of one angle, in the order of [`NAMES`]: δx, δy, δz (mm),
/// εx, εy, εz (rad).
pub type SixErrors = Vector6<f64>;

/// One ball: its name and its centre at every measured angle.
#[derive(Debug, Clone, PartialEq)]
pub struct Ball {
    /// The ball's name (as the input names it, e.g. `1`).
    pub name: String,
    /// Measured centre (mm, table frame) at each angle of
    /// [`Measurement::angles_deg`], in the same order.
    pub centres: Vec<Point3<f64>>,
    /// The sphere fits the centres came from, one per angle, when the input
    /// was probed points; empty when centres were given.
    pub fits: Vec<CentreFit>,
}

/// The input of the method: every ball measured at the same angles.
#[derive(Debug, Clone, PartialEq)]
pub struct Measurement {
    /// Table angles (degrees): strictly increasing in `[0, 360)`, the first 0
    /// (the reference).
    pub angles_deg: Vec<f64>,
    /// The balls (≥ 3, not on one line).
    pub balls: Vec<Ball>,
}

/// The label that names one measured centre in errors and warnings:
/// `ball 2 at 90°`.
pub(crate) fn centre_label(ball: &str, angle_deg: f64) -> String {
    format!("ball {ball} at {angle_deg}°")
}

/// Counter-clockwise rotation by `angle_deg` about +Z (`Rz(θ)` of §2).
pub fn rz(angle_deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), angle_deg.to_radians())
}

impl Measurement {
    /// Check the invariants of the input: ≥ 2 angles, strictly increasing in
    /// `[0, 360)` starting at 0; ≥ 3 balls with distinct names, one finite
    /// centre per angle each (and one fit per angle or none).
    pub fn validate(&self) -> Result<()> {
        let fault = |f: RotaryFault| Err(ProbeError::Rotary(f));
        if self.angles_deg.len() < 2 {
            return Err(Unsolvable::TooFewAngles {
                angles: self.angles_deg.len(),
            }
            .into());
        }
        if let Some(a) = self
            .angles_deg
            .iter()
            .find(|a| !(a.is_finite() && (0.0..FULL_TURN_DEG).contains(*a)))
        {
            return fault(RotaryFault::AngleRange { angle: *a });
        }
        if self.angles_deg[0] != 0.0 {
            return fault(RotaryFault::NoZero {
                first: self.angles_deg[0],
            });
        }
        if let Some(w) = self.angles_deg.windows(2).find(|w| w[1] <= w[0]) {
            return fault(RotaryFault::NotIncreasing {
                angle: w[1],
                previous: w[0],
            });
        }
        if self.balls.len() < 3 {
            return Err(Unsolvable::TooFewBalls {
                names: self.ball_names(),
            }
            .into());
        }
        for (k, ball) in self.balls.iter().enumerate() {
            if ball.name.trim().is_empty() {
                return fault(RotaryFault::Unnamed { number: k + 1 });
            }
            if self.balls[..k].iter().any(|b| b.name == ball.name) {
                return fault(RotaryFault::DuplicateBall {
                    ball: ball.name.clone(),
                });
            }
            if ball.centres.len() != self.angles_deg.len() {
                return fault(RotaryFault::CentreCount {
                    ball: ball.name.clone(),
                    centres: ball.centres.len(),
                    angles: self.angles_deg.len(),
                });
            }
            let fitted = self.balls.iter().any(|b| !b.fits.is_empty());
            if fitted && ball.fits.len() != self.angles_deg.len() {
                return fault(RotaryFault::FitCount {
                    ball: ball.name.clone(),
                    fits: ball.fits.len(),
                    angles: self.angles_deg.len(),
                });
            }
            for (c, a) in ball.centres.iter().zip(&self.angles_deg) {
                if !c.iter().all(|v| v.is_finite()) {
                    return Err(ProbeError::Centre {
                        ball: ball.name.clone(),
                        angle_deg: *a,
                        fault: CentreFault::NotFinite { centre: *c },
                    });
                }
            }
        }
        Ok(())
    }

    /// A measurement from centres: per ball its name and its centre (mm) at
    /// each of `angles_deg`.
    pub fn from_centres(angles_deg: Vec<f64>, balls: Vec<(String, Vec<[f64; 3]>)>) -> Measurement {
        Measurement {
            angles_deg,
            balls: balls
                .into_iter()
                .map(|(name, centres)| Ball {
                    name,
                    centres: centres.into_iter().map(Point3::from).collect(),
                    fits: Vec::new(),
                })
                .collect(),
        }
    }

    /// A measurement from probed points: per ball its name and, at each of
    /// `angles_deg`, the probed points (mm); a sphere is fitted to each
    /// ([`fit_centre`]). A fit that fails is a [`ProbeError::Centre`] of
    /// its ball and angle.
    pub fn from_points(
        angles_deg: Vec<f64>,
        balls: Vec<(String, Vec<Vec<[f64; 3]>>)>,
    ) -> Result<Measurement> {
        let mut out = Vec::with_capacity(balls.len());
        for (name, groups) in balls {
            if groups.len() != angles_deg.len() {
                return Err(ProbeError::Rotary(RotaryFault::PointGroups {
                    ball: name,
                    groups: groups.len(),
                    angles: angles_deg.len(),
                }));
            }
            let mut fits = Vec::with_capacity(groups.len());
            for (points, a) in groups.iter().zip(&angles_deg) {
                let points: Vec<Point3<f64>> = points.iter().copied().map(Point3::from).collect();
                let fit = fit_centre(&points).map_err(|e| ProbeError::Centre {
                    ball: name.clone(),
                    angle_deg: *a,
                    fault: CentreFault::SphereFit(Box::new(e)),
                })?;
                fits.push(fit);
            }
            out.push(Ball {
                name,
                centres: fits.iter().map(|f| f.centre).collect(),
                fits,
            });
        }
        Ok(Measurement {
            angles_deg,
            balls: out,
        })
    }

    /// The balls' names in input order.
    pub fn ball_names(&self) -> Vec<String> {
        self.balls.iter().map(|b| b.name.clone()).collect()
    }

    /// Each ball's reference centre P0 (its centre at 0°).
    pub fn reference(&self) -> Vec<Point3<f64>> {
        self.balls
            .iter()
            .filter_map(|b| b.centres.first().copied())
            .collect()
    }
}

/// Everything the method found.
#[derive(Debug, Clone, PartialEq)]
pub struct Solution {
    /// The measured angles (degrees).
    pub angles_deg: Vec<f64>,
    /// The balls' names.
    pub balls: Vec<String>,
    /// Each ball's reference centre P0 (mm).
    pub reference: Vec<Point3<f64>>,
    /// The layout check: condition number and scale.
    pub layout: Layout,
    /// The six errors per measured angle, with uncertainties and residuals.
    pub errors: Vec<AngleErrors>,
    /// The axis average line and the component errors; `None` when the
    /// measured angles do not separate them (see [`AxisLine`]).
    pub axis: Option<AxisLine>,
    /// The sphere fits per ball (in ball order) and angle, when the input
    /// was probed points; empty when centres were given.
    pub fits: Vec<Vec<CentreFit>>,
    /// Things worth knowing that did not stop the method.
    pub warnings: Vec<String>,
}

/// The six errors and their standard uncertainties at any angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interpolated {
    /// The angle asked for (degrees, as given).
    pub angle_deg: f64,
    /// The six errors (mm, rad), linear between the two nearest measured angles.
    pub errors: SixErrors,
    /// Their standard uncertainties, interpolated the same way.
    pub uncertainty: SixErrors,
}

/// Run the method (docs/probe-rotary.md): validate, check the layout, the six
/// errors per angle by least squares, then the axis average line.
///
/// # Example
/// A table that turns about an axis 10 µm off in x:
/// `P(θ) = c + Rz(θ)·(P0 − c)` — all of it location, X0C = 10 µm.
/// ```
/// use geom::nalgebra::Point3;
/// use probe::rotary::{Measurement, rz, solve};
///
/// let c = Point3::new(0.010, 0.0, 0.0);
/// let layout = [[150.0, 10.0, 60.0], [-70.0, 120.0, 95.0], [-55.0, -135.0, 30.0]];
/// let angles: Vec<f64> = (0..12).map(|k| 30.0 * f64::from(k)).collect();
/// let balls = layout
///     .iter()
///     .enumerate()
///     .map(|(i, p)| {
///         let p0 = Point3::from(*p);
///         let centres = angles
///             .iter()
///             .map(|a| (c + rz(*a) * (p0 - c)).coords.into())
///             .collect();
///         (format!("{}", i + 1), centres)
///     })
///     .collect();
/// let s = solve(&Measurement::from_centres(angles, balls))?;
/// let l = s.axis.expect("a full turn").location;
/// assert!((l.x0c_mm - 0.010).abs() < 1e-12 && l.y0c_mm.abs() < 1e-12);
/// assert!(s.errors[6].errors[0] > 0.0199); // EXC at 180° = 2·X0C
/// # Ok::<(), probe::ProbeError>(())
/// ```
pub fn solve(measurement: &Measurement) -> Result<Solution> {
    measurement.validate()?;
    let reference = measurement.reference();
    let layout = identify::layout(&reference)?;
    if layout.condition > CONDITION_LIMIT {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::BallLayout {
                balls: measurement.ball_names(),
            },
            condition: layout.condition,
            limit: CONDITION_LIMIT,
        });
    }
    let errors = identify::errors_per_angle(measurement, &layout)?;
    let mut warnings = Vec::new();
    let axis = match location::axis_line(&measurement.angles_deg, &errors) {
        Ok(axis) => {
            if axis.condition > 1.0 + location::FULL_TURN_TOLERANCE {
                warnings.push(format!(
                    "the measured angles are not a full turn in equal steps (location fit condition number \
                     {:.2}): the location errors assume component errors without a constant or \
                     once-per-turn part",
                    axis.condition
                ));
            }
            Some(axis)
        }
        Err(ProbeError::IllConditioned {
            condition, limit, ..
        }) => {
            warnings.push(format!(
                "the axis average line is not reported: the measured angles ({}° to {}°) do not \
                 separate a fixed axis from the reference pose (condition number {condition:.1} > {limit}); \
                 measure through a full turn",
                measurement.angles_deg[0],
                measurement.angles_deg[measurement.angles_deg.len() - 1]
            ));
            None
        }
        Err(e) => return Err(e),
    };
    let fits: Vec<Vec<CentreFit>> = if measurement.balls.iter().all(|b| b.fits.is_empty()) {
        Vec::new()
    } else {
        measurement.balls.iter().map(|b| b.fits.clone()).collect()
    };
    warnings.extend(centres::fit_warnings(measurement));
    Ok(Solution {
        angles_deg: measurement.angles_deg.clone(),
        balls: measurement.ball_names(),
        reference,
        layout,
        errors,
        axis,
        fits,
        warnings,
    })
}

impl Solution {
    /// The six errors and uncertainties at `angle_deg` (any value: reduced
    /// to `[0, 360)`), linear between the two nearest measured angles,
    /// wrapping from the last measured angle to 360° = 0°.
    pub fn at(&self, angle_deg: f64) -> Result<Interpolated> {
        if !angle_deg.is_finite() {
            return Err(ProbeError::Rotary(RotaryFault::AngleNotFinite {
                angle: angle_deg,
            }));
        }
        let values: Vec<SixErrors> = self.errors.iter().map(|e| e.errors).collect();
        let u: Vec<SixErrors> = self.errors.iter().map(|e| e.uncertainty).collect();
        let errors =
            geom::interp::linear_periodic(&self.angles_deg, &values, angle_deg, FULL_TURN_DEG)?;
        let uncertainty =
            geom::interp::linear_periodic(&self.angles_deg, &u, angle_deg, FULL_TURN_DEG)?;
        Ok(Interpolated {
            angle_deg,
            errors,
            uncertainty,
        })
    }

    /// Range (max − min over the measured angles) of each of the six errors.
    pub fn ranges(&self) -> SixErrors {
        ranges(self.errors.iter().map(|e| e.errors))
    }

    /// Root mean square of every residual of every angle's least squares (mm).
    pub fn residual_rms_mm(&self) -> f64 {
        let (ss, n) = self.errors.iter().fold((0.0, 0usize), |(ss, n), e| {
            (
                ss + e.residual_rms_mm.powi(2) * e.residuals as f64,
                n + e.residuals,
            )
        });
        if n == 0 { 0.0 } else { (ss / n as f64).sqrt() }
    }
}

/// Range (max − min) of each component over the six-vectors; zero for none.
pub(crate) fn ranges(values: impl Iterator<Item = SixErrors>) -> SixErrors {
    let mut lo = SixErrors::repeat(f64::INFINITY);
    let mut hi = SixErrors::repeat(f64::NEG_INFINITY);
    let mut any = false;
    for v in values {
        lo = lo.inf(&v);
        hi = hi.sup(&v);
        any = true;
    }
    if any { hi - lo } else { SixErrors::zeros() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::transform::SmallError;
    use proptest::prelude::*;

    /// Centres that follow the first-order model of §2 exactly:
    /// `P(θ) = Rz·P0 + δ(θ) + ε(θ) × Rz·P0`, errors zero at 0°.
    fn exact(reference: &[Point3<f64>], angles: &[f64], errors: &[SmallError]) -> Measurement {
        let balls = reference
            .iter()
            .enumerate()
            .map(|(i, p0)| Ball {
                name: format!("{}", i + 1),
                centres: angles
                    .iter()
                    .zip(errors)
                    .map(|(a, e)| e.apply(&(rz(*a) * p0)))
                    .collect(),
                fits: Vec::new(),
            })
            .collect();
        Measurement {
            angles_deg: angles.to_vec(),
            balls,
        }
    }

    fn small_error() -> impl Strategy<Value = SmallError> {
        (
            prop::array::uniform3(-0.05..0.05f64),
            prop::array::uniform3(-1e-4..1e-4f64),
        )
            .prop_map(|(d, e)| SmallError {
                delta: Vector3::from(d),
                epsilon: Vector3::from(e),
            })
    }

    proptest! {
        /// Any layout the check accepts and any errors: the per-angle least
        /// squares returns the errors that made the centres, to rounding.
        #[test]
        fn exact_centres_give_back_their_errors(
            layout in prop::collection::vec(prop::array::uniform3(-300.0..300.0f64), 3..6),
            step in prop::sample::select(vec![15.0, 30.0, 45.0, 60.0, 90.0]),
            errors in prop::collection::vec(small_error(), 24),
        ) {
            let reference: Vec<Point3<f64>> = layout.iter().map(|p| Point3::from(*p)).collect();
            let angles: Vec<f64> = (0..).map(|k| f64::from(k) * step).take_while(|a| *a < 360.0).collect();
            let mut errors = errors[..angles.len()].to_vec();
            errors[0] = SmallError::ZERO;
            let m = exact(&reference, &angles, &errors);
            match solve(&m) {
                Ok(s) => {
                    for (got, want) in s.errors.iter().zip(&errors) {
                        let want = SixErrors::new(
                            want.delta.x, want.delta.y, want.delta.z,
                            want.epsilon.x, want.epsilon.y, want.epsilon.z,
                        );
                        let d = got.errors - want;
                        // Rounding of coordinates up to 520 mm (≈ 1e-13 mm), amplified
                        // by the condition number (≤ 100) through the QR solve.
                        prop_assert!(d.fixed_rows::<3>(0).amax() < 1e-11, "{d:?}");
                        prop_assert!(d.fixed_rows::<3>(3).amax() < 1e-13, "{d:?}");
                        prop_assert!(got.residual_rms_mm < 1e-11);
                    }
                }
                Err(ProbeError::IllConditioned { condition, limit, .. }) => prop_assert!(condition > limit),
                Err(e) => prop_assert!(false, "{e}"),
            }
        }

        /// A fixed misplaced axis and nothing else: all of it is location,
        /// none of it component error, whatever the layout and step.
        #[test]
        fn a_fixed_axis_is_found_whatever_the_layout(
            c in prop::array::uniform2(-0.05..0.05f64),
            t in prop::array::uniform2(-1e-4..1e-4f64),
            step in prop::sample::select(vec![10.0, 20.0, 30.0, 40.0, 72.0, 120.0]),
        ) {
            let truth = Location { x0c_mm: c[0], y0c_mm: c[1], a0c_rad: t[0], b0c_rad: t[1], uncertainty: [0.0; 4] };
            let angles: Vec<f64> = (0..).map(|k| f64::from(k) * step).take_while(|a| *a < 360.0).collect();
            let errors: Vec<SmallError> = angles
                .iter()
                .map(|a| {
                    let f = truth.fixed_axis_errors(*a);
                    SmallError { delta: Vector3::new(f[0], f[1], f[2]), epsilon: Vector3::new(f[3], f[4], f[5]) }
                })
                .collect();
            let reference = [
                Point3::new(150.0, 10.0, 60.0),
                Point3::new(-70.0, 120.0, 95.0),
                Point3::new(-55.0, -135.0, 30.0),
            ];
            let s = solve(&exact(&reference, &angles, &errors)).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let axis = s.axis.ok_or_else(|| TestCaseError::fail("no location"))?;
            let l = axis.location;
            prop_assert!((l.x0c_mm - c[0]).abs() < 1e-12 && (l.y0c_mm - c[1]).abs() < 1e-12);
            prop_assert!((l.a0c_rad - t[0]).abs() < 1e-14 && (l.b0c_rad - t[1]).abs() < 1e-14);
            prop_assert!(axis.component_ranges().amax() < 1e-12);
        }
    }

    #[test]
    fn bad_measurements_are_errors() {
        let reference = [
            Point3::new(150.0, 10.0, 60.0),
            Point3::new(-70.0, 120.0, 95.0),
            Point3::new(-55.0, -135.0, 30.0),
        ];
        let angles = [0.0, 90.0, 180.0, 270.0];
        let good = exact(&reference, &angles, &[SmallError::ZERO; 4]);
        assert!(solve(&good).is_ok());
        let mut m = good.clone();
        m.balls[1].centres[2].x = f64::NAN;
        assert!(
            solve(&m)
                .unwrap_err()
                .to_string()
                .contains("ball 2 at 180°")
        );
        let mut m = good.clone();
        m.angles_deg[0] = 10.0;
        assert!(
            solve(&m)
                .unwrap_err()
                .to_string()
                .contains("no measurement at 0°")
        );
        let mut m = good.clone();
        m.angles_deg.swap(1, 2);
        assert!(
            solve(&m)
                .unwrap_err()
                .to_string()
                .contains("increase strictly")
        );
        let mut m = good.clone();
        m.balls[2].name = "1".into();
        assert!(solve(&m).unwrap_err().to_string().contains("twice"));
        let mut m = good.clone();
        m.balls[0].centres.pop();
        assert!(
            solve(&m)
                .unwrap_err()
                .to_string()
                .contains("3 centres for 4 angles")
        );
        let mut m = good;
        m.angles_deg[3] = 360.0;
        assert!(solve(&m).unwrap_err().to_string().contains("[0°, 360°)"));
    }
}
