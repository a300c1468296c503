//! The eighteen error curves (docs/probe-volumetric.md): per linear axis its six error
//! motions at the measured carriage positions, checked, with the
//! least-squares line removed from the two straightness curves.

use formats::Axis;
use formats::probe::volumetric::ErrorRow;
pub use formats::probe::volumetric::Motion;

use crate::{CurveFault, ProbeError, Result};

/// The six error curves of one axis as measured: carriage positions `q`
/// (mm, strictly increasing) and the six motions at each (mm, rad), plus
/// optionally the positioning error per approach direction (mm), which only
/// the compensation tables use.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredAxis {
    /// The axis.
    pub axis: Axis,
    /// Carriage positions q (mm), strictly increasing.
    pub positions: Vec<f64>,
    /// `values[m][k]`: motion `Motion::ALL[m]` at `positions[k]` (mm or rad).
    pub values: [Vec<f64>; 6],
    /// Positioning error approached in the + direction (mm), per position.
    pub positioning_up: Option<Vec<f64>>,
    /// Positioning error approached in the − direction (mm), per position.
    pub positioning_down: Option<Vec<f64>>,
}

impl MeasuredAxis {
    /// Curves of `axis` from rows `[position, ex, ey, ez, ea, eb, ec]`.
    pub fn from_rows(axis: Axis, rows: &[[f64; 7]]) -> MeasuredAxis {
        MeasuredAxis {
            axis,
            positions: rows.iter().map(|r| r[0]).collect(),
            values: std::array::from_fn(|m| rows.iter().map(|r| r[m + 1]).collect()),
            positioning_up: None,
            positioning_down: None,
        }
    }
}

/// The curves of `E.csv` rows: one per axis present (X, Y, Z order), the
/// rows of each in the order given, with the direction columns when given.
pub fn measured_axes(rows: &[ErrorRow]) -> Vec<MeasuredAxis> {
    [Axis::X, Axis::Y, Axis::Z]
        .into_iter()
        .filter_map(|axis| {
            let of_axis: Vec<&ErrorRow> = rows.iter().filter(|r| r.axis() == axis).collect();
            if of_axis.is_empty() {
                return None;
            }
            let table: Vec<[f64; 7]> = of_axis
                .iter()
                .map(|r| {
                    let m = r.motions();
                    [r.position, m[0], m[1], m[2], m[3], m[4], m[5]]
                })
                .collect();
            let mut m = MeasuredAxis::from_rows(axis, &table);
            m.positioning_up = of_axis.iter().map(|r| r.positioning_up).collect();
            m.positioning_down = of_axis.iter().map(|r| r.positioning_down).collect();
            Some(m)
        })
        .collect()
}

/// The slope removed from a straightness curve with its least-squares line
/// (rad: mm per mm), which belongs to the axis's squareness and alignment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RemovedSlope {
    /// The axis.
    pub axis: Axis,
    /// The straightness (`ey`, `ez` of X, …).
    pub error: Motion,
    /// The slope `k` of the line `v = k·q + b` that was removed (mm/mm).
    pub slope: f64,
    /// The intercept `b` (mm).
    pub intercept_mm: f64,
}

/// The curves of one axis as the model uses them: checked, the straightness
/// curves with their least-squares line removed (§5).
#[derive(Debug, Clone, PartialEq)]
pub struct AxisCurves {
    /// The axis.
    pub axis: Axis,
    /// Carriage positions (mm), strictly increasing.
    pub positions: Vec<f64>,
    /// The six motions at the positions (mm, rad).
    pub values: [Vec<f64>; 6],
    /// Positioning error per approach direction (mm), when measured.
    pub positioning_up: Option<Vec<f64>>,
    /// Positioning error of the − approach (mm), when measured.
    pub positioning_down: Option<Vec<f64>>,
    /// The lines removed from the two straightness curves.
    pub removed: Vec<RemovedSlope>,
}

impl AxisCurves {
    /// Check `m` (≥ 2 finite points, positions strictly increasing, every
    /// column as long as the positions) and remove the least-squares line
    /// `v = k·q + b` from its straightness curves.
    pub fn new(m: MeasuredAxis) -> Result<AxisCurves> {
        let axis = m.axis;
        let n = m.positions.len();
        let curve = |fault| ProbeError::Curve { axis, fault };
        if n < 2 {
            return Err(curve(CurveFault::TooFewPositions { count: n }));
        }
        let columns = m
            .values
            .iter()
            .zip(Motion::ALL)
            .map(|(v, motion)| (motion.name(), v))
            .chain(m.positioning_up.iter().map(|v| ("positioning_up", v)))
            .chain(m.positioning_down.iter().map(|v| ("positioning_down", v)));
        for (name, v) in columns {
            if v.len() != n {
                return Err(curve(CurveFault::Length {
                    column: name,
                    values: v.len(),
                    positions: n,
                }));
            }
            if let Some(k) = v.iter().position(|x| !x.is_finite()) {
                return Err(curve(CurveFault::NotFinite {
                    point: k + 1,
                    column: name,
                    value: v[k],
                }));
            }
        }
        if let Some(k) = m.positions.iter().position(|x| !x.is_finite()) {
            return Err(curve(CurveFault::PositionNotFinite {
                point: k + 1,
                value: m.positions[k],
            }));
        }
        if let Some(k) = m.positions.windows(2).position(|w| w[1] <= w[0]) {
            return Err(curve(CurveFault::NotIncreasing {
                point: k + 2,
                position: m.positions[k + 1],
                previous: m.positions[k],
            }));
        }
        let mut values = m.values;
        let mut removed = Vec::new();
        for motion in Motion::ALL
            .into_iter()
            .filter(|mo| mo.is_straightness(axis))
        {
            let points: Vec<geom::Point2<f64>> = m
                .positions
                .iter()
                .zip(&values[motion.index()])
                .map(|(&q, &v)| geom::Point2::new(q, v))
                .collect();
            let line = geom::fit::line_y_on_x(&points)?;
            values[motion.index()] = line.residuals;
            removed.push(RemovedSlope {
                axis,
                error: motion,
                slope: line.k,
                intercept_mm: line.b,
            });
        }
        Ok(AxisCurves {
            axis,
            positions: m.positions,
            values,
            positioning_up: m.positioning_up,
            positioning_down: m.positioning_down,
            removed,
        })
    }

    /// The measured travel `[first, last]` position (mm).
    pub fn travel(&self) -> (f64, f64) {
        (
            self.positions.first().copied().unwrap_or(0.0),
            self.positions.last().copied().unwrap_or(0.0),
        )
    }

    /// The values of one motion at the positions.
    pub fn curve(&self, motion: Motion) -> &[f64] {
        &self.values[motion.index()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn axis(positions: Vec<f64>, ey: Vec<f64>) -> MeasuredAxis {
        let n = positions.len();
        let mut values: [Vec<f64>; 6] = std::array::from_fn(|_| vec![0.0; n]);
        values[1] = ey;
        MeasuredAxis {
            axis: Axis::X,
            positions,
            values,
            positioning_up: None,
            positioning_down: None,
        }
    }

    #[test]
    fn straightness_loses_its_line_and_reports_it() {
        // ey = 0.002·q + 0.01 + a bow: the line comes back, the bow stays.
        let q: Vec<f64> = (0..9).map(|k| 10.0 * k as f64).collect();
        let bow = |q: f64| 1e-6 * (q - 40.0).powi(2);
        let ey: Vec<f64> = q.iter().map(|&q| 0.002 * q + 0.01 + bow(q)).collect();
        let c = AxisCurves::new(axis(q.clone(), ey)).unwrap();
        // The bow's own least-squares line is horizontal (symmetric about 40).
        let mean_bow = q.iter().map(|&q| bow(q)).sum::<f64>() / 9.0;
        assert!((c.removed[0].slope - 0.002).abs() < 1e-15);
        assert!((c.removed[0].intercept_mm - 0.01 - mean_bow).abs() < 1e-15);
        for (k, &q) in q.iter().enumerate() {
            assert!((c.curve(Motion::Ey)[k] - (bow(q) - mean_bow)).abs() < 1e-15);
        }
        assert_eq!(c.removed.len(), 2);
        assert_eq!(c.removed[1].error, Motion::Ez);
    }

    #[test]
    fn bad_curves_are_errors() {
        let e = AxisCurves::new(axis(vec![0.0, 10.0, 10.0], vec![0.0; 3])).unwrap_err();
        assert!(e.to_string().contains("point 3") && e.to_string().contains("increase"));
        let e = AxisCurves::new(axis(vec![0.0], vec![0.0])).unwrap_err();
        assert!(e.to_string().contains("at least 2"));
        let e = AxisCurves::new(axis(vec![0.0, 1.0], vec![0.0, f64::NAN])).unwrap_err();
        assert!(e.to_string().contains("'ey'"), "{e}");
    }

    #[test]
    fn names_and_symbols() {
        assert_eq!(Motion::Ey.symbol(Axis::X), "EYX");
        assert_eq!(Motion::Ea.symbol(Axis::Z), "EAZ");
        assert!(Motion::Ex.is_positioning(Axis::X) && Motion::Ey.is_straightness(Axis::X));
        assert!(!Motion::Eb.is_straightness(Axis::Y));
        assert_eq!(Motion::along(Axis::Y), Motion::Ey);
        assert_eq!(Motion::from_name("ec"), Some(Motion::Ec));
    }
}
