//! The test conditions of a measurement (`--conditions conditions.toml`,
//! docs/formats.md): the machine and who tested it where, and the
//! temperatures and expansion coefficients that ISO 230-2 §5.3 asks a test
//! report to state and that the nominal differential expansion (NDE)
//! correction to 20 °C needs (ISO 230-2 §3.3, ISO 1: 20 °C reference).

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::table::{Invalid, Record};
use crate::{FormatError, InstantKey, Result};

/// Temperatures a machine hall can have (°C); outside, a value is a typo or
/// in the wrong unit.
pub const TEMPERATURE_RANGE_C: (f64, f64) = (0.0, 50.0);

/// The reference temperature of dimensional metrology (ISO 1), °C.
pub const REFERENCE_C: f64 = 20.0;

/// The conditions file: every table and key optional.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Conditions {
    /// The machine tested and by whom, where and when.
    #[serde(default, skip_serializing_if = "Machine::is_empty")]
    pub machine: Machine,
    /// Temperatures and expansion coefficients.
    #[serde(default, skip_serializing_if = "Temperature::is_empty")]
    pub temperature: Temperature,
}

/// `[machine]`: free text, shown in the report's header as given.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Machine {
    /// Maker of the machine.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub maker: Option<String>,
    /// Model.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<String>,
    /// Serial number.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub serial: Option<String>,
    /// Who tested it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operator: Option<String>,
    /// Where.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub place: Option<String>,
    /// When (free text; e.g. `2026-11-28 09:00–11:30`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub date: Option<String>,
    /// The axes tested and how (free text).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub axes: Option<String>,
    /// The measuring equipment (free text; the rig's cameras are listed
    /// from `rig.json`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub equipment: Option<String>,
}

impl Machine {
    fn is_empty(&self) -> bool {
        *self == Machine::default()
    }

    /// `(label, value)` of every field given, in the order of a test report.
    pub fn fields(&self) -> Vec<(&'static str, &str)> {
        [
            ("maker", &self.maker),
            ("model", &self.model),
            ("serial", &self.serial),
            ("axes tested", &self.axes),
            ("operator", &self.operator),
            ("place", &self.place),
            ("date", &self.date),
            ("equipment", &self.equipment),
        ]
        .into_iter()
        .filter_map(|(k, v)| v.as_deref().map(|v| (k, v)))
        .collect()
    }
}

/// `[temperature]` (°C and µm/(m·K); `_u_` keys are standard uncertainties).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Temperature {
    /// The machine's temperature at its scale (axis), during the test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine_c: Option<f64>,
    /// Its standard uncertainty.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub machine_u_c: Option<f64>,
    /// The machine scale's expansion coefficient α.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expansion_um_per_m_k: Option<f64>,
    /// Its standard uncertainty.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expansion_u_um_per_m_k: Option<f64>,
    /// The air's temperature (stated, not corrected for).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub air_c: Option<f64>,
    /// The calibration target's temperature during the calibration.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_c: Option<f64>,
    /// The target's expansion coefficient.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_expansion_um_per_m_k: Option<f64>,
}

/// The machine's temperature and expansion coefficient with their standard
/// uncertainties: what the NDE correction and its Type B uncertainty need.
/// The temperature is one for the whole test, or one per instant (the
/// `machine_c` column of `manifest.csv`, [`read_instant_temperatures`]).
#[derive(Debug, Clone, PartialEq)]
pub struct MachineExpansion {
    /// T (°C) of the whole test, when given.
    pub temperature_c: Option<f64>,
    /// T (°C) per instant, in place of `temperature_c` (empty: none).
    pub instants: BTreeMap<InstantKey, f64>,
    /// u(T) (°C), the thermometer's: common to every instant.
    pub temperature_u_c: f64,
    /// α (µm/(m·K)).
    pub alpha_um_per_m_k: f64,
    /// u(α) (µm/(m·K)).
    pub alpha_u_um_per_m_k: f64,
}

impl MachineExpansion {
    /// The temperature at `instant`: its own, else the test's.
    pub fn temperature_at(&self, instant: &InstantKey) -> Option<f64> {
        self.instants.get(instant).copied().or(self.temperature_c)
    }

    /// The nominal differential expansion strain α·(T − 20 °C) of the
    /// machine's scale at `instant` (dimensionless); `None` without a
    /// temperature there.
    pub fn strain_at(&self, instant: &InstantKey) -> Option<f64> {
        self.temperature_at(instant).map(|t| self.strain_of(t))
    }

    /// The strain α·(T − 20 °C) of the scale at temperature `t_c`.
    pub fn strain_of(&self, t_c: f64) -> f64 {
        strain(self.alpha_um_per_m_k, t_c)
    }

    /// The expansion of drawn values `T + δT` (every instant: the
    /// thermometer's error is common to them) and `α + δα`.
    pub fn drawn(&self, dt_c: f64, dalpha: f64) -> MachineExpansion {
        MachineExpansion {
            temperature_c: self.temperature_c.map(|t| t + dt_c),
            instants: self.instants.iter().map(|(k, t)| (*k, t + dt_c)).collect(),
            temperature_u_c: self.temperature_u_c,
            alpha_um_per_m_k: self.alpha_um_per_m_k + dalpha,
            alpha_u_um_per_m_k: self.alpha_u_um_per_m_k,
        }
    }

    /// The lowest and highest temperature it holds (°C).
    pub fn range_c(&self) -> Option<(f64, f64)> {
        let all = self.instants.values().copied().chain(self.temperature_c);
        all.fold(None, |r, t| match r {
            None => Some((t, t)),
            Some((lo, hi)) => Some((f64::min(lo, t), f64::max(hi, t))),
        })
    }
}

/// α·(T − 20 °C), α in µm/(m·K): a dimensionless strain.
fn strain(alpha_um_per_m_k: f64, t_c: f64) -> f64 {
    alpha_um_per_m_k * 1e-6 * (t_c - REFERENCE_C)
}

impl Temperature {
    fn is_empty(&self) -> bool {
        *self == Temperature::default()
    }

    /// The machine's temperature (the test's, or per instant from
    /// `instants`) and α, when α and a temperature are given.
    pub fn machine(&self, instants: BTreeMap<InstantKey, f64>) -> Option<MachineExpansion> {
        (self.machine_c.is_some() || !instants.is_empty()).then_some(())?;
        Some(MachineExpansion {
            temperature_c: self.machine_c,
            instants,
            temperature_u_c: self.machine_u_c.unwrap_or(0.0),
            alpha_um_per_m_k: self.expansion_um_per_m_k?,
            alpha_u_um_per_m_k: self.expansion_u_um_per_m_k.unwrap_or(0.0),
        })
    }

    /// The calibration target's expansion strain α_t·(T_t − 20 °C), when
    /// both are given: a target warmer than 20 °C was larger than
    /// `target.csv` says, so lengths measured with the rig are too short by
    /// the factor 1/(1 + strain).
    pub fn target_strain(&self) -> Option<f64> {
        Some(strain(self.target_expansion_um_per_m_k?, self.target_c?))
    }

    /// Every value in range, and each temperature that needs its
    /// coefficient with it; the first problem as `(key, reason)`.
    fn check(&self) -> std::result::Result<(), (&'static str, String)> {
        let (lo, hi) = TEMPERATURE_RANGE_C;
        for (key, v) in [
            ("machine_c", self.machine_c),
            ("air_c", self.air_c),
            ("target_c", self.target_c),
        ] {
            if let Some(v) = v
                && !(lo..=hi).contains(&v)
            {
                return Err((
                    key,
                    format!("{v} °C is outside {lo}–{hi} °C (a temperature in °C is expected)"),
                ));
            }
        }
        for (key, v) in [
            ("machine_u_c", self.machine_u_c),
            ("expansion_um_per_m_k", self.expansion_um_per_m_k),
            ("expansion_u_um_per_m_k", self.expansion_u_um_per_m_k),
            (
                "target_expansion_um_per_m_k",
                self.target_expansion_um_per_m_k,
            ),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v >= 0.0)
            {
                return Err((key, format!("{v} is not a finite value ≥ 0")));
            }
        }
        let pairs = [
            (
                "machine_c",
                self.machine_c.is_some(),
                "expansion_um_per_m_k",
                self.expansion_um_per_m_k.is_some(),
            ),
            (
                "target_c",
                self.target_c.is_some(),
                "target_expansion_um_per_m_k",
                self.target_expansion_um_per_m_k.is_some(),
            ),
        ];
        // A temperature needs its coefficient; the machine's α alone is
        // for temperatures per instant (manifest.csv's `machine_c`).
        for (a, has_a, b, has_b) in pairs {
            if has_a && !has_b {
                return Err((
                    a,
                    format!("needs `temperature.{b}` too: the correction to 20 °C uses both"),
                ));
            }
        }
        Ok(())
    }
}

impl Conditions {
    /// Read and check `path`; errors name the file, the key and the reason.
    pub fn read(path: &Path) -> Result<Conditions> {
        let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
        let conditions: Conditions = toml::from_str(&text).map_err(|e| FormatError::File {
            path: path.to_path_buf(),
            message: format!("not a conditions file: {}", e.to_string().trim()),
        })?;
        conditions
            .temperature
            .check()
            .map_err(|(key, reason)| FormatError::File {
                path: path.to_path_buf(),
                message: format!("temperature.{key}: {reason}"),
            })?;
        Ok(conditions)
    }
}

instant_row! {
    /// A row of `manifest.csv` with its optional `machine_c` column: the
    /// machine's temperature at the row's instant (°C).
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    pub struct InstantTemperatureRow {
        ..InstantKey,
        /// The machine's temperature at its scale at this instant (°C).
        pub machine_c: f64,
    }
}

impl Record for InstantTemperatureRow {
    const COLUMNS: &'static [&'static str] = instant_columns![..InstantKey, "machine_c"];

    fn validate(&self) -> std::result::Result<(), Invalid> {
        self.validate_instant()?;
        let (lo, hi) = TEMPERATURE_RANGE_C;
        if !(lo..=hi).contains(&self.machine_c) {
            return Err(Invalid::new(
                "machine_c",
                format!(
                    "{} °C is outside {lo}–{hi} °C (a temperature in °C is expected)",
                    self.machine_c
                ),
            ));
        }
        Ok(())
    }
}

/// The machine's temperature per instant from the optional `machine_c`
/// column of `manifest` (empty without the column). The images of one
/// instant must agree on it; a row that disagrees, an empty cell or a value
/// outside 0–50 °C is an error naming the file, line and column.
pub fn read_instant_temperatures(manifest: &Path) -> Result<BTreeMap<InstantKey, f64>> {
    let mut reader = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_path(manifest)
        .map_err(|e| FormatError::file(manifest, e.to_string()))?;
    let has_column = reader
        .headers()
        .map_err(|e| FormatError::file(manifest, e.to_string()))?
        .iter()
        .any(|h| h == "machine_c");
    let mut instants: BTreeMap<InstantKey, (f64, u64)> = BTreeMap::new();
    if has_column {
        for row in crate::read_csv::<InstantTemperatureRow>(manifest)? {
            let t = row.record.machine_c;
            let (seen, line) = *instants
                .entry(row.record.instant())
                .or_insert((t, row.line));
            if seen != t {
                return Err(FormatError::Row {
                    path: manifest.to_path_buf(),
                    line: row.line,
                    column: Some("machine_c".into()),
                    message: format!(
                        "{t} °C, where line {line} of the same instant says {seen} °C: the images \
                         of one instant share its temperature"
                    ),
                });
            }
        }
    }
    Ok(instants.into_iter().map(|(k, (t, _))| (k, t)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Conditions> {
        let dir = tempfile::tempdir().map_err(|e| FormatError::io("tmp", e))?;
        let path = dir.path().join("conditions.toml");
        std::fs::write(&path, text).map_err(|e| FormatError::io(&path, e))?;
        Conditions::read(&path)
    }

    #[test]
    fn the_contract_reads_and_gives_the_strains() -> Result<()> {
        let c = read(
            "[machine]\nmaker = \"ACME\"\nserial = \"42\"\n[temperature]\nmachine_c = 25.0\n\
             machine_u_c = 0.2\nexpansion_um_per_m_k = 11.5\nexpansion_u_um_per_m_k = 1.0\n\
             air_c = 21.0\ntarget_c = 20.0\ntarget_expansion_um_per_m_k = 23.1\n",
        )?;
        assert_eq!(
            c.machine.fields(),
            vec![("maker", "ACME"), ("serial", "42")]
        );
        let m = c
            .temperature
            .machine(BTreeMap::new())
            .ok_or(FormatError::File {
                path: "c".into(),
                message: "no machine".into(),
            })?;
        // 11.5 µm/(m·K) × 5 K = 57.5 µm/m, at every instant.
        let instant = InstantKey::new((crate::Axis::X, crate::Direction::Up), [1, 0, 1], [0.0; 3]);
        let at = m.strain_at(&instant).unwrap_or(f64::NAN);
        assert!((at - 57.5e-6).abs() < 1e-15);
        assert_eq!(c.temperature.target_strain(), Some(0.0));
        Ok(())
    }

    #[test]
    fn bad_values_are_refused_with_the_key() {
        for (text, key) in [
            (
                "[temperature]\nmachine_c = 60.0\nexpansion_um_per_m_k = 11.5\n",
                "temperature.machine_c",
            ),
            (
                "[temperature]\nmachine_c = 25.0\nexpansion_um_per_m_k = -1.0\n",
                "temperature.expansion_um_per_m_k",
            ),
            (
                "[temperature]\nmachine_c = 25.0\n",
                "temperature.machine_c: needs `temperature.expansion_um_per_m_k`",
            ),
            ("[temperature]\nair_c = nan\n", "temperature.air_c"),
            (
                "[temperature]\nhumidity = 40.0\n",
                "unknown field `humidity`",
            ),
            ("[machine]\nmaker = 3\n", "maker"),
        ] {
            match read(text) {
                Err(e) => {
                    let m = e.to_string();
                    assert!(
                        m.contains("conditions.toml") && m.contains(key),
                        "{text}: {m}"
                    );
                }
                Ok(c) => panic!("{text}: accepted as {c:?}"),
            }
        }
    }
}
