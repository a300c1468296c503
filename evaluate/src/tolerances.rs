//! Which figure of `report.json` each key of a tolerance file limits
//! (docs/formats.md): in `[X]`, `[Y]`, `[Z]` the main line's ISO 230-2
//! figures by their report names (`A_um`, `E_up_um`, …), straightness as
//! `straightness_<direction>_um` (the minimum zone, ISO 12780) or
//! `straightness_<direction>_lsq_um`, the angular ranges `roll_urad`,
//! `pitch_urad`, `yaw_urad`; at the top level `flatness_um` (minimum zone)
//! and `flatness_lsq_um`.

/// The positioning figures a limit can name.
const POSITIONING: [&str; 13] = [
    "A_um",
    "A_up_um",
    "A_down_um",
    "E_um",
    "E_up_um",
    "E_down_um",
    "M_um",
    "R_um",
    "R_up_um",
    "R_down_um",
    "B_um",
    "B_mean_um",
    "seed_3sigma_um",
];

/// The keys, as the error for an unknown one lists them.
pub const KNOWN: &str = "tables [X], [Y], [Z] with A_um, A_up_um, A_down_um, E_um, E_up_um, E_down_um, M_um, \
     R_um, R_up_um, R_down_um, B_um, B_mean_um, seed_3sigma_um, straightness_<Y|Z|X>_um (minimum zone), \
     straightness_<Y|Z|X>_lsq_um, roll_urad, pitch_urad, yaw_urad; top level flatness_um (minimum zone), \
     flatness_lsq_um";

/// The report path limited by `key` in table `axis` (`None`: top level).
pub fn figure(axis: Option<&str>, key: &str) -> Option<String> {
    let Some(axis) = axis else {
        return match key {
            "flatness_um" => Some("flatness.min_zone_um".into()),
            "flatness_lsq_um" => Some("flatness.lsq_um".into()),
            _ => None,
        };
    };
    if !["X", "Y", "Z"].contains(&axis) {
        return None;
    }
    if POSITIONING.contains(&key) {
        return Some(format!("axes.{axis}.positioning.{key}"));
    }
    if ["roll_urad", "pitch_urad", "yaw_urad"].contains(&key) {
        return Some(format!("axes.{axis}.angular.{key}"));
    }
    let direction = key.strip_prefix("straightness_")?;
    let (direction, figure) = match direction.strip_suffix("_lsq_um") {
        Some(d) => (d, "lsq_um"),
        None => (direction.strip_suffix("_um")?, "min_zone_um"),
    };
    (["X", "Y", "Z"].contains(&direction) && direction != axis)
        .then(|| format!("axes.{axis}.straightness.{direction}.{figure}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_name_report_figures() {
        assert_eq!(
            figure(Some("X"), "A_um").as_deref(),
            Some("axes.X.positioning.A_um")
        );
        assert_eq!(
            figure(Some("X"), "straightness_Y_um").as_deref(),
            Some("axes.X.straightness.Y.min_zone_um")
        );
        assert_eq!(
            figure(Some("Y"), "straightness_Z_lsq_um").as_deref(),
            Some("axes.Y.straightness.Z.lsq_um")
        );
        assert_eq!(
            figure(Some("Z"), "yaw_urad").as_deref(),
            Some("axes.Z.angular.yaw_urad")
        );
        assert_eq!(
            figure(None, "flatness_um").as_deref(),
            Some("flatness.min_zone_um")
        );
        for (axis, key) in [
            (Some("X"), "straightness_X_um"),
            (Some("W"), "A_um"),
            (Some("X"), "flatness_um"),
            (None, "A_um"),
            (Some("X"), "a_um"),
        ] {
            assert_eq!(figure(axis, key), None, "{axis:?} {key}");
        }
    }
}
