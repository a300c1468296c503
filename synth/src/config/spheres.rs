//! The `[[spheres]]` array of tables.

use serde::{Deserialize, Serialize};

use super::check::{bad, finite, non_negative, positive};
use crate::Result;

/// A self-luminous sphere fixed to the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SphereConfig {
    /// Name used in files and reports.
    pub name: String,
    /// Diameter (mm).
    pub diameter_mm: f64,
    /// Centre relative to the table reference point, table frame = machine
    /// frame at the nominal zero (mm).
    pub position_mm: [f64; 3],
    /// Signal of a fully covered pixel (electrons per exposure): uniform
    /// radiance gives uniform image irradiance over the silhouette.
    pub radiance_e: f64,
}

impl Default for SphereConfig {
    fn default() -> Self {
        Self {
            name: String::new(),
            diameter_mm: 10.0,
            position_mm: [0.0; 3],
            radiance_e: 12_000.0,
        }
    }
}

impl SphereConfig {
    /// Check the sphere set: each sphere's values, unique names, and the set
    /// as `trinocular measure` checks it (spheres one diameter cannot be told
    /// apart). The error names the key.
    pub(crate) fn validate_set(spheres: &[SphereConfig]) -> Result<()> {
        if spheres.is_empty() {
            return Err(bad("spheres", "at least one sphere is needed"));
        }
        for (i, sp) in spheres.iter().enumerate() {
            let key = format!("spheres[{i}]");
            if sp.name.trim().is_empty() || sp.name.contains(',') {
                return Err(bad(
                    &format!("{key}.name"),
                    format!("'{}' is empty or contains a comma", sp.name),
                ));
            }
            if spheres[..i].iter().any(|o| o.name == sp.name) {
                return Err(bad(
                    &format!("{key}.name"),
                    format!("duplicate sphere name '{}'", sp.name),
                ));
            }
            positive(&format!("{key}.diameter_mm"), sp.diameter_mm)?;
            finite(&format!("{key}.position_mm"), &sp.position_mm)?;
            non_negative(&format!("{key}.radiance_e"), sp.radiance_e)?;
        }
        formats::check_sphere_set(spheres.iter().map(|s| (s.name.as_str(), s.diameter_mm))).map_err(
            |problem| {
                let field = match problem.column() {
                    "diameter" => "diameter_mm",
                    column => column,
                };
                bad(&format!("spheres[{}].{field}", problem.index()), problem)
            },
        )
    }
}
