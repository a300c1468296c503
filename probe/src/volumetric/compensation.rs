//! Pitch-error compensation tables from the positioning curves, for a
//! LinuxCNC joint `COMP_FILE` of `COMP_FILE_TYPE = 0` (LinuxCNC INI
//! configuration, `[JOINT_n]`): per line the nominal position, then the
//! actual position reached moving in the + direction and in the −
//! direction. Here `nominal = q` (the carriage position as the curves are
//! indexed) and `actual = q + e(q)`, e the positioning error of the axis
//! (EXX of X, …) approached in that direction, or the bidirectional curve
//! for both when the data has no directions. LinuxCNC turns each into the
//! trim `nominal − actual` and interpolates linearly between lines.

use formats::probe::volumetric::{COMP_FILE_MAX_LINES, CompLine};

use super::curves::{AxisCurves, Motion};

/// The table of one axis at its measured positions; more than
/// [`COMP_FILE_MAX_LINES`] positions are thinned to that many, evenly by
/// index, keeping both ends.
pub(crate) fn table(curves: &AxisCurves) -> Vec<CompLine> {
    let n = curves.positions.len();
    let picks: Vec<usize> = if n <= COMP_FILE_MAX_LINES {
        (0..n).collect()
    } else {
        let last = COMP_FILE_MAX_LINES - 1;
        (0..COMP_FILE_MAX_LINES)
            .map(|k| (k * (n - 1) + last / 2) / last)
            .collect()
    };
    let both = curves.curve(Motion::along(curves.axis));
    let up = curves.positioning_up.as_deref().unwrap_or(both);
    let down = curves.positioning_down.as_deref().unwrap_or(both);
    picks
        .into_iter()
        .map(|k| {
            let q = curves.positions[k];
            CompLine {
                nominal: q,
                forward: q + up[k],
                reverse: q + down[k],
            }
        })
        .collect()
}

/// Whether the table of `curves` has separate forward and reverse values.
pub(crate) fn bidirectional(curves: &AxisCurves) -> bool {
    curves.positioning_up.is_some() || curves.positioning_down.is_some()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volumetric::curves::MeasuredAxis;
    use formats::Axis;

    #[test]
    fn long_curves_are_thinned_keeping_the_ends() {
        let n = 1000;
        let rows: Vec<[f64; 7]> = (0..n)
            .map(|k| {
                let q = k as f64 * 0.5;
                [q, 1e-6 * q, 0.0, 0.0, 0.0, 0.0, 0.0]
            })
            .collect();
        let c = AxisCurves::new(MeasuredAxis::from_rows(Axis::X, &rows))
            .unwrap_or_else(|e| panic!("{e}"));
        let t = table(&c);
        assert_eq!(t.len(), COMP_FILE_MAX_LINES);
        assert_eq!(t[0].nominal, 0.0);
        assert_eq!(t[t.len() - 1].nominal, 499.5);
        assert!(t.windows(2).all(|w| w[1].nominal > w[0].nominal));
        // (q + e) − q loses the last bits of q ≈ 500 mm: 1e-12 mm.
        assert!(
            t.iter()
                .all(|l| (l.forward - l.nominal - 1e-6 * l.nominal).abs() < 1e-12)
        );
        assert!(!bidirectional(&c));
    }
}
