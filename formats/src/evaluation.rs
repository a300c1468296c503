//! `report.json` of `trinocular evaluate` (docs/formats.md; µm, µrad), with
//! extra keys for the per-target tables and plots: the file's types, filled
//! by the `evaluate` crate, and the report's CSV tables ([`write_tables`]).
//!
//! Figures of an axis or direction not present in the data are `None` and
//! left out of the JSON, never zero-filled.

use serde::Serialize;

mod tables;

pub use tables::write_tables;

/// Key names of the angular convention, written into every angular report.
pub const ANGULAR_CONVENTION: &str = "rotation vector of the table's rigid motion from the first target \
     (Kabsch fit of the spheres' mean centres), world axes: X axis roll=εx pitch=εy yaw=εz; \
     Y axis roll=εy pitch=εx yaw=εz; Z axis roll=εz pitch=εx yaw=εy; right-handed, µrad";

/// Everything `evaluate` found: per axis, flatness, and what it was computed from.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// Per-axis figures (`axes.X`, `axes.Y`, `axes.Z`).
    pub axes: Axes,
    /// Flatness of the combined X- and Y-run points; absent when they do not span a plane.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flatness: Option<FlatnessReport>,
    /// Name of the sphere that carries positioning, straightness and flatness.
    pub sphere: String,
    /// Every sphere name in the points, in order of first appearance.
    pub spheres: Vec<String>,
    /// Where the points came from (file name, or `points`).
    pub source: String,
    /// Number of point rows evaluated.
    pub rows: usize,
    /// Conventions of the figures (units, datum, angular convention).
    pub conventions: Vec<String>,
    /// Things worth knowing that did not stop the evaluation (e.g. angular
    /// errors left out because a sphere is missing).
    pub warnings: Vec<String>,
    /// How the figures' expanded uncertainties were found, or why there are
    /// none (docs/uncertainty.md); each figure's U is written beside it
    /// (`A_U_um`). Absent when not asked for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<crate::uncertainty::Uncertainty>,
    /// The figures before the correction to 20 °C, by path; present when
    /// the conditions asked for one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub uncorrected: Option<std::collections::BTreeMap<String, f64>>,
    /// What the correction to 20 °C did, in words (ISO 230-2 §3.2, 5.3;
    /// also among the conventions); present when the conditions asked for
    /// one, and said beside the results on the page and the terminal.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub correction: Option<String>,
    /// The test conditions, decisions and verdict (`--conditions`,
    /// `--tolerances`).
    #[serde(flatten)]
    pub signoff: crate::conformance::SignOff,
}

impl Report {
    /// U (k = 2) of the figure at `path` (`axes.X.positioning.A_um`), when given.
    pub fn expanded(&self, path: &str) -> Option<f64> {
        self.uncertainty.as_ref().and_then(|u| u.of(path))
    }
}

/// The axes present in the data.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Axes {
    /// X axis, when measured.
    #[serde(rename = "X", skip_serializing_if = "Option::is_none")]
    pub x: Option<AxisReport>,
    /// Y axis, when measured.
    #[serde(rename = "Y", skip_serializing_if = "Option::is_none")]
    pub y: Option<AxisReport>,
    /// Z axis, when measured.
    #[serde(rename = "Z", skip_serializing_if = "Option::is_none")]
    pub z: Option<AxisReport>,
}

impl Axes {
    /// The report of one axis.
    pub fn get(&self, axis: crate::Axis) -> Option<&AxisReport> {
        match axis {
            crate::Axis::X => self.x.as_ref(),
            crate::Axis::Y => self.y.as_ref(),
            crate::Axis::Z => self.z.as_ref(),
        }
    }

    /// Mutable slot of one axis.
    pub fn slot(&mut self, axis: crate::Axis) -> &mut Option<AxisReport> {
        match axis {
            crate::Axis::X => &mut self.x,
            crate::Axis::Y => &mut self.y,
            crate::Axis::Z => &mut self.z,
        }
    }

    /// The axes present, in order X, Y, Z.
    pub fn iter(&self) -> impl Iterator<Item = (crate::Axis, &AxisReport)> {
        [crate::Axis::X, crate::Axis::Y, crate::Axis::Z]
            .into_iter()
            .filter_map(|a| self.get(a).map(|r| (a, r)))
    }
}

/// One axis: the figures of its main line (the one with the most runs; tie:
/// nearest the origin) flattened in, and every line in `lines`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisReport {
    /// The main line's figures (`axes.X.positioning`, …).
    #[serde(flatten)]
    pub main: LineReport,
    /// Every line the axis was swept along, the main one included.
    pub lines: Vec<LineReport>,
}

/// Figures of one line: one sweep of an axis at fixed off-axis nominal coordinates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LineReport {
    /// Index of this line in `lines` (ordered by off-axis coordinates).
    pub line: usize,
    /// The off-axis nominal coordinates (mm), keyed `x`/`y`/`z`.
    pub off_axis: std::collections::BTreeMap<String, f64>,
    /// Number of targets.
    pub targets: usize,
    /// Fitted axis direction (unit vector, world frame) through the per-target mean positions.
    pub direction: [f64; 3],
    /// Positioning (ISO 230-2, the 3σ band, optional VDI/DGQ 3441).
    pub positioning: PositioningReport,
    /// Straightness in the two directions perpendicular to the axis, keyed
    /// by world axis; empty when the line has too few targets
    /// (`straightness_left_out`).
    pub straightness: std::collections::BTreeMap<String, StraightnessReport>,
    /// Why the line has no straightness (a line of two targets: the
    /// reference line passes through both); absent when it has.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub straightness_left_out: Option<String>,
    /// Roll, pitch and yaw, when the points carry three spheres at every target.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub angular: Option<AngularReport>,
}

/// Positioning figures of a line (µm), ISO 230-2 names.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PositioningReport {
    /// What of ISO 230-2 is left out of this line and why (fewer than 2 runs
    /// of a direction at a target, or one direction only); absent when every
    /// figure is given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_out: Option<String>,
    /// Bidirectional accuracy A = max(x̄ + 2s) − min(x̄ − 2s) over both directions.
    #[serde(rename = "A_um", skip_serializing_if = "Option::is_none")]
    pub a_um: Option<f64>,
    /// Unidirectional accuracy A↑.
    #[serde(rename = "A_up_um", skip_serializing_if = "Option::is_none")]
    pub a_up_um: Option<f64>,
    /// Unidirectional accuracy A↓.
    #[serde(rename = "A_down_um", skip_serializing_if = "Option::is_none")]
    pub a_down_um: Option<f64>,
    /// Bidirectional systematic positional deviation E = max(x̄↑, x̄↓) − min(x̄↑, x̄↓).
    #[serde(rename = "E_um", skip_serializing_if = "Option::is_none")]
    pub e_um: Option<f64>,
    /// Unidirectional systematic positional deviation E↑ = max x̄↑ − min x̄↑.
    #[serde(rename = "E_up_um", skip_serializing_if = "Option::is_none")]
    pub e_up_um: Option<f64>,
    /// Unidirectional systematic positional deviation E↓.
    #[serde(rename = "E_down_um", skip_serializing_if = "Option::is_none")]
    pub e_down_um: Option<f64>,
    /// Mean bidirectional positional deviation M = max x̄ − min x̄.
    #[serde(rename = "M_um", skip_serializing_if = "Option::is_none")]
    pub m_um: Option<f64>,
    /// Bidirectional repeatability R = max Rᵢ.
    #[serde(rename = "R_um", skip_serializing_if = "Option::is_none")]
    pub r_um: Option<f64>,
    /// Unidirectional repeatability R↑ = max 4sᵢ↑.
    #[serde(rename = "R_up_um", skip_serializing_if = "Option::is_none")]
    pub r_up_um: Option<f64>,
    /// Unidirectional repeatability R↓ = max 4sᵢ↓.
    #[serde(rename = "R_down_um", skip_serializing_if = "Option::is_none")]
    pub r_down_um: Option<f64>,
    /// Reversal value B = max |Bᵢ|.
    #[serde(rename = "B_um", skip_serializing_if = "Option::is_none")]
    pub b_um: Option<f64>,
    /// Mean reversal value B̄ = mean Bᵢ.
    #[serde(rename = "B_mean_um", skip_serializing_if = "Option::is_none")]
    pub b_mean_um: Option<f64>,
    /// The source method's 3σ band: max(x̄ₖ + 3sₖ) − min(x̄ₖ − 3sₖ) over all measurements
    /// per target; given with ISO 230-2 figures of at least one direction.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed_3sigma_um: Option<f64>,
    /// Runs in the ↑ direction (0 when absent).
    pub runs_up: usize,
    /// Runs in the ↓ direction (0 when absent).
    pub runs_down: usize,
    /// Per-target table.
    pub targets: Vec<PositioningTarget>,
    /// VDI/DGQ 3441 figures, when asked for and both directions are present.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vdi3441: Option<Vdi3441Report>,
}

impl PositioningReport {
    /// A, E and R as a summary shows them, each with its report key: the
    /// bidirectional figure, else that of the one direction ISO 230-2 could
    /// evaluate (↑ before ↓).
    pub fn shown_a_e_r(&self) -> [(Option<f64>, &'static str); 3] {
        let pick = |both: Option<f64>,
                    up: Option<f64>,
                    down: Option<f64>,
                    keys: [&'static str; 3]| {
            match (both, up) {
                (Some(v), _) => (Some(v), keys[0]),
                (None, Some(v)) => (Some(v), keys[1]),
                (None, None) => (down, keys[2]),
            }
        };
        [
            pick(
                self.a_um,
                self.a_up_um,
                self.a_down_um,
                ["A_um", "A_up_um", "A_down_um"],
            ),
            pick(
                self.e_um,
                self.e_up_um,
                self.e_down_um,
                ["E_um", "E_up_um", "E_down_um"],
            ),
            pick(
                self.r_um,
                self.r_up_um,
                self.r_down_um,
                ["R_um", "R_up_um", "R_down_um"],
            ),
        ]
    }
}

/// One target of the positioning table (µm; `nominal` in mm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PositioningTarget {
    /// Target index.
    pub target: u32,
    /// Commanded coordinate of the moving axis (mm).
    pub nominal: f64,
    /// Mean unidirectional positional deviation x̄ᵢ↑.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_up_um: Option<f64>,
    /// Mean unidirectional positional deviation x̄ᵢ↓.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_down_um: Option<f64>,
    /// Unidirectional standard uncertainty sᵢ↑ (n − 1 divisor).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub s_up_um: Option<f64>,
    /// Unidirectional standard uncertainty sᵢ↓.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub s_down_um: Option<f64>,
    /// Reversal value Bᵢ = x̄ᵢ↑ − x̄ᵢ↓.
    #[serde(rename = "B_um", skip_serializing_if = "Option::is_none")]
    pub b_um: Option<f64>,
    /// Mean bidirectional positional deviation x̄ᵢ = (x̄ᵢ↑ + x̄ᵢ↓)/2.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_um: Option<f64>,
    /// Unidirectional repeatability Rᵢ↑ = 4sᵢ↑.
    #[serde(rename = "R_up_um", skip_serializing_if = "Option::is_none")]
    pub r_up_um: Option<f64>,
    /// Unidirectional repeatability Rᵢ↓ = 4sᵢ↓.
    #[serde(rename = "R_down_um", skip_serializing_if = "Option::is_none")]
    pub r_down_um: Option<f64>,
    /// Bidirectional repeatability Rᵢ = max(2sᵢ↑ + 2sᵢ↓ + |Bᵢ|, Rᵢ↑, Rᵢ↓).
    #[serde(rename = "R_um", skip_serializing_if = "Option::is_none")]
    pub r_um: Option<f64>,
    /// Deviation xᵢⱼ↑ of each ↑ run (captures averaged), in run order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub runs_up_um: Vec<f64>,
    /// Deviation xᵢⱼ↓ of each ↓ run, in run order.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub runs_down_um: Vec<f64>,
    /// Mean of every measurement at the target (all runs, directions,
    /// captures); given with the line's 3σ band.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed_mean_um: Option<f64>,
    /// Sample standard deviation of every measurement at the target; given
    /// with the line's 3σ band.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seed_s_um: Option<f64>,
}

/// VDI/DGQ 3441 (1977) figures (µm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Vdi3441Report {
    /// Positional uncertainty P = max(x̄ⱼ + (Uⱼ + Psⱼ)/2) − min(x̄ⱼ − (Uⱼ + Psⱼ)/2).
    #[serde(rename = "P_um")]
    pub p_um: f64,
    /// Largest positional scatter Ps = max Psⱼ, Psⱼ = 6·(sⱼ↑ + sⱼ↓)/2.
    #[serde(rename = "Ps_um")]
    pub ps_um: f64,
    /// Largest reversal span U = max |x̄ⱼ↑ − x̄ⱼ↓|.
    #[serde(rename = "U_um")]
    pub u_um: f64,
    /// Mean reversal span Ū = mean |x̄ⱼ↑ − x̄ⱼ↓|.
    #[serde(rename = "U_mean_um")]
    pub u_mean_um: f64,
    /// Position deviation Pa = max x̄ⱼ − min x̄ⱼ, x̄ⱼ = (x̄ⱼ↑ + x̄ⱼ↓)/2.
    #[serde(rename = "Pa_um")]
    pub pa_um: f64,
}

/// Straightness in one perpendicular direction (µm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StraightnessReport {
    /// Range (max − min) of the deviations from the least-squares reference line.
    pub lsq_um: f64,
    /// Minimum zone (ISO 12780): distance between the two closest parallel lines enclosing the profile.
    pub min_zone_um: f64,
    /// The profile, per target.
    pub targets: Vec<StraightnessTarget>,
}

/// One target of a straightness profile (µm; `nominal` in mm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StraightnessTarget {
    /// Target index.
    pub target: u32,
    /// Commanded coordinate of the moving axis (mm).
    pub nominal: f64,
    /// Deviation from the least-squares reference line.
    pub deviation_um: f64,
    /// Lower boundary of the minimum zone at this target, in the same reference.
    pub zone_low_um: f64,
    /// Upper boundary of the minimum zone at this target, in the same reference.
    pub zone_high_um: f64,
}

/// Angular errors of a line (µrad): ranges and the per-target values.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AngularReport {
    /// Range (max − min) of the roll over the targets.
    pub roll_urad: f64,
    /// Range of the pitch.
    pub pitch_urad: f64,
    /// Range of the yaw.
    pub yaw_urad: f64,
    /// Spheres used for the rigid fits.
    pub spheres: Vec<String>,
    /// RMS residual of the rigid fits (µm): how rigid the sphere triplet stayed.
    pub fit_rms_um: f64,
    /// Smallest principal lever of the sphere set (mm): the rotation error is
    /// ≈ position error / lever about the worst axis (`angular::lever`).
    pub lever_mm: f64,
    /// How roll, pitch and yaw are defined.
    pub convention: String,
    /// Per-target values relative to the first target.
    pub targets: Vec<AngularTarget>,
}

/// Roll, pitch, yaw at one target relative to the first target (µrad).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AngularTarget {
    /// Target index.
    pub target: u32,
    /// Commanded coordinate of the moving axis (mm).
    pub nominal: f64,
    /// Rotation about the moving axis.
    pub roll_urad: f64,
    /// Pitch (see the convention).
    pub pitch_urad: f64,
    /// Yaw (see the convention).
    pub yaw_urad: f64,
}

/// Flatness of the combined X- and Y-run points (µm).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlatnessReport {
    /// Range of the vertical deviations from the least-squares plane z = aX + bY + c.
    pub lsq_um: f64,
    /// Minimum zone: distance between the two closest parallel planes enclosing the points (vertical).
    pub min_zone_um: f64,
    /// Least-squares plane: slope a = ∂z/∂x.
    pub a: f64,
    /// Least-squares plane: slope b = ∂z/∂y.
    pub b: f64,
    /// Least-squares plane: height c at x = y = 0 (mm).
    pub c: f64,
    /// The points (per-target mean centres of the sphere), with their deviations.
    pub points: Vec<FlatnessPoint>,
}

/// One point of the flatness cloud.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlatnessPoint {
    /// Axis of the run it comes from.
    pub axis: String,
    /// Line index within that axis.
    pub line: usize,
    /// Target index.
    pub target: u32,
    /// Measured x (mm).
    pub x: f64,
    /// Measured y (mm).
    pub y: f64,
    /// Measured z (mm).
    pub z: f64,
    /// Vertical deviation from the least-squares plane.
    pub lsq_um: f64,
    /// Vertical deviation from the centre plane of the minimum zone.
    pub min_zone_um: f64,
}
