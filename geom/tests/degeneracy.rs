//! The texts of `GeomError::Degenerate`: each reason's words are written once,
//! in `Degeneracy`, and are pinned here exactly as the free-form messages they
//! replace read (one row per reason, a few reached through the public API).

use geom::fit::{line_3d, plane, sphere};
use geom::interp::{Grid3, linear};
use geom::transform::rigid_fit;
use geom::{Camera, Degeneracy, GeomError, Intrinsics, Point3, PrincipalSpread, Vector3};

fn text(reason: Degeneracy) -> String {
    GeomError::Degenerate(reason).to_string()
}

#[test]
fn every_reason_reads_as_before() {
    let rows = [
        (
            Degeneracy::LengthsDiffer {
                what: None,
                first: 3,
                first_items: "knots",
                second: 2,
                second_items: "values",
            },
            "3 knots but 2 values",
        ),
        (
            Degeneracy::LengthsDiffer {
                what: Some("rigid fit"),
                first: 4,
                first_items: "source points",
                second: 5,
                second_items: "target points",
            },
            "rigid fit: 4 source points but 5 target points",
        ),
        (
            Degeneracy::GridValues {
                dims: [2, 3, 4],
                got: 5,
            },
            "grid of 2×3×4 nodes needs 24 values, got 5",
        ),
        (
            Degeneracy::OutsideRange {
                x: 5.5,
                first: 0.0,
                last: 3.0,
            },
            "5.5 outside the interpolation range [0, 3]",
        ),
        (
            Degeneracy::OutsideGrid {
                point: [1.0, 2.5, -3.0],
            },
            "point [1.0, 2.5, -3.0] outside the interpolation grid",
        ),
        (
            Degeneracy::KnotsNotIncreasing,
            "interpolation knots must increase strictly",
        ),
        (
            Degeneracy::KnotsOutsidePeriod,
            "periodic knots must lie in [0, period)",
        ),
        (
            Degeneracy::GridTooSmall,
            "a trilinear grid needs ≥ 2 nodes per axis",
        ),
        (
            Degeneracy::GridStepNotPositive,
            "grid steps must be positive",
        ),
        (
            Degeneracy::Coincide {
                what: "algebraic sphere",
            },
            "algebraic sphere: all points coincide",
        ),
        (
            Degeneracy::SetCoincides { set: "image" },
            "all image points coincide",
        ),
        (
            Degeneracy::Collinear { what: "rigid fit" },
            "rigid fit: points are collinear",
        ),
        (
            Degeneracy::CollinearOrCoincide {
                what: "cylinder fit",
            },
            "cylinder fit: the points are collinear or coincide",
        ),
        (
            Degeneracy::SameX {
                what: "line y = kx + b",
            },
            "line y = kx + b: all points have the same x",
        ),
        (
            Degeneracy::NoSingleDirection {
                what: "plane fit",
                spread: PrincipalSpread::Least,
            },
            "plane fit: no single direction of least spread",
        ),
        (
            Degeneracy::NoSingleDirection {
                what: "3-D line fit",
                spread: PrincipalSpread::Largest,
            },
            "3-D line fit: no single direction of largest spread",
        ),
        (
            Degeneracy::Isotropic {
                what: "2-D line fit",
            },
            "2-D line fit: the points spread equally in every direction",
        ),
        (
            Degeneracy::Underdetermined {
                what: "algebraic circle",
            },
            "algebraic circle: the points do not determine the element",
        ),
        (
            Degeneracy::NoRealElement {
                what: "algebraic circle",
                element: "circle",
            },
            "algebraic circle: no real circle",
        ),
        (Degeneracy::NoStartAxis, "cylinder fit: no start axis found"),
        (
            Degeneracy::SvdFailed { what: "rigid fit" },
            "rigid fit: SVD failed",
        ),
        (
            Degeneracy::NoSingularVectors,
            "singular value decomposition returned no vectors",
        ),
        (Degeneracy::SvdNotConverged, "SVD did not converge"),
        (
            Degeneracy::SolveFailed {
                what: "Gauss–Newton step",
                reason: "SVD solve: U and V^t have not been computed.",
            },
            "Gauss–Newton step: SVD solve: U and V^t have not been computed.",
        ),
        (
            Degeneracy::MultipleSolutions,
            "the linear system has more than one solution (critical configuration)",
        ),
        (
            Degeneracy::LpFailed(microlp::Error::Infeasible),
            "flatness linear programme failed: problem is infeasible",
        ),
        (
            Degeneracy::LpInterrupted,
            "flatness linear programme was interrupted",
        ),
        (
            Degeneracy::Singular {
                matrix: "distortion Jacobian",
            },
            "singular distortion Jacobian",
        ),
        (Degeneracy::SingularRq, "RQ of a singular matrix"),
        (
            Degeneracy::SingularProjection,
            "projection matrix has a singular left 3×3 block",
        ),
        (
            Degeneracy::NotIntrinsic,
            "intrinsic matrix is not upper triangular with K[2][2] ≠ 0",
        ),
        (
            Degeneracy::FocalNotPositive,
            "focal lengths must be positive",
        ),
        (
            Degeneracy::LooksAtItself,
            "camera looks at its own position",
        ),
        (
            Degeneracy::UpAlongAxis,
            "camera up vector is parallel to its optical axis",
        ),
        (
            Degeneracy::DistortionFolds { u: 1.26, v: -2.0 },
            "distortion folds the image at (1.3, -2.0) px",
        ),
        (
            Degeneracy::RadiusNotPositive { radius: -2.5 },
            "sphere radius -2.5 mm is not positive",
        ),
        (
            Degeneracy::SphereNotInFront,
            "sphere is not wholly in front of the camera (its image is not an ellipse)",
        ),
        (
            Degeneracy::CameraInsideSphere,
            "camera is inside the sphere",
        ),
    ];
    for (reason, expected) in rows {
        assert_eq!(text(reason), format!("degenerate input: {expected}"));
    }
}

#[test]
fn public_computations_name_their_reason() {
    let e = linear(&[0.0, 1.0, 3.0], &[1.0, 2.0, 4.0], 3.5).unwrap_err();
    assert_eq!(
        e,
        GeomError::Degenerate(Degeneracy::OutsideRange {
            x: 3.5,
            first: 0.0,
            last: 3.0
        })
    );
    assert_eq!(
        e.to_string(),
        "degenerate input: 3.5 outside the interpolation range [0, 3]"
    );

    let e = linear(&[0.0, 1.0], &[1.0, 2.0, 4.0], 0.5).unwrap_err();
    assert_eq!(e.to_string(), "degenerate input: 2 knots but 3 values");

    let grid = Grid3::new(
        Point3::origin(),
        Vector3::new(1.0, 1.0, 1.0),
        [2, 2, 2],
        vec![0.0; 8],
    )
    .unwrap();
    assert_eq!(
        grid.trilinear(&Point3::new(0.5, 2.0, 0.0))
            .unwrap_err()
            .to_string(),
        "degenerate input: point [0.5, 2.0, 0.0] outside the interpolation grid"
    );

    let p = Point3::new(1.0, 2.0, 3.0);
    assert_eq!(
        sphere(&[p; 5]).unwrap_err().to_string(),
        "degenerate input: algebraic sphere: all points coincide"
    );
    assert_eq!(
        line_3d(&[p, p]).unwrap_err(),
        GeomError::Degenerate(Degeneracy::Coincide {
            what: "3-D line fit"
        })
    );
    let line: Vec<_> = (0..5).map(|k| Point3::new(k as f64, 0.0, 0.0)).collect();
    assert_eq!(
        plane(&line).unwrap_err().to_string(),
        "degenerate input: plane fit: the points are collinear or coincide"
    );
    assert_eq!(
        rigid_fit(&line, &line[..4]).unwrap_err().to_string(),
        "degenerate input: rigid fit: 5 source points but 4 target points"
    );
    assert_eq!(
        rigid_fit(&line, &line).unwrap_err(),
        GeomError::Degenerate(Degeneracy::Collinear { what: "rigid fit" })
    );

    let k = Intrinsics::centred(1000.0, 640, 480);
    let e = Camera::look_at(p, p, Vector3::y(), k, 640, 480).unwrap_err();
    assert_eq!(
        e.to_string(),
        "degenerate input: camera looks at its own position"
    );
}
