//! The datum of docs/probe-tracer.md and the covariance through it.
//!
//! The network fixes shape and scale, not position and orientation: `JᵀJ`
//! has the six rigid motions as its null space. Corrections are formed after
//! the least-squares rigid alignment of the estimated points to the nominal
//! grid (`geom::transform::rigid_fit`); to first order that alignment is the
//! projector `P = I − G(GᵀG)⁻¹Gᵀ` on the point coordinates, G (3n × 6) the
//! rigid motions of the points (translations, rotations about their
//! centroid). The corrections are estimable functions of the unknowns, so
//! their covariance `σ²·P·Q_pp·P` is the same for every generalised
//! inverse Q of `JᵀJ`; the one used is the block inverse through the
//! regularised Schur complement S⁻ = (S + λQQᵀ)⁻¹:
//! `Q_ss = S⁻`, `Q_ps = −U⁻¹W·S⁻`, `Q_pp = U⁻¹ + U⁻¹W·S⁻·WᵀU⁻¹`.
//! Only the 3×3 diagonal blocks of `P·Q_pp·P` are formed (Q_pp is
//! block-diagonal plus rank 4m), so time and memory stay linear in n.
//! Stations take the same S-transformation: a station minus the rigid motion
//! fitted to the points.
//!
//! A reading's redundancy number is `r = 1 − J_row·Q·J_rowᵀ`; its normalised
//! residual `w = v / (σ_w·√r)` with `σ_w` the robust scale
//! `1.4826·median|v/√r|` (one gross error does not hide itself by inflating
//! σ); `|w| > k` flags it.

use geom::nalgebra::{DMatrix, Matrix3, Matrix3x6, Matrix6, Point3, Vector3, Vector4};
use rayon::prelude::*;

use super::normal::{
    self, Linearisation, State, Structure, condition, regularised, station_rigid_basis,
};
use super::{
    CONDITION_LIMIT, Correction, Network, Options, Residual, Solution, Station, WEAK_FACTOR, Weak,
};
use crate::{Conditioning, ProbeError, Result, Unsolvable};

/// Normal-distribution consistency factor of the median absolute deviation.
const MAD_TO_SIGMA: f64 = 1.4826;
/// Smallest robust scale of the residuals (mm): below 0.1 nm the residuals
/// are rounding, and nothing is flagged.
const RESIDUAL_FLOOR_MM: f64 = 1e-7;
/// A reading whose redundancy number is below this cannot be tested: its
/// error hardly shows in its residual.
const MIN_REDUNDANCY: f64 = 1e-6;

/// `ã = (a, 1)`.
fn tilde(a: &Vector3<f64>) -> Vector4<f64> {
    Vector4::new(a.x, a.y, a.z, 1.0)
}

/// Skew matrix `[p]×` with `[p]×·v = p × v`.
fn skew(p: &Vector3<f64>) -> Matrix3<f64> {
    p.cross_matrix()
}

/// Rigid-motion block of a point at `p` (relative to the centroid):
/// `δA = t + ω × p = [I, −[p]×]·(t, ω)`.
fn rigid_block(p: &Vector3<f64>) -> Matrix3x6<f64> {
    let mut g = Matrix3x6::zeros();
    g.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&Matrix3::identity());
    g.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-skew(p)));
    g
}

/// Per point: `Q_pp,ii`, `(Q_pp·G)ᵢ`, and per entry the hat value `J·Q·Jᵀ`.
struct PointCovariance {
    q: Vec<Matrix3<f64>>,
    qg: Vec<Matrix3x6<f64>>,
    hat: Vec<f64>,
    gqg: Matrix6<f64>,
}

/// Covariance blocks of the points (unit σ) through the regularised Schur
/// complement's inverse `s_inv`.
fn point_covariance(
    st: &Structure,
    lin: &Linearisation,
    s_inv: &DMatrix<f64>,
    centred: &[Vector3<f64>],
) -> (PointCovariance, DMatrix<f64>) {
    let size = 4 * st.m;
    // BᵀG = Σᵢ (U⁻¹W)ᵢᵀGᵢ; Bᵢ's block j is e_j·b_jᵀ, e_j = Uᵢ⁻¹a_j, b_j = −ã_j.
    let parts: Vec<DMatrix<f64>> = st
        .chunks()
        .into_par_iter()
        .map(|points| {
            let mut btg = DMatrix::zeros(size, 6);
            for i in points {
                let g = rigid_block(&centred[i]);
                for e in st.entries(i) {
                    let row = (lin.u_inv[i] * lin.unit[e]).transpose() * g;
                    let at = tilde(&lin.unit[e]);
                    let j = st.station_of[e];
                    for p in 0..4 {
                        for c in 0..6 {
                            btg[(4 * j + p, c)] -= at[p] * row[c];
                        }
                    }
                }
            }
            btg
        })
        .collect();
    let btg = parts
        .into_iter()
        .fold(DMatrix::zeros(size, 6), |acc, p| acc + p);
    let s_btg = s_inv * &btg;
    type Part = (
        Vec<Matrix3<f64>>,
        Vec<Matrix3x6<f64>>,
        Vec<f64>,
        Matrix6<f64>,
    );
    let parts: Vec<Part> = st
        .chunks()
        .into_par_iter()
        .map(|points| {
            let mut out: Part = (Vec::new(), Vec::new(), Vec::new(), Matrix6::zeros());
            for i in points {
                let u_inv = lin.u_inv[i];
                let entries = st.entries(i);
                // Tᵢ = Bᵢ·S⁻ (3 × 4m) = −Σⱼ e_j·(ã_jᵀ S⁻[rows of j]).
                let mut t = DMatrix::<f64>::zeros(3, size);
                for e in entries.clone() {
                    let e_j = u_inv * lin.unit[e];
                    let at = tilde(&lin.unit[e]);
                    let j = st.station_of[e];
                    for c in 0..size {
                        let row = at[0] * s_inv[(4 * j, c)]
                            + at[1] * s_inv[(4 * j + 1, c)]
                            + at[2] * s_inv[(4 * j + 2, c)]
                            + at[3] * s_inv[(4 * j + 3, c)];
                        for r in 0..3 {
                            t[(r, c)] -= e_j[r] * row;
                        }
                    }
                }
                // Q_ii = U⁻¹ + Tᵢ·Bᵢᵀ, Bᵢᵀ's block j = b_j·e_jᵀ.
                let mut q = u_inv;
                for e in entries.clone() {
                    let e_j = u_inv * lin.unit[e];
                    let tb = t_block(&t, st.station_of[e]) * tilde(&lin.unit[e]);
                    q -= tb * e_j.transpose();
                }
                // (Q_pp·G)ᵢ = U⁻¹Gᵢ + Tᵢ·(BᵀG).
                let g = rigid_block(&centred[i]);
                let tbtg = &t * &btg;
                let qg = u_inv * g + tbtg.fixed_view::<3, 6>(0, 0).into_owned();
                out.3 += g.transpose() * qg;
                // Hat value of each reading: aᵀQ_ii·a + 2aᵀ(Q_ps)_ij·b + bᵀS⁻_jj·b,
                // with (Q_ps)_ij·b = T_ij·ã.
                for e in entries {
                    let a = lin.unit[e];
                    let at = tilde(&a);
                    let j = st.station_of[e];
                    let cross = a.dot(&(t_block(&t, j) * at));
                    let s_jj = s_inv.fixed_view::<4, 4>(4 * j, 4 * j);
                    let station = at.dot(&(s_jj * at));
                    out.2.push(a.dot(&(q * a)) + 2.0 * cross + station);
                }
                out.0.push(q);
                out.1.push(qg);
            }
            out
        })
        .collect();
    let mut cov = PointCovariance {
        q: Vec::with_capacity(st.n),
        qg: Vec::with_capacity(st.n),
        hat: Vec::with_capacity(st.l.len()),
        gqg: Matrix6::zeros(),
    };
    for (q, qg, hat, gqg) in parts {
        cov.q.extend(q);
        cov.qg.extend(qg);
        cov.hat.extend(hat);
        cov.gqg += gqg;
    }
    // Gᵖᵀ·Q_ps = −(BᵀG)ᵀ·S⁻ (6 × 4m).
    let k = -s_btg.transpose();
    (cov, k)
}

/// Station j's 3×4 block of Tᵢ.
fn t_block(t: &DMatrix<f64>, j: usize) -> geom::nalgebra::Matrix3x4<f64> {
    t.fixed_view::<3, 4>(0, 4 * j).into_owned()
}

/// Square roots of a covariance diagonal, rotated by `r`.
fn rotated_sd(r: &Matrix3<f64>, c: &Matrix3<f64>) -> Vector3<f64> {
    let c = r * c * r.transpose();
    Vector3::new(c[(0, 0)], c[(1, 1)], c[(2, 2)]).map(|v| v.max(0.0).sqrt())
}

fn median(values: &mut [f64]) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// From the converged state: residuals, alignment, corrections and stations
/// with their uncertainties, conditioning and weak items.
pub(super) fn finish(
    net: &Network,
    st: &Structure,
    state: &State,
    options: &Options,
    iterations: usize,
    last_step: f64,
) -> Result<Solution> {
    let lin = normal::linearise(net, st, state, 0.0, true)?;
    let worst_point = lin.worst_point;
    if worst_point.1.is_nan() || worst_point.1 > CONDITION_LIMIT {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::PointAtSolution {
                point: net.point_names[worst_point.0].clone(),
            },
            condition: worst_point.1,
            limit: CONDITION_LIMIT,
        });
    }
    let basis = station_rigid_basis(state);
    let reduced = regularised(&lin, &basis);
    let condition = condition(&reduced);
    let s_inv = reduced
        .cholesky()
        .map(|c| c.inverse())
        .ok_or_else(|| ProbeError::from(Unsolvable::ReducedSingular))?;

    let n = st.n;
    let centroid = state.points.iter().fold(Vector3::zeros(), |s, p| s + p) / n as f64;
    let centred: Vec<Vector3<f64>> = state.points.iter().map(|p| p - centroid).collect();
    let (cov, k) = point_covariance(st, &lin, &s_inv, &centred);
    let gtg = centred.iter().fold(Matrix6::zeros(), |s, p| {
        s + rigid_block(p).transpose() * rigid_block(p)
    });
    let h = gtg
        .try_inverse()
        .ok_or_else(|| ProbeError::from(Unsolvable::CollinearGrid))?;
    let middle = h * cov.gqg * h;

    // Residuals, σ, redundancy numbers, outliers.
    let equations = st.l.len();
    let unknowns = net.unknowns();
    let redundancy = equations - unknowns;
    let cost: f64 = lin.residual.iter().map(|v| v * v).sum();
    let sigma0 = if redundancy > 0 {
        (cost / redundancy as f64).sqrt()
    } else {
        0.0
    };
    let sigma = match options.sigma_mm {
        Some(s) => s,
        None if redundancy > 0 => sigma0,
        None => {
            return Err(Unsolvable::NoRedundancy {
                readings: equations,
                unknowns,
            }
            .into());
        }
    };
    let r_num: Vec<f64> = cov.hat.iter().map(|h| (1.0 - h).clamp(0.0, 1.0)).collect();
    let mut scaled: Vec<f64> = lin
        .residual
        .iter()
        .zip(&r_num)
        .filter(|(_, r)| **r > MIN_REDUNDANCY)
        .map(|(v, r)| (v / r.sqrt()).abs())
        .collect();
    let outliers_by_chance =
        scaled.len() as f64 * libm::erfc(options.outlier_k / std::f64::consts::SQRT_2);
    let sigma_outliers = MAD_TO_SIGMA * median(&mut scaled);
    let scale = sigma_outliers.max(RESIDUAL_FLOOR_MM);
    let mut residuals = vec![
        Residual {
            value: 0.0,
            redundancy: 0.0,
            normalized: 0.0,
            outlier: false,
        };
        equations
    ];
    let mut station_ss = vec![0.0; st.m];
    for (e, (&v, &r)) in lin.residual.iter().zip(&r_num).enumerate() {
        let normalized = if r > MIN_REDUNDANCY {
            v / (scale * r.sqrt())
        } else {
            0.0
        };
        residuals[st.reading_of[e]] = Residual {
            value: v,
            redundancy: r,
            normalized,
            outlier: normalized.abs() > options.outlier_k,
        };
        station_ss[st.station_of[e]] += v * v;
    }

    // Alignment to the nominal grid (the datum) and corrections.
    let estimated: Vec<Point3<f64>> = state.points.iter().map(|p| Point3::from(*p)).collect();
    let align = geom::transform::rigid_fit(&estimated, &net.points)?;
    let rot = *align.rotation.to_rotation_matrix().matrix();
    let mut unit_u = Vec::with_capacity(n);
    let corrections: Vec<Correction> = (0..n)
        .map(|i| {
            let g = rigid_block(&centred[i]);
            let m_i = cov.qg[i];
            let c = cov.q[i] - g * h * m_i.transpose() - m_i * h * g.transpose()
                + g * middle * g.transpose();
            let sd = rotated_sd(&rot, &c);
            unit_u.push(sd.max());
            Correction {
                vector: align * estimated[i] - net.points[i],
                u: sd * sigma,
            }
        })
        .collect();

    // Stations in the same datum: sⱼ − G_sⱼ·H·Gᵀδp.
    let mut station_unit_u = Vec::with_capacity(st.m);
    let stations: Vec<Station> = state
        .stations
        .iter()
        .enumerate()
        .map(|(j, s)| {
            let mut gs = geom::nalgebra::Matrix4x6::zeros();
            gs.fixed_view_mut::<3, 6>(0, 0)
                .copy_from(&rigid_block(&(s.xyz() - centroid)));
            let kj = k.fixed_view::<6, 4>(0, 4 * j).into_owned();
            let cross = gs * h * kj;
            let c = s_inv.fixed_view::<4, 4>(4 * j, 4 * j).into_owned() - cross - cross.transpose()
                + gs * middle * gs.transpose();
            let sd = rotated_sd(&rot, &c.fixed_view::<3, 3>(0, 0).into_owned());
            station_unit_u.push(sd.max());
            let count = st.station_readings[j];
            Station {
                position: align * Point3::from(s.xyz()),
                dead_path: s.w,
                u_position: sd * sigma,
                u_dead_path: c[(3, 3)].max(0.0).sqrt() * sigma,
                readings: count,
                residual_rms: (station_ss[j] / count as f64).sqrt(),
            }
        })
        .collect();

    let weak_points = weak_points(st, &unit_u);
    let weak_stations = weak_stations(&station_unit_u);
    Ok(Solution {
        corrections,
        stations,
        residuals,
        iterations,
        last_step,
        residual_rms: (cost / equations as f64).sqrt(),
        sigma0,
        sigma,
        sigma_a_priori: options.sigma_mm.is_some(),
        sigma_outliers,
        outlier_k: options.outlier_k,
        outliers_by_chance,
        redundancy,
        unknowns,
        equations,
        condition,
        worst_point,
        weak_points,
        weak_stations,
    })
}

/// Points read by only three stations (no redundancy of their own) or whose
/// largest unit-σ uncertainty exceeds [`WEAK_FACTOR`] × the median.
fn weak_points(st: &Structure, unit_u: &[f64]) -> Vec<Weak> {
    let typical = median(&mut unit_u.to_vec());
    (0..st.n)
        .filter_map(|i| {
            let seen = st.entries(i).len();
            let ratio = unit_u[i] / typical;
            if seen <= 3 {
                Some(Weak {
                    index: i,
                    reason: format!(
                        "read by {seen} stations only: no redundancy, its readings cannot be checked"
                    ),
                })
            } else if ratio > WEAK_FACTOR {
                Some(Weak {
                    index: i,
                    reason: format!("uncertainty {ratio:.1} × the median of the points"),
                })
            } else {
                None
            }
        })
        .collect()
}

/// Stations whose largest unit-σ position uncertainty exceeds
/// [`WEAK_FACTOR`] × the median of the stations.
fn weak_stations(unit_u: &[f64]) -> Vec<Weak> {
    let typical = median(&mut unit_u.to_vec());
    unit_u
        .iter()
        .enumerate()
        .filter(|(_, u)| **u > WEAK_FACTOR * typical)
        .map(|(j, u)| Weak {
            index: j,
            reason: format!(
                "position uncertainty {:.1} × the median of the stations",
                u / typical
            ),
        })
        .collect()
}
