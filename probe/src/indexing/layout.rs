//! The head positions a measurement must hold for the §3 construction, and
//! the faults that break it: a full B turn at even steps at A = 0° (its mean
//! is the centre of its circle, on the B axis), the B = 0° sweep with A > 0°
//! (the plane of the A axis), no position twice, A in [0°, 180°).

use std::collections::BTreeMap;
use std::fmt::Write;

/// Commanded angles closer than this (degrees) are the same detent.
pub const DETENT_TOLERANCE_DEG: f64 = 1e-6;

/// Fewest positions the sphere fit needs: four determine a sphere, one more
/// gives its residual (the noise estimate of the uncertainties).
pub const MIN_POSITIONS: usize = 5;

/// How far (degrees) a B of the turn at A = 0° may be from its even step.
pub const TURN_TOLERANCE_DEG: f64 = 1e-5;

/// Most B values of the turn at A = 0° an error message lists.
const TURN_LISTED: usize = 8;

/// Fewest A = 0° positions that make a circle of the B turn.
pub const MIN_TURN: usize = 3;

/// A commanded angle as an integer key: multiples of [`DETENT_TOLERANCE_DEG`].
pub(crate) fn detent_key(deg: f64) -> i64 {
    (deg / DETENT_TOLERANCE_DEG).round() as i64
}

/// `deg` wrapped to (−180°, 180°].
pub(crate) fn wrap_deg(deg: f64) -> f64 {
    let r = deg.rem_euclid(360.0);
    if r > 180.0 { r - 360.0 } else { r }
}

/// The roles of the positions in the §3 construction (indices into the input).
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The A = 0° positions: the full B turn whose mean is Q.
    pub b_turn: Vec<usize>,
    /// The B = 0°, A > 0° positions: the sweep that fixes the A axis.
    pub a_sweep: Vec<usize>,
    /// Step of the B turn (degrees), `360 / b_turn.len()`.
    pub b_step_deg: f64,
    /// The commanded A values, ascending.
    pub a_levels: Vec<f64>,
    /// The commanded B values (wrapped to (−180°, 180°]), ascending.
    pub b_levels: Vec<f64>,
    /// Positions of the grid `a_levels × b_levels` that were not measured
    /// (the construction does not need them; a full PH10 campaign has none).
    pub missing: Vec<(f64, f64)>,
}

/// Why positions do not support the §3 construction. [`Fault::describe`]
/// words it, naming input rows the caller's way (data row or file line).
#[derive(Debug, Clone, PartialEq)]
pub enum Fault {
    /// A value is NaN or infinite.
    NonFinite {
        /// Index of the position.
        row: usize,
        /// Its column.
        column: &'static str,
        /// The value.
        value: f64,
    },
    /// A commanded A outside [0°, 180°) (θA = arccos n cannot say it).
    ARange {
        /// Index of the position.
        row: usize,
        /// The value (degrees).
        value: f64,
    },
    /// The same (A, B) (B modulo 360°) as an earlier position.
    Duplicate {
        /// Index of the position.
        row: usize,
        /// Index of the earlier one.
        first: usize,
        /// Commanded A (degrees).
        a_deg: f64,
        /// Commanded B (degrees).
        b_deg: f64,
    },
    /// Fewer positions than the sphere fit needs.
    TooFew {
        /// Positions given.
        count: usize,
    },
    /// No position at A = 0°: no B turn, no B axis.
    NoBTurn,
    /// The A = 0° positions are not a full B turn at even steps.
    UnevenBTurn {
        /// Index of the first position off the even steps, if one is.
        row: Option<usize>,
        /// The B values at A = 0° (degrees, wrapped, ascending).
        b_deg: Vec<f64>,
    },
    /// No position at B = 0° with A > 0°: no A axis.
    NoASweep,
}

impl Fault {
    /// The row at fault (index into the input), its column and the message;
    /// `name` words a row index in the message (e.g. `row 12` or `line 13`).
    pub fn describe(
        &self,
        name: impl Fn(usize) -> String,
    ) -> (Option<usize>, &'static str, String) {
        match self {
            Fault::NonFinite { row, column, value } => (
                Some(*row),
                column,
                format!("value {value} is not a finite number"),
            ),
            Fault::ARange { row, value } => (
                Some(*row),
                "a_deg",
                format!(
                    "A = {value}° is outside [0°, 180°): the construction measures A as the angle \
                     of the stylus from the B axis"
                ),
            ),
            Fault::Duplicate {
                row,
                first,
                a_deg,
                b_deg,
            } => (
                Some(*row),
                "b_deg",
                format!(
                    "head position A = {a_deg}°, B = {b_deg}° is measured twice (first on {}; B is \
                     taken modulo 360°)",
                    name(*first)
                ),
            ),
            Fault::TooFew { count } => (
                None,
                "a_deg",
                format!(
                    "{count} positions: the sphere through the centres needs at least \
                     {MIN_POSITIONS} (4 for the sphere, one more for its residual)"
                ),
            ),
            Fault::NoBTurn => (
                None,
                "a_deg",
                "no position at A = 0°: the B axis comes from a full B turn at A = 0°".into(),
            ),
            Fault::UnevenBTurn { row, b_deg } => {
                let mut list = String::new();
                for (k, b) in b_deg.iter().enumerate() {
                    if k == TURN_LISTED {
                        let _ = write!(list, ", … ({} in all)", b_deg.len());
                        break;
                    }
                    let _ = write!(list, "{}{b}°", if k == 0 { "" } else { ", " });
                }
                let radians = if b_deg.iter().all(|b| b.abs() <= std::f64::consts::TAU) {
                    " (are the angles in radians? the file wants degrees)"
                } else {
                    ""
                };
                (
                    *row,
                    "b_deg",
                    format!(
                        "the A = 0° positions (B = {list}) are not a full B turn at even steps \
                         (at least {MIN_TURN}, 360°/n apart): the mean of their centres would not \
                         be the centre of their circle, so the B axis would be wrong{radians}"
                    ),
                )
            }
            Fault::NoASweep => (
                None,
                "b_deg",
                "no position at B = 0° with A > 0°: the A axis comes from the B = 0° sweep".into(),
            ),
        }
    }

    /// Where (`row k, column 'c'`, rows 1-based among the positions) and what.
    pub fn located(&self) -> (String, String) {
        let (row, column, message) = self.describe(|k| format!("row {}", k + 1));
        let what = match row {
            Some(k) => format!("row {}, column '{column}'", k + 1),
            None => format!("column '{column}'"),
        };
        (what, message)
    }
}

/// Check commanded `(A, B)` angles and the centres' coordinates (`xyz`, one
/// triple per position) and find the roles of the positions.
pub fn check(angles: &[(f64, f64)], xyz: &[[f64; 3]]) -> Result<Layout, Fault> {
    const COLUMNS: [&str; 5] = ["a_deg", "b_deg", "x", "y", "z"];
    for (row, ((a, b), p)) in angles.iter().zip(xyz).enumerate() {
        for (column, value) in COLUMNS.into_iter().zip([*a, *b, p[0], p[1], p[2]]) {
            if !value.is_finite() {
                return Err(Fault::NonFinite { row, column, value });
            }
        }
        if !(0.0..180.0).contains(a) && detent_key(*a) != 0 {
            return Err(Fault::ARange { row, value: *a });
        }
    }
    let mut seen = BTreeMap::new();
    for (row, &(a, b)) in angles.iter().enumerate() {
        let key = (detent_key(a), detent_key(wrap_deg(b)));
        if let Some(&first) = seen.get(&key) {
            return Err(Fault::Duplicate {
                row,
                first,
                a_deg: a,
                b_deg: b,
            });
        }
        seen.insert(key, row);
    }
    if angles.len() < MIN_POSITIONS {
        return Err(Fault::TooFew {
            count: angles.len(),
        });
    }
    let b_turn: Vec<usize> = (0..angles.len())
        .filter(|&k| detent_key(angles[k].0) == 0)
        .collect();
    if b_turn.is_empty() {
        return Err(Fault::NoBTurn);
    }
    let b_step_deg = even_turn(angles, &b_turn)?;
    let a_sweep: Vec<usize> = (0..angles.len())
        .filter(|&k| detent_key(angles[k].0) > 0 && detent_key(wrap_deg(angles[k].1)) == 0)
        .collect();
    if a_sweep.is_empty() {
        return Err(Fault::NoASweep);
    }
    let levels = |values: &mut dyn Iterator<Item = f64>| {
        let map: BTreeMap<i64, f64> = values.map(|v| (detent_key(v), v)).collect();
        map.into_values().collect::<Vec<f64>>()
    };
    let a_levels = levels(&mut angles.iter().map(|p| p.0));
    let b_levels = levels(&mut angles.iter().map(|p| wrap_deg(p.1)));
    let missing = a_levels
        .iter()
        .flat_map(|&a| b_levels.iter().map(move |&b| (a, b)))
        .filter(|&(a, b)| !seen.contains_key(&(detent_key(a), detent_key(b))))
        .collect();
    Ok(Layout {
        b_turn,
        a_sweep,
        b_step_deg,
        a_levels,
        b_levels,
        missing,
    })
}

/// The step of the B turn at A = 0°: `n ≥ 3` distinct B values (modulo
/// 360°) whose differences are whole multiples of `360°/n`. When they are
/// not, the row named is the first off the even steps through most of them.
fn even_turn(angles: &[(f64, f64)], turn: &[usize]) -> Result<f64, Fault> {
    let mut b: Vec<(f64, usize)> = turn.iter().map(|&k| (wrap_deg(angles[k].1), k)).collect();
    b.sort_by(|p, q| p.0.total_cmp(&q.0));
    let step = 360.0 / b.len() as f64;
    let on_steps = |from: f64, value: f64| {
        let steps = (value - from) / step;
        (steps - steps.round()).abs() * step <= TURN_TOLERANCE_DEG
    };
    let odd_one = b
        .iter()
        .map(|&(from, _)| {
            b.iter()
                .filter(|q| !on_steps(from, q.0))
                .map(|q| q.1)
                .collect::<Vec<_>>()
        })
        .min_by_key(Vec::len)
        .unwrap_or_default();
    if b.len() < MIN_TURN || !odd_one.is_empty() {
        return Err(Fault::UnevenBTurn {
            row: odd_one.into_iter().min(),
            b_deg: b.iter().map(|p| p.0).collect(),
        });
    }
    Ok(step)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(a: &[f64], b_step: f64) -> Vec<(f64, f64)> {
        let n = (360.0 / b_step).round() as i64;
        a.iter()
            .flat_map(|&a| (0..n).map(move |k| (a, -180.0 + k as f64 * b_step)))
            .collect()
    }

    fn xyz(n: usize) -> Vec<[f64; 3]> {
        vec![[0.0; 3]; n]
    }

    #[test]
    fn wraps_to_half_open_interval() {
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-0.0), 0.0);
        assert_eq!(wrap_deg(725.0), 5.0);
    }

    #[test]
    fn full_grid_has_its_roles() {
        let g = grid(&[0.0, 15.0, 30.0], 30.0);
        let l = check(&g, &xyz(g.len())).unwrap();
        assert_eq!(l.b_turn.len(), 12);
        assert_eq!(l.a_sweep.len(), 2);
        assert!((l.b_step_deg - 30.0).abs() < 1e-12);
        assert_eq!(l.a_levels, vec![0.0, 15.0, 30.0]);
        assert_eq!(l.b_levels.len(), 12);
        assert!(l.missing.is_empty());
    }

    #[test]
    fn missing_positions_are_listed_not_refused() {
        let mut g = grid(&[0.0, 15.0], 90.0);
        g.retain(|&(a, b)| !(a == 15.0 && b == 90.0));
        let l = check(&g, &xyz(g.len())).unwrap();
        assert_eq!(l.missing, vec![(15.0, 90.0)]);
    }

    #[test]
    fn faults_are_found() {
        let g = grid(&[0.0, 15.0], 90.0);
        let mut dup = g.clone();
        dup.push((15.0, 180.0 + 360.0 * 0.0));
        // (15, 180) duplicates (15, −180) modulo 360°.
        let e = check(&dup, &xyz(dup.len())).unwrap_err();
        assert!(
            matches!(
                e,
                Fault::Duplicate {
                    row: 8,
                    first: 4,
                    ..
                }
            ),
            "{e:?}"
        );
        let no_turn: Vec<_> = g.iter().map(|&(a, b)| (a + 7.5, b)).collect();
        assert_eq!(check(&no_turn, &xyz(8)).unwrap_err(), Fault::NoBTurn);
        let mut uneven = g.clone();
        uneven[1].1 = -80.0;
        assert!(matches!(
            check(&uneven, &xyz(8)).unwrap_err(),
            Fault::UnevenBTurn { row: Some(1), .. }
        ));
        let mut half = g.clone();
        half.remove(3);
        assert!(matches!(
            check(&half, &xyz(7)).unwrap_err(),
            Fault::UnevenBTurn { .. }
        ));
        let no_sweep: Vec<_> = g
            .iter()
            .copied()
            .filter(|&(a, b)| !(a > 0.0 && b == 0.0))
            .collect();
        assert_eq!(check(&no_sweep, &xyz(7)).unwrap_err(), Fault::NoASweep);
        let mut nan = xyz(8);
        nan[5][1] = f64::NAN;
        assert!(matches!(
            check(&g, &nan).unwrap_err(),
            Fault::NonFinite {
                row: 5,
                column: "y",
                ..
            }
        ));
        let mut neg = g.clone();
        neg[6].0 = -15.0;
        assert!(matches!(
            check(&neg, &xyz(8)).unwrap_err(),
            Fault::ARange { row: 6, .. }
        ));
        assert_eq!(
            check(&g[..4], &xyz(4)).unwrap_err(),
            Fault::TooFew { count: 4 }
        );
    }

    #[test]
    fn radians_are_suspected() {
        let g: Vec<_> = (0..4)
            .map(|k| (0.0, k as f64 * 0.5))
            .chain([(0.2, 0.0)])
            .collect();
        let e = check(&g, &xyz(5)).unwrap_err();
        let (what, message) = e.located();
        assert!(what.ends_with("column 'b_deg'"), "{what}");
        assert!(message.contains("radians"), "{message}");
    }
}
