//! Export of a calibrated camera in OpenCV's `FileStorage` YAML format, as
//! `cv::FileStorage` writes it (`%YAML:1.0`, `!!opencv-matrix` with rows, cols,
//! dt, data; doubles as `%.16e`, integral doubles as `1.`), with the keys of
//! OpenCV's calibration sample: `camera_matrix`, `distortion_coefficients`
//! (5×1: k1, k2, p1, p2, k3), plus `rvec`, `tvec` (target → camera, as
//! `cv::calibrateCamera` returns them) and the projection matrix.
//! The conventions are OpenCV's own: pixel (0, 0) is the centre of the
//! top-left pixel, and the distortion has OpenCV's coefficient names and signs.

use std::fmt::Write;

use geom::Camera;

/// Line length past which a flow sequence wraps (OpenCV's `wrap_margin`).
const WRAP_MARGIN: usize = 71;

/// A double as OpenCV writes it: `%d.` when integral, else `%.16e` with a
/// two-digit signed exponent; `.Nan`, `.Inf`, `-.Inf` otherwise.
pub fn format_double(v: f64) -> String {
    if v.is_nan() {
        return ".Nan".into();
    }
    if v.is_infinite() {
        return if v > 0.0 {
            ".Inf".into()
        } else {
            "-.Inf".into()
        };
    }
    if v == v.round() && v.abs() < 2_147_483_648.0 {
        return format!("{}.", v as i64);
    }
    let s = format!("{v:.16e}");
    let (mantissa, exponent) = s.split_once('e').unwrap_or((&s, "0"));
    let e: i32 = exponent.parse().unwrap_or(0);
    format!("{mantissa}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
}

/// One `!!opencv-matrix` node of doubles (`dt: d`), row-major.
fn matrix(out: &mut String, key: &str, rows: usize, cols: usize, data: &[f64]) {
    let _ = writeln!(out, "{key}: !!opencv-matrix");
    let _ = writeln!(out, "   rows: {rows}");
    let _ = writeln!(out, "   cols: {cols}");
    let _ = writeln!(out, "   dt: d");
    let mut line = String::from("   data: [");
    for (i, v) in data.iter().enumerate() {
        let item = format_double(*v);
        if i > 0 {
            line.push(',');
        }
        if i > 0 && line.len() + item.len() > WRAP_MARGIN {
            let _ = writeln!(out, "{line}");
            line = String::from("       ");
        } else {
            line.push(' ');
        }
        line.push_str(&item);
    }
    let _ = writeln!(out, "{line} ]");
}

/// The camera as an OpenCV YAML file. `calibration_time` is written as a
/// string when given; `rms_px` becomes `avg_reprojection_error`.
pub fn opencv_yaml(id: u8, camera: &Camera, rms_px: f64, calibration_time: Option<&str>) -> String {
    let mut out = String::from("%YAML:1.0\n---\n");
    if let Some(t) = calibration_time {
        let _ = writeln!(out, "calibration_time: \"{}\"", t.replace('"', "'"));
    }
    let _ = writeln!(out, "camera_id: {id}");
    let _ = writeln!(out, "image_width: {}", camera.width);
    let _ = writeln!(out, "image_height: {}", camera.height);
    let k = camera.intrinsics.matrix();
    matrix(
        &mut out,
        "camera_matrix",
        3,
        3,
        &[0, 1, 2]
            .map(|i| [k[(i, 0)], k[(i, 1)], k[(i, 2)]])
            .concat(),
    );
    matrix(
        &mut out,
        "distortion_coefficients",
        5,
        1,
        &camera.distortion.to_opencv(),
    );
    let rvec = camera.rotation().scaled_axis();
    matrix(&mut out, "rvec", 3, 1, rvec.as_slice());
    matrix(&mut out, "tvec", 3, 1, camera.translation().as_slice());
    let p = camera.projection_matrix();
    let p: Vec<f64> = (0..3)
        .flat_map(|i| (0..4).map(move |j| p[(i, j)]))
        .collect();
    matrix(&mut out, "projection_matrix", 3, 4, &p);
    let _ = writeln!(out, "avg_reprojection_error: {}", format_double(rms_px));
    out
}

#[cfg(test)]
// Values copied digit for digit from files OpenCV wrote.
#[allow(clippy::excessive_precision)]
mod tests {
    use super::*;
    use geom::{Distortion, Intrinsics, Isometry3, Vector3};

    /// The `data` values of a matrix node, parsed back.
    fn data(text: &str, key: &str) -> (usize, usize, Vec<f64>) {
        let start = text.find(&format!("{key}: !!opencv-matrix")).unwrap();
        let node = &text[start..];
        let field = |name: &str| -> usize {
            let i = node.find(&format!("   {name}: ")).unwrap() + name.len() + 5;
            node[i..].lines().next().unwrap().trim().parse().unwrap()
        };
        let open = node.find('[').unwrap();
        let close = node.find(']').unwrap();
        let values = node[open + 1..close]
            .split(',')
            .map(|v| v.trim().parse::<f64>().unwrap())
            .collect();
        (field("rows"), field("cols"), values)
    }

    #[test]
    fn writes_what_opencv_writes_and_round_trips_exactly() {
        let camera = Camera {
            intrinsics: Intrinsics {
                fx: 1037.3795012345678,
                fy: 1034.0181,
                cx: 367.31429,
                cy: 306.63207,
                skew: 0.0,
            },
            distortion: Distortion {
                k1: -0.21822,
                k2: 0.21427,
                k3: 0.0,
                p1: 8.1e-5,
                p2: -2.9e-4,
            },
            pose: Isometry3::new(
                Vector3::new(-0.63, -100.45, 316.96),
                Vector3::new(0.24457, -0.76436, -0.13457),
            ),
            width: 768,
            height: 576,
        };
        let y = opencv_yaml(1, &camera, 0.072, Some("2026-01-01T00:00:00"));
        assert!(y.starts_with("%YAML:1.0\n---\n"));
        assert!(y.contains("image_width: 768\nimage_height: 576\n"));
        assert!(y.contains("camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1.0373795012345679e+03, 0., 3.6731429000000003e+02"), "{y}");
        for line in y.lines() {
            assert!(line.len() <= WRAP_MARGIN + 24, "line too long: {line}");
        }
        let (r, c, k) = data(&y, "camera_matrix");
        assert_eq!((r, c), (3, 3));
        let km = camera.intrinsics.matrix();
        for i in 0..9 {
            assert_eq!(k[i], km[(i / 3, i % 3)]);
        }
        let (r, c, d) = data(&y, "distortion_coefficients");
        assert_eq!((r, c), (5, 1));
        assert_eq!(d, camera.distortion.to_opencv().to_vec());
        let (_, _, rv) = data(&y, "rvec");
        let (_, _, tv) = data(&y, "tvec");
        let pose = Isometry3::new(
            Vector3::new(tv[0], tv[1], tv[2]),
            Vector3::new(rv[0], rv[1], rv[2]),
        );
        assert!((pose.to_homogeneous() - camera.pose.to_homogeneous()).norm() < 1e-14);
        let (r, c, p) = data(&y, "projection_matrix");
        assert_eq!((r, c, p.len()), (3, 4, 12));
        assert!(
            y.ends_with("avg_reprojection_error: 7.1999999999999995e-02\n"),
            "{y}"
        );
    }

    #[test]
    fn doubles_are_formatted_like_opencv() {
        assert_eq!(format_double(0.0), "0.");
        assert_eq!(format_double(1.0), "1.");
        assert_eq!(format_double(-3.0), "-3.");
        assert_eq!(format_double(535.91573396163199), "5.3591573396163199e+02");
        assert_eq!(
            format_double(-2.6637260909660682e-01),
            "-2.6637260909660682e-01"
        );
        assert_eq!(format_double(1.5e-120), "1.5000000000000001e-120");
        assert_eq!(format_double(f64::NAN), ".Nan");
        assert_eq!(format_double(f64::NEG_INFINITY), "-.Inf");
    }
}
