//! The figures of an evaluation as `report.json` holds them (docs/formats.md),
//! and as `truth.json` holds the same evaluation on the exact positions under
//! its `figures` key: the part a summary reads (ISO 230-2 positioning values,
//! straightness, angular ranges and per-target angles, flatness). Other keys
//! are ignored; a figure written as `null` (not finite) reads as `None`.

use std::collections::BTreeMap;

use serde::Deserialize;

/// `report.json`'s figures (µm, µrad).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct ReportFigures {
    /// Axis name (`X`, `Y`, `Z`) → the figures of its main line.
    #[serde(default)]
    pub axes: BTreeMap<String, AxisFigures>,
    /// Flatness of the plane through the measured lines, when evaluated.
    #[serde(default)]
    pub flatness: Option<ZoneFigures>,
}

/// The figures of one axis's main line.
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct AxisFigures {
    /// ISO 230-2 positioning values.
    #[serde(default)]
    pub positioning: PositioningFigures,
    /// Direction (`X`, `Y`, `Z`) → straightness in it.
    #[serde(default)]
    pub straightness: BTreeMap<String, ZoneFigures>,
    /// Roll, pitch and yaw, when two spheres were measured.
    #[serde(default)]
    pub angular: Option<AngularFigures>,
}

/// ISO 230-2 positioning values of a line (µm).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct PositioningFigures {
    /// A: bidirectional accuracy.
    #[serde(rename = "A_um", default)]
    pub a_um: Option<f64>,
    /// E: bidirectional systematic deviation.
    #[serde(rename = "E_um", default)]
    pub e_um: Option<f64>,
    /// R: bidirectional repeatability.
    #[serde(rename = "R_um", default)]
    pub r_um: Option<f64>,
    /// B: reversal value.
    #[serde(rename = "B_um", default)]
    pub b_um: Option<f64>,
    /// M: mean bidirectional deviation.
    #[serde(rename = "M_um", default)]
    pub m_um: Option<f64>,
    /// 3σ of the seed positioning error.
    #[serde(default)]
    pub seed_3sigma_um: Option<f64>,
}

/// A deviation zone: least-squares and minimum-zone widths (µm).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct ZoneFigures {
    /// Width about the least-squares reference.
    #[serde(default)]
    pub lsq_um: Option<f64>,
    /// Minimum-zone width.
    #[serde(default)]
    pub min_zone_um: Option<f64>,
}

/// Roll, pitch and yaw of a line (µrad).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct AngularFigures {
    /// Ranges of roll, pitch and yaw over the line.
    #[serde(flatten)]
    pub range: RollPitchYaw,
    /// The angles at each target, in target order.
    #[serde(default)]
    pub targets: Vec<RollPitchYaw>,
}

/// Roll, pitch and yaw (µrad).
#[derive(Debug, Clone, Default, PartialEq, Deserialize)]
pub struct RollPitchYaw {
    /// Roll.
    #[serde(default)]
    pub roll_urad: Option<f64>,
    /// Pitch.
    #[serde(default)]
    pub pitch_urad: Option<f64>,
    /// Yaw.
    #[serde(default)]
    pub yaw_urad: Option<f64>,
}

impl RollPitchYaw {
    /// Roll, pitch and yaw, in that order.
    pub fn angles(&self) -> [Option<f64>; 3] {
        [self.roll_urad, self.pitch_urad, self.yaw_urad]
    }

    /// One of them by its key (`roll_urad`, `pitch_urad`, `yaw_urad`).
    pub fn get(&self, key: &str) -> Option<f64> {
        match key {
            "roll_urad" => self.roll_urad,
            "pitch_urad" => self.pitch_urad,
            "yaw_urad" => self.yaw_urad,
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_read_from_a_report_shape() {
        let json = r#"{"axes": {"X": {"line": 1, "positioning": {"A_um": 3.5, "E_um": null,
            "runs_up": 3}, "straightness": {"Y": {"lsq_um": 1.0, "min_zone_um": 0.9,
            "targets": []}}, "angular": {"roll_urad": 2.0, "pitch_urad": 1.0,
            "yaw_urad": 0.5, "targets": [{"target": 1, "roll_urad": 0.1,
            "pitch_urad": 0.2, "yaw_urad": 0.3}]}}}, "flatness": {"lsq_um": 4.0,
            "min_zone_um": 3.0}, "sphere": "A"}"#;
        let f: ReportFigures = serde_json::from_str(json).unwrap();
        let x = &f.axes["X"];
        assert_eq!(x.positioning.a_um, Some(3.5));
        assert_eq!(x.positioning.e_um, None);
        assert_eq!(x.straightness["Y"].min_zone_um, Some(0.9));
        let a = x.angular.as_ref().unwrap();
        assert_eq!(a.range.get("yaw_urad"), Some(0.5));
        assert_eq!(a.targets[0].angles(), [Some(0.1), Some(0.2), Some(0.3)]);
        assert_eq!(f.flatness.unwrap().lsq_um, Some(4.0));
    }
}
