//! The seed's step 1: each station from the nominal points by linear least
//! squares. Squaring `|Aᵢ − Pⱼ| = dⱼ + lᵢⱼ` and writing
//! `k = Xⱼ² + Yⱼ² + Zⱼ² − dⱼ²` gives, per reading (seed eq. 4),
//! `2xᵢXⱼ + 2yᵢYⱼ + 2zᵢZⱼ + 2lᵢⱼdⱼ − k = xᵢ² + yᵢ² + zᵢ² − lᵢⱼ²`,
//! linear in (Xⱼ, Yⱼ, Zⱼ, dⱼ, k). Coordinates are taken about the centroid of
//! the station's points and the columns scaled to unit norm before the SVD,
//! so the condition number measures the layout, not the units.

use geom::nalgebra::{DMatrix, DVector, Vector3, Vector4};

use super::normal::Structure;
use super::{CONDITION_LIMIT, Network};
use crate::{Conditioning, ProbeError, Result, Unsolvable};

/// Points whose smallest principal spread is below this fraction of the
/// largest lie in one plane: a station and its mirror image in that plane
/// fit the readings equally.
const COPLANAR_RATIO: f64 = 1e-6;

/// Start every station: (X, Y, Z, d) per station, in station order.
pub(super) fn stations(net: &Network, st: &Structure) -> Result<Vec<Vector4<f64>>> {
    let mut seen: Vec<Vec<(usize, f64)>> = vec![Vec::new(); st.m];
    for i in 0..st.n {
        for e in st.entries(i) {
            seen[st.station_of[e]].push((i, st.l[e]));
        }
    }
    seen.iter()
        .enumerate()
        .map(|(j, readings)| station(net, j, readings))
        .collect()
}

fn station(net: &Network, j: usize, readings: &[(usize, f64)]) -> Result<Vector4<f64>> {
    let name = &net.station_names[j];
    let count = readings.len();
    let centroid = readings
        .iter()
        .fold(Vector3::zeros(), |s, (i, _)| s + net.points[*i].coords)
        / count as f64;
    let mut spread = DMatrix::zeros(count, 3);
    let mut design = DMatrix::zeros(count, 5);
    let mut rhs = DVector::zeros(count);
    for (row, &(i, l)) in readings.iter().enumerate() {
        let a = net.points[i].coords - centroid;
        for c in 0..3 {
            spread[(row, c)] = a[c];
            design[(row, c)] = 2.0 * a[c];
        }
        design[(row, 3)] = 2.0 * l;
        design[(row, 4)] = -1.0;
        rhs[row] = a.norm_squared() - l * l;
    }
    let s = spread.singular_values();
    if s.min().is_nan() || s.min() <= COPLANAR_RATIO * s.max() {
        return Err(Unsolvable::StationPlanar {
            station: name.to_string(),
            count,
            largest: s.max(),
            smallest: s.min(),
        }
        .into());
    }
    let norms: Vec<f64> = (0..5).map(|c| design.column(c).norm()).collect();
    if norms.iter().any(|v| v.is_nan() || *v <= 0.0) {
        return Err(Unsolvable::StationZero {
            station: name.to_string(),
        }
        .into());
    }
    for (c, v) in norms.iter().enumerate() {
        design.column_mut(c).scale_mut(1.0 / v);
    }
    let svd = design.svd(true, true);
    let (lo, hi) = (svd.singular_values.min(), svd.singular_values.max());
    let condition = if lo > 0.0 { hi / lo } else { f64::INFINITY };
    if condition.is_nan() || condition > CONDITION_LIMIT {
        return Err(ProbeError::IllConditioned {
            what: Conditioning::StationStart {
                station: name.to_string(),
                count,
            },
            condition,
            limit: CONDITION_LIMIT,
        });
    }
    let theta = svd
        .solve(&rhs, 0.0)
        .map_err(|reason| Unsolvable::StationStart {
            station: name.to_string(),
            reason,
        })?;
    let p = centroid
        + Vector3::new(
            theta[0] / norms[0],
            theta[1] / norms[1],
            theta[2] / norms[2],
        );
    Ok(Vector4::new(p.x, p.y, p.z, theta[3] / norms[3]))
}
