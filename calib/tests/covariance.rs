//! The covariance of a calibrated camera's parameters (issue 25, point 3),
//! checked against known truth: synthetic calibrations of the seed rig's
//! cameras (the default 49-marker target, sphere markers, the true lens
//! distortion) from their exact images plus Gaussian centroid noise and,
//! for the target's part, Gaussian errors of the marker coordinates given to
//! the calibration. Over many noise seeds the actual error of the calibrated
//! camera — of its parameters (Mahalanobis distance, χ² with n dof) and of
//! its projection of points in the measurement volume — must agree with the
//! covariance.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use common::{mahalanobis, parameter_error};

use calib::{
    Layout, Model, Observation, Options, ParameterCovariance, TargetUncertainty, calibrate,
    parameter_covariance,
};
use geom::nalgebra::{DMatrix, DVector};
use geom::{Camera, Point2, Point3, Vector3};

/// Calibrations per scenario: 40 seeds × 3 cameras.
const SEEDS: u64 = 40;

struct Truth {
    cameras: Vec<Camera>,
    markers: Vec<synth::Marker>,
}

fn truth() -> Truth {
    let config = synth::Config::default();
    let rig = synth::SynthRig::from_config(&config).unwrap();
    Truth {
        cameras: rig.cameras.iter().map(|c| c.camera.clone()).collect(),
        markers: synth::markers(&config.target),
    }
}

/// A stream of standard normal deviates (Box–Muller on `common::uniform`).
fn normal(seed: u64) -> impl FnMut() -> f64 {
    let mut u = common::uniform(seed);
    move || {
        let (a, b) = (u().max(1e-300), u());
        (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
    }
}

/// The exact image of a sphere marker (its outline ellipse's centre, full lens model).
fn image_of(camera: &Camera, m: &synth::Marker) -> Point2<f64> {
    let e =
        geom::sphere_image::ellipse_centre(&camera.to_camera(&m.centre), m.diameter / 2.0).unwrap();
    camera.intrinsics.to_pixel(camera.distortion.distort(e))
}

/// Observations of `markers` by `camera`: images with pixel noise σ
/// (`pixel_px`), target coordinates as given to the calibration off by
/// Gaussian errors of σ `target_um` per coordinate.
fn observe(
    camera: &Camera,
    markers: &[synth::Marker],
    pixel_px: f64,
    target_um: f64,
    seed: u64,
) -> Vec<Observation> {
    let mut n = normal(seed);
    markers
        .iter()
        .map(|m| {
            let p = image_of(camera, m);
            let noise = Vector3::new(n(), n(), n()) * (target_um / 1000.0);
            Observation {
                id: m.id,
                world: m.centre + noise,
                pixel: Point2::new(p.x + pixel_px * n(), p.y + pixel_px * n()),
                sphere_diameter: Some(m.diameter),
            }
        })
        .collect()
}

/// ∂π(X)/∂δ of `camera.perturbed(names, δ)` at δ = 0 (central differences,
/// steps of 10⁻³ standard uncertainty): 2 × n.
fn projection_jacobian(
    camera: &Camera,
    cov: &ParameterCovariance,
    x: &Point3<f64>,
) -> DMatrix<f64> {
    let n = cov.names.len();
    let sd = cov.std_devs();
    let mut g = DMatrix::zeros(2, n);
    for j in 0..n {
        let h = 1e-3 * sd[j];
        let mut d = vec![0.0; n];
        d[j] = h;
        let plus = camera
            .perturbed(&cov.names, &d)
            .unwrap()
            .project(x)
            .unwrap();
        d[j] = -h;
        let minus = camera
            .perturbed(&cov.names, &d)
            .unwrap()
            .project(x)
            .unwrap();
        let col = (plus - minus) / (2.0 * h);
        g[(0, j)] = col.x;
        g[(1, j)] = col.y;
    }
    g
}

/// Points of the measurement volume: the target's bounding box (it spans
/// the spheres' travel), 8 pseudo-random points per seed.
fn volume_points(markers: &[synth::Marker], seed: u64) -> Vec<Point3<f64>> {
    let (mut lo, mut hi) = (Vector3::repeat(f64::MAX), Vector3::repeat(f64::MIN));
    for m in markers {
        lo = lo.inf(&m.centre.coords);
        hi = hi.sup(&m.centre.coords);
    }
    let mut u = common::uniform(seed ^ 0x5eed);
    (0..8)
        .map(|_| Point3::from(lo + (hi - lo).component_mul(&Vector3::new(u(), u(), u()))))
        .collect()
}

/// What a scenario's calibrations gave.
#[derive(Default)]
struct Agreement {
    /// χ²/n of each calibration's parameter error.
    chi2_per_dof: Vec<f64>,
    /// The same under the covariance that counts the target twice (s² + target part).
    chi2_double_counted: Vec<f64>,
    /// Each projected coordinate's error over its predicted standard uncertainty.
    normalised: Vec<f64>,
}

impl Agreement {
    fn mean_chi2(&self) -> f64 {
        self.chi2_per_dof.iter().sum::<f64>() / self.chi2_per_dof.len() as f64
    }

    fn mean_double_counted(&self) -> f64 {
        self.chi2_double_counted.iter().sum::<f64>() / self.chi2_double_counted.len() as f64
    }

    fn within_k2(&self) -> f64 {
        self.normalised.iter().filter(|z| z.abs() <= 2.0).count() as f64
            / self.normalised.len() as f64
    }
}

/// Calibrate every camera for every seed and compare the actual errors
/// with the covariance (target uncertainty declared = the one applied).
fn scenario(truth: &Truth, pixel_px: f64, target_um: f64) -> Agreement {
    let mut out = Agreement::default();
    let declared = TargetUncertainty::uniform(target_um, "test");
    for seed in 0..SEEDS {
        for (k, camera) in truth.cameras.iter().enumerate() {
            let stream = 1000 * seed + k as u64 + (target_um * 1e3) as u64;
            let obs = observe(camera, &truth.markers, pixel_px, target_um, stream);
            let cal = calibrate(&obs, camera.width, camera.height, &Options::default()).unwrap();
            let cov = parameter_covariance(&cal, &obs, &declared)
                .unwrap()
                .expect("determined");
            let delta = parameter_error(&cov.names, &cal.camera, camera);
            let n = cov.names.len() as f64;
            out.chi2_per_dof.push(mahalanobis(&cov.total, &delta) / n);
            let (s2, sigma2) = (cov.residual_sigma_px.powi(2), cov.image_sigma_px.powi(2));
            if sigma2 > 0.0 {
                let doubled = &cov.target + (&cov.total - &cov.target) * (s2 / sigma2);
                out.chi2_double_counted
                    .push(mahalanobis(&doubled, &delta) / n);
            }
            for x in volume_points(&truth.markers, stream) {
                let Ok(actual) = cal.camera.project(&x) else {
                    continue;
                };
                let e = actual - camera.project(&x).unwrap();
                let g = projection_jacobian(&cal.camera, &cov, &x);
                let predicted = &g * &cov.total * g.transpose();
                out.normalised.push(e.x / predicted[(0, 0)].sqrt());
                out.normalised.push(e.y / predicted[(1, 1)].sqrt());
            }
        }
    }
    out
}

/// The acceptance of a scenario: mean χ²/n within its sampling band (sd
/// √(2/(n·N)) ≈ 0.035 for n = 14, N = 120: ±0.15 is > 4 sd) and 92–98 % of
/// the projected coordinates within ±2 predicted standard uncertainties.
fn assert_agrees(name: &str, a: &Agreement) {
    let (chi2, k2) = (a.mean_chi2(), a.within_k2());
    println!(
        "{name}: {} calibrations, mean χ²/n = {chi2:.3} (counting the target twice: {:.3}); \
         {:.1} % of {} projected coordinates within k = 2",
        a.chi2_per_dof.len(),
        a.mean_double_counted(),
        100.0 * k2,
        a.normalised.len()
    );
    assert!(a.chi2_per_dof.len() >= 100);
    assert!((0.85..=1.15).contains(&chi2), "{name}: mean χ²/n {chi2}");
    assert!((0.92..=0.98).contains(&k2), "{name}: {k2} within k = 2");
}

#[test]
fn covariance_agrees_with_the_actual_errors_of_image_noise() {
    let truth = truth();
    assert_agrees("image noise 0.02 px", &scenario(&truth, 0.02, 0.0));
}

#[test]
fn covariance_agrees_with_the_actual_errors_of_target_and_image_noise() {
    let truth = truth();
    // 2 µm ≈ 0.035 px at these cameras' ≈ 17 px/mm: as large as the image noise.
    let both = scenario(&truth, 0.02, 2.0);
    assert_agrees("image 0.02 px + target 2 µm", &both);
    // The target dominant: 3 µm ≈ 0.05 px against 0.005 px of image noise.
    let target = scenario(&truth, 0.005, 3.0);
    assert_agrees("image 0.005 px + target 3 µm", &target);
    // Counting the target's share of the residuals twice would inflate the
    // covariance: the actual errors would be far inside it.
    assert!(
        target.mean_double_counted() < 0.7,
        "{}",
        target.mean_double_counted()
    );
}

/// Predicted standard uncertainty (px, RMS over u and v and the volume's
/// points) of the projection of points in the measurement volume.
fn projection_sd(
    camera: &Camera,
    cov: &DMatrix<f64>,
    names: &ParameterCovariance,
    x: &[Point3<f64>],
) -> f64 {
    let var: f64 = x
        .iter()
        .map(|p| {
            let g = projection_jacobian(camera, names, p);
            (&g * cov * g.transpose()).trace() / 2.0
        })
        .sum();
    (var / x.len() as f64).sqrt()
}

#[test]
fn fewer_markers_and_a_larger_target_uncertainty_give_a_larger_covariance() {
    let truth = truth();
    let camera = &truth.cameras[1];
    let points = volume_points(&truth.markers, 7);
    let obs = observe(camera, &truth.markers, 0.02, 0.0, 7);
    let fit = |obs: &[Observation], target: &TargetUncertainty| {
        let cal = calibrate(obs, camera.width, camera.height, &Options::default()).unwrap();
        let cov = parameter_covariance(&cal, obs, target).unwrap().unwrap();
        (cal, cov)
    };
    let none = TargetUncertainty::uniform(0.0, "none");
    let (cal, all) = fit(&obs, &none);
    let sd_all = projection_sd(&cal.camera, &all.total, &all, &points);
    // Every third marker: 17 of 49, still spanning the target's depth.
    let few: Vec<Observation> = obs.iter().step_by(3).copied().collect();
    let (cal_few, fewer) = fit(&few, &none);
    let sd_few = projection_sd(&cal_few.camera, &fewer.total, &fewer, &points);
    println!("projected point sd: 49 markers {sd_all:.5} px, 17 markers {sd_few:.5} px");
    assert!(sd_few > 1.3 * sd_all, "{sd_few} vs {sd_all}");
    assert_eq!(all.target.norm(), 0.0);

    // A stated target uncertainty within what the residuals show splits the
    // covariance (nothing counted twice): the total stays, the target part appears.
    let (_, one) = fit(&obs, &TargetUncertainty::uniform(1.0, "1 µm"));
    let sd_one = projection_sd(&cal.camera, &one.total, &one, &points);
    let sd_one_target = projection_sd(&cal.camera, &one.target, &one, &points);
    println!("1 µm stated: total {sd_one:.5} px, of it the target {sd_one_target:.5} px");
    assert!((sd_one / sd_all - 1.0).abs() < 0.1, "{sd_one} vs {sd_all}");
    assert!(sd_one_target > 0.2 * sd_one && sd_one_target < sd_one);
    assert!(one.image_sigma_px < one.residual_sigma_px);

    // One beyond them (20 µm ≈ 0.34 px against 0.02 px of residuals) makes it
    // larger, and all of it is the target's.
    let (_, twenty) = fit(&obs, &TargetUncertainty::uniform(20.0, "20 µm"));
    let sd_twenty = projection_sd(&cal.camera, &twenty.total, &twenty, &points);
    println!("20 µm stated: total {sd_twenty:.5} px");
    assert!(sd_twenty > 5.0 * sd_all, "{sd_twenty} vs {sd_all}");
    assert!(twenty.target_exceeds_residuals());
    assert!((&twenty.total - &twenty.target).norm() <= 1e-12 * twenty.total.norm());
    // The target part grows as u²: 20² / 1² = 400.
    let ratio = twenty.target.norm() / one.target.norm();
    assert!((ratio / 400.0 - 1.0).abs() < 1e-9, "{ratio}");
    assert_eq!(twenty.target_uncertainty_um, 20.0);
}

#[test]
fn a_draw_applied_by_perturbed_is_refines_own_parameter_step() {
    let truth = truth();
    let camera = &truth.cameras[2];
    let layout = Layout {
        model: Model::K1K2P1P2,
        k3: true,
        skew: true,
    };
    let names = layout.names();
    let mut n = normal(11);
    // A small step of every parameter (rotation 1e-4 rad, t 0.01 mm, …).
    let scale = |name: &str| match name {
        "fx" | "fy" | "cx" | "cy" | "skew" => 0.5,
        "rx" | "ry" | "rz" => 1e-4,
        "tx" | "ty" | "tz" => 0.01,
        _ => 1e-4,
    };
    let delta: Vec<f64> = names.iter().map(|s| scale(s) * n()).collect();
    let by_refine = layout.unpack(
        &(layout.pack(camera) + DVector::from_column_slice(&delta)),
        &camera.rotation(),
        camera.width,
        camera.height,
    );
    let by_perturbed = camera.perturbed(&names, &delta).unwrap();
    let (ka, kb) = (by_refine.intrinsics, by_perturbed.intrinsics);
    let (da, db) = (by_refine.distortion, by_perturbed.distortion);
    for (x, y) in [
        (ka.fx, kb.fx),
        (ka.fy, kb.fy),
        (ka.cx, kb.cx),
        (ka.cy, kb.cy),
        (ka.skew, kb.skew),
        (da.k1, db.k1),
        (da.k2, db.k2),
        (da.p1, db.p1),
        (da.p2, db.p2),
        (da.k3, db.k3),
    ] {
        assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0), "{x} {y}");
    }
    let dr = (by_refine.rotation().matrix() - by_perturbed.rotation().matrix()).amax();
    let dt = (by_refine.translation() - by_perturbed.translation()).amax();
    assert!(
        dr <= 1e-12 && dt <= 1e-12 * camera.translation().amax(),
        "{dr} {dt}"
    );
    // The projection of a target point agrees too.
    let m = &truth.markers[0];
    let d = by_refine.project(&m.centre).unwrap() - by_perturbed.project(&m.centre).unwrap();
    assert!(d.amax() < 1e-9, "{d}");
}

#[test]
fn covariance_round_trips_through_rig_json() {
    let truth = truth();
    let camera = &truth.cameras[0];
    let obs = observe(camera, &truth.markers, 0.02, 0.0, 3);
    let cal = calibrate(&obs, camera.width, camera.height, &Options::default()).unwrap();
    let cov = parameter_covariance(
        &cal,
        &obs,
        &TargetUncertainty::uniform(0.5, "--target-uncertainty-um 0.5"),
    )
    .unwrap()
    .unwrap();
    let mut entry = formats::RigCamera::new(1, &cal.camera, cal.rms_px, cal.points_used());
    entry.covariance = Some(cov.record());
    let rig = formats::Rig {
        cameras: vec![entry],
    };
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("rig.json");
    formats::write_json(&path, &rig).unwrap();
    let back = formats::read_rig(&path).unwrap();
    let c = back.cameras[0].covariance.as_ref().unwrap();
    // serde_json reads a float back to within an ulp.
    let close = |a: &DMatrix<f64>, b: &DMatrix<f64>| (a - b).amax() <= 1e-15 * b.amax();
    assert!(close(&c.to_matrix().unwrap(), &cov.total));
    assert!(close(&c.target_matrix().unwrap(), &cov.target));
    assert!(cov.target.amax() > 0.0 && cov.target != cov.total);
    assert_eq!(
        c.parameters,
        [
            "fx", "fy", "cx", "cy", "rx", "ry", "rz", "tx", "ty", "tz", "k1", "k2", "p1", "p2"
        ]
    );
    assert_eq!(c.target_uncertainty_um, 0.5);
    assert_eq!(c.target_uncertainty_source, "--target-uncertainty-um 0.5");
}

#[test]
fn a_bad_target_uncertainty_is_named_with_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("target.csv");
    for (bad, shown) in [("-0.001", "-0.001"), ("nan", "NaN"), ("inf", "inf")] {
        std::fs::write(
            &path,
            format!("id,x,y,z,diameter,u_mm\n1,0,0,0,3,0.001\n2,10,0,5,3,{bad}\n"),
        )
        .unwrap();
        let e = formats::read_target(&path).unwrap_err().to_string();
        assert!(
            e.contains("target.csv: line 3, column 'u_mm'")
                && e.contains(&format!(
                    "standard uncertainty {shown} is not a finite number ≥ 0"
                )),
            "{e}"
        );
    }
    // A good column is read per marker; markers without a figure take the default.
    std::fs::write(&path, "id,x,y,z,u_mm\n1,0,0,0,0.002\n2,10,0,5,\n").unwrap();
    let rows: Vec<formats::TargetRow> = formats::read_target(&path)
        .unwrap()
        .into_iter()
        .map(|r| r.record)
        .collect();
    assert_eq!(rows[0].u_mm, Some(0.002));
    assert_eq!(rows[1].u_mm, None);
    let t = TargetUncertainty::resolve(&rows, None).unwrap();
    assert_eq!(t.of_um(1), 2.0);
    assert_eq!(t.of_um(2), calib::DEFAULT_TARGET_UNCERTAINTY_UM);
    assert!(
        t.source.contains("target.csv u_mm (1 of 2 markers)"),
        "{}",
        t.source
    );
    // The option overrides the column; a bad option value is an error.
    let t = TargetUncertainty::resolve(&rows, Some(0.5)).unwrap();
    assert_eq!((t.of_um(1), t.of_um(2)), (0.5, 0.5));
    assert_eq!(t.source, "--target-uncertainty-um 0.5");
    assert!(TargetUncertainty::resolve(&rows, Some(f64::NAN)).is_err());
    let t = TargetUncertainty::resolve(&rows[1..], None).unwrap();
    assert!(t.source.starts_with("default 1 µm"), "{}", t.source);
}
