//! The least-squares fits against the NIST Algorithm Testing System reference
//! pairs in `testdata/nist-fits/` (see its README.md for provenance): every
//! Line2d, Line3d, Plane, Circle3d, Sphere and Cylinder pair must agree with
//! NIST's `.fit` to 1e-9 mm in position and diameter and 1e-9 rad in direction.
//!
//! The Cone pairs are not checked: `geom` has no cone fit.
//!
//! Positions are compared where they are defined: for lines, planes and
//! cylinders the distance of NIST's point from the fitted line, plane or axis
//! (where along it the point sits is a convention); for circles and spheres the
//! centres themselves. Directions and normals are compared without sign.
//! Run with `--nocapture` to see the largest deviation of each quantity.

// Test helpers: a panic here is a test failure naming the file.
#![allow(clippy::unwrap_used)]

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use formats::read_ds;
use geom::fit;
use geom::{Point2, Point3, Vector3};

/// Largest accepted deviation of a position or a diameter (mm).
const TOLERANCE_MM: f64 = 1e-9;
/// Largest accepted deviation of a direction (rad).
const TOLERANCE_RAD: f64 = 1e-9;
/// Size of the deliberate error in the sensitivity checks (mm).
const PERTURBATION_MM: f64 = 1e-4;

/// One reference pair: the points of `NAME.ds` and the numbers of `NAME.fit`.
struct Case {
    name: String,
    points: Vec<Point3<f64>>,
    reference: Vec<f64>,
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../testdata/nist-fits")
}

fn parse_fit(path: &Path) -> Vec<f64> {
    let text = fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .map(|l| {
            l.trim()
                .parse()
                .unwrap_or_else(|e| panic!("{}: {l:?}: {e}", path.display()))
        })
        .collect()
}

/// The pairs of one kind, which must be exactly `expected` (file stems).
fn cases(kind: &str, expected: &[&str], fit_len: usize) -> Vec<Case> {
    let dir = data_dir().join(kind);
    let mut found: Vec<String> = fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "ds"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    found.sort();
    let mut wanted: Vec<String> = expected.iter().map(|s| s.to_string()).collect();
    wanted.sort();
    assert_eq!(found, wanted, "{kind}: data sets present");
    wanted
        .into_iter()
        .map(|name| {
            let points = read_ds(&dir.join(format!("{name}.ds"))).unwrap();
            let reference = parse_fit(&dir.join(format!("{name}.fit")));
            assert_eq!(reference.len(), fit_len, "{kind}/{name}.fit");
            Case {
                name,
                points,
                reference,
            }
        })
        .collect()
}

fn vec3(v: &[f64]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

/// Angle between two lines (sign-insensitive), accurate for small angles.
fn angle(u: &Vector3<f64>, v: &Vector3<f64>) -> f64 {
    u.cross(v).norm().atan2(u.dot(v).abs())
}

/// Distance of `q` from the line through `p` along `d`.
fn line_distance(q: &Point3<f64>, p: &Point3<f64>, d: &Vector3<f64>) -> f64 {
    (q - p).cross(d).norm() / d.norm()
}

/// Named deviations `(quantity, value, tolerance)` of a fit from its reference.
type Deviations = Vec<(&'static str, f64, f64)>;

/// Deviations of each case, with the largest per quantity; panics naming every
/// set and quantity out of tolerance.
fn check_all(kind: &str, cases: &[Case], deviations: impl Fn(&Case) -> Result<Deviations, String>) {
    let mut failures = Vec::new();
    let mut largest: BTreeMap<&str, (f64, String)> = BTreeMap::new();
    for case in cases {
        match deviations(case) {
            Err(e) => failures.push(format!("{kind}/{}: fit failed: {e}", case.name)),
            Ok(devs) => {
                for (quantity, value, tolerance) in devs {
                    if value.is_nan() || value > tolerance {
                        failures.push(format!(
                            "{kind}/{}: {quantity} deviates by {value:e} (tolerance {tolerance:e})",
                            case.name
                        ));
                    }
                    let entry = largest
                        .entry(quantity)
                        .or_insert((f64::NEG_INFINITY, String::new()));
                    if value > entry.0 {
                        *entry = (value, case.name.clone());
                    }
                }
            }
        }
    }
    for (quantity, (value, name)) in &largest {
        println!("{kind}: largest {quantity} deviation {value:.3e} ({name})");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The one coordinate that is the same for every point of a Line2d set.
fn constant_axis(points: &[Point3<f64>]) -> Option<usize> {
    (0..3).find(|&k| points.iter().all(|p| p[k] == points[0][k]))
}

fn line2d_deviations(case: &Case) -> Result<Deviations, String> {
    let axis = constant_axis(&case.points).ok_or("no constant coordinate")?;
    let (i, j) = ((axis + 1) % 3, (axis + 2) % 3);
    let flat: Vec<Point2<f64>> = case
        .points
        .iter()
        .map(|p| Point2::new(p[i], p[j]))
        .collect();
    let fit2 = fit::line_2d(&flat).map_err(|e| e.to_string())?;
    let lift = |a: f64, b: f64, c: f64| {
        let mut v = Vector3::zeros();
        v[axis] = c;
        v[i] = a;
        v[j] = b;
        v
    };
    let point2 = Point3::from(lift(fit2.point.x, fit2.point.y, case.points[0][axis]));
    let dir2 = lift(fit2.direction.x, fit2.direction.y, 0.0);
    let fit3 = fit::line_3d(&case.points).map_err(|e| e.to_string())?;
    let (p_ref, d_ref) = (
        Point3::from(vec3(&case.reference[..3])),
        vec3(&case.reference[3..6]),
    );
    Ok(vec![
        (
            "2-D point",
            line_distance(&p_ref, &point2, &dir2),
            TOLERANCE_MM,
        ),
        ("2-D direction", angle(&dir2, &d_ref), TOLERANCE_RAD),
        (
            "3-D point",
            line_distance(&p_ref, &fit3.point, &fit3.direction),
            TOLERANCE_MM,
        ),
        (
            "3-D direction",
            angle(&fit3.direction, &d_ref),
            TOLERANCE_RAD,
        ),
        (
            "reference cosine on the constant axis",
            d_ref[axis].abs(),
            0.0,
        ),
    ])
}

fn line3d_deviations(case: &Case) -> Result<Deviations, String> {
    let fit = fit::line_3d(&case.points).map_err(|e| e.to_string())?;
    let (p_ref, d_ref) = (
        Point3::from(vec3(&case.reference[..3])),
        vec3(&case.reference[3..6]),
    );
    Ok(vec![
        (
            "point",
            line_distance(&p_ref, &fit.point, &fit.direction),
            TOLERANCE_MM,
        ),
        ("direction", angle(&fit.direction, &d_ref), TOLERANCE_RAD),
    ])
}

fn plane_deviations(case: &Case) -> Result<Deviations, String> {
    let fit = fit::plane(&case.points).map_err(|e| e.to_string())?;
    let (p_ref, n_ref) = (
        Point3::from(vec3(&case.reference[..3])),
        vec3(&case.reference[3..6]),
    );
    Ok(vec![
        (
            "point",
            (p_ref - fit.point).dot(&fit.normal).abs(),
            TOLERANCE_MM,
        ),
        ("normal", angle(&fit.normal, &n_ref), TOLERANCE_RAD),
    ])
}

fn circle3d_deviations(case: &Case) -> Result<Deviations, String> {
    let fit = fit::circle_3d(&case.points).map_err(|e| e.to_string())?;
    let r = &case.reference;
    Ok(vec![
        (
            "centre",
            (fit.centre - Point3::from(vec3(&r[..3]))).norm(),
            TOLERANCE_MM,
        ),
        ("normal", angle(&fit.normal, &vec3(&r[3..6])), TOLERANCE_RAD),
        ("diameter", (fit.diameter - r[6]).abs(), TOLERANCE_MM),
    ])
}

fn sphere_deviations(case: &Case) -> Result<Deviations, String> {
    let fit = fit::sphere(&case.points).map_err(|e| e.to_string())?;
    let r = &case.reference;
    Ok(vec![
        (
            "centre",
            (fit.centre - Point3::from(vec3(&r[..3]))).norm(),
            TOLERANCE_MM,
        ),
        ("diameter", (fit.diameter - r[3]).abs(), TOLERANCE_MM),
    ])
}

fn cylinder_deviations(case: &Case) -> Result<Deviations, String> {
    let fit = fit::cylinder(&case.points).map_err(|e| e.to_string())?;
    let r = &case.reference;
    let p_ref = Point3::from(vec3(&r[..3]));
    Ok(vec![
        (
            "axis point",
            line_distance(&p_ref, &fit.point, &fit.direction),
            TOLERANCE_MM,
        ),
        (
            "axis direction",
            angle(&fit.direction, &vec3(&r[3..6])),
            TOLERANCE_RAD,
        ),
        ("diameter", (fit.diameter - r[6]).abs(), TOLERANCE_MM),
    ])
}

const LINE2D: [&str; 12] = [
    "lin2d1", "lin2d2", "lin2d3", "lin2d9", "lin2d10", "lin2d11", "lin2d12", "lin2d16", "lin2d17",
    "lin2d19", "lin2d21", "lin2d27",
];
const LINE3D: [&str; 3] = ["lin3", "lin8", "lin17"];
const PLANE: [&str; 4] = ["pla7", "pla8", "pla22", "pla26"];
const CIRCLE3D: [&str; 6] = ["cir5", "cir7", "cir10", "cir20", "cir22", "cir25"];
const SPHERE: [&str; 6] = ["sph5", "sph11", "sph14", "sph16", "sph20", "sph22"];
const CYLINDER: [&str; 3] = ["cyl21", "cyl23", "cyl29"];

#[test]
fn line2d_matches_nist() {
    check_all("Line2d", &cases("Line2d", &LINE2D, 6), line2d_deviations);
}

#[test]
fn line3d_matches_nist() {
    check_all("Line3d", &cases("Line3d", &LINE3D, 6), line3d_deviations);
}

#[test]
fn plane_matches_nist() {
    check_all("Plane", &cases("Plane", &PLANE, 6), plane_deviations);
}

#[test]
fn circle3d_matches_nist() {
    check_all(
        "Circle3d",
        &cases("Circle3d", &CIRCLE3D, 7),
        circle3d_deviations,
    );
}

#[test]
fn sphere_matches_nist() {
    check_all("Sphere", &cases("Sphere", &SPHERE, 4), sphere_deviations);
}

#[test]
fn cylinder_matches_nist() {
    check_all(
        "Cylinder",
        &cases("Cylinder", &CYLINDER, 7),
        cylinder_deviations,
    );
}

/// The comparison is sharp enough to see a small error in the data: moving one
/// point of every set by [`PERTURBATION_MM`] must push some quantity of that
/// set out of tolerance.
#[test]
fn a_perturbed_point_is_detected() {
    type Check = fn(&Case) -> Result<Deviations, String>;
    let kinds: [(&str, &[&str], usize, Check); 6] = [
        ("Line2d", &LINE2D, 6, line2d_deviations),
        ("Line3d", &LINE3D, 6, line3d_deviations),
        ("Plane", &PLANE, 6, plane_deviations),
        ("Circle3d", &CIRCLE3D, 7, circle3d_deviations),
        ("Sphere", &SPHERE, 4, sphere_deviations),
        ("Cylinder", &CYLINDER, 7, cylinder_deviations),
    ];
    for (kind, names, fit_len, deviations) in kinds {
        for mut case in cases(kind, names, fit_len) {
            // Move the first point along the two coordinates that vary in a
            // Line2d set (and along all three elsewhere).
            let fixed = if kind == "Line2d" {
                constant_axis(&case.points)
            } else {
                None
            };
            for k in (0..3).filter(|&k| Some(k) != fixed) {
                case.points[0][k] += PERTURBATION_MM * (k as f64 + 1.0);
            }
            let devs = deviations(&case).unwrap();
            assert!(
                devs.iter().any(|(_, value, tolerance)| value > tolerance),
                "{kind}/{}: a {PERTURBATION_MM} mm error went unnoticed: {devs:?}",
                case.name
            );
        }
    }
}
