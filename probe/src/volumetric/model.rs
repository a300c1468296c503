//! The error model: per axis its curves and both series fits of each, and
//! the six error motions at any carriage position inside the measured travel
//! — `raw` (linear between measured positions), `fourier`, `polynomial`, or
//! what compensation with a series would leave (raw minus the series).

use formats::Axis;
pub use formats::probe::volumetric::Model;
use geom::Vector3;

use super::curves::{AxisCurves, Motion};
use super::series::{
    MAX_AUTO_ORDER, OrderScore, POINTS_PER_COEFFICIENT, Series, SeriesFit, choose_order,
};
use crate::{ProbeError, Result, Unsolvable, VolumetricFault};

/// Default Fourier order N (§5; the polynomial then has degree 6).
pub const DEFAULT_ORDER: usize = 3;
/// A position this close outside the measured travel (mm) is its end: the
/// rounding of positions computed from a circle or a frame, not an extrapolation.
pub(crate) const TRAVEL_TOLERANCE_MM: f64 = 1e-9;

/// The order N of the series (`--order N` or `--order auto`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Order {
    /// The same N for every curve and both series (`--order N`); a curve
    /// with too few points for it is an error.
    Fixed(usize),
    /// N, or for a curve whose points do not allow it the highest order they
    /// allow (down to 0, the mean) — the default, with a note per axis.
    Highest(usize),
    /// N per curve and series by leave-one-out cross-validation.
    Auto,
}

/// What the error model gives at a position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Evaluation {
    /// The curves under a model.
    Model(Model),
    /// Raw minus a series: the errors left after compensating with that series.
    Residual(Series),
}

/// Both series fitted to one curve, and the order scores when chosen automatically.
#[derive(Debug, Clone, PartialEq)]
pub struct CurveFits {
    /// Fourier series.
    pub fourier: SeriesFit,
    /// Polynomial of the same coefficient count (under `--order auto`, its own order).
    pub polynomial: SeriesFit,
    /// Leave-one-out scores per series (Fourier, polynomial) under `--order auto`.
    pub scores: Option<[Vec<OrderScore>; 2]>,
    /// Per series (Fourier, polynomial): whether its order is the highest the
    /// points allow rather than the order asked for (or cross-validation's).
    pub lowered: [bool; 2],
}

impl CurveFits {
    /// The fit of `series`.
    pub fn get(&self, series: Series) -> &SeriesFit {
        match series {
            Series::Fourier => &self.fourier,
            Series::Polynomial => &self.polynomial,
        }
    }

    /// Whether the order of `series` is the highest the points allow
    /// rather than the order asked for ([`CurveFits::lowered`]).
    pub fn is_lowered(&self, series: Series) -> bool {
        match series {
            Series::Fourier => self.lowered[0],
            Series::Polynomial => self.lowered[1],
        }
    }
}

/// One axis of the model: its curves and the fits of each.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisModel {
    /// The curves (straightness lines removed).
    pub curves: AxisCurves,
    /// Fits of the six motions, in [`Motion::ALL`] order.
    pub fits: Vec<CurveFits>,
}

impl AxisModel {
    /// Fit both series to every curve of `curves`.
    pub fn new(curves: AxisCurves, order: Order) -> Result<AxisModel> {
        let mut fits = Vec::with_capacity(6);
        for motion in Motion::ALL {
            let what = format!("axis {} curve {}", curves.axis, motion.name());
            let (p, v) = (&curves.positions, curves.curve(motion));
            // (fit, scores, whether the order is the highest the points allow)
            type Fitted = (SeriesFit, Option<Vec<OrderScore>>, bool);
            let fit = |series: Series| -> Result<Fitted> {
                match order {
                    Order::Fixed(n) => Ok((SeriesFit::fit(series, n, p, v, &what)?, None, false)),
                    Order::Highest(n) => {
                        let f = SeriesFit::highest(series, n, p, v, &what)?;
                        let lowered = f.order < n;
                        Ok((f, None, lowered))
                    }
                    Order::Auto => match choose_order(series, p, v, &what) {
                        Ok((n, scores)) => {
                            Ok((SeriesFit::fit(series, n, p, v, &what)?, Some(scores), false))
                        }
                        Err(ProbeError::Volumetric(VolumetricFault::NothingToCrossValidate {
                            ..
                        })) => Ok((
                            SeriesFit::highest(series, MAX_AUTO_ORDER, p, v, &what)?,
                            Some(Vec::new()),
                            true,
                        )),
                        Err(e) => Err(e),
                    },
                }
            };
            let (fourier, fs, fl) = fit(Series::Fourier)?;
            let (polynomial, ps, pl) = fit(Series::Polynomial)?;
            fits.push(CurveFits {
                fourier,
                polynomial,
                scores: fs.zip(ps).map(|(f, p)| [f, p]),
                lowered: [fl, pl],
            });
        }
        Ok(AxisModel { curves, fits })
    }

    /// The note on the orders of this axis's fits when some are the highest
    /// its points allow rather than the order asked for; `None` otherwise.
    pub fn order_note(&self, order: Order) -> Option<String> {
        if self.fits.iter().all(|f| f.lowered == [false, false]) {
            return None;
        }
        let n = self.curves.positions.len();
        let why = match order {
            Order::Auto => format!(
                "too few to cross-validate an order (--order auto needs {} for order 1, {} per \
                 coefficient)",
                3 * POINTS_PER_COEFFICIENT,
                POINTS_PER_COEFFICIENT
            ),
            Order::Fixed(k) | Order::Highest(k) => format!(
                "too few for the default order {k} ({} coefficients, points that determine them)",
                2 * k + 1
            ),
        };
        let orders: Vec<String> = Series::BOTH
            .iter()
            .map(|s| {
                let mut used: Vec<(usize, Vec<&str>)> = Vec::new();
                for (f, m) in self.fits.iter().zip(Motion::ALL) {
                    let o = f.get(*s).order;
                    match used.iter_mut().find(|(k, _)| *k == o) {
                        Some((_, names)) => names.push(m.name()),
                        None => used.push((o, vec![m.name()])),
                    }
                }
                let text = match used.as_slice() {
                    [(o, _)] => format!("N = {o}"),
                    _ => used
                        .iter()
                        .map(|(o, names)| format!("N = {o} ({})", names.join(", ")))
                        .collect::<Vec<_>>()
                        .join(", "),
                };
                let asked = if self.fits.iter().any(|f| f.is_lowered(*s)) {
                    ""
                } else {
                    " as asked"
                };
                format!("{} {text}{asked}", s.name())
            })
            .collect();
        let mean = self
            .fits
            .iter()
            .any(|f| f.fourier.order == 0 || f.polynomial.order == 0);
        Some(format!(
            "axis {}: {n} points, {why}: its curves take the highest order the points allow, {}{}; \
             the R² of those fits is not judged",
            self.axis(),
            orders.join(", "),
            if mean { " (N = 0: the mean)" } else { "" }
        ))
    }

    /// The axis.
    pub fn axis(&self) -> Axis {
        self.curves.axis
    }

    /// One motion at carriage position `q` under `how`; `q` must lie in the
    /// measured travel (no extrapolation).
    pub fn value(&self, motion: Motion, q: f64, how: Evaluation) -> Result<f64> {
        let (lo, hi) = self.curves.travel();
        if !(q >= lo - TRAVEL_TOLERANCE_MM && q <= hi + TRAVEL_TOLERANCE_MM) {
            return Err(ProbeError::Volumetric(VolumetricFault::OutsideTravel {
                axis: self.axis(),
                position: q,
                lo,
                hi,
            }));
        }
        let q = q.clamp(lo, hi);
        let raw = || geom::interp::linear(&self.curves.positions, self.curves.curve(motion), q);
        let series = |s: Series| {
            self.fits[motion.index()]
                .get(s)
                .value(q)
                .ok_or(ProbeError::Unsolvable(Unsolvable::OutsideFit {
                    position_mm: q,
                }))
        };
        Ok(match how {
            Evaluation::Model(m) => match m.series() {
                None => raw()?,
                Some(s) => series(s)?,
            },
            Evaluation::Residual(s) => raw()? - series(s)?,
        })
    }

    /// Translation δ (mm) and rotation ε (rad) of the carriage at `q`.
    pub fn motions(&self, q: f64, how: Evaluation) -> Result<(Vector3<f64>, Vector3<f64>)> {
        let mut v = [0.0; 6];
        for m in Motion::ALL {
            v[m.index()] = self.value(m, q, how)?;
        }
        Ok((
            Vector3::new(v[0], v[1], v[2]),
            Vector3::new(v[3], v[4], v[5]),
        ))
    }
}

/// The error model of a machine: the axes that were measured.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorModel {
    /// Per axis, in X, Y, Z order.
    pub axes: Vec<AxisModel>,
    /// The order setting the fits were made with.
    pub order: Order,
}

impl ErrorModel {
    /// Fit every curve of every axis; each axis at most once.
    pub fn new(curves: Vec<AxisCurves>, order: Order) -> Result<ErrorModel> {
        if let Order::Fixed(0) = order {
            return Err(ProbeError::Volumetric(VolumetricFault::OrderZero));
        }
        let mut axes: Vec<AxisModel> = Vec::with_capacity(curves.len());
        for c in curves {
            if axes.iter().any(|a| a.axis() == c.axis) {
                return Err(ProbeError::Volumetric(VolumetricFault::AxisTwice {
                    axis: c.axis,
                }));
            }
            axes.push(AxisModel::new(c, order)?);
        }
        axes.sort_by_key(AxisModel::axis);
        Ok(ErrorModel { axes, order })
    }

    /// The model of one axis, if measured.
    pub fn axis(&self, axis: Axis) -> Option<&AxisModel> {
        self.axes.iter().find(|a| a.axis() == axis)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volumetric::MeasuredAxis;

    /// Axis X at `n` equally spaced positions over 150 mm, every curve a bow.
    fn short_axis(n: usize) -> AxisCurves {
        let rows: Vec<[f64; 7]> = (0..n)
            .map(|k| {
                let q = -75.0 + 150.0 * k as f64 / (n - 1) as f64;
                let bow = (q / 75.0).powi(2) + 0.1 * k as f64;
                [q, 1e-3 * bow, 2e-3 * bow, 1e-3, 1e-6 * bow, 0.0, 2e-6 * bow]
            })
            .collect();
        AxisCurves::new(MeasuredAxis::from_rows(Axis::X, &rows)).unwrap()
    }

    #[test]
    fn short_curves_take_the_highest_order_their_points_allow() {
        // 4 points: order 3 needs 7 coefficients; the default takes order 1
        // for both series and says so, --order auto (6 points for order 1)
        // too, and an explicit --order 3 stays an error.
        let default = AxisModel::new(short_axis(4), Order::Highest(3)).unwrap();
        assert!(
            default.fits.iter().all(|f| f.fourier.order == 1
                && f.polynomial.order == 1
                && f.lowered == [true, true])
        );
        let note = default.order_note(Order::Highest(3)).unwrap();
        assert!(
            note.starts_with("axis X: 4 points, too few for the default order 3 (7 coefficients")
                && note.contains("fourier N = 1, polynomial N = 1;")
                && !note.contains("the mean"),
            "{note}"
        );
        let auto = AxisModel::new(short_axis(4), Order::Auto).unwrap();
        assert!(
            auto.fits
                .iter()
                .all(|f| f.fourier.order == 1 && f.lowered == [true, true])
        );
        let note = auto.order_note(Order::Auto).unwrap();
        assert!(
            note.contains("too few to cross-validate an order (--order auto needs 6"),
            "{note}"
        );
        let e = AxisModel::new(short_axis(4), Order::Fixed(3)).unwrap_err();
        assert!(
            e.to_string()
                .contains("4 points, fewer than the 7 coefficients"),
            "{e}"
        );
        // 3 points: the Fourier series falls to the mean, the polynomial to degree 2.
        let three = AxisModel::new(short_axis(3), Order::Highest(3)).unwrap();
        assert!(
            three
                .fits
                .iter()
                .all(|f| f.fourier.order == 0 && f.polynomial.order == 1)
        );
        let note = three.order_note(Order::Highest(3)).unwrap();
        assert!(
            note.contains("fourier N = 0, polynomial N = 1 (N = 0: the mean)"),
            "{note}"
        );
        // Enough points: the order asked for, no note.
        let long = AxisModel::new(short_axis(9), Order::Highest(3)).unwrap();
        assert!(
            long.fits
                .iter()
                .all(|f| f.fourier.order == 3 && f.lowered == [false, false])
        );
        assert_eq!(long.order_note(Order::Highest(3)), None);
    }
}
