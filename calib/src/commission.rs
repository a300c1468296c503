//! Rig commissioning: is the calibrated rig fit for the trinocular method
//! (docs/methods.md, Rig; Matching and fusion)?
//!
//! - Angles between the three optical axes (the method needs them
//!   perpendicular) and of each optical axis against its machine axis
//!   (camera 1 ∥ X, 2 ∥ Y, 3 ∥ Z), with the cosine error `1 − cos α` in ppm.
//! - Pixel size at the working distance per camera (the seed's p1, p2, p3):
//!   `p = Z/f` mm/px, Z the depth of the working point, f = fx or fy.
//! - Principal point and its offset from the image centre; reprojection RMS.
//! - Depth of field (thin lens, Hecht §5.7.4 / the photographic formulas):
//!   hyperfocal `H = f²/(N·c) + f`, near limit `s·(H − f)/(H + s − 2f)`, far
//!   limit `s·(H − f)/(H − s)` (∞ when s ≥ H), with f the lens focal length,
//!   N the f-number, c the circle of confusion and s the focus distance. Each
//!   axis's travel through the working point must stay within the depth of
//!   field, and inside the image, of every camera used for that axis: the
//!   camera looking along an axis is not used for it (X: cameras 2 + 3,
//!   Y: 1 + 3, Z: 1 + 2).
//!
//! - Relative illumination (`crate::illumination`): the camera's measured
//!   (or assumed) fall-off against the ideal lens's cos⁴θ over the field, and
//!   what correcting with the ideal lens or with none would cost in scale
//!   (ppm) for each sphere at the ends of each travel.
//!
//! Past a tolerance the report carries a warning; it never fails.

use formats::Axis;
use geom::nalgebra::{Matrix3, Vector3};
use geom::{Camera, Illumination, Point3};

use formats::commissioning::{
    AxisPair, CameraReport, DepthOfField, FlatFieldFit, IlluminationReport, ParameterUncertainty,
    Report, ScaleCost, TravelCamera, TravelReport,
};

use crate::illumination::{profile, scale_error_ppm};

/// Field positions of the relative-illumination profile.
const PROFILE_POINTS: usize = 6;
/// Largest distance of the fall-off's centre from the principal point before
/// a warning, as a fraction of the image diagonal.
const RI_CENTRE_TOLERANCE: f64 = 0.02;

/// Default f-number when the nominal rig does not give one.
pub const DEFAULT_F_NUMBER: f64 = 8.0;
/// Default circle of confusion (px) when the nominal rig does not give one.
pub const DEFAULT_COC_PX: f64 = 2.0;

/// Lens and sensor data for the depth of field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Optics {
    /// Pixel pitch (mm).
    pub pixel_mm: f64,
    /// f-number N.
    pub f_number: f64,
    /// Circle of confusion (px).
    pub coc_px: f64,
    /// Lens focal length (mm); `None`: from the principal distance `b = fx·pixel`
    /// and the focus distance by the lens equation `f = s·b/(s + b)`.
    pub focal_mm: Option<f64>,
    /// Focus distance from the lens (mm); `None`: the depth of the working point.
    pub focus_distance_mm: Option<f64>,
}

/// One calibrated camera to commission.
#[derive(Debug, Clone)]
pub struct CameraInput {
    /// Camera number: 1 looks along X, 2 along Y, 3 along Z.
    pub id: u8,
    /// The calibrated camera (world = machine frame).
    pub camera: Camera,
    /// Reprojection RMS of its calibration (px).
    pub rms_px: f64,
    /// Optics; `None` skips the depth-of-field check for this camera.
    pub optics: Option<Optics>,
    /// The lens's relative illumination (measured, or the ideal lens assumed).
    pub illumination: Illumination,
    /// The flat-field fit it came from, when measured.
    pub flat_field: Option<FlatFieldFit>,
    /// The sensor's calibration from stacks of flats and darks, when given.
    pub sensor: Option<formats::SensorJson>,
    /// The covariance of its calibrated parameters, when determined.
    pub covariance: Option<formats::CameraCovariance>,
}

/// Tolerances and the travels to check.
#[derive(Debug, Clone, PartialEq)]
pub struct CommissionOptions {
    /// Point the cameras look at (mm); `None`: the least-squares intersection
    /// of the calibrated optical axes.
    pub working_point: Option<Point3<f64>>,
    /// Travel (mm) per machine axis, centred on the working point.
    pub travel_mm: Vec<(Axis, f64)>,
    /// Largest deviation from 90° between two optical axes (deg).
    pub perpendicularity_tolerance_deg: f64,
    /// Largest angle between an optical axis and its machine axis (deg).
    pub alignment_tolerance_deg: f64,
    /// Largest reprojection RMS (px).
    pub rms_tolerance_px: f64,
    /// Largest principal-point offset from the image centre, as a fraction of the image diagonal.
    pub principal_point_tolerance: f64,
    /// Spheres (name, diameter mm) whose scale error the relative
    /// illumination is reported for.
    pub spheres: Vec<(String, f64)>,
}

impl Default for CommissionOptions {
    fn default() -> Self {
        Self {
            working_point: None,
            travel_mm: vec![(Axis::X, 150.0), (Axis::Y, 100.0)],
            perpendicularity_tolerance_deg: 1.0,
            alignment_tolerance_deg: 1.0,
            rms_tolerance_px: 0.1,
            principal_point_tolerance: 0.05,
            spheres: vec![("A".into(), 20.0), ("B".into(), 15.0), ("C".into(), 10.0)],
        }
    }
}

fn line_angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    let c = (a.dot(b).abs() / (a.norm() * b.norm())).min(1.0);
    c.acos().to_degrees()
}

/// Least-squares point nearest to a set of lines `(point, unit direction)`:
/// `Σ(I − d·dᵀ)·x = Σ(I − d·dᵀ)·p`. `None` when the lines are parallel.
pub fn nearest_point(lines: &[(Point3<f64>, Vector3<f64>)]) -> Option<Point3<f64>> {
    let (mut a, mut b) = (Matrix3::zeros(), Vector3::zeros());
    for (p, d) in lines {
        let m = Matrix3::identity() - d * d.transpose();
        a += m;
        b += m * p.coords;
    }
    let x = a.try_inverse()? * b;
    x.iter().all(|v| v.is_finite()).then_some(Point3::from(x))
}

/// Thin-lens depth of field around focus distance `s` (module docs).
pub fn depth_of_field(focal_mm: f64, f_number: f64, coc_mm: f64, s: f64) -> DepthOfField {
    let f = focal_mm;
    let h = f * f / (f_number * coc_mm) + f;
    let near = s * (h - f) / (h + s - 2.0 * f);
    let far = (s < h).then(|| s * (h - f) / (h - s));
    DepthOfField {
        focal_mm: f,
        f_number,
        coc_mm,
        focus_mm: s,
        near_mm: near,
        far_mm: far,
    }
}

/// The relative-illumination part of a camera's report: profile, and per
/// travel the camera is used for, the scale costs at the travel's end that
/// images farther from the principal point.
fn illumination_report(
    c: &CameraInput,
    wp: Option<&Point3<f64>>,
    options: &CommissionOptions,
) -> IlluminationReport {
    let cam = &c.camera;
    let mut scale_costs = Vec::new();
    // The travels run through the working point: without one, no ends.
    let travels = wp.map(|wp| options.travel_mm.iter().map(move |t| (t, wp)));
    for (&(axis, length), wp) in travels.into_iter().flatten() {
        let dir = axis.unit();
        if Axis::of_camera(c.id).is_none_or(|n| n == axis) {
            continue;
        }
        let pp = geom::Point2::new(cam.intrinsics.cx, cam.intrinsics.cy);
        let radius = |p: &Point3<f64>| cam.project_pinhole(p).map_or(0.0, |q| (q - pp).norm());
        let ends = [wp - dir * (length / 2.0), wp + dir * (length / 2.0)];
        let end = if radius(&ends[0]) >= radius(&ends[1]) {
            ends[0]
        } else {
            ends[1]
        };
        for (name, diameter) in &options.spheres {
            let cost = |assumed: &Illumination| {
                scale_error_ppm(cam, &c.illumination, assumed, &end, diameter / 2.0)
            };
            if let (Some(ideal), Some(flat)) =
                (cost(&Illumination::Ideal), cost(&Illumination::Uniform))
            {
                scale_costs.push(ScaleCost {
                    axis: axis.to_string(),
                    sphere: name.clone(),
                    diameter_mm: *diameter,
                    ideal_lens_ppm: ideal,
                    flat_ppm: flat,
                });
            }
        }
    }
    IlluminationReport {
        model: match c.illumination {
            Illumination::Ideal => "ideal",
            Illumination::Uniform => "uniform",
            Illumination::Radial(_) => "radial",
        }
        .into(),
        flat_field: c.flat_field.clone(),
        centre_offset_px: match &c.illumination {
            Illumination::Radial(r) => Some([
                r.centre[0] - cam.intrinsics.cx,
                r.centre[1] - cam.intrinsics.cy,
            ]),
            _ => None,
        },
        profile: profile(cam, &c.illumination, PROFILE_POINTS),
        scale_costs,
    }
}

/// Commission a calibrated rig (module docs): the working point, each
/// camera's figures, the angles between optical axes, and each travel.
pub fn commission(cameras: &[CameraInput], options: &CommissionOptions) -> Report {
    let mut warnings = Vec::new();
    let axes: Vec<(Point3<f64>, Vector3<f64>)> = cameras
        .iter()
        .map(|c| (c.camera.centre(), c.camera.optical_axis().into_inner()))
        .collect();
    // Given, or where the optical axes meet: one camera's axis alone fixes
    // no point, and with none neither the pixel size at the working
    // distance nor the travels can be given.
    let wp = options
        .working_point
        .or_else(|| (cameras.len() >= 2).then(|| nearest_point(&axes)).flatten());
    let reports: Vec<CameraReport> = cameras
        .iter()
        .map(|c| camera_report(c, wp.as_ref(), options, &mut warnings))
        .collect();
    let axis_pairs = axis_pairs(cameras, &axes, options, &mut warnings);
    let travel = match &wp {
        Some(wp) => options
            .travel_mm
            .iter()
            .map(|&(axis, length)| {
                travel_report(cameras, &reports, wp, axis, length, &mut warnings)
            })
            .collect(),
        None => Vec::new(),
    };
    Report {
        working_point_mm: wp.map(|p| p.coords.into()),
        cameras: reports,
        axis_pairs,
        travel,
        warnings,
    }
}

/// The machine axis of camera `c` by its number, and the angle of its
/// optical axis to it (deg; NaN without one), with the warnings on its alignment.
fn alignment(
    c: &CameraInput,
    options: &CommissionOptions,
    warnings: &mut Vec<String>,
) -> (Option<Axis>, f64) {
    let axis = c.camera.optical_axis().into_inner();
    let machine = Axis::of_camera(c.id);
    let axis_angle = machine.map_or(f64::NAN, |m| line_angle_deg(&axis, &m.unit()));
    if let Some(name) = machine {
        let closest = [Axis::X, Axis::Y, Axis::Z]
            .into_iter()
            .min_by(|a, b| {
                line_angle_deg(&axis, &a.unit()).total_cmp(&line_angle_deg(&axis, &b.unit()))
            })
            .unwrap_or(name);
        if closest != name {
            warnings.push(format!(
                "camera {}: its optical axis is closest to machine {closest}, but camera {} should look along {name}",
                c.id, c.id
            ));
        } else if axis_angle > options.alignment_tolerance_deg {
            warnings.push(format!(
                "camera {}: optical axis {axis_angle:.3}° from machine {name} (tolerance {}°, cosine error {:.0} ppm)",
                c.id,
                options.alignment_tolerance_deg,
                (1.0 - axis_angle.to_radians().cos()) * 1e6
            ));
        }
    } else {
        warnings.push(format!(
            "camera {}: no machine axis for this camera number (1 ∥ X, 2 ∥ Y, 3 ∥ Z)",
            c.id
        ));
    }
    (machine, axis_angle)
}

/// One camera's figures at the working point `wp`, its warnings appended.
fn camera_report(
    c: &CameraInput,
    wp: Option<&Point3<f64>>,
    options: &CommissionOptions,
    warnings: &mut Vec<String>,
) -> CameraReport {
    let cam = &c.camera;
    let k = cam.intrinsics;
    let (machine, axis_angle) = alignment(c, options, warnings);
    let z = wp.map(|wp| cam.to_camera(wp).z);
    if z.is_some_and(|z| z <= 0.0) {
        warnings.push(format!(
            "camera {}: the working point is behind the camera",
            c.id
        ));
    }
    let centre = [
        (f64::from(cam.width) - 1.0) / 2.0,
        (f64::from(cam.height) - 1.0) / 2.0,
    ];
    let offset = [k.cx - centre[0], k.cy - centre[1]];
    let diagonal = f64::from(cam.width).hypot(f64::from(cam.height));
    if offset[0].hypot(offset[1]) > options.principal_point_tolerance * diagonal {
        warnings.push(format!(
            "camera {}: principal point ({:.1}, {:.1}) px is {:.1} px from the image centre (tolerance {:.1} px)",
            c.id,
            k.cx,
            k.cy,
            offset[0].hypot(offset[1]),
            options.principal_point_tolerance * diagonal
        ));
    }
    if c.rms_px > options.rms_tolerance_px {
        warnings.push(format!(
            "camera {}: reprojection RMS {:.4} px exceeds {} px",
            c.id, c.rms_px, options.rms_tolerance_px
        ));
    }
    // Focused at the working point unless the focus is given.
    let dof = c.optics.and_then(|o| {
        let s = o.focus_distance_mm.or(z)?;
        let b = k.fx * o.pixel_mm;
        let f = o.focal_mm.unwrap_or(s * b / (s + b));
        Some(depth_of_field(f, o.f_number, o.coc_px * o.pixel_mm, s))
    });
    let (pu, pv) = (z.map(|z| z / k.fx), z.map(|z| z / k.fy));
    let relative_illumination = illumination_report(c, wp, options);
    if let Some(w) = c.flat_field.as_ref().and_then(|f| f.warning.as_ref()) {
        warnings.push(format!("camera {}: {w}", c.id));
    }
    if let Some([du, dv]) = relative_illumination.centre_offset_px
        && du.hypot(dv) > RI_CENTRE_TOLERANCE * diagonal
    {
        warnings.push(format!(
            "camera {}: the flat field's fall-off is centred {:.0} px from the principal point: \
             a decentred lens, or a source that is not uniform",
            c.id,
            du.hypot(dv)
        ));
    }
    CameraReport {
        id: c.id,
        machine_axis: machine.map_or("?", Axis::name).to_string(),
        centre_mm: cam.centre().coords.into(),
        optical_axis: cam.optical_axis().into_inner().into(),
        axis_angle_deg: axis_angle,
        cosine_error_ppm: (1.0 - axis_angle.to_radians().cos()) * 1e6,
        working_distance_mm: z,
        pixel_size_u_mm: pu,
        pixel_size_v_mm: pv,
        pixel_size_mm: pu.zip(pv).map(|(pu, pv)| 0.5 * (pu + pv)),
        principal_point_px: [k.cx, k.cy],
        principal_point_offset_px: offset,
        rms_px: c.rms_px,
        depth_of_field: dof,
        relative_illumination,
        sensor: c.sensor.clone(),
        parameter_uncertainty: c.covariance.as_ref().and_then(ParameterUncertainty::of),
    }
}

/// The angle between each pair of optical axes (`axes`: centre, direction
/// per camera) and its deviation from 90°.
fn axis_pairs(
    cameras: &[CameraInput],
    axes: &[(Point3<f64>, Vector3<f64>)],
    options: &CommissionOptions,
    warnings: &mut Vec<String>,
) -> Vec<AxisPair> {
    let mut pairs = Vec::new();
    for i in 0..cameras.len() {
        for j in i + 1..cameras.len() {
            let angle = line_angle_deg(&axes[i].1, &axes[j].1);
            let deviation = 90.0 - angle;
            if deviation.abs() > options.perpendicularity_tolerance_deg {
                warnings.push(format!(
                    "cameras {} and {}: optical axes at {angle:.3}°, {deviation:.3}° from perpendicular (tolerance {}°)",
                    cameras[i].id, cameras[j].id, options.perpendicularity_tolerance_deg
                ));
            }
            pairs.push(AxisPair {
                cameras: [cameras[i].id, cameras[j].id],
                angle_deg: angle,
                deviation_deg: deviation,
            });
        }
    }
    pairs
}

/// The travel of `length` mm along `axis` through the working point, seen by
/// every camera used for the axis: depths, depth of field, field of view.
fn travel_report(
    cameras: &[CameraInput],
    reports: &[CameraReport],
    wp: &Point3<f64>,
    axis: Axis,
    length: f64,
    warnings: &mut Vec<String>,
) -> TravelReport {
    let dir = axis.unit();
    let ends = [wp - dir * (length / 2.0), wp + dir * (length / 2.0)];
    let mut used = Vec::new();
    for (c, r) in cameras.iter().zip(reports) {
        if Axis::of_camera(c.id).is_none_or(|n| n == axis) {
            continue;
        }
        let depths = ends.map(|p| c.camera.to_camera(&p).z);
        let (lo, hi) = (depths[0].min(depths[1]), depths[0].max(depths[1]));
        let within = r
            .depth_of_field
            .map(|d| lo >= d.near_mm && d.far_mm.is_none_or(|far| hi <= far));
        let in_view = ends.iter().all(|p| {
            c.camera.project(p).is_ok_and(|q| {
                q.x >= -0.5
                    && q.y >= -0.5
                    && q.x <= f64::from(c.camera.width) - 0.5
                    && q.y <= f64::from(c.camera.height) - 0.5
            })
        });
        if within == Some(false)
            && let Some(d) = r.depth_of_field
        {
            warnings.push(format!(
                "axis {axis}: camera {} sees the {length} mm travel at depths {lo:.1}…{hi:.1} mm, outside its depth of field {:.1}…{} mm",
                c.id,
                d.near_mm,
                d.far_mm.map_or("∞".to_string(), |f| format!("{f:.1}"))
            ));
        }
        if !in_view {
            warnings.push(format!(
                "axis {axis}: the {length} mm travel leaves the image of camera {}",
                c.id
            ));
        }
        used.push(TravelCamera {
            id: c.id,
            depth_mm: [lo, hi],
            within_depth_of_field: within,
            in_view,
        });
    }
    TravelReport {
        axis: axis.to_string(),
        travel_mm: length,
        cameras: used,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Intrinsics;

    fn seed_camera(id: u8, position: Point3<f64>, up: Vector3<f64>) -> CameraInput {
        let target = Point3::new(0.0, 0.0, 30.0);
        let camera = Camera::look_at(
            position,
            target,
            up,
            Intrinsics::centred(7966.0, 4096, 3072),
            4096,
            3072,
        )
        .unwrap();
        CameraInput {
            id,
            camera,
            rms_px: 0.01,
            optics: Some(Optics {
                pixel_mm: 0.0055,
                f_number: 8.0,
                coc_px: 2.0,
                focal_mm: None,
                focus_distance_mm: None,
            }),
            illumination: Illumination::Ideal,
            flat_field: None,
            sensor: None,
            covariance: None,
        }
    }

    fn seed_rig() -> Vec<CameraInput> {
        vec![
            seed_camera(1, Point3::new(-460.0, 0.0, 30.0), Vector3::z()),
            seed_camera(2, Point3::new(0.0, -460.0, 30.0), Vector3::z()),
            seed_camera(3, Point3::new(0.0, 0.0, 490.0), Vector3::y()),
        ]
    }

    #[test]
    fn ideal_seed_rig_has_no_warnings_and_the_seed_pixel_size() {
        let r = commission(&seed_rig(), &CommissionOptions::default());
        assert!(r.warnings.is_empty(), "{:?}", r.warnings);
        let point = r
            .working_point_mm
            .expect("a working point with three cameras");
        assert!((Vector3::from(point) - Vector3::new(0.0, 0.0, 30.0)).norm() < 1e-9);
        for c in &r.cameras {
            // ≈ 58 µm per pixel at 460 mm (docs/methods.md).
            assert!((c.pixel_size_mm.expect("a pixel size") - 460.0 / 7966.0).abs() < 1e-12);
            assert!(c.axis_angle_deg.abs() < 1e-6);
            let d = c.depth_of_field.unwrap();
            // Lens equation: b = 43.81 mm at s = 460 mm gives f = 40 mm.
            assert!((d.focal_mm - 40.0).abs() < 0.01, "f = {}", d.focal_mm);
            assert!(d.near_mm < 460.0 && d.far_mm.unwrap() > 460.0);
        }
        for p in &r.axis_pairs {
            assert!(p.deviation_deg.abs() < 1e-6);
        }
        // X uses cameras 2 and 3, Y uses 1 and 3.
        let ids = |a: &str| -> Vec<u8> {
            r.travel
                .iter()
                .find(|t| t.axis == a)
                .unwrap()
                .cameras
                .iter()
                .map(|c| c.id)
                .collect()
        };
        assert_eq!(ids("X"), vec![2, 3]);
        assert_eq!(ids("Y"), vec![1, 3]);
        assert!(r.text().contains("No warnings."));
    }

    #[test]
    fn misalignment_and_travel_along_the_axis_are_warned() {
        let mut rig = seed_rig();
        // Tilt camera 2 by 2° about world Z: 2° from Y, 88° to camera 1.
        let tilt = geom::Rotation3::new(Vector3::z() * 2f64.to_radians());
        let c = rig[1].camera.centre();
        let r = rig[1].camera.rotation() * tilt.inverse();
        rig[1].camera.pose = geom::Isometry3::from_parts(
            geom::nalgebra::Translation3::from(-(r * c.coords)),
            geom::nalgebra::UnitQuaternion::from_rotation_matrix(&r),
        );
        let options = CommissionOptions {
            travel_mm: vec![(Axis::X, 150.0), (Axis::Y, 100.0), (Axis::Z, 60.0)],
            working_point: Some(Point3::new(0.0, 0.0, 30.0)),
            ..CommissionOptions::default()
        };
        let r = commission(&rig, &options);
        let joined = r.warnings.join("\n");
        assert!(
            joined.contains("camera 2: optical axis 2.000° from machine Y"),
            "{joined}"
        );
        assert!(joined.contains("cameras 1 and 2"), "{joined}");
        // Camera 2 now sees X travel change depth by 150·sin 2° ≈ 5.2 mm: still within ±10 mm.
        let x2 = &r.travel[0].cameras[0];
        assert_eq!(x2.id, 2);
        assert!((x2.depth_mm[1] - x2.depth_mm[0] - 150.0 * 2f64.to_radians().sin()).abs() < 0.01);
        assert_eq!(x2.within_depth_of_field, Some(true));
        // Z travel of 60 mm is along camera 3's axis: camera 3 is not used for Z.
        let z: Vec<u8> = r.travel[2].cameras.iter().map(|c| c.id).collect();
        assert_eq!(z, vec![1, 2]);
        // A camera used along its line of sight leaves the depth of field.
        let mut swapped = seed_rig();
        swapped[0].id = 2;
        swapped[1].id = 1;
        let r = commission(&swapped, &CommissionOptions::default());
        assert!(
            r.warnings
                .iter()
                .any(|w| w.contains("outside its depth of field")),
            "{:?}",
            r.warnings
        );
        assert!(
            r.warnings.iter().any(|w| w.contains("closest to machine")),
            "{:?}",
            r.warnings
        );
    }

    #[test]
    fn depth_of_field_formula() {
        // f = 40 mm, f/8, c = 0.011 mm, s = 460 mm: H = 18222 mm.
        let d = depth_of_field(40.0, 8.0, 0.011, 460.0);
        let h = 40.0 * 40.0 / (8.0 * 0.011) + 40.0;
        assert!((d.near_mm - 460.0 * (h - 40.0) / (h + 460.0 - 80.0)).abs() < 1e-9);
        assert!((d.near_mm - 449.6).abs() < 0.1 && (d.far_mm.unwrap() - 470.9).abs() < 0.1);
        assert!(depth_of_field(40.0, 8.0, 0.011, 20000.0).far_mm.is_none());
    }
}
