//! Degenerate and bad inputs (issue 5, point 3): each is an error whose
//! message says what is wrong, never a panic or a wrong calibration.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use calib::{
    CalibError, CorrespondOptions, Marker, Observation, Options, calibrate, correspond,
    observations,
};
use formats::{CorrespondenceRow, TargetRow};
use geom::{Camera, Intrinsics, Point2, Point3, Vector3};

/// A camera 500 mm above the origin looking down, 2000×1500 px, fx 2000 px.
fn down_camera(offset: Vector3<f64>) -> Camera {
    let c = Point3::new(0.0, 0.0, 500.0) + offset;
    Camera::look_at(
        c,
        c - Vector3::z() * 500.0,
        Vector3::y(),
        Intrinsics::centred(2000.0, 2000, 1500),
        2000,
        1500,
    )
    .unwrap()
}

/// A 3-D target: 6×6 markers, 20 mm pitch, heights 0…50 mm in a Latin-square pattern.
fn target() -> Vec<Marker> {
    grid(6, 20.0, |i, j| 10.0 * f64::from((i + 2 * j) % 6))
}

/// An n×n grid of markers of `pitch` (mm) centred on the origin, ids row by
/// row from 1, marker (i, j) at height `height(i, j)` (mm).
fn grid(n: u32, pitch: f64, height: impl Fn(u32, u32) -> f64) -> Vec<Marker> {
    let half = pitch * f64::from(n - 1) / 2.0;
    let mut v = Vec::new();
    for i in 0..n {
        for j in 0..n {
            v.push(Marker {
                id: i * n + j + 1,
                centre: Point3::new(
                    pitch * f64::from(i) - half,
                    pitch * f64::from(j) - half,
                    height(i, j),
                ),
            });
        }
    }
    v
}

fn images(cam: &Camera, markers: &[Marker]) -> Vec<Point2<f64>> {
    markers
        .iter()
        .map(|m| cam.project(&m.centre).unwrap())
        .collect()
}

fn obs(markers: &[Marker], cam: &Camera) -> Vec<Observation> {
    markers
        .iter()
        .map(|m| Observation {
            id: m.id,
            world: m.centre,
            pixel: cam.project(&m.centre).unwrap(),
            sphere_diameter: None,
        })
        .collect()
}

#[test]
fn good_input_works() {
    // The fixtures themselves are sound: the failures below are due to the defect each adds.
    let cam = down_camera(Vector3::zeros());
    let t = target();
    let c = correspond(
        &t,
        &images(&cam, &t),
        &down_camera(Vector3::new(4.0, -3.0, 2.0)),
        &CorrespondOptions::default(),
    )
    .unwrap();
    assert_eq!(c.matches.len(), 36);
    assert!(c.matches.iter().all(|m| t[m.detection].id == m.id));
    let cal = calibrate(&obs(&t, &cam), 2000, 1500, &Options::default()).unwrap();
    assert!(cal.rms_px < 1e-6);
}

#[test]
fn fewer_than_six_points() {
    let cam = down_camera(Vector3::zeros());
    let t = target();
    let e = calibrate(&obs(&t[..5], &cam), 2000, 1500, &Options::default()).unwrap_err();
    assert_eq!(e.to_string(), "calibration needs at least 6 points, got 5");

    // Five detections in the image.
    let e = correspond(
        &t,
        &images(&cam, &t[..5]),
        &cam,
        &CorrespondOptions::default(),
    )
    .unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::TooFewDetections {
                detections: 5,
                needed: 6
            }
        ),
        "{e}"
    );
    assert!(
        e.to_string().contains("only 5 markers were detected"),
        "{e}"
    );

    // Ten blobs, of which only five are markers: five matches are not enough.
    let mut dets = images(&cam, &[t[0], t[7], t[14], t[21], t[35]]);
    dets.extend(
        [
            [1900.0, 100.0],
            [100.0, 1400.0],
            [1950.0, 1450.0],
            [60.0, 40.0],
            [1000.0, 1480.0],
        ]
        .map(|p| Point2::new(p[0], p[1])),
    );
    let e = correspond(&t, &dets, &cam, &CorrespondOptions::default()).unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::TooFewMatches {
                matched: 5,
                needed: 6,
                detections: 10,
                markers: 36
            }
        ),
        "{e}"
    );
    assert!(
        e.to_string()
            .starts_with("only 5 target markers could be matched to the 10 detections"),
        "{e}"
    );
}

#[test]
fn coplanar_target() {
    let cam = down_camera(Vector3::zeros());
    let flat: Vec<Marker> = target()
        .into_iter()
        .map(|m| Marker {
            centre: Point3::new(m.centre.x, m.centre.y, 5.0),
            ..m
        })
        .collect();
    let e = calibrate(&obs(&flat, &cam), 2000, 1500, &Options::default()).unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::Coplanar {
                kind: "coplanar",
                ..
            }
        ),
        "{e}"
    );
    assert!(
        e.to_string().starts_with("the target points are coplanar"),
        "{e}"
    );
    let e = correspond(
        &flat,
        &images(&cam, &flat),
        &cam,
        &CorrespondOptions::default(),
    )
    .unwrap_err();
    assert!(
        e.to_string().starts_with("the target points are coplanar"),
        "{e}"
    );

    // 0.2 mm of relief over a 100 mm target is not a 3-D target either.
    let thin: Vec<Marker> = target()
        .into_iter()
        .map(|m| Marker {
            centre: Point3::new(m.centre.x, m.centre.y, m.centre.z * 0.004),
            ..m
        })
        .collect();
    let e = calibrate(&obs(&thin, &cam), 2000, 1500, &Options::default()).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("the target points are nearly coplanar"),
        "{e}"
    );
}

/// A periodic target (heights alternate with the parity of i + j) seen with a
/// nominal camera half a period off: two assignments, one diagonal step
/// apart, fit the image exactly.
#[test]
fn ambiguous_assignment() {
    let lattice = grid(10, 15.0, |i, j| 10.0 * f64::from((i + j) % 2));
    let cam = down_camera(Vector3::zeros());
    // Only the central 8×8 markers are detected.
    let central: Vec<Marker> = lattice
        .iter()
        .filter(|m| {
            let (i, j) = ((m.id - 1) / 10, (m.id - 1) % 10);
            (1..9).contains(&i) && (1..9).contains(&j)
        })
        .copied()
        .collect();
    let nominal = down_camera(Vector3::new(7.5, 7.5, 0.0));
    let e = correspond(
        &lattice,
        &images(&cam, &central),
        &nominal,
        &CorrespondOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, CalibError::Ambiguous(_)), "{e}");
    assert!(e.to_string().starts_with("the marker assignment is ambiguous: two different assignments fit the image equally well"), "{e}");
    // With the nominal camera close enough the same image is not ambiguous.
    let c = correspond(
        &lattice,
        &images(&cam, &central),
        &down_camera(Vector3::new(2.0, -1.0, 0.0)),
        &CorrespondOptions::default(),
    );
    let c = c.unwrap();
    assert_eq!(c.matches.len(), 64);
}

/// Two blobs on one marker (a split or doubled blob): the assignment of that marker is a guess.
#[test]
fn two_detections_on_one_marker() {
    let cam = down_camera(Vector3::zeros());
    let t = target();
    let mut dets = images(&cam, &t);
    dets.push(dets[7] + geom::Vector2::new(0.6, -0.4));
    let e = correspond(&t, &dets, &cam, &CorrespondOptions::default()).unwrap_err();
    assert!(
        e.to_string()
            .contains(&format!("marker {} has two detections within the", t[7].id)),
        "{e}"
    );
}

/// The image of another camera (or of another scene) fits no camera.
#[test]
fn wrong_image() {
    let t = target();
    // The target seen from the side: its image is a different pattern.
    let side = Camera::look_at(
        Point3::new(-500.0, 0.0, 25.0),
        Point3::new(0.0, 0.0, 25.0),
        Vector3::z(),
        Intrinsics::centred(2000.0, 2000, 1500),
        2000,
        1500,
    )
    .unwrap();
    let down = down_camera(Vector3::zeros());
    let e = correspond(&t, &images(&side, &t), &down, &CorrespondOptions::default()).unwrap_err();
    assert_wrong_image(&e);
    // Random blobs.
    let mut next = common::uniform(99);
    let noise: Vec<Point2<f64>> = (0..40)
        .map(|_| Point2::new(next() * 1999.0, next() * 1499.0))
        .collect();
    let e = correspond(&t, &noise, &down, &CorrespondOptions::default()).unwrap_err();
    assert_wrong_image(&e);
}

#[test]
fn missing_and_nan_rows() {
    let cam = down_camera(Vector3::zeros());
    let t = target();
    let mut o = obs(&t, &cam);
    o[4].pixel.y = f64::NAN;
    let e = calibrate(&o, 2000, 1500, &Options::default()).unwrap_err();
    assert_eq!(
        e.to_string(),
        format!("point {}: v = NaN is not a finite number", t[4].id)
    );

    let rows: Vec<TargetRow> = t
        .iter()
        .map(|m| TargetRow {
            id: m.id,
            x: m.centre.x,
            y: m.centre.y,
            z: m.centre.z,
            diameter: Some(3.0),
            u_mm: None,
        })
        .collect();
    let mut points: Vec<CorrespondenceRow> = t
        .iter()
        .map(|m| {
            let p = cam.project(&m.centre).unwrap();
            CorrespondenceRow {
                id: m.id,
                u: p.x,
                v: p.y,
            }
        })
        .collect();
    let good = observations(&rows, &points, true).unwrap();
    assert_eq!(good[0].sphere_diameter, Some(3.0));
    points[3].id = 99;
    assert_eq!(
        observations(&rows, &points, true).unwrap_err().to_string(),
        "marker id 99 is not on the target"
    );
    points[3].id = points[2].id;
    assert_eq!(
        observations(&rows, &points, true).unwrap_err().to_string(),
        format!("marker id {} occurs more than once", points[2].id)
    );
    // A target row missing its id's marker: the correspondences name an absent id.
    let short = &rows[1..];
    points[3].id = rows[3].id;
    assert_eq!(
        observations(short, &points, false).unwrap_err().to_string(),
        format!("marker id {} is not on the target", rows[0].id)
    );

    // NaN in target.csv is caught while reading, with file, line and column.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("target.csv");
    std::fs::write(&path, "id,x,y,z,diameter\n1,0,0,0,3\n2,10,0,nan,3\n").unwrap();
    let e = formats::read_csv::<TargetRow>(&path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("target.csv: line 3, column 'z'") && e.contains("not a finite number"),
        "{e}"
    );
}

#[test]
fn bad_options() {
    let cam = down_camera(Vector3::zeros());
    let o = obs(&target(), &cam);
    let bad = Options {
        model: calib::Model::Pinhole,
        k3: true,
        ..Options::default()
    };
    let e = calibrate(&o, 2000, 1500, &bad).unwrap_err();
    assert!(e.to_string().contains("k3 needs a radial model"), "{e}");
    let bad = Options {
        outlier_k: Some(0.5),
        ..Options::default()
    };
    assert!(
        calibrate(&o, 2000, 1500, &bad)
            .unwrap_err()
            .to_string()
            .contains("outlier k")
    );
    assert!(calibrate(&o, 0, 1500, &Options::default()).is_err());
}

/// The error for an image no camera near the nominal one explains.
fn assert_wrong_image(e: &CalibError) {
    println!("{e}");
    assert!(
        matches!(
            e,
            CalibError::Inconsistent { .. } | CalibError::FarFromNominal { .. }
        ),
        "{e}"
    );
    assert!(
        e.to_string()
            .contains("is this the right image for this camera"),
        "{e}"
    );
}
