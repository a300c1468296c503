//! Files of `trinocular probe indexing` (docs/probe-indexing.md): the measured
//! reference-sphere centre per head position `centres.csv`, the result
//! `indexing.csv`, and the generator's `truth.json`.

pub mod report;

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::row_error;
use crate::table::{Invalid, Record, Row, finite, read_csv};
use crate::{FormatError, Result};

/// Largest coordinate accepted in mm: no CMM is 100 m long, so a larger value
/// is a file in µm.
pub const MAX_COORDINATE_MM: f64 = 1.0e5;

/// Largest distance of a centre from the centres' mean (mm): a probe head's
/// stylus with its extensions is far shorter than a metre, so centres spread
/// wider are in µm.
pub const MAX_SPREAD_MM: f64 = 1.0e3;

/// One row of `centres.csv`: the reference-sphere centre the CMM reported
/// with the head at (A, B).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CentreRow {
    /// Commanded A (degrees).
    pub a_deg: f64,
    /// Commanded B (degrees).
    pub b_deg: f64,
    /// Centre x (mm, machine frame).
    pub x: f64,
    /// Centre y (mm).
    pub y: f64,
    /// Centre z (mm).
    pub z: f64,
}

impl Record for CentreRow {
    const COLUMNS: &'static [&'static str] = &["a_deg", "b_deg", "x", "y", "z"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("a_deg", self.a_deg)?;
        finite("b_deg", self.b_deg)?;
        for (column, value) in [("x", self.x), ("y", self.y), ("z", self.z)] {
            finite(column, value)?;
            if value.abs() > MAX_COORDINATE_MM {
                return Err(Invalid::new(
                    column,
                    format!(
                        "{value} mm is beyond {} m: are the centres in µm? the file wants mm",
                        MAX_COORDINATE_MM / 1000.0
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Read `centres.csv`: every row checked, then the spread of the centres
/// (values in µm instead of mm). The head positions' own checks (duplicates,
/// the B turn at A = 0°, the B = 0° sweep) are `probe::indexing::layout`'s.
pub fn read_centres(path: &Path) -> Result<Vec<Row<CentreRow>>> {
    let rows: Vec<Row<CentreRow>> = read_csv(path)?;
    if rows.is_empty() {
        return Err(FormatError::file(path, "no data rows"));
    }
    let n = rows.len() as f64;
    let mean = rows.iter().fold([0.0; 3], |m, r| {
        [
            m[0] + r.record.x / n,
            m[1] + r.record.y / n,
            m[2] + r.record.z / n,
        ]
    });
    let offset = |r: &CentreRow| [r.x - mean[0], r.y - mean[1], r.z - mean[2]];
    let distance = |r: &CentreRow| offset(r).iter().map(|d| d * d).sum::<f64>().sqrt();
    if let Some(far) = rows
        .iter()
        .max_by(|p, q| distance(&p.record).total_cmp(&distance(&q.record)))
        && distance(&far.record) > MAX_SPREAD_MM
    {
        let d = offset(&far.record);
        let column = ["x", "y", "z"]
            .into_iter()
            .zip(d)
            .max_by(|p, q| p.1.abs().total_cmp(&q.1.abs()))
            .map_or("x", |p| p.0);
        return Err(row_error(
            path,
            far.line,
            column,
            format!(
                "this centre is {:.0} mm from the mean of all centres, but a probe head's \
                 stylus is shorter than {MAX_SPREAD_MM} mm: are the centres in µm? the file wants mm",
                distance(&far.record)
            ),
        ));
    }
    Ok(rows)
}

/// One row of `indexing.csv`: the absolute angles and indexing errors of one
/// head position, with their standard uncertainties.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IndexingRow {
    /// Commanded A (degrees).
    pub a_deg: f64,
    /// Commanded B (degrees).
    pub b_deg: f64,
    /// θA = arccos n (degrees).
    pub theta_a_deg: f64,
    /// θB = atan2(m, l) (degrees).
    pub theta_b_deg: f64,
    /// ΔθA = θA − A (arc-seconds).
    #[serde(rename = "dA_arcsec")]
    pub d_a_arcsec: f64,
    /// ΔθB = wrap(θB − B) (arc-seconds); empty at A = 0°.
    #[serde(rename = "dB_arcsec")]
    pub d_b_arcsec: Option<f64>,
    /// Standard uncertainty of ΔθA (arc-seconds).
    #[serde(rename = "u_dA_arcsec")]
    pub u_d_a_arcsec: f64,
    /// Standard uncertainty of ΔθB (arc-seconds); empty at A = 0°.
    #[serde(rename = "u_dB_arcsec")]
    pub u_d_b_arcsec: Option<f64>,
    /// The centre's distance from O minus the radius (µm).
    pub residual_um: f64,
}

impl Record for IndexingRow {
    const COLUMNS: &'static [&'static str] = &[
        "a_deg",
        "b_deg",
        "theta_a_deg",
        "theta_b_deg",
        "dA_arcsec",
        "dB_arcsec",
        "u_dA_arcsec",
        "u_dB_arcsec",
        "residual_um",
    ];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        finite("a_deg", self.a_deg)?;
        finite("b_deg", self.b_deg)?;
        finite("theta_a_deg", self.theta_a_deg)?;
        finite("theta_b_deg", self.theta_b_deg)?;
        finite("dA_arcsec", self.d_a_arcsec)?;
        finite("u_dA_arcsec", self.u_d_a_arcsec)?;
        finite("residual_um", self.residual_um)?;
        if let Some(v) = self.d_b_arcsec {
            finite("dB_arcsec", v)?;
        }
        if let Some(v) = self.u_d_b_arcsec {
            finite("u_dB_arcsec", v)?;
        }
        Ok(())
    }
}

/// The columns of [`IndexingTruth::truth`].
pub const TRUTH_COLUMNS: [&str; 4] = ["a_deg", "b_deg", "dA_arcsec", "dB_arcsec"];

/// `truth.json` of `trinocular synth probe indexing`: the injected indexing
/// errors per position (`dB_arcsec` null at A = 0°) and the true head.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IndexingTruth {
    /// [`TRUTH_COLUMNS`].
    pub columns: Vec<String>,
    /// `[a_deg, b_deg, dA_arcsec, dB_arcsec]` per position, in the order of `centres.csv`.
    pub truth: Vec<(f64, f64, f64, Option<f64>)>,
    /// The true head, when the generator knows it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub head: Option<TrueHead>,
    /// The generator's configuration, as it ran.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<serde_json::Value>,
}

/// The true geometry of a generated head.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrueHead {
    /// O, the rotation centre as the CMM reports it (mm).
    pub rotation_centre: [f64; 3],
    /// Head-centre-to-stylus-ball length (mm).
    pub radius_mm: f64,
    /// The B axis (unit vector, machine frame), pointing from O towards the
    /// A = 0° centres.
    pub b_axis: [f64; 3],
    /// The A axis (unit vector): the §3 y axis of the true head.
    pub a_axis: [f64; 3],
    /// Noise of each reported coordinate (µm, standard deviation).
    pub noise_um: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::probe::assert_mentions;
    use crate::table::read_csv_from;

    #[test]
    fn micrometres_are_refused_per_value() {
        let text = "a_deg,b_deg,x,y,z\n0,0,1,2,3\n0,90,412300.2,-218900.0,-305200.0\n";
        let e = read_csv_from::<CentreRow, _>(text.as_bytes(), Path::new("c.csv"))
            .unwrap_err()
            .to_string();
        assert_mentions(&e, &["c.csv: line 3, column 'x'", "µm"]);
    }

    #[test]
    fn micrometres_are_refused_by_spread() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.csv");
        // A 117 mm head written in µm near the origin: every value below the
        // per-value limit, the spread 117 000.
        std::fs::write(
            &path,
            "a_deg,b_deg,x,y,z\n0,0,0,0,58500\n90,0,58500,0,0\n90,180,-40000,0,0\n",
        )
        .unwrap();
        let e = read_centres(&path).unwrap_err().to_string();
        assert_mentions(&e, &["line 3, column 'x'", "µm"]);
    }

    #[test]
    fn empty_b_error_is_written_empty() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("i.csv");
        let row = IndexingRow {
            a_deg: 0.0,
            b_deg: 7.5,
            theta_a_deg: 1e-4,
            theta_b_deg: 12.0,
            d_a_arcsec: 0.36,
            d_b_arcsec: None,
            u_d_a_arcsec: 0.5,
            u_d_b_arcsec: None,
            residual_um: 0.1,
        };
        crate::write_records(&path, &[row]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(
            text,
            "a_deg,b_deg,theta_a_deg,theta_b_deg,dA_arcsec,dB_arcsec,u_dA_arcsec,u_dB_arcsec,residual_um\n\
             0.0,7.5,0.0001,12.0,0.36,,0.5,,0.1\n"
        );
        let back: Vec<Row<IndexingRow>> = read_csv(&path).unwrap();
        assert_eq!(back[0].record, row);
    }

    #[test]
    fn truth_of_the_check_data_form_reads() {
        let text = r#"{"columns": ["a_deg", "b_deg", "dA_arcsec", "dB_arcsec"],
                       "truth": [[0.0, -180.0, 0.0, null], [7.5, 0.0, 0.81, 0.0]]}"#;
        let t: IndexingTruth = serde_json::from_str(text).unwrap();
        assert_eq!(t.truth[0].3, None);
        assert_eq!(t.truth[1], (7.5, 0.0, 0.81, Some(0.0)));
        assert!(t.head.is_none());
    }
}
