//! Levenberg–Marquardt refinement of one camera on reprojection error
//! (Hartley & Zisserman §7.2; Brown distortion as in OpenCV's
//! `calibrateCamera`), with an analytic Jacobian.
//!
//! Parameters, in this order: `fx, fy, cx, cy, [skew], ωx, ωy, ωz, tx, ty,
//! tz, [k1, k2], [p1, p2], [k3]`. The rotation is `R = exp([ω]×)·R₀` with R₀
//! the starting rotation, so ω is a small rotation about the camera's own
//! axes (rad) and never meets the singularity of a rotation vector at π.
//!
//! A marker may be a sphere of radius ρ: its image is an ellipse whose centre
//! is `e = (Cx, Cy)·Cz/(Cz² − ρ²)` in normalised coordinates
//! ([`geom::sphere_image::ellipse_centre`]), not the projected centre
//! `(Cx, Cy)/Cz`. The model predicts `e` (ρ = 0 gives the point model), so
//! the centroids need no correction.

use geom::lm::Residuals;
use geom::nalgebra::{
    DMatrix, DVector, Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion,
};
use geom::sphere_image::ellipse_centre_jacobian;
use geom::{Camera, Distortion, Intrinsics, Point2, Point3, Vector2, Vector3};

use crate::{CalibError, OptionProblem, Result};

/// Lens distortion model (`--model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Model {
    /// No distortion.
    Pinhole,
    /// Radial k1, k2.
    K1K2,
    /// Radial k1, k2 and tangential p1, p2.
    K1K2P1P2,
}

impl Model {
    /// Name as on the command line: `pinhole`, `k1k2`, `k1k2p1p2`.
    pub fn name(self) -> &'static str {
        match self {
            Model::Pinhole => "pinhole",
            Model::K1K2 => "k1k2",
            Model::K1K2P1P2 => "k1k2p1p2",
        }
    }
}

impl std::str::FromStr for Model {
    type Err = CalibError;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "pinhole" => Ok(Model::Pinhole),
            "k1k2" => Ok(Model::K1K2),
            "k1k2p1p2" => Ok(Model::K1K2P1P2),
            other => Err(CalibError::Option(OptionProblem::Model(other.to_string()))),
        }
    }
}

impl std::fmt::Display for Model {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which parameters the refinement estimates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Distortion model.
    pub model: Model,
    /// Estimate k3 (radial r⁶) as well; needs a radial model.
    pub k3: bool,
    /// Estimate the skew `K[0][1]`; otherwise it is held at 0.
    pub skew: bool,
}

/// Index of the first rotation parameter without skew.
const ROTATION: usize = 4;

impl Layout {
    /// Check the combination (k3 needs k1, k2).
    pub fn validate(&self) -> Result<()> {
        if self.k3 && self.model == Model::Pinhole {
            return Err(CalibError::Option(OptionProblem::K3WithoutRadial));
        }
        Ok(())
    }

    fn rotation(&self) -> usize {
        ROTATION + usize::from(self.skew)
    }

    /// Index of `tx` (then `ty`, `tz`).
    pub(crate) fn translation_index(&self) -> usize {
        self.rotation() + 3
    }

    fn radial(&self) -> Option<usize> {
        (self.model != Model::Pinhole).then(|| self.rotation() + 6)
    }

    fn tangential(&self) -> Option<usize> {
        (self.model == Model::K1K2P1P2).then(|| self.rotation() + 8)
    }

    fn k3_index(&self) -> Option<usize> {
        self.k3.then(|| self.len() - 1)
    }

    /// Number of parameters.
    pub fn len(&self) -> usize {
        let d = match self.model {
            Model::Pinhole => 0,
            Model::K1K2 => 2,
            Model::K1K2P1P2 => 4,
        };
        self.rotation() + 6 + d + usize::from(self.k3)
    }

    /// Always false: a camera has at least ten parameters.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Parameter names in order (`rx, ry, rz` are the small rotation ω about
    /// the camera axes, rad; `tx, ty, tz` mm; the rest px or dimensionless).
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = vec!["fx", "fy", "cx", "cy"];
        if self.skew {
            v.push("skew");
        }
        v.extend(["rx", "ry", "rz", "tx", "ty", "tz"]);
        if self.radial().is_some() {
            v.extend(["k1", "k2"]);
        }
        if self.tangential().is_some() {
            v.extend(["p1", "p2"]);
        }
        if self.k3 {
            v.push("k3");
        }
        v
    }

    /// Parameter vector of a camera, with ω = 0 (the camera's rotation is R₀).
    pub fn pack(&self, camera: &Camera) -> DVector<f64> {
        let k = camera.intrinsics;
        let d = camera.distortion;
        let mut p = DVector::zeros(self.len());
        p[0] = k.fx;
        p[1] = k.fy;
        p[2] = k.cx;
        p[3] = k.cy;
        if self.skew {
            p[4] = k.skew;
        }
        let r = self.rotation();
        p.fixed_rows_mut::<3>(r + 3)
            .copy_from(&camera.translation());
        if let Some(i) = self.radial() {
            p[i] = d.k1;
            p[i + 1] = d.k2;
        }
        if let Some(i) = self.tangential() {
            p[i] = d.p1;
            p[i + 1] = d.p2;
        }
        if let Some(i) = self.k3_index() {
            p[i] = d.k3;
        }
        p
    }

    /// The camera of a parameter vector, with rotation `exp([ω]×)·R₀`.
    pub fn unpack(&self, p: &DVector<f64>, r0: &Rotation3<f64>, width: u32, height: u32) -> Camera {
        let r = self.rotation();
        let omega = Vector3::new(p[r], p[r + 1], p[r + 2]);
        let t = Vector3::new(p[r + 3], p[r + 4], p[r + 5]);
        let rotation = Rotation3::new(omega) * r0;
        let (k1, k2) = self.radial().map_or((0.0, 0.0), |i| (p[i], p[i + 1]));
        let (p1, p2) = self.tangential().map_or((0.0, 0.0), |i| (p[i], p[i + 1]));
        let k3 = self.k3_index().map_or(0.0, |i| p[i]);
        Camera {
            intrinsics: Intrinsics {
                fx: p[0],
                fy: p[1],
                cx: p[2],
                cy: p[3],
                skew: if self.skew { p[4] } else { 0.0 },
            },
            distortion: Distortion { k1, k2, k3, p1, p2 },
            pose: Isometry3::from_parts(
                Translation3::from(t),
                UnitQuaternion::from_rotation_matrix(&rotation),
            ),
            width,
            height,
        }
    }
}

/// Skew-symmetric matrix `[a]×` with `[a]×·b = a × b`.
pub(crate) fn cross_matrix(a: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0)
}

/// Left Jacobian of SO(3): `J(ω) = I + (1 − cos θ)/θ²·[ω]× + (θ − sin θ)/θ³·[ω]×²`,
/// so that `∂(exp([ω]×)·y)/∂ω = −[exp([ω]×)·y]×·J(ω)` (Barfoot, *State
/// Estimation for Robotics*, §7.1.5).
pub(crate) fn left_jacobian(omega: &Vector3<f64>) -> Matrix3<f64> {
    let theta2 = omega.norm_squared();
    let (a, b) = if theta2 < 1e-8 {
        (0.5 - theta2 / 24.0, 1.0 / 6.0 - theta2 / 120.0)
    } else {
        let theta = theta2.sqrt();
        (
            (1.0 - theta.cos()) / theta2,
            (theta - theta.sin()) / (theta2 * theta),
        )
    };
    let w = cross_matrix(omega);
    Matrix3::identity() + w * a + w * w * b
}

/// Reprojection residuals of one camera: for each point, predicted pixel
/// minus observed pixel (u then v), under a [`Layout`].
#[derive(Debug, Clone)]
pub struct Reprojection<'a> {
    /// Free parameters.
    pub layout: Layout,
    /// Starting rotation R₀.
    pub r0: Rotation3<f64>,
    /// Marker centres (target frame, mm).
    pub world: &'a [Point3<f64>],
    /// Observed centroids (px).
    pub image: &'a [Point2<f64>],
    /// Marker sphere radius per point (mm; 0 for a point marker).
    pub radius: &'a [f64],
}

impl Reprojection<'_> {
    /// Residual of point `i` and, when asked, its two Jacobian rows.
    fn point(
        &self,
        p: &DVector<f64>,
        i: usize,
        jac: Option<(&mut DMatrix<f64>, usize)>,
    ) -> Vector2<f64> {
        let projected = project(
            &self.layout,
            &self.r0,
            p,
            0,
            &self.world[i],
            self.radius[i],
            jac.map(|(m, row)| (m, row, 0)),
        );
        projected.map_or(Vector2::new(f64::NAN, f64::NAN), |(pixel, _)| {
            pixel - self.image[i].coords
        })
    }
}

/// The pixel a camera predicts for marker `world` of radius `radius` (its
/// image ellipse's centre; a point for 0), the camera's parameters at
/// `p[col..col + layout.len()]` in [`Layout`] order with rotation
/// `exp([ω]×)·r0`, and `∂pixel/∂world`; when asked, the derivatives with
/// respect to those parameters written into rows `row, row + 1` at columns
/// `col…` of a Jacobian. `None` for a marker behind the camera.
pub(crate) fn project(
    l: &Layout,
    r0: &Rotation3<f64>,
    p: &DVector<f64>,
    col: usize,
    world: &Point3<f64>,
    radius: f64,
    jac: Option<(&mut DMatrix<f64>, usize, usize)>,
) -> Option<(Vector2<f64>, geom::nalgebra::Matrix2x3<f64>)> {
    let r = l.rotation();
    let q = |j: usize| p[col + j];
    let omega = Vector3::new(q(r), q(r + 1), q(r + 2));
    let t = Vector3::new(q(r + 3), q(r + 4), q(r + 5));
    let rotation = Rotation3::new(omega) * r0;
    let z = Rotation3::new(omega) * (r0 * world.coords);
    let c = z + t;
    let (e, de_dc) = ellipse_centre_jacobian(&c, radius).ok()?;
    let (k1, k2) = l.radial().map_or((0.0, 0.0), |j| (q(j), q(j + 1)));
    let (p1, p2) = l.tangential().map_or((0.0, 0.0), |j| (q(j), q(j + 1)));
    let k3 = l.k3_index().map_or(0.0, &q);
    let dist = Distortion { k1, k2, k3, p1, p2 };
    let d = dist.distort(e);
    let skew = if l.skew { q(4) } else { 0.0 };
    let (fx, fy) = (q(0), q(1));
    let pred = Vector2::new(fx * d.x + skew * d.y + q(2), fy * d.y + q(3));
    // ∂pixel/∂d = [[fx, skew], [0, fy]].
    let dpix_dd = geom::nalgebra::Matrix2::new(fx, skew, 0.0, fy);
    let dd_de = dist.jacobian(e);
    let dpix_dc = dpix_dd * dd_de * de_dc;
    if let Some((jm, row, col)) = jac {
        let dc_domega = -cross_matrix(&z) * left_jacobian(&omega);
        let dpix_domega = dpix_dc * dc_domega;
        // Intrinsics.
        jm[(row, col)] = d.x;
        jm[(row + 1, col + 1)] = d.y;
        jm[(row, col + 2)] = 1.0;
        jm[(row + 1, col + 3)] = 1.0;
        if l.skew {
            jm[(row, col + 4)] = d.y;
        }
        for k in 0..3 {
            jm[(row, col + r + k)] = dpix_domega[(0, k)];
            jm[(row + 1, col + r + k)] = dpix_domega[(1, k)];
            jm[(row, col + r + 3 + k)] = dpix_dc[(0, k)];
            jm[(row + 1, col + r + 3 + k)] = dpix_dc[(1, k)];
        }
        let (x, y) = (e.x, e.y);
        let r2 = x * x + y * y;
        // ∂d/∂(distortion coefficient), mapped to pixels.
        let mut coefficient = |j: usize, ddx: f64, ddy: f64| {
            jm[(row, col + j)] = fx * ddx + skew * ddy;
            jm[(row + 1, col + j)] = fy * ddy;
        };
        if let Some(j) = l.radial() {
            coefficient(j, x * r2, y * r2);
            coefficient(j + 1, x * r2 * r2, y * r2 * r2);
        }
        if let Some(j) = l.tangential() {
            coefficient(j, 2.0 * x * y, r2 + 2.0 * y * y);
            coefficient(j + 1, r2 + 2.0 * x * x, 2.0 * x * y);
        }
        if let Some(j) = l.k3_index() {
            let r6 = r2 * r2 * r2;
            coefficient(j, x * r6, y * r6);
        }
    }
    Some((pred, dpix_dc * rotation.matrix()))
}

impl Residuals for Reprojection<'_> {
    fn residuals(&self, p: &DVector<f64>) -> DVector<f64> {
        let mut out = DVector::zeros(2 * self.world.len());
        for i in 0..self.world.len() {
            let r = self.point(p, i, None);
            out[2 * i] = r.x;
            out[2 * i + 1] = r.y;
        }
        out
    }

    fn jacobian(&self, p: &DVector<f64>) -> DMatrix<f64> {
        let mut j = DMatrix::zeros(2 * self.world.len(), self.layout.len());
        for i in 0..self.world.len() {
            self.point(p, i, Some((&mut j, 2 * i)));
        }
        j
    }
}

/// A refined camera and what the solver knows about it.
#[derive(Debug, Clone)]
pub struct Refined {
    /// The camera at the minimum.
    pub camera: Camera,
    /// Standard deviation per parameter (in [`Layout::names`] order), from
    /// `s²·(JᵀJ)⁻¹`; `None` without redundancy or with a singular `JᵀJ`.
    pub std_devs: Option<Vec<f64>>,
}

/// Minimise the reprojection error of the points from `start` (Levenberg–Marquardt,
/// MINPACK `lmder`), estimating the parameters of `layout`; parameters not in
/// the layout are held at zero.
pub fn refine(
    layout: Layout,
    start: &Camera,
    world: &[Point3<f64>],
    image: &[Point2<f64>],
    radius: &[f64],
) -> Result<Refined> {
    layout.validate()?;
    let r0 = start.rotation();
    let problem = Reprojection {
        layout,
        r0,
        world,
        image,
        radius,
    };
    let solution = geom::lm::minimize(
        &problem,
        layout.pack(start),
        &geom::lm::LmOptions::default(),
    )
    .map_err(CalibError::geom("Levenberg–Marquardt refinement"))?;
    let camera = layout.unpack(&solution.params, &r0, start.width, start.height);
    Ok(Refined {
        camera,
        std_devs: solution.std_devs().map(|s| s.iter().copied().collect()),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::lm::jacobian_error;

    fn scene() -> (Camera, Vec<Point3<f64>>) {
        let cam = Camera {
            intrinsics: Intrinsics {
                fx: 1500.0,
                fy: 1490.0,
                cx: 640.0,
                cy: 470.0,
                skew: 0.4,
            },
            distortion: Distortion {
                k1: -0.2,
                k2: 0.15,
                k3: -0.03,
                p1: 1e-3,
                p2: -7e-4,
            },
            pose: Isometry3::new(
                Vector3::new(-30.0, 10.0, 500.0),
                Vector3::new(2.9, 0.4, -0.3),
            ),
            width: 1280,
            height: 960,
        };
        let mut world = Vec::new();
        for i in 0..5 {
            for j in 0..5 {
                world.push(Point3::new(
                    40.0 * f64::from(i) - 80.0,
                    40.0 * f64::from(j) - 80.0,
                    25.0 * f64::from((i + 2 * j) % 4),
                ));
            }
        }
        (cam, world)
    }

    #[test]
    fn analytic_jacobian_matches_central_differences() {
        let (cam, world) = scene();
        let image: Vec<_> = world.iter().map(|x| cam.project(x).unwrap()).collect();
        let radius: Vec<f64> = (0..world.len()).map(|i| 1.5 * (i % 3) as f64).collect();
        for model in [Model::Pinhole, Model::K1K2, Model::K1K2P1P2] {
            for (k3, skew) in [(false, false), (true, true), (false, true)] {
                if k3 && model == Model::Pinhole {
                    continue;
                }
                let layout = Layout { model, k3, skew };
                let r0 = Rotation3::new(Vector3::new(0.1, -0.2, 0.3)) * cam.rotation();
                let problem = Reprojection {
                    layout,
                    r0,
                    world: &world,
                    image: &image,
                    radius: &radius,
                };
                let mut p = layout.pack(&cam);
                // A rotation increment away from zero exercises the full left Jacobian.
                let r = layout.rotation();
                p[r] = -0.1;
                p[r + 1] = 0.2;
                p[r + 2] = -0.3;
                let err = jacobian_error(&problem, &p);
                assert!(
                    err < 1e-6,
                    "{model} k3 {k3} skew {skew}: Jacobian error {err}"
                );
            }
        }
    }

    #[test]
    fn refinement_recovers_the_camera_from_a_perturbed_start() {
        let (cam, world) = scene();
        let radius = vec![2.0; world.len()];
        // Observations: the centres of the spheres' outline ellipses.
        let image: Vec<_> = world
            .iter()
            .map(|x| {
                let c = cam.to_camera(x);
                let e = geom::sphere_image::ellipse_centre(&c, 2.0).unwrap();
                cam.intrinsics.to_pixel(cam.distortion.distort(e))
            })
            .collect();
        let mut start = cam.clone();
        start.intrinsics.fx *= 1.01;
        start.intrinsics.cy += 5.0;
        start.distortion = Distortion::NONE;
        start.pose = Isometry3::new(
            Vector3::new(-28.0, 12.0, 505.0),
            Vector3::new(2.91, 0.39, -0.31),
        );
        let layout = Layout {
            model: Model::K1K2P1P2,
            k3: true,
            skew: true,
        };
        let out = refine(layout, &start, &world, &image, &radius).unwrap();
        let c = &out.camera;
        let rms = (world
            .iter()
            .zip(&image)
            .map(|(x, p)| {
                let e = geom::sphere_image::ellipse_centre(&c.to_camera(x), 2.0).unwrap();
                (c.intrinsics.to_pixel(c.distortion.distort(e)) - p).norm_squared()
            })
            .sum::<f64>()
            / world.len() as f64)
            .sqrt();
        assert!(rms < 1e-8, "rms {rms}");
        assert!((out.camera.intrinsics.fx - cam.intrinsics.fx).abs() < 1e-6);
        assert!((out.camera.distortion.k1 - cam.distortion.k1).abs() < 1e-8);
        assert!((out.camera.centre() - cam.centre()).norm() < 1e-6);
        assert_eq!(layout.names().len(), layout.len());
        assert_eq!(layout.names()[4], "skew");
    }

    #[test]
    fn k3_without_radial_terms_is_an_option_error() {
        let l = Layout {
            model: Model::Pinhole,
            k3: true,
            skew: false,
        };
        assert!(l.validate().unwrap_err().to_string().contains("k3"));
        assert!(
            "fisheye"
                .parse::<Model>()
                .unwrap_err()
                .to_string()
                .contains("fisheye")
        );
    }
}
