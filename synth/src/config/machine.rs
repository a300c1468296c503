//! The `[machine]` table: the injected errors of each moving axis and the
//! curve every error follows.

use std::collections::BTreeMap;

use formats::Axis;
use serde::{Deserialize, Serialize};

use super::check::{bad, finite, non_negative, positive};
use crate::Result;

/// Injected errors of the moving axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MachineConfig {
    /// Errors of the X axis, as functions of the commanded x.
    #[serde(rename = "X")]
    pub x: AxisErrors,
    /// Errors of the Y axis, as functions of the commanded y.
    #[serde(rename = "Y")]
    pub y: AxisErrors,
}

impl MachineConfig {
    /// The errors of `axis` (Z does not move: none).
    pub fn axis(&self, axis: Axis) -> Option<&AxisErrors> {
        match axis {
            Axis::X => Some(&self.x),
            Axis::Y => Some(&self.y),
            Axis::Z => None,
        }
    }
}

/// The six error motions of one linear axis (ISO 230-1), plus repeatability.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AxisErrors {
    /// Positioning error along the axis (µm), direction-independent part.
    pub positioning: ErrorCurve,
    /// Reversal error B (µm): the + approach is displaced by +B/2, the − approach by −B/2.
    pub reversal_um: f64,
    /// Straightness errors (µm) in the two other axes, keyed by axis name
    /// (`X` axis: `Y`, `Z`; `Y` axis: `X`, `Z`).
    pub straightness: BTreeMap<String, ErrorCurve>,
    /// Roll: rotation about the moving axis (µrad).
    pub roll: ErrorCurve,
    /// Pitch: rotation about the other horizontal axis (µrad).
    pub pitch: ErrorCurve,
    /// Yaw: rotation about Z (µrad).
    pub yaw: ErrorCurve,
    /// Run-to-run repeatability along the axis: standard deviation of a
    /// random offset drawn per approach (µm).
    pub repeatability_um: f64,
    /// The same, in each of the two perpendicular directions (µm).
    pub repeatability_perp_um: f64,
    /// Standard deviation of a random offset drawn per capture, each direction (µm).
    pub capture_noise_um: f64,
}

/// An error as a function of the commanded position p on a travel
/// `[start, start + L]` with midpoint m:
/// `e(p) = slope·(p − m)/1000 + bow·(1 − (2(p − m)/L)²) + wave·sin(2π(p − start)/period + phase)`.
/// Units: µm for translations, µrad for rotations; `slope` per metre.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ErrorCurve {
    /// Linear part, per metre of travel (µm/m = ppm, or µrad/m).
    pub slope_per_m: f64,
    /// Parabolic bow: value at mid-travel relative to the ends.
    pub bow: f64,
    /// Amplitude of the periodic part.
    pub wave: f64,
    /// Period of the periodic part (mm).
    pub wave_period_mm: f64,
    /// Phase of the periodic part at the start of the travel (degrees).
    pub wave_phase_deg: f64,
}

impl Default for ErrorCurve {
    fn default() -> Self {
        Self {
            slope_per_m: 0.0,
            bow: 0.0,
            wave: 0.0,
            wave_period_mm: 50.0,
            wave_phase_deg: 0.0,
        }
    }
}

impl ErrorCurve {
    /// Value at commanded position `p` on a travel starting at `start` of length `length`.
    pub fn value(&self, p: f64, start: f64, length: f64) -> f64 {
        let mid = start + length / 2.0;
        let x = if length > 0.0 {
            2.0 * (p - mid) / length
        } else {
            0.0
        };
        self.slope_per_m * (p - mid) / 1000.0
            + self.bow * (1.0 - x * x)
            + self.wave
                * (std::f64::consts::TAU * (p - start) / self.wave_period_mm
                    + self.wave_phase_deg.to_radians())
                .sin()
    }
}

fn curve(
    slope_per_m: f64,
    bow: f64,
    wave: f64,
    wave_period_mm: f64,
    wave_phase_deg: f64,
) -> ErrorCurve {
    ErrorCurve {
        slope_per_m,
        bow,
        wave,
        wave_period_mm,
        wave_phase_deg,
    }
}

impl Default for MachineConfig {
    fn default() -> Self {
        let x = AxisErrors {
            positioning: curve(6.0, 1.5, 1.2, 36.0, 20.0),
            reversal_um: 2.5,
            straightness: BTreeMap::from([
                ("Y".to_string(), curve(0.0, 3.0, 0.6, 50.0, 0.0)),
                ("Z".to_string(), curve(4.0, -2.0, 0.4, 75.0, 30.0)),
            ]),
            roll: curve(0.0, 12.0, 3.0, 60.0, 0.0),
            pitch: curve(40.0, 8.0, 0.0, 50.0, 0.0),
            yaw: curve(0.0, -10.0, 4.0, 45.0, 90.0),
            repeatability_um: 0.8,
            repeatability_perp_um: 0.3,
            capture_noise_um: 0.1,
        };
        let y = AxisErrors {
            positioning: curve(-8.0, 1.0, 0.9, 25.0, 0.0),
            reversal_um: 3.5,
            straightness: BTreeMap::from([
                ("X".to_string(), curve(0.0, -1.5, 0.5, 40.0, 45.0)),
                ("Z".to_string(), curve(0.0, 2.5, 0.0, 50.0, 0.0)),
            ]),
            roll: curve(0.0, 9.0, 0.0, 50.0, 0.0),
            pitch: curve(-30.0, 0.0, 3.0, 50.0, 0.0),
            yaw: curve(0.0, 6.0, 0.0, 50.0, 0.0),
            repeatability_um: 1.0,
            repeatability_perp_um: 0.3,
            capture_noise_um: 0.1,
        };
        Self { x, y }
    }
}

impl MachineConfig {
    /// Check both axes' errors, X first; the error names the key.
    pub(crate) fn validate(&self) -> Result<()> {
        self.x.validate(Axis::X)?;
        self.y.validate(Axis::Y)
    }
}

impl AxisErrors {
    /// Check the errors of `axis` (`machine.X`, `machine.Y`).
    fn validate(&self, axis: Axis) -> Result<()> {
        let key = format!("machine.{axis}");
        let others = axis.others().map(Axis::name);
        for (name, c) in &self.straightness {
            if !others.contains(&name.as_str()) {
                return Err(bad(
                    &format!("{key}.straightness.{name}"),
                    format!(
                        "straightness of {axis} is in {} or {}",
                        others[0], others[1]
                    ),
                ));
            }
            c.validate(&format!("{key}.straightness.{name}"))?;
        }
        self.positioning.validate(&format!("{key}.positioning"))?;
        self.roll.validate(&format!("{key}.roll"))?;
        self.pitch.validate(&format!("{key}.pitch"))?;
        self.yaw.validate(&format!("{key}.yaw"))?;
        finite(&format!("{key}.reversal_um"), &[self.reversal_um])?;
        non_negative(&format!("{key}.repeatability_um"), self.repeatability_um)?;
        non_negative(
            &format!("{key}.repeatability_perp_um"),
            self.repeatability_perp_um,
        )?;
        non_negative(&format!("{key}.capture_noise_um"), self.capture_noise_um)
    }
}

impl ErrorCurve {
    fn validate(&self, key: &str) -> Result<()> {
        finite(
            key,
            &[self.slope_per_m, self.bow, self.wave, self.wave_phase_deg],
        )?;
        positive(&format!("{key}.wave_period_mm"), self.wave_period_mm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curve_has_its_documented_shape() {
        let c = curve(10.0, 2.0, 0.0, 50.0, 0.0);
        // Ends: ∓ slope·L/2; middle: bow.
        assert!((c.value(0.0, 0.0, 100.0) + 0.5).abs() < 1e-12);
        assert!((c.value(100.0, 0.0, 100.0) - 0.5).abs() < 1e-12);
        assert!((c.value(50.0, 0.0, 100.0) - 2.0).abs() < 1e-12);
        let w = curve(0.0, 0.0, 1.0, 40.0, 90.0);
        assert!((w.value(0.0, 0.0, 100.0) - 1.0).abs() < 1e-12);
        assert!((w.value(20.0, 0.0, 100.0) + 1.0).abs() < 1e-12);
    }
}
