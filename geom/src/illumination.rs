//! Relative illumination of a lens: the image irradiance of a uniform
//! radiance source at each image point, relative to the principal point.
//!
//! A pixel's value (offset removed) is the scene radiance times the lens's
//! relative illumination RI at that point. An ideal lens has the natural
//! vignetting cos⁴θ (θ the field angle of the pixel's ray) and conserves
//! energy under distortion: the light that the pinhole image would spread
//! over an area dA_ideal lands on dA_observed, so
//! `RI = cos⁴θ · |∂ideal/∂observed|`. A real lens departs from that by its
//! own vignetting V (mechanical vignetting, pupil aberration); that part is
//! measured from flat-field frames and modelled by [`RadialIllumination`].
//! Dividing a frame by RI turns it into a radiance image, where the image of a
//! uniformly luminous sphere is uniform over its ellipse (the model that
//! `sphere_image` describes).

use nalgebra::Vector2;

/// Natural vignetting `cos⁴θ = 1/(1 + x² + y²)²` of the ray through the ideal
/// normalised image point `n = (x, y)`.
pub fn cos4(n: Vector2<f64>) -> f64 {
    let q = 1.0 + n.norm_squared();
    1.0 / (q * q)
}

/// The ideal lens at an observed pixel: `cos⁴θ · J`, with `n` the pixel's
/// ideal normalised coordinates and `J = |∂ideal/∂observed|` its area
/// Jacobian (energy conservation under distortion).
pub fn natural(n: Vector2<f64>, area_jacobian: f64) -> f64 {
    cos4(n) * area_jacobian
}

/// A smooth radial model of the relative illumination fitted from flat
/// fields: `RI(p) = Σₖ qₖ·ρ²ᵏ`, `ρ = |p − c|/s` (observed pixels), with
/// `q₀ = 1` when normalised to the centre.
#[derive(Debug, Clone, PartialEq)]
pub struct RadialIllumination {
    /// Centre `c` of the model (observed pixels): where the illumination is
    /// symmetric about, normally near the principal point.
    pub centre: [f64; 2],
    /// Scale `s` of ρ (px), e.g. the focal length: ρ is then ≈ tan θ.
    pub scale_px: f64,
    /// `q₀, q₁, …`: coefficients of ρ⁰, ρ², ρ⁴, ….
    pub coefficients: Vec<f64>,
}

impl RadialIllumination {
    /// `ρ²` of pixel (u, v).
    pub fn rho2(&self, u: f64, v: f64) -> f64 {
        let (du, dv) = (u - self.centre[0], v - self.centre[1]);
        (du * du + dv * dv) / (self.scale_px * self.scale_px)
    }

    /// `RI` at pixel (u, v) (Horner in ρ²).
    pub fn at(&self, u: f64, v: f64) -> f64 {
        let r2 = self.rho2(u, v);
        self.coefficients
            .iter()
            .rev()
            .fold(0.0, |acc, &q| acc * r2 + q)
    }
}

/// The relative illumination a camera's pixels are corrected with.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Illumination {
    /// The ideal lens, [`natural`]: assumed when no flat field was measured.
    #[default]
    Ideal,
    /// No fall-off at all, `RI = 1`: the images are radiance images (what a
    /// pinhole ray tracer writes).
    Uniform,
    /// Measured from flat fields.
    Radial(RadialIllumination),
}

impl Illumination {
    /// `RI` at the observed pixel `observed`, whose ideal normalised
    /// coordinates are `n` and area Jacobian `area_jacobian` (only the ideal
    /// lens uses them).
    pub fn at(&self, observed: [f64; 2], n: Vector2<f64>, area_jacobian: f64) -> f64 {
        match self {
            Illumination::Ideal => natural(n, area_jacobian),
            Illumination::Uniform => 1.0,
            Illumination::Radial(r) => r.at(observed[0], observed[1]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cos4_of_known_angles() {
        assert_eq!(cos4(Vector2::zeros()), 1.0);
        // 45°: tan θ = 1, cos⁴θ = 1/4.
        assert!((cos4(Vector2::new(1.0, 0.0)) - 0.25).abs() < 1e-15);
        let t = 0.3f64;
        let c = (1.0 / (1.0 + t * t).sqrt()).powi(4);
        assert!((cos4(Vector2::new(0.0, t)) - c).abs() < 1e-15);
    }

    #[test]
    fn radial_model_is_a_polynomial_in_rho_squared() {
        let r = RadialIllumination {
            centre: [100.0, 50.0],
            scale_px: 1000.0,
            coefficients: vec![1.0, -2.0, 3.0],
        };
        assert_eq!(r.at(100.0, 50.0), 1.0);
        // ρ = 0.5: 1 − 2·0.25 + 3·0.0625.
        assert!((r.at(600.0, 50.0) - (1.0 - 0.5 + 0.1875)).abs() < 1e-15);
        assert!((r.at(100.0, 550.0) - r.at(600.0, 50.0)).abs() < 1e-15);
    }
}
