//! The page's test conditions (`#conditions`): the machine, who tested it
//! where and when, and the temperatures, as ISO 230-2 §5.3 asks a test
//! report to state them; the same on every page that has them.

use formats::conditions::Conditions;

use crate::Page;

/// The section, nothing when no conditions were given.
pub fn section(h: &mut Page, conditions: Option<&Conditions>) {
    let Some(c) = conditions else {
        return;
    };
    let mut rows: Vec<Vec<String>> = c
        .machine
        .fields()
        .into_iter()
        .map(|(k, v)| vec![k.to_string(), v.to_string()])
        .collect();
    let t = &c.temperature;
    let with_u = |v: Option<f64>, u: Option<f64>, unit: &str| {
        v.map(|v| match u {
            Some(u) => format!("{v} {unit} (u = {u} {unit})"),
            None => format!("{v} {unit}"),
        })
    };
    let temperatures = [
        (
            "machine temperature",
            with_u(t.machine_c, t.machine_u_c, "°C"),
        ),
        (
            "machine expansion coefficient α",
            with_u(t.expansion_um_per_m_k, t.expansion_u_um_per_m_k, "µm/(m·K)"),
        ),
        ("air temperature", with_u(t.air_c, None, "°C")),
        (
            "calibration target temperature",
            with_u(t.target_c, None, "°C"),
        ),
        (
            "calibration target expansion coefficient",
            with_u(t.target_expansion_um_per_m_k, None, "µm/(m·K)"),
        ),
    ];
    rows.extend(
        temperatures
            .into_iter()
            .filter_map(|(k, v)| v.map(|v| vec![k.to_string(), v])),
    );
    if rows.is_empty() {
        return;
    }
    h.h2("conditions", "Test conditions");
    h.table(Some("conditions-table"), &["condition", "value"], &rows);
}
