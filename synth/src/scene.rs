//! What the cameras look at: self-luminous spheres, and their analytic
//! images — silhouette cones, outline points, ellipse centres, separations —
//! the independent truth the renderer is checked against.

use geom::nalgebra::{Point2, Point3, Vector2, Vector3};
use geom::{Camera, sphere_image};

use crate::{Result, SynthError};

/// Number of outline points used for bounding boxes and frame checks.
pub(crate) const OUTLINE_POINTS: usize = 256;

/// A self-luminous sphere of uniform radiance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre, world frame (mm).
    pub centre: Point3<f64>,
    /// Radius (mm).
    pub radius: f64,
    /// Signal of a fully covered pixel (electrons per exposure).
    pub radiance_e: f64,
}

/// A sphere as one camera sees it: its silhouette cone `angle(ray, axis) ≤ half_angle`
/// in the camera frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewedSphere {
    /// Centre in the camera frame (mm).
    pub centre: Vector3<f64>,
    /// Radius (mm).
    pub radius: f64,
    /// Unit direction from the projection centre to the sphere centre.
    pub axis: Vector3<f64>,
    /// Half-angle of the silhouette cone, `asin(R/|C|)` (rad).
    pub half_angle: f64,
}

impl ViewedSphere {
    /// The sphere in `camera`'s frame; fails if the camera is inside it or the
    /// silhouette cone is not wholly in front of the image plane.
    pub fn new(camera: &Camera, sphere: &Sphere) -> Result<Self> {
        if !(sphere.radius.is_finite() && sphere.radius > 0.0) {
            return Err(SynthError::SphereRadius(sphere.radius));
        }
        let c = camera.to_camera(&sphere.centre).coords;
        let d = c.norm();
        if d.is_nan() || d <= sphere.radius {
            return Err(SynthError::CameraInsideSphere(sphere.centre.into()));
        }
        let axis = c / d;
        let half_angle = (sphere.radius / d).asin();
        // Every silhouette ray must point forward: angle(axis, z) + α < 90°, with margin.
        let off_axis = axis.z.clamp(-1.0, 1.0).acos();
        if off_axis + half_angle >= 80f64.to_radians() {
            return Err(SynthError::BehindCamera(sphere.centre.into()));
        }
        Ok(Self {
            centre: c,
            radius: sphere.radius,
            axis,
            half_angle,
        })
    }

    /// Angle between a camera-frame ray direction `d` (any length) and the cone axis.
    pub fn angle(&self, d: &Vector3<f64>) -> f64 {
        d.cross(&self.axis).norm().atan2(d.dot(&self.axis))
    }

    /// Signed angular distance of ray `d` from the silhouette (rad, negative inside).
    pub fn signed_angle(&self, d: &Vector3<f64>) -> f64 {
        self.angle(d) - self.half_angle
    }

    /// Unit directions of `n` rays on the silhouette cone.
    pub fn outline_rays(&self, n: usize) -> Vec<Vector3<f64>> {
        let a = self.axis;
        let helper = if a.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let e1 = a.cross(&helper).normalize();
        let e2 = a.cross(&e1);
        let (s, c) = self.half_angle.sin_cos();
        (0..n)
            .map(|k| {
                let phi = std::f64::consts::TAU * k as f64 / n as f64;
                a * c + (e1 * phi.cos() + e2 * phi.sin()) * s
            })
            .collect()
    }

    /// Whether `self` and `other` (both seen by the same camera, not
    /// intersecting) have overlapping silhouettes, and if so whether `other`
    /// is in front. Two disjoint spheres are separated by a plane; the one on
    /// the camera's side of it occludes the other wherever they overlap.
    pub fn occluded_by(&self, other: &ViewedSphere) -> bool {
        let between = self.axis.dot(&other.axis).clamp(-1.0, 1.0).acos();
        if between >= self.half_angle + other.half_angle {
            return false;
        }
        let d = other.centre - self.centre;
        let dist = d.norm();
        let n = d / dist;
        // Mid-plane between the two surfaces along the line of centres.
        let p = self.centre + n * (self.radius + (dist - self.radius - other.radius) / 2.0);
        // Camera (the origin) on other's side ⇔ (0 − p)·n > 0.
        -p.dot(&n) > 0.0
    }
}

/// Observed (distorted) pixel of a camera-frame direction.
pub(crate) fn direction_to_pixel(camera: &Camera, d: &Vector3<f64>) -> Point2<f64> {
    let n = Vector2::new(d.x / d.z, d.y / d.z);
    camera.intrinsics.to_pixel(camera.distortion.distort(n))
}

/// Points of a sphere's observed outline (distorted image, px).
pub(crate) fn outline_pixels(
    camera: &Camera,
    sphere: &Sphere,
    n: usize,
) -> Result<Vec<Point2<f64>>> {
    let v = ViewedSphere::new(camera, sphere)?;
    Ok(v.outline_rays(n)
        .iter()
        .map(|d| direction_to_pixel(camera, d))
        .collect())
}

/// Bounding box `[u_min, v_min, u_max, v_max]` of a sphere's observed outline (px),
/// from [`OUTLINE_POINTS`] outline points and widened by the largest chord
/// sagitta between them.
pub(crate) fn outline_bounds(camera: &Camera, sphere: &Sphere) -> Result<[f64; 4]> {
    let pts = outline_pixels(camera, sphere, OUTLINE_POINTS)?;
    let mut b = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for p in &pts {
        b[0] = b[0].min(p.x);
        b[1] = b[1].min(p.y);
        b[2] = b[2].max(p.x);
        b[3] = b[3].max(p.y);
    }
    let radius = 0.5 * (b[2] - b[0]).max(b[3] - b[1]);
    let step = std::f64::consts::TAU / OUTLINE_POINTS as f64;
    let sagitta = radius * step * step / 8.0 * 4.0 + 0.5;
    Ok([
        b[0] - sagitta,
        b[1] - sagitta,
        b[2] + sagitta,
        b[3] + sagitta,
    ])
}

/// Centre of the sphere's outline ellipse in the ideal (undistorted) image, px:
/// `K·(Cx, Cy)·Cz/(Cz² − R²)` (docs/methods.md, perspective bias). This is the area
/// centroid of the silhouette after undistortion.
pub fn ellipse_centre_px(camera: &Camera, sphere: &Sphere) -> Result<Point2<f64>> {
    let c = camera.to_camera(&sphere.centre);
    let e = sphere_image::ellipse_centre(&c, sphere.radius)
        .map_err(|e| SynthError::geometry("ellipse centre", e))?;
    Ok(camera.intrinsics.to_pixel(e))
}

/// Area of the outline ellipse in the ideal image (px²), from its conic
/// `xᵀQx = 0`: `π/√(det A)·(−det Q/det A)` with A the conic's 2×2 block,
/// expressed in pixels of K (fx·fy per unit normalised area, skew-free);
/// the reference the coverage tests are checked against.
#[cfg(test)]
pub(crate) fn ellipse_area_px(camera: &Camera, sphere: &Sphere) -> Result<f64> {
    let c = camera.to_camera(&sphere.centre);
    let q = sphere_image::outline_conic(&c, sphere.radius)
        .map_err(|e| SynthError::geometry("outline conic", e))?;
    // Inside is xᵀQx > 0; use −Q so that the quadratic part is positive definite.
    let q = -q;
    let a = q.fixed_view::<2, 2>(0, 0).into_owned();
    let det_a = a.determinant();
    if det_a <= 0.0 {
        return Err(SynthError::NotAnEllipse);
    }
    let area_n = std::f64::consts::PI * (-q.determinant() / det_a) / det_a.sqrt();
    Ok(area_n * camera.intrinsics.fx * camera.intrinsics.fy)
}

/// Clearance between the silhouettes of two spheres in one camera (px, at the
/// local image scale `fx`): `(angle between centres − α₁ − α₂)·fx`; negative
/// when they overlap.
pub fn separation_px(camera: &Camera, a: &Sphere, b: &Sphere) -> Result<f64> {
    let va = ViewedSphere::new(camera, a)?;
    let vb = ViewedSphere::new(camera, b)?;
    let between = va.axis.dot(&vb.axis).clamp(-1.0, 1.0).acos();
    Ok((between - va.half_angle - vb.half_angle) * camera.intrinsics.fx.min(camera.intrinsics.fy))
}

/// Smallest distance (px) from a sphere's observed outline to the image border
/// (pixel-centre convention: the image spans [−0.5, W − 0.5]); negative when
/// part of it is outside.
pub fn frame_clearance_px(camera: &Camera, sphere: &Sphere) -> Result<f64> {
    let pts = outline_pixels(camera, sphere, OUTLINE_POINTS)?;
    let (w, h) = (
        f64::from(camera.width) - 0.5,
        f64::from(camera.height) - 0.5,
    );
    Ok(pts
        .iter()
        .map(|p| (p.x + 0.5).min(p.y + 0.5).min(w - p.x).min(h - p.y))
        .fold(f64::INFINITY, f64::min))
}

/// Fails if two spheres intersect (the renderer and the occlusion rule need disjoint spheres).
pub(crate) fn check_disjoint(spheres: &[Sphere]) -> Result<()> {
    for (i, a) in spheres.iter().enumerate() {
        for b in &spheres[i + 1..] {
            if (a.centre - b.centre).norm() <= a.radius + b.radius {
                return Err(SynthError::SpheresIntersect(
                    a.centre.into(),
                    b.centre.into(),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Intrinsics;

    fn camera() -> Camera {
        Camera::look_at(
            Point3::new(0.0, 0.0, 460.0),
            Point3::origin(),
            Vector3::y(),
            Intrinsics::centred(7966.0, 4096, 3072),
            4096,
            3072,
        )
        .unwrap()
    }

    #[test]
    fn outline_rays_lie_on_the_cone_and_project_onto_the_conic() {
        let cam = camera();
        let s = Sphere {
            centre: Point3::new(60.0, -40.0, 5.0),
            radius: 10.0,
            radiance_e: 1.0,
        };
        let v = ViewedSphere::new(&cam, &s).unwrap();
        let q = sphere_image::outline_conic(&Point3::from(v.centre), s.radius).unwrap();
        for d in v.outline_rays(16) {
            assert!(v.signed_angle(&d).abs() < 1e-14);
            let x = d / d.z;
            assert!((x.transpose() * q * x)[0].abs() < 1e-9 * v.centre.norm_squared());
        }
    }

    #[test]
    fn ellipse_area_matches_the_outline_polygon() {
        let cam = camera();
        let s = Sphere {
            centre: Point3::new(80.0, 50.0, 0.0),
            radius: 10.0,
            radiance_e: 1.0,
        };
        let pts = outline_pixels(&cam, &s, 4096).unwrap();
        let mut area = 0.0;
        for i in 0..pts.len() {
            let (a, b) = (pts[i], pts[(i + 1) % pts.len()]);
            area += a.x * b.y - b.x * a.y;
        }
        let area = area.abs() / 2.0;
        let exact = ellipse_area_px(&cam, &s).unwrap();
        // Inscribed 4096-gon: relative deficit ≈ (2π/n)²/6 ≈ 4e-7.
        assert!((area / exact - 1.0).abs() < 1e-6, "{area} vs {exact}");
    }

    #[test]
    fn front_sphere_occludes() {
        let cam = camera();
        let near = ViewedSphere::new(
            &cam,
            &Sphere {
                centre: Point3::new(0.0, 0.0, 100.0),
                radius: 10.0,
                radiance_e: 1.0,
            },
        )
        .unwrap();
        let far = ViewedSphere::new(
            &cam,
            &Sphere {
                centre: Point3::new(5.0, 0.0, 0.0),
                radius: 10.0,
                radiance_e: 1.0,
            },
        )
        .unwrap();
        assert!(far.occluded_by(&near));
        assert!(!near.occluded_by(&far));
    }
}
