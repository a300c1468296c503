//! Flatness of the combined X- and Y-run points (docs/methods.md): the
//! least-squares plane `z = aX + bY + c` and the range `η = h_max − h_min` of
//! the vertical deviations from it; and the minimum zone (ISO 12781, vertical
//! Chebyshev plane, exact: `geom::min_zone::flatness`).

use geom::Point3;

/// Flatness figures and deviations (mm).
#[derive(Debug, Clone, PartialEq)]
pub struct Flatness {
    /// Range of the vertical deviations from the least-squares plane.
    pub lsq: f64,
    /// Minimum-zone width (vertical).
    pub min_zone: f64,
    /// Least-squares slope `a = ∂z/∂x`.
    pub a: f64,
    /// Least-squares slope `b = ∂z/∂y`.
    pub b: f64,
    /// Least-squares height `c` at `x = y = 0`.
    pub c: f64,
    /// Vertical deviation of each point from the least-squares plane.
    pub lsq_deviations: Vec<f64>,
    /// Vertical deviation of each point from the minimum zone's centre plane.
    pub zone_deviations: Vec<f64>,
}

/// Flatness of at least three points that span a plane (mm).
pub fn flatness(points: &[Point3<f64>]) -> geom::Result<Flatness> {
    let ls = geom::fit::plane_z_on_xy(points)?;
    let zone = geom::min_zone::flatness(points)?;
    let (lo, hi) = geom::stats::min_max(&ls.residuals)?;
    Ok(Flatness {
        lsq: hi - lo,
        min_zone: zone.width,
        a: ls.a,
        b: ls.b,
        c: ls.c,
        lsq_deviations: ls.residuals,
        zone_deviations: zone.residuals,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saddle_on_a_tilted_table() {
        // z = 100 + 1e-3·x + 1e-3·(x y)/100² on a 3×3 grid of ±100 mm.
        let mut pts = Vec::new();
        for i in -1..=1 {
            for j in -1..=1 {
                let (x, y) = (100.0 * i as f64, 100.0 * j as f64);
                pts.push(Point3::new(x, y, 100.0 + 1e-3 * x + 1e-3 * x * y / 1e4));
            }
        }
        let f = flatness(&pts).unwrap();
        // The saddle is orthogonal to 1, x, y on the grid: the least-squares
        // plane is the tilt, the deviations ±1 µm at the corners.
        assert!((f.a - 1e-3).abs() < 1e-15 && f.b.abs() < 1e-15);
        assert!((f.lsq - 2e-3).abs() < 1e-12, "{}", f.lsq);
        assert!(f.min_zone <= f.lsq + 1e-15);
    }
}
