//! `<stem>.commissioning.json` and `<stem>.commissioning.txt` of `trinocular calibrate`
//! (docs/formats.md): the rig commissioning report's types and its plain-text
//! rendering, filled by the `calib` crate (its `commission` and flat-field
//! fit). Lengths mm, angles degrees, scale costs ppm.

use geom::RadialIllumination;
use serde::Serialize;

/// What a user must capture for the relative illumination, in the report.
pub const FLAT_FIELD_ADVICE: &str = "A pixel's value is the sphere's radiance times the lens's \
relative illumination, which falls off towards the edge of the field (cos⁴θ for an ideal lens, \
more or less for a real one); left uncorrected, or corrected with the wrong model, it moves each \
sphere's centroid along the radius and scales every displacement by up to ≈ 480 ppm. Capture per \
camera, with the same lens, aperture, focus and exposure settings as the measurement: a flat \
field (a uniform radiance source, e.g. an opal diffuser or integrating sphere, filling the whole \
view, at about ¾ of full scale, never saturated) and a dark frame (lens capped), and give them to \
`trinocular calibrate --flat-fields … --dark-frames …`.";

/// Per-camera figures.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CameraReport {
    /// Camera number.
    pub id: u8,
    /// Machine axis it should look along.
    pub machine_axis: String,
    /// Projection centre (mm).
    pub centre_mm: [f64; 3],
    /// Optical axis (unit vector, world frame).
    pub optical_axis: [f64; 3],
    /// Angle between the optical axis and its machine axis (deg, as lines).
    pub axis_angle_deg: f64,
    /// Cosine error of that angle, `(1 − cos α)·10⁶`.
    pub cosine_error_ppm: f64,
    /// Depth of the working point (mm); absent without one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub working_distance_mm: Option<f64>,
    /// Pixel size at the working distance along u, `Z/fx` (mm/px).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixel_size_u_mm: Option<f64>,
    /// Pixel size at the working distance along v, `Z/fy` (mm/px).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixel_size_v_mm: Option<f64>,
    /// Mean of the two (the seed's p_k, mm/px).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pixel_size_mm: Option<f64>,
    /// Principal point (px).
    pub principal_point_px: [f64; 2],
    /// Principal point minus the image centre `((W − 1)/2, (H − 1)/2)` (px).
    pub principal_point_offset_px: [f64; 2],
    /// Reprojection RMS of the calibration (px).
    pub rms_px: f64,
    /// Depth of field, when the optics are known.
    pub depth_of_field: Option<DepthOfField>,
    /// Relative illumination: model, profile and scale costs.
    pub relative_illumination: IlluminationReport,
    /// The sensor as calibrated from stacks of flats and darks, when given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sensor: Option<crate::SensorJson>,
    /// The standard uncertainties of the calibrated parameters, when their
    /// covariance is determined.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub parameter_uncertainty: Option<ParameterUncertainty>,
}

/// The standard uncertainties (k = 1) of a camera's calibrated parameters,
/// from its covariance in `rig.json`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterUncertainty {
    /// Per parameter, in the covariance's order.
    pub parameters: Vec<ParameterSd>,
    /// Standard uncertainty of each marker coordinate used (µm, RMS over the markers).
    pub target_uncertainty_um: f64,
    /// Where it came from.
    pub target_uncertainty_source: String,
}

/// One parameter's standard uncertainty (units of [`crate::CameraCovariance`]:
/// px, rad, mm or none) and, of it, the part due to the target.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ParameterSd {
    /// Name (`fx`, …, `rx`, …, `tx`, …, `k1`, …).
    pub name: String,
    /// Standard uncertainty, `√Σ_jj`.
    pub u: f64,
    /// Of it, the target's part, `√(Σ_target)_jj`.
    pub u_target: f64,
}

impl ParameterUncertainty {
    /// The standard uncertainties of a covariance; `None` when its matrix
    /// is not square and of its parameters' size.
    pub fn of(c: &crate::CameraCovariance) -> Option<Self> {
        let total = c.to_matrix()?;
        let target = c.target_matrix();
        let parameters = c
            .parameters
            .iter()
            .enumerate()
            .map(|(j, name)| ParameterSd {
                name: name.clone(),
                u: total[(j, j)].max(0.0).sqrt(),
                u_target: target.as_ref().map_or(0.0, |t| t[(j, j)].max(0.0).sqrt()),
            })
            .collect();
        Some(Self {
            parameters,
            target_uncertainty_um: c.target_uncertainty_um,
            target_uncertainty_source: c.target_uncertainty_source.clone(),
        })
    }

    /// Two lines of the text report: the standard uncertainties by unit
    /// (px; µrad for the rotation; µm for the translation; the distortion
    /// coefficients as they are), and the target's uncertainty with its
    /// largest share of a parameter's variance.
    fn text(&self, s: &mut String) {
        use std::fmt::Write;
        let group = |names: &[&str], scale: f64, unit: &str, digits: usize| {
            let items: Vec<String> = self
                .parameters
                .iter()
                .filter(|p| names.contains(&p.name.as_str()))
                .map(|p| format!("{} {:.*}", p.name, digits, scale * p.u))
                .collect();
            (!items.is_empty()).then(|| format!("{}{unit}", items.join(", ")))
        };
        let distortion: Vec<String> = self
            .parameters
            .iter()
            .filter(|p| ["k1", "k2", "p1", "p2", "k3"].contains(&p.name.as_str()))
            .map(|p| format!("{} {:.2e}", p.name, p.u))
            .collect();
        let parts: Vec<String> = [
            group(&["fx", "fy", "cx", "cy", "skew"], 1.0, " px", 3),
            group(&["rx", "ry", "rz"], 1e6, " µrad", 1),
            group(&["tx", "ty", "tz"], 1e3, " µm", 1),
            (!distortion.is_empty()).then(|| distortion.join(", ")),
        ]
        .into_iter()
        .flatten()
        .collect();
        let _ = writeln!(
            s,
            "  calibration standard uncertainties (k = 1): {}",
            parts.join("; ")
        );
        let share = self
            .parameters
            .iter()
            .filter(|p| p.u > 0.0)
            .map(|p| (p.u_target / p.u).powi(2))
            .fold(0.0, f64::max);
        let _ = writeln!(
            s,
            "    target marker coordinates {:.2} µm each ({}): at most {:.1} % of a parameter's variance",
            self.target_uncertainty_um,
            self.target_uncertainty_source,
            100.0 * share
        );
    }
}

/// The relative illumination of one camera in the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct IlluminationReport {
    /// `radial` (measured from a flat field), `ideal` (assumed: no flat
    /// field given) or `uniform`.
    pub model: String,
    /// The flat-field fit, when measured.
    pub flat_field: Option<FlatFieldFit>,
    /// Centre of the measured fall-off minus the principal point (px): a
    /// decentred lens, or a source that is not uniform (a smooth gradient in
    /// the flat moves the centre).
    pub centre_offset_px: Option<[f64; 2]>,
    /// RI against the ideal lens from the principal point to the farthest corner.
    pub profile: Vec<ProfilePoint>,
    /// Scale errors of wrong assumptions, per sphere and travel end.
    pub scale_costs: Vec<ScaleCost>,
}

/// What a wrong relative illumination would cost one sphere at the end of a travel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ScaleCost {
    /// Machine axis of the travel.
    pub axis: String,
    /// Sphere name.
    pub sphere: String,
    /// Sphere diameter (mm).
    pub diameter_mm: f64,
    /// Correcting with the ideal lens (cos⁴θ) instead of this camera's model (ppm).
    pub ideal_lens_ppm: f64,
    /// Not correcting at all (flat RI) (ppm).
    pub flat_ppm: f64,
}

/// Near and far limits of acceptable sharpness.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DepthOfField {
    /// Lens focal length used (mm).
    pub focal_mm: f64,
    /// f-number.
    pub f_number: f64,
    /// Circle of confusion (mm on the sensor).
    pub coc_mm: f64,
    /// Focus distance (mm).
    pub focus_mm: f64,
    /// Near limit (mm).
    pub near_mm: f64,
    /// Far limit (mm; infinite beyond the hyperfocal distance, written as null).
    pub far_mm: Option<f64>,
}

/// Angle between two optical axes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AxisPair {
    /// The two cameras.
    pub cameras: [u8; 2],
    /// Angle between the axes as lines (deg, 0…90).
    pub angle_deg: f64,
    /// 90° minus that angle (deg).
    pub deviation_deg: f64,
}

/// One camera's view of one axis's travel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TravelCamera {
    /// Camera number.
    pub id: u8,
    /// Depth range of the travel (mm).
    pub depth_mm: [f64; 2],
    /// Within the depth of field over the whole travel (`None`: optics unknown).
    pub within_depth_of_field: Option<bool>,
    /// The working point stays inside the image over the whole travel.
    pub in_view: bool,
}

/// A machine axis's travel and the cameras used for it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TravelReport {
    /// Machine axis.
    pub axis: String,
    /// Travel (mm), centred on the working point.
    pub travel_mm: f64,
    /// The cameras used for this axis.
    pub cameras: Vec<TravelCamera>,
}

/// What the report says without a working point.
pub const NO_WORKING_POINT: &str = "Working point: unknown (one camera, and no second optical axis \
     to meet: the working distance, the pixel size there and the travels through it cannot be given)";

/// The commissioning report (`<stem>.commissioning.json`; [`Report::text`] for `<stem>.commissioning.txt`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// Working point (mm): given, or where the optical axes meet; absent
    /// for one camera without one given (its axis alone fixes no point).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub working_point_mm: Option<[f64; 3]>,
    /// Per camera.
    pub cameras: Vec<CameraReport>,
    /// Between each pair of optical axes.
    pub axis_pairs: Vec<AxisPair>,
    /// Per machine axis.
    pub travel: Vec<TravelReport>,
    /// Everything past a tolerance.
    pub warnings: Vec<String>,
}

/// The relative-illumination lines of one camera in the text report.
fn illumination_text(s: &mut String, r: &IlluminationReport) {
    use std::fmt::Write;
    match &r.flat_field {
        Some(f) => {
            let [du, dv] = r.centre_offset_px.unwrap_or_default();
            let _ = writeln!(
                s,
                "  relative illumination measured from the flat field: RI {:.4}…{:.4} of the centre, \
                 centred ({du:+.1}, {dv:+.1}) px from the principal point, fit residual {:.4} % RMS \
                 (noise {:.4} %), dark {:.1} DN, flat {:.0} DN above it",
                f.ri_range[0],
                f.ri_range[1],
                100.0 * f.residual_rms,
                100.0 * f.noise_rms,
                f.dark_dn,
                f.flat_level_dn
            );
        }
        None => {
            let _ = writeln!(
                s,
                "  relative illumination ASSUMED: the {} lens (no flat field given)",
                r.model
            );
        }
    }
    let row = |label: &str, f: &dyn Fn(&ProfilePoint) -> String| {
        let cells: Vec<String> = r.profile.iter().map(f).collect();
        format!("    {label:<22}{}", cells.join(""))
    };
    let _ = writeln!(
        s,
        "{}",
        row("field angle (deg)", &|p| format!(
            "{:>9.2}",
            p.field_angle_deg
        ))
    );
    let _ = writeln!(s, "{}", row("RI", &|p| format!("{:>9.4}", p.ri)));
    let _ = writeln!(
        s,
        "{}",
        row("ideal lens cos⁴θ·J", &|p| format!("{:>9.4}", p.ideal))
    );
    let _ = writeln!(s, "{}", row("RI / ideal", &|p| format!("{:>9.4}", p.ratio)));
    for c in &r.scale_costs {
        let _ = writeln!(
            s,
            "    sphere {} ({} mm) at the end of the {} travel: assuming cos⁴θ would cost {:+.1} ppm of scale, no correction {:+.1} ppm",
            c.sphere, c.diameter_mm, c.axis, c.ideal_lens_ppm, c.flat_ppm
        );
    }
}

/// The sensor lines of one camera in the text report.
fn sensor_text(s: &mut String, r: &crate::SensorJson) {
    use std::fmt::Write;
    let st = &r.stack;
    let noise = |n: Option<f64>| {
        n.map_or("not measured (one frame)".to_string(), |n| {
            format!("{n:.2} DN per pixel")
        })
    };
    let _ = writeln!(
        s,
        "  sensor: {}-bit ADC in {}-bit files; stacks of {} flat and {} dark frames (master flat noise {}, master dark noise {})",
        r.adc_bits,
        r.container_bits,
        st.flats,
        st.darks,
        noise(st.flat_noise_dn),
        noise(st.dark_noise_dn)
    );
    match (r.gain_dn_per_e, r.read_noise_e) {
        (Some(k), Some(rn)) => {
            let _ = writeln!(
                s,
                "    photon transfer (EMVA 1288): gain {k:.4} DN/e⁻, read noise {rn:.2} e⁻"
            );
        }
        _ => {
            let note = r
                .extra
                .get("transfer_note")
                .and_then(|v| v.as_str())
                .unwrap_or("not measured");
            let _ = writeln!(s, "    photon transfer: {note}");
        }
    }
    let d = &r.defects;
    let _ = writeln!(
        s,
        "    PRNU {:.3} %, DSNU {:.2} DN (columns {:.2} DN), black level {:.1} DN; defects: {} hot, {} dead, {} weak, {} strong ({} clusters)",
        100.0 * r.prnu,
        r.dsnu_dn,
        r.column_dsnu_dn,
        r.black_level_dn,
        d.hot,
        d.dead,
        d.weak,
        d.strong,
        d.clusters
    );
    for key in ["dark_note", "gain_note"] {
        if let Some(note) = r.extra.get(key).and_then(|v| v.as_str()) {
            let _ = writeln!(s, "    {note}");
        }
    }
}

impl Report {
    /// Plain-text rendering for `<stem>.commissioning.txt`.
    pub fn text(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(s, "Rig commissioning");
        let _ = writeln!(s, "=================");
        match self.working_point_mm {
            Some(wp) => {
                let _ = writeln!(
                    s,
                    "Working point: ({:.2}, {:.2}, {:.2}) mm (nearest point to the optical axes unless given)",
                    wp[0], wp[1], wp[2]
                );
            }
            None => {
                let _ = writeln!(s, "{NO_WORKING_POINT}");
            }
        }
        let _ = writeln!(s);
        for c in &self.cameras {
            let _ = writeln!(s, "Camera {} (looks along {})", c.id, c.machine_axis);
            let _ = writeln!(
                s,
                "  optical axis {:.4}° from {} (cosine error {:.0} ppm); centre ({:.2}, {:.2}, {:.2}) mm",
                c.axis_angle_deg,
                c.machine_axis,
                c.cosine_error_ppm,
                c.centre_mm[0],
                c.centre_mm[1],
                c.centre_mm[2]
            );
            if let (Some(z), Some(p), Some(pu), Some(pv)) = (
                c.working_distance_mm,
                c.pixel_size_mm,
                c.pixel_size_u_mm,
                c.pixel_size_v_mm,
            ) {
                let _ = writeln!(
                    s,
                    "  working distance {z:.2} mm; pixel size {p:.6} mm/px (u {pu:.6}, v {pv:.6})"
                );
            }
            let _ = writeln!(
                s,
                "  principal point ({:.2}, {:.2}) px, ({:+.2}, {:+.2}) px from the image centre; reprojection RMS {:.4} px",
                c.principal_point_px[0],
                c.principal_point_px[1],
                c.principal_point_offset_px[0],
                c.principal_point_offset_px[1],
                c.rms_px
            );
            match c.depth_of_field {
                Some(d) => {
                    let _ = writeln!(
                        s,
                        "  depth of field {:.1}…{} mm (lens {:.2} mm, f/{}, circle of confusion {:.4} mm, focus {:.1} mm)",
                        d.near_mm,
                        d.far_mm.map_or("∞".to_string(), |f| format!("{f:.1}")),
                        d.focal_mm,
                        d.f_number,
                        d.coc_mm,
                        d.focus_mm
                    );
                }
                None => {
                    let _ = writeln!(s, "  depth of field unknown (no optics given)");
                }
            }
            illumination_text(&mut s, &c.relative_illumination);
            if let Some(sensor) = &c.sensor {
                sensor_text(&mut s, sensor);
            }
            if let Some(u) = &c.parameter_uncertainty {
                u.text(&mut s);
            }
            let _ = writeln!(s);
        }
        let _ = writeln!(s, "Angles between optical axes (the method needs 90°):");
        if self.axis_pairs.is_empty() {
            let _ = writeln!(s, "  one camera: no pair of axes");
        }
        for p in &self.axis_pairs {
            let _ = writeln!(
                s,
                "  cameras {} and {}: {:.4}° ({:+.4}° from perpendicular)",
                p.cameras[0], p.cameras[1], p.angle_deg, -p.deviation_deg
            );
        }
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "Travel through the working point, cameras used for each axis:"
        );
        if self.working_point_mm.is_none() {
            let _ = writeln!(s, "  not checked: no working point");
        }
        for t in &self.travel {
            for c in &t.cameras {
                let dof = match c.within_depth_of_field {
                    Some(true) => "within depth of field",
                    Some(false) => "OUTSIDE depth of field",
                    None => "depth of field unknown",
                };
                let view = if c.in_view {
                    "in view"
                } else {
                    "LEAVES the image"
                };
                let _ = writeln!(
                    s,
                    "  {} {:.0} mm, camera {}: depth {:.2}…{:.2} mm, {dof}, {view}",
                    t.axis, t.travel_mm, c.id, c.depth_mm[0], c.depth_mm[1]
                );
            }
        }
        let _ = writeln!(s);
        let _ = writeln!(s, "Relative illumination:");
        let _ = writeln!(s, "  {FLAT_FIELD_ADVICE}");
        let _ = writeln!(s);
        if self.warnings.is_empty() {
            let _ = writeln!(s, "No warnings.");
        } else {
            let _ = writeln!(s, "Warnings:");
            for w in &self.warnings {
                let _ = writeln!(s, "  - {w}");
            }
        }
        s
    }
}

/// The fitted relative illumination and what is known about it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FlatFieldFit {
    /// The model, normalised to 1 at its centre.
    #[serde(skip)]
    pub model: RadialIllumination,
    /// Flat-field level at the centre above the dark (DN).
    pub flat_level_dn: f64,
    /// Mean of the dark frame (DN).
    pub dark_dn: f64,
    /// Smallest and largest RI over the image (relative to the centre).
    pub ri_range: [f64; 2],
    /// RMS of the block residuals relative to the model.
    pub residual_rms: f64,
    /// Largest block residual relative to the model.
    pub residual_max: f64,
    /// RMS noise of the block means relative to the level (what the residual
    /// would be for a perfect model).
    pub noise_rms: f64,
    /// Blocks fitted.
    pub blocks: usize,
    /// Block size (px).
    pub block_px: u32,
    /// Set when the residual shows structure the radial model does not follow.
    pub warning: Option<String>,
}

/// The relative illumination at one field position: the camera's model
/// against the ideal lens (cos⁴θ, energy-conserving under distortion), both
/// relative to their value at the principal point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProfilePoint {
    /// Field angle θ (deg).
    pub field_angle_deg: f64,
    /// Distance from the principal point (observed px).
    pub radius_px: f64,
    /// The camera's RI.
    pub ri: f64,
    /// The ideal lens's RI, cos⁴θ·J.
    pub ideal: f64,
    /// `ri / ideal`: the lens's own vignetting V.
    pub ratio: f64,
}
