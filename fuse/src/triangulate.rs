//! The source method's pixel-scale fusion of sphere centres (docs/methods.md); the
//! rigorous triangulation is `geom::triangulate`.

use geom::Vector3;
use geom::nalgebra::{DMatrix, DVector};
use geom::triangulate::View;

use crate::{FuseError, Result};

/// The source method's pixel-scale fusion (docs/methods.md): the displacement of a sphere
/// since a reference instant from each camera's image displacement, scaled by
/// the camera's mm per pixel at the sphere's depth. Each camera sees the
/// displacement's components along its image axes, `[x̂_c; ŷ_c]·Δ = Z_c·Δn`
/// (x̂_c, ŷ_c the camera's x and y axes in the world, Z_c the reference depth,
/// Δn the change of normalised coordinates); the cameras' equations are solved
/// together by least squares — for cameras 2 and 3 on an X sweep, x is the
/// mean of the two cameras' Δx, y comes from camera 3 and z from camera 2.
/// Returns Δ (mm) and the RMS residual of the equations in pixels.
pub fn seed_displacement(
    reference: &[View<'_>],
    current: &[View<'_>],
    depths: &[f64],
) -> Result<(Vector3<f64>, f64)> {
    if reference.len() != current.len() || reference.len() != depths.len() || reference.len() < 2 {
        return Err(FuseError::SeedCameras {
            reference: reference.len(),
            current: current.len(),
            depths: depths.len(),
        });
    }
    let n = reference.len();
    let mut a = DMatrix::zeros(2 * n, 3);
    let mut b = DVector::zeros(2 * n);
    let mut scale = Vec::with_capacity(2 * n);
    for (i, ((r, c), &z)) in reference.iter().zip(current).zip(depths).enumerate() {
        let k = &r.camera.intrinsics;
        let dn = k.to_normalized(c.ideal_px) - k.to_normalized(r.ideal_px);
        let rot = r.camera.rotation();
        for (row, axis) in [(2 * i, 0), (2 * i + 1, 1)] {
            for col in 0..3 {
                a[(row, col)] = rot[(axis, col)];
            }
            b[row] = z * dn[axis];
        }
        // mm → px at this camera's depth, for the residual.
        scale.push(k.fx / z);
        scale.push(k.fy / z);
    }
    let svd = a.clone().svd(true, true);
    let d = svd.solve(&b, 1e-12).map_err(FuseError::SeedSolve)?;
    let res = &a * &d - &b;
    let rms = (res
        .iter()
        .zip(&scale)
        .map(|(r, s)| (r * s).powi(2))
        .sum::<f64>()
        / n as f64)
        .sqrt();
    Ok((Vector3::new(d[0], d[1], d[2]), rms))
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::triangulate::predict;
    use geom::{Camera, Intrinsics, Point2, Point3};

    #[test]
    fn the_pixel_scale_fusion_recovers_an_x_displacement() {
        // Cameras 2 and 3 of an X sweep, aimed at the working point without
        // tilt (the pixel-scale model's assumption), with barrel distortion.
        let k = Intrinsics::centred(7966.0, 4096, 3072);
        let x0 = Point3::new(0.0, 0.0, 30.0);
        let cams: Vec<Camera> = [
            (Point3::new(0.0, -460.0, 30.0), Vector3::z()),
            (Point3::new(0.0, 0.0, 490.0), Vector3::y()),
        ]
        .into_iter()
        .map(|(position, up)| {
            let mut c = Camera::look_at(position, x0, up, k, 4096, 3072).unwrap();
            c.distortion.k1 = -0.04;
            c
        })
        .collect();
        let x1 = Point3::new(30.0, 0.002, -0.001);
        let ideal = |x: &Point3<f64>| -> Vec<View<'_>> {
            cams.iter()
                .map(|camera| {
                    let (p, _) = predict(camera, x, 0.0).unwrap();
                    View {
                        camera,
                        ideal_px: Point2::new(p.x, p.y),
                    }
                })
                .collect()
        };
        let depths: Vec<f64> = cams.iter().map(|c| c.to_camera(&x0).z).collect();
        let (d, _) = seed_displacement(&ideal(&x0), &ideal(&(x0 + x1.coords)), &depths).unwrap();
        // Pixel scale at the reference depth: the motion across the field is
        // recovered to the (small) perspective error of the pixel-scale model.
        assert!((d.x - 30.0).abs() < 1e-3, "{d:?}");
    }
}
