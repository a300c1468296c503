//! The motion program and what `trinocular manifest` reports: the
//! `[procedure]` table shared by the renderer's configuration and a user's
//! `program.toml` (one record, same keys and meaning), the ISO 230-2 linear
//! cycle it describes as a sequence of dwells with their programmed times,
//! and the rows of the `<stem>.problems.csv` written beside a built manifest.
//!
//! The cycle (ISO 230-2 §4.3, linear test cycle): per axis, per line, per
//! run, go to the first target minus the overshoot and approach every target
//! upward (+), then go past the last target by the overshoot and approach
//! every target downward (−). At each target the machine settles for
//! `settle_s`, then `captures` frames are taken `1/fps` apart.

use geom::nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use crate::campaign::{Axis, Direction};
use crate::table::{Invalid, Record};

/// The measurement procedure (ISO 230-2 linear test cycle): the `[procedure]`
/// table of the renderer's configuration and of `program.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProcedureConfig {
    /// Axes to test, in order.
    pub axes: Vec<AxisProcedure>,
    /// Runs (each run approaches every target once in + and once in −).
    pub runs: u32,
    /// Frames captured at each target per approach.
    pub captures: u32,
    /// Overshoot beyond the end targets before reversing (mm), taking up backlash.
    pub overshoot_mm: f64,
    /// Frame rate of the captures at one target (frames per second).
    pub fps: f64,
    /// Feed rate between targets (mm/s), for the time stamps.
    pub feed_mm_per_s: f64,
    /// Dwell after arriving at a target before the first capture (s).
    pub settle_s: f64,
    /// Date and time of the campaign start, `YYYY-MM-DDTHH:MM:SS[.fff]`.
    pub start_time: String,
}

/// The targets and lines of one axis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AxisProcedure {
    /// Axis moved: X or Y.
    pub axis: Axis,
    /// First target (commanded position, mm).
    pub start_mm: f64,
    /// Travel from the first to the last target (mm).
    pub length_mm: f64,
    /// Number of segments; there are `segments + 1` equally spaced targets.
    pub segments: u32,
    /// Lines: commanded position of the other horizontal axis during the
    /// sweeps (Y for an X sweep, X for a Y sweep), mm; one sweep set per line.
    pub lines_mm: Vec<f64>,
}

impl Default for AxisProcedure {
    fn default() -> Self {
        Self {
            axis: Axis::X,
            start_mm: 0.0,
            length_mm: 100.0,
            segments: 10,
            lines_mm: vec![0.0],
        }
    }
}

impl AxisProcedure {
    /// Number of targets.
    pub fn targets(&self) -> u32 {
        self.segments + 1
    }

    /// Commanded position of target `k` (mm).
    pub fn target_position(&self, k: u32) -> f64 {
        self.start_mm + self.length_mm * f64::from(k) / f64::from(self.segments.max(1))
    }
}

impl Default for ProcedureConfig {
    /// The seed's procedure.
    fn default() -> Self {
        Self {
            axes: vec![
                AxisProcedure {
                    axis: Axis::X,
                    start_mm: -75.0,
                    length_mm: 150.0,
                    segments: 50,
                    lines_mm: vec![0.0, 10.0],
                },
                AxisProcedure {
                    axis: Axis::Y,
                    start_mm: -50.0,
                    length_mm: 100.0,
                    segments: 10,
                    lines_mm: vec![0.0],
                },
            ],
            runs: 5,
            captures: 10,
            overshoot_mm: 10.0,
            fps: 180.0,
            feed_mm_per_s: 20.0,
            settle_s: 0.3,
            start_time: "2025-06-02T08:00:00".into(),
        }
    }
}

/// Most instants a campaign may have (≈ 90 times the seed's 11 300): the
/// list of instants and their positions is held in memory.
pub const MAX_INSTANTS: usize = 1_000_000;

/// A value of the procedure that breaks its rules: the key (as
/// `procedure.axes[0].segments`) and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct InvalidKey {
    /// The key at fault.
    pub key: String,
    /// What is wrong with its value.
    pub message: String,
}

fn bad(key: &str, message: impl Into<String>) -> InvalidKey {
    InvalidKey {
        key: key.to_string(),
        message: message.into(),
    }
}

fn positive(key: &str, v: f64) -> Result<(), InvalidKey> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("{v} must be a positive number")))
    }
}

fn non_negative(key: &str, v: f64) -> Result<(), InvalidKey> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(key, format!("{v} must be a finite number ≥ 0")))
    }
}

fn finite(key: &str, values: &[f64]) -> Result<(), InvalidKey> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(bad(key, format!("{v} is not a finite number"))),
        None => Ok(()),
    }
}

/// One stop of the machine at a target: the cameras take `captures` frames there.
#[derive(Debug, Clone, PartialEq)]
pub struct Dwell {
    /// Position in the program (0-based).
    pub index: usize,
    /// Axis moved.
    pub axis: Axis,
    /// Line index (into the axis' `lines_mm`).
    pub line: u32,
    /// Run (≥ 1).
    pub run: u32,
    /// Approach direction.
    pub direction: Direction,
    /// Target index (≥ 0).
    pub target: u32,
    /// Commanded position (mm).
    pub nominal: [f64; 3],
    /// Commanded points the machine moves through from the previous dwell,
    /// in order, ending at `nominal` (the overshoot point first when the
    /// dwell starts a pass; for the program's first dwell the overshoot point
    /// is where the machine starts).
    pub path: Vec<[f64; 3]>,
    /// Programmed time of the first capture (s from the program start): every
    /// move at `feed_mm_per_s`, then `settle_s`; the captures of a dwell are
    /// `1/fps` apart and the machine leaves after the last one's period.
    pub time_s: f64,
}

impl ProcedureConfig {
    /// Check every value except `start_time` (a calendar matter of the
    /// renderer); the error names the key.
    pub fn validate(&self) -> Result<(), InvalidKey> {
        if self.runs < 1 {
            return Err(bad("procedure.runs", "at least one run is needed"));
        }
        if self.captures < 1 {
            return Err(bad("procedure.captures", "at least one capture is needed"));
        }
        non_negative("procedure.overshoot_mm", self.overshoot_mm)?;
        positive("procedure.fps", self.fps)?;
        positive("procedure.feed_mm_per_s", self.feed_mm_per_s)?;
        non_negative("procedure.settle_s", self.settle_s)?;
        for (i, a) in self.axes.iter().enumerate() {
            let key = format!("procedure.axes[{i}]");
            if a.axis == Axis::Z {
                return Err(bad(&format!("{key}.axis"), "only X and Y are moved"));
            }
            if self.axes[..i].iter().any(|o| o.axis == a.axis) {
                return Err(bad(
                    &format!("{key}.axis"),
                    format!("axis {} listed twice", a.axis),
                ));
            }
            finite(&format!("{key}.start_mm"), &[a.start_mm])?;
            positive(&format!("{key}.length_mm"), a.length_mm)?;
            if a.segments < 1 {
                return Err(bad(
                    &format!("{key}.segments"),
                    "at least one segment is needed",
                ));
            }
            if a.lines_mm.is_empty() {
                return Err(bad(
                    &format!("{key}.lines_mm"),
                    "at least one line is needed",
                ));
            }
            finite(&format!("{key}.lines_mm"), &a.lines_mm)?;
        }
        // Counts multiply into the list of instants held in memory: checked
        // before anything is sized from them.
        let instants: u128 = self
            .axes
            .iter()
            .map(|a| {
                a.lines_mm.len() as u128
                    * (u128::from(a.segments) + 1)
                    * 2
                    * u128::from(self.runs)
                    * u128::from(self.captures)
            })
            .sum();
        if instants > MAX_INSTANTS as u128 {
            return Err(bad(
                "procedure",
                format!(
                    "lines × (segments + 1) × 2 directions × runs × captures = {instants} instants, \
                     more than {MAX_INSTANTS} (the seed's campaign has 11300)"
                ),
            ));
        }
        Ok(())
    }

    /// Every dwell of the program in the order the machine runs it, with its
    /// programmed time. Axis Z (never moved) has none.
    pub fn dwells(&self) -> Vec<Dwell> {
        let mut dwells = Vec::new();
        let mut time = 0.0;
        let mut at: Option<[f64; 3]> = None;
        for travel in &self.axes {
            let axis = travel.axis;
            let other = match axis {
                Axis::X => Axis::Y,
                Axis::Y => Axis::X,
                Axis::Z => continue,
            };
            let targets: Vec<f64> = (0..travel.targets())
                .map(|k| travel.target_position(k))
                .collect();
            let (Some(&first), Some(&last)) = (targets.first(), targets.last()) else {
                continue;
            };
            for (line, &offset) in travel.lines_mm.iter().enumerate() {
                let position = |q: f64| {
                    let mut n = [0.0; 3];
                    n[axis.index()] = q;
                    n[other.index()] = offset;
                    n
                };
                for run in 1..=self.runs {
                    for direction in [Direction::Up, Direction::Down] {
                        let (approach, order): (f64, Vec<u32>) = match direction {
                            Direction::Up => {
                                (first - self.overshoot_mm, (0..travel.targets()).collect())
                            }
                            Direction::Down => (
                                last + self.overshoot_mm,
                                (0..travel.targets()).rev().collect(),
                            ),
                        };
                        let mut path = vec![position(approach)];
                        for k in order {
                            let nominal = position(targets[k as usize]);
                            path.push(nominal);
                            for &to in &path {
                                if let Some(from) = at {
                                    let d = Vector3::from(to) - Vector3::from(from);
                                    time += d.norm() / self.feed_mm_per_s;
                                }
                                at = Some(to);
                            }
                            time += self.settle_s;
                            dwells.push(Dwell {
                                index: dwells.len(),
                                axis,
                                line: line as u32,
                                run,
                                direction,
                                target: k,
                                nominal,
                                path: std::mem::take(&mut path),
                                time_s: time,
                            });
                            for _ in 0..self.captures {
                                time += 1.0 / self.fps;
                            }
                        }
                    }
                }
            }
        }
        dwells
    }
}

/// One row of the `<stem>.problems.csv` that `trinocular manifest` writes beside the
/// manifest: a frame (or a camera, or an instant) it could not place, and
/// why. Columns that do not apply are empty.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestProblemRow {
    /// The image at fault, relative to the manifest (empty when no file is:
    /// a camera without frames, an instant a camera has no frame of).
    pub image: Option<String>,
    /// The camera's serial number, when known.
    pub serial: Option<String>,
    /// The camera number, when known.
    pub camera: Option<u8>,
    /// The frame's time stamp as the camera wrote it, when read.
    pub time: Option<String>,
    /// Axis of the instant concerned, when one is.
    pub axis: Option<Axis>,
    /// Approach direction of that instant.
    pub direction: Option<Direction>,
    /// Run of that instant.
    pub run: Option<u32>,
    /// Target of that instant.
    pub target: Option<u32>,
    /// Capture of that instant.
    pub capture: Option<u32>,
    /// What is wrong.
    pub reason: String,
}

impl Record for ManifestProblemRow {
    const COLUMNS: &'static [&'static str] = &[
        "image",
        "serial",
        "camera",
        "time",
        "axis",
        "direction",
        "run",
        "target",
        "capture",
        "reason",
    ];

    fn validate(&self) -> Result<(), Invalid> {
        if self.reason.trim().is_empty() {
            return Err(Invalid::new("reason", "empty reason"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small() -> ProcedureConfig {
        ProcedureConfig {
            axes: vec![AxisProcedure {
                axis: Axis::X,
                start_mm: 0.0,
                length_mm: 20.0,
                segments: 2,
                lines_mm: vec![5.0],
            }],
            runs: 1,
            captures: 2,
            overshoot_mm: 5.0,
            fps: 10.0,
            feed_mm_per_s: 10.0,
            settle_s: 0.5,
            start_time: String::new(),
        }
    }

    #[test]
    fn the_cycle_and_its_times() {
        let d = small().dwells();
        let order: Vec<(Direction, u32)> = d.iter().map(|d| (d.direction, d.target)).collect();
        assert_eq!(
            order,
            [
                (Direction::Up, 0),
                (Direction::Up, 1),
                (Direction::Up, 2),
                (Direction::Down, 2),
                (Direction::Down, 1),
                (Direction::Down, 0)
            ]
        );
        assert_eq!(d[1].nominal, [10.0, 5.0, 0.0]);
        // Start at x = −5: 5 mm at 10 mm/s, settle 0.5 s.
        assert!((d[0].time_s - 1.0).abs() < 1e-12);
        // Two captures at 10 fps (0.2 s), 10 mm, settle.
        assert!((d[1].time_s - (1.0 + 0.2 + 1.0 + 0.5)).abs() < 1e-12);
        // Reversal: 20 → 25 → 20 mm.
        assert_eq!(d[3].path, vec![[25.0, 5.0, 0.0], [20.0, 5.0, 0.0]]);
        assert!((d[3].time_s - d[2].time_s - (0.2 + 1.0 + 0.5)).abs() < 1e-12);
    }

    #[test]
    fn bad_values_are_named() {
        let mut p = small();
        p.axes[0].segments = 0;
        assert_eq!(p.validate().unwrap_err().key, "procedure.axes[0].segments");
        let mut p = small();
        p.fps = 0.0;
        assert_eq!(p.validate().unwrap_err().key, "procedure.fps");
        assert!(small().validate().is_ok());
    }
}
