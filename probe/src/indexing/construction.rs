//! The construction of docs/probe-indexing.md and its first-order uncertainty.
//!
//! O: geometric least-squares sphere through all centres; Q: mean of the
//! A = 0° centres; z = unit(Q − O); y = unit(z × Σ unit(Oᵢ − O)) over the
//! B = 0°, A > 0° centres; x = y × z; (l, m, n) = the components of
//! unit(Oᵢ − O) on (x, y, z); θA = arccos n, θB = atan2(m, l).
//!
//! Uncertainty: every angle is a smooth function of all the centres, so its
//! standard uncertainty follows from the gradient (chain rule through the
//! sphere fit's normal equations, Q, z, the sweep sum and y) and the noise of
//! a centre, estimated from the sphere fit's radial residuals (isotropic
//! noise σ per coordinate gives radial residuals of standard deviation σ).

use geom::nalgebra::{DMatrix, Matrix3, Matrix4, Point3, Vector3, Vector4};

use super::layout::Layout;
use crate::{Conditioning, ProbeError, Result, Unsolvable};

/// Largest accepted condition number of the sphere fit's normal matrix JᵀJ:
/// beyond it the centres lie too near a plane or a small cap (noise in the
/// centres would move O by more than a thousand times as much).
pub const SPHERE_CONDITION_LIMIT: f64 = 1e6;

/// Smallest |z × Σ unit(Oᵢ − O)| (the sweep's lever about the B axis): below
/// it the B = 0° sweep lies along the B axis and gives no A axis.
const SWEEP_LEVER_MIN: f64 = 1e-9;

/// The fitted sphere, the frame and each position's direction cosines.
#[derive(Debug, Clone)]
pub(crate) struct Construction {
    pub(crate) centre: Point3<f64>,
    pub(crate) radius: f64,
    pub(crate) residuals: Vec<f64>,
    /// `σ²·(JᵀJ)⁻¹` of (centre, radius).
    pub(crate) covariance: Matrix4<f64>,
    pub(crate) condition: f64,
    pub(crate) sigma: f64,
    pub(crate) q: Point3<f64>,
    pub(crate) x: Vector3<f64>,
    pub(crate) y: Vector3<f64>,
    pub(crate) z: Vector3<f64>,
    /// `(l, m, n)` per position.
    pub(crate) cosines: Vec<Vector3<f64>>,
    /// Standard uncertainties of θA and θB (rad) per position; at A = 0°, the
    /// first is that of the tilt √(l² + m²) per component and the second is
    /// not defined (NaN).
    pub(crate) u_theta: Vec<(f64, f64)>,
}

/// Run the construction on the centres (their roles from `layout`).
pub(crate) fn construct(centres: &[Point3<f64>], layout: &Layout) -> Result<Construction> {
    let fit = geom::fit::sphere(centres)?;
    let o = fit.centre;
    let n = centres.len();
    // Jacobian rows of the radial residuals at the solution: [−nᵢᵀ, −1].
    let radial: Vec<Vector3<f64>> = centres
        .iter()
        .map(|p| (p - o).try_normalize(0.0).unwrap_or_else(Vector3::zeros))
        .collect();
    let jtj = radial.iter().fold(Matrix4::zeros(), |acc, r| {
        let row = Vector4::new(-r.x, -r.y, -r.z, -1.0);
        acc + row * row.transpose()
    });
    let eigen = jtj.symmetric_eigenvalues();
    let (lo, hi) = (eigen.min(), eigen.max());
    let condition = if lo > 0.0 { hi / lo } else { f64::INFINITY };
    if condition > SPHERE_CONDITION_LIMIT {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::CentresSphere,
            condition,
            limit: SPHERE_CONDITION_LIMIT,
        });
    }
    let inverse = jtj
        .try_inverse()
        .ok_or_else(|| ProbeError::from(Unsolvable::SingularSphere))?;
    let ssr: f64 = fit.residuals.iter().map(|r| r * r).sum();
    let sigma = (ssr / (n - 4) as f64).sqrt();

    let turn: Vec<Point3<f64>> = layout.b_turn.iter().map(|&k| centres[k]).collect();
    let q = Point3::from(
        turn.iter().fold(Vector3::zeros(), |acc, p| acc + p.coords) / turn.len() as f64,
    );
    let w = q - o;
    let z = w
        .try_normalize(0.0)
        .ok_or_else(|| ProbeError::from(Unsolvable::NoBAxis))?;
    let s: Vector3<f64> = layout
        .a_sweep
        .iter()
        .map(|&k| radial[k])
        .fold(Vector3::zeros(), |acc, u| acc + u);
    let c = z.cross(&s);
    if c.norm() < SWEEP_LEVER_MIN * layout.a_sweep.len() as f64 {
        return Err(Unsolvable::NoAAxis.into());
    }
    let y = c.normalize();
    let x = y.cross(&z);
    let cosines: Vec<Vector3<f64>> = radial
        .iter()
        .map(|u| Vector3::new(u.dot(&x), u.dot(&y), u.dot(&z)))
        .collect();

    let gradients = Gradients::new(centres, &radial, o, &inverse, layout, (w, z), (s, c, y));
    let u_theta = (0..n)
        .map(|i| {
            let zero = layout.b_turn.binary_search(&i).is_ok();
            gradients.theta_uncertainty(i, centres[i] - o, (x, y, z), zero, sigma)
        })
        .collect();
    Ok(Construction {
        centre: o,
        radius: fit.radius,
        residuals: fit.residuals,
        covariance: inverse * sigma * sigma,
        condition,
        sigma,
        q,
        x,
        y,
        z,
        cosines,
        u_theta,
    })
}

/// `[v]×`: the matrix of `w ↦ v × w`.
fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    v.cross_matrix()
}

/// `(I − uuᵀ)/ρ`: the derivative of `v/|v|` at `v = ρu`.
fn unit_derivative(u: &Vector3<f64>, rho: f64) -> Matrix3<f64> {
    (Matrix3::identity() - u * u.transpose()) / rho
}

/// Derivatives of the global quantities Γ = (O, z, y) with respect to every
/// centre coordinate: `d` is 9 × 3n, `dd` = d·dᵀ.
struct Gradients {
    d: DMatrix<f64>,
    dd: DMatrix<f64>,
}

impl Gradients {
    fn new(
        centres: &[Point3<f64>],
        radial: &[Vector3<f64>],
        o: Point3<f64>,
        inverse: &Matrix4<f64>,
        layout: &Layout,
        (w, z): (Vector3<f64>, Vector3<f64>),
        (s, c, y): (Vector3<f64>, Vector3<f64>, Vector3<f64>),
    ) -> Gradients {
        let n = centres.len();
        let mut d = DMatrix::zeros(9, 3 * n);
        // dβ = −(JᵀJ)⁻¹ Σ Jⱼᵀ nⱼᵀ dpⱼ with Jⱼ = [−nⱼᵀ, −1]: dO/dpⱼ = [(JᵀJ)⁻¹(nⱼ; 1)]₀..₃ nⱼᵀ.
        for (j, r) in radial.iter().enumerate() {
            let k = inverse * Vector4::new(r.x, r.y, r.z, 1.0);
            let block = Vector3::new(k[0], k[1], k[2]) * r.transpose();
            d.view_mut((0, 3 * j), (3, 3)).copy_from(&block);
        }
        let d_o = d.rows(0, 3).into_owned();
        // dz = P_z/|w| (dQ − dO), dQ = Σ dpⱼ / N over the A = 0° centres.
        let pz = unit_derivative(&z, w.norm());
        let mut dz = -(pz * &d_o);
        let share = pz / layout.b_turn.len() as f64;
        for &j in &layout.b_turn {
            let mut block = dz.view_mut((0, 3 * j), (3, 3));
            block += share;
        }
        // ds = Σ P_k/ρ_k (dp_k − dO) over the sweep; dc = −[s]× dz + [z]× ds; dy = P_y/|c| dc.
        let mut ds = DMatrix::zeros(3, 3 * n);
        let mut sum = Matrix3::zeros();
        for &k in &layout.a_sweep {
            let pk = unit_derivative(&radial[k], (centres[k] - o).norm());
            sum += pk;
            let mut block = ds.view_mut((0, 3 * k), (3, 3));
            block += pk;
        }
        ds -= sum * &d_o;
        let dy = unit_derivative(&y, c.norm()) * (-(skew(&s) * &dz) + skew(&z) * ds);
        d.rows_mut(3, 3).copy_from(&dz);
        d.rows_mut(6, 3).copy_from(&dy);
        let dd = &d * d.transpose();
        Gradients { d, dd }
    }

    /// `σ²·|∂f/∂p|²` of a linearised `f` at position `i`.
    fn variance(&self, i: usize, f: &Linear, sigma: f64) -> f64 {
        let h = geom::nalgebra::SVector::<f64, 9>::from(f.global);
        let di = self.d.columns(3 * i, 3);
        let cross = f.local.dot(&(di.transpose() * h));
        let global = (h.transpose() * &self.dd * h)[0];
        sigma * sigma * (f.local.norm_squared() + 2.0 * cross + global)
    }

    /// Standard uncertainties of θA and θB at position `i` (`v = Oᵢ − O`).
    fn theta_uncertainty(
        &self,
        i: usize,
        v: Vector3<f64>,
        (x, y, z): (Vector3<f64>, Vector3<f64>, Vector3<f64>),
        a_zero: bool,
        sigma: f64,
    ) -> (f64, f64) {
        let rho = v.norm();
        let u = v / rho;
        let pu = unit_derivative(&u, rho);
        let zero = Vector3::zeros();
        // dl = a_xᵀ(dpᵢ − dO) + (u × y)ᵀ dz + (z × u)ᵀ dy, a_v = P_u v / ρ;
        // dm = a_yᵀ(dpᵢ − dO) + uᵀ dy;  dn = a_zᵀ(dpᵢ − dO) + uᵀ dz.
        let dl = Linear::new(pu * x, u.cross(&y), z.cross(&u));
        let dm = Linear::new(pu * y, zero, u);
        let dn = Linear::new(pu * z, u, zero);
        let (l, m) = (u.dot(&x), u.dot(&y));
        if a_zero {
            let tilt = ((self.variance(i, &dl, sigma) + self.variance(i, &dm, sigma)) / 2.0).sqrt();
            return (tilt, f64::NAN);
        }
        // θA = arccos n: dθA = −dn / sin θA, sin θA = √(l² + m²);
        // θB = atan2(m, l): dθB = (l dm − m dl)/(l² + m²).
        let lm2 = l * l + m * m;
        let d_a = dn.scaled(-1.0 / lm2.sqrt());
        let d_b = dm.scaled(l / lm2).plus(&dl.scaled(-m / lm2));
        (
            self.variance(i, &d_a, sigma).sqrt(),
            self.variance(i, &d_b, sigma).sqrt(),
        )
    }
}

/// A linearised quantity at position i: `localᵀ dpᵢ + globalᵀ dΓ`, Γ = (O, z, y).
struct Linear {
    local: Vector3<f64>,
    global: [f64; 9],
}

impl Linear {
    /// `aᵀ(dpᵢ − dO) + b_zᵀ dz + b_yᵀ dy`.
    fn new(a: Vector3<f64>, b_z: Vector3<f64>, b_y: Vector3<f64>) -> Linear {
        Linear {
            local: a,
            global: [-a.x, -a.y, -a.z, b_z.x, b_z.y, b_z.z, b_y.x, b_y.y, b_y.z],
        }
    }

    fn scaled(&self, k: f64) -> Linear {
        Linear {
            local: self.local * k,
            global: self.global.map(|g| g * k),
        }
    }

    fn plus(&self, other: &Linear) -> Linear {
        let mut global = self.global;
        for (g, o) in global.iter_mut().zip(other.global) {
            *g += o;
        }
        Linear {
            local: self.local + other.local,
            global,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::layout;
    use super::*;

    /// A small head grid with centres off the sphere by a deterministic
    /// pseudo-noise of about 1 µm.
    fn grid() -> (Vec<Point3<f64>>, Layout) {
        let mut angles = Vec::new();
        let mut centres = Vec::new();
        let o = Vector3::new(10.0, -20.0, 30.0);
        for (i, a) in [0.0_f64, 30.0, 60.0, 90.0].into_iter().enumerate() {
            for j in 0..8 {
                let b = -180.0 + 45.0 * j as f64;
                let (ar, br) = (a.to_radians(), b.to_radians());
                let u = Vector3::new(ar.sin() * br.cos(), ar.sin() * br.sin(), ar.cos());
                let k = (i * 8 + j) as f64;
                let noise =
                    Vector3::new((1.3 * k).sin(), (2.1 * k + 0.4).cos(), (0.7 * k).sin()) * 1e-3;
                angles.push((a, b));
                centres.push(Point3::from(o + u * 100.0 + noise));
            }
        }
        let xyz: Vec<[f64; 3]> = centres.iter().map(|p| [p.x, p.y, p.z]).collect();
        let layout = layout::check(&angles, &xyz).unwrap();
        (centres, layout)
    }

    /// θA, θB (rad) per position, or (l, m) at A = 0°.
    fn angles(c: &Construction, layout: &Layout) -> Vec<(f64, f64)> {
        c.cosines
            .iter()
            .enumerate()
            .map(|(i, v)| {
                if layout.b_turn.contains(&i) {
                    (v.x, v.y)
                } else {
                    (v.x.hypot(v.y).atan2(v.z), v.y.atan2(v.x))
                }
            })
            .collect()
    }

    /// The first-order uncertainties equal σ̂·|∇θ| with the gradient taken
    /// by central differences through the whole construction (sphere fit,
    /// Q, frame, angles).
    #[test]
    fn uncertainty_is_the_propagated_noise() {
        let (centres, layout) = grid();
        let c = construct(&centres, &layout).unwrap();
        let n = centres.len();
        let h = 1e-5;
        let mut grad = vec![(0.0, 0.0, 0.0, 0.0); n];
        for j in 0..n {
            for k in 0..3 {
                let mut plus = centres.clone();
                let mut minus = centres.clone();
                plus[j][k] += h;
                minus[j][k] -= h;
                let fp = angles(&construct(&plus, &layout).unwrap(), &layout);
                let fm = angles(&construct(&minus, &layout).unwrap(), &layout);
                for i in 0..n {
                    let d0 = (fp[i].0 - fm[i].0) / (2.0 * h);
                    let d1 = (fp[i].1 - fm[i].1) / (2.0 * h);
                    grad[i].0 += d0 * d0;
                    grad[i].1 += d1 * d1;
                }
            }
        }
        for (i, (g0, g1)) in grad.iter().map(|g| (g.0, g.1)).enumerate() {
            let (u_a, u_b) = c.u_theta[i];
            if layout.b_turn.contains(&i) {
                let tilt = c.sigma * ((g0 + g1) / 2.0).sqrt();
                assert!(
                    (u_a / tilt - 1.0).abs() < 1e-4,
                    "position {i}: {u_a} vs {tilt}"
                );
                assert!(u_b.is_nan());
            } else {
                let (num_a, num_b) = (c.sigma * g0.sqrt(), c.sigma * g1.sqrt());
                assert!(
                    (u_a / num_a - 1.0).abs() < 1e-4,
                    "θA at {i}: {u_a} vs {num_a}"
                );
                assert!(
                    (u_b / num_b - 1.0).abs() < 1e-4,
                    "θB at {i}: {u_b} vs {num_b}"
                );
            }
        }
    }

    #[test]
    fn centres_in_one_plane_are_ill_conditioned() {
        // A = 0° turn (all at one point but for µm noise) and sweeps at B = 0° and 180° only.
        let mut angles = Vec::new();
        let mut xyz = Vec::new();
        for j in 0..4 {
            let t = f64::from(j);
            angles.push((0.0, -180.0 + 90.0 * t));
            xyz.push([1e-4 * t.cos(), 1e-4 * t.sin(), 100.0]);
        }
        for a in [30.0_f64, 60.0, 90.0] {
            for b in [0.0_f64, 180.0] {
                let s = if b == 0.0 { 1.0 } else { -1.0 };
                angles.push((a, b));
                xyz.push([
                    s * 100.0 * a.to_radians().sin(),
                    0.0,
                    100.0 * a.to_radians().cos(),
                ]);
            }
        }
        let centres: Vec<Point3<f64>> = xyz.iter().map(|p| Point3::from(*p)).collect();
        let layout = layout::check(&angles, &xyz).unwrap();
        let e = construct(&centres, &layout).unwrap_err();
        assert!(
            matches!(e, ProbeError::IllConditioned { .. } | ProbeError::Geom(_)),
            "{e:?}"
        );
    }
}
