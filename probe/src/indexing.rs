//! Probe-head (PH10-type) indexing errors from the reference-sphere centre
//! measured at each indexed head position (docs/probe-indexing.md, seed 002).
//!
//! A CMM measures one fixed reference sphere with the head indexed to every
//! (A, B) position, always with the probe offset of one qualification. The
//! reported centres Oᵢ then lie on a sphere about the head's rotation centre
//! O whose radius is the head-centre-to-stylus-ball length. [`solve`] runs
//! the construction exactly:
//!
//! 1. O and the radius: geometric least-squares sphere through all centres
//!    ([`geom::fit::sphere`]).
//! 2. B axis: Q = mean of the A = 0° centres (a full B turn at even steps,
//!    so Q is the centre of their circle); z = unit(Q − O).
//! 3. A axis: y = unit(z × Σ unit(Oᵢ − O)) over the B = 0°, A > 0° centres;
//!    x = y × z.
//! 4. Per position: direction cosines (l, m, n) of O→Oᵢ in (x, y, z);
//!    θA = arccos n, θB = atan2(m, l); ΔθA = θA − A, ΔθB = wrap(θB − B).
//!
//! [`report()`] adds what a user signs off (maxima, RMS, the radius against a
//! nominal, per-detent means, the positions beyond a tolerance) and
//! [`html()`] draws the page.
//!
//! # Conventions
//! - Centres in millimetres in the machine frame; commanded A and B in
//!   degrees; θA, θB in degrees; ΔθA, ΔθB in arc-seconds.
//! - O→Oᵢ turns with the head: a centre is `const − tᵢ` (tᵢ the vector from
//!   the head centre to the stylus ball), so O→Q points from the head centre
//!   away from the stylus at A = 0° and θA is the stylus's angle from there.
//! - ΔθA = θA − A for every position, A = 0° included (there θA ≥ 0 is the
//!   tilt of the stylus from the B axis); ΔθB = θB − B wrapped to
//!   (−180°, 180°] and undefined at A = 0°.
//! - B is taken modulo 360° (B = 180° and B = −180° are one position); two
//!   commanded angles within [`layout::DETENT_TOLERANCE_DEG`] are one detent.
//! - Standard uncertainties are first order: the noise of a centre (from the
//!   sphere fit's radial residuals, assumed isotropic) carried through the
//!   whole construction, frame included.

mod construction;
mod html;
pub mod layout;
mod plot;
mod summary;
pub mod uncertainty;

use geom::nalgebra::{Point3, Vector3};

pub use construction::SPHERE_CONDITION_LIMIT;
pub use html::render as html;
pub use layout::{Fault, Layout};
pub use summary::{
    ADetent, AxesReport, BDetent, Exceedance, Extreme, GridReport, Options, Report, SphereReport,
    ToleranceReport, report,
};

use crate::{ProbeError, Result};

/// Arc-seconds per degree.
pub const ARCSEC_PER_DEG: f64 = 3600.0;
/// Micrometres per millimetre.
const UM_PER_MM: f64 = 1000.0;

/// One measured head position: the commanded angles and the reference-sphere
/// centre the CMM reported there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position {
    /// Commanded A (degrees, 0 ≤ A < 180).
    pub a_deg: f64,
    /// Commanded B (degrees, any turn).
    pub b_deg: f64,
    /// Measured centre (mm, machine frame).
    pub centre: Point3<f64>,
}

impl Position {
    /// The position at commanded (A, B) with the centre `xyz` (mm).
    pub fn new(a_deg: f64, b_deg: f64, xyz: [f64; 3]) -> Position {
        Position {
            a_deg,
            b_deg,
            centre: Point3::from(xyz),
        }
    }
}

/// The head's frame (§3 steps 1–3), in machine coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// O, the rotation centre: centre of the sphere through all centres (mm).
    pub origin: Point3<f64>,
    /// Q, the mean of the A = 0° centres: centre of their circle (mm).
    pub b_circle_centre: Point3<f64>,
    /// x = y × z.
    pub x: Vector3<f64>,
    /// y, along the A axis: unit(z × Σ unit(Oᵢ − O)) over the B = 0° sweep.
    pub y: Vector3<f64>,
    /// z, along the B axis: unit(Q − O).
    pub z: Vector3<f64>,
}

/// The absolute angles and indexing errors of one position (§3 step 4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Angles {
    /// Commanded A (degrees).
    pub a_deg: f64,
    /// Commanded B (degrees, as given).
    pub b_deg: f64,
    /// Direction cosines (l, m, n) of O→Oᵢ in the frame.
    pub cosines: Vector3<f64>,
    /// θA = arccos n (degrees), computed as atan2(√(l² + m²), n).
    pub theta_a_deg: f64,
    /// θB = atan2(m, l) (degrees, (−180°, 180°]).
    pub theta_b_deg: f64,
    /// ΔθA = θA − A (arc-seconds).
    pub d_a_arcsec: f64,
    /// ΔθB = wrap(θB − B) (arc-seconds); `None` at A = 0°.
    pub d_b_arcsec: Option<f64>,
    /// Standard uncertainty of ΔθA (arc-seconds); at A = 0° that of each
    /// component of the stylus tilt.
    pub u_d_a_arcsec: f64,
    /// Standard uncertainty of ΔθB (arc-seconds); `None` at A = 0°.
    pub u_d_b_arcsec: Option<f64>,
    /// Distance |Oᵢ − O| minus the radius (µm): the sphere fit's residual.
    pub residual_um: f64,
}

/// The result of the §3 construction.
#[derive(Debug, Clone, PartialEq)]
pub struct Indexing {
    /// The frame.
    pub frame: Frame,
    /// Radius of the sphere through the centres: the head's rotation centre
    /// to stylus-ball length (mm).
    pub radius_mm: f64,
    /// Standard uncertainty of the radius (mm).
    pub u_radius_mm: f64,
    /// Standard uncertainties of the rotation centre's coordinates (mm).
    pub u_origin_mm: [f64; 3],
    /// Noise of a centre estimated from the sphere fit's residuals,
    /// `√(Σr²/(n − 4))` (mm).
    pub noise_mm: f64,
    /// Condition number of the sphere fit's normal matrix JᵀJ.
    pub condition: f64,
    /// Per position, in input order.
    pub angles: Vec<Angles>,
    /// Roles of the positions (B turn, A sweep), the levels and the gaps.
    pub layout: Layout,
}

/// The §3 construction on measured positions: O and radius, frame, θA, θB,
/// ΔθA, ΔθB with standard uncertainties. Rows in errors are 1-based
/// positions in `positions`.
pub fn solve(positions: &[Position]) -> Result<Indexing> {
    let angles: Vec<(f64, f64)> = positions.iter().map(|p| (p.a_deg, p.b_deg)).collect();
    let xyz: Vec<[f64; 3]> = positions
        .iter()
        .map(|p| [p.centre.x, p.centre.y, p.centre.z])
        .collect();
    let layout = layout::check(&angles, &xyz).map_err(ProbeError::Layout)?;
    let centres: Vec<Point3<f64>> = positions.iter().map(|p| p.centre).collect();
    let c = construction::construct(&centres, &layout)?;
    let angles = positions
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let (l, m, n) = (c.cosines[k].x, c.cosines[k].y, c.cosines[k].z);
            // arccos n as atan2(√(l² + m²), n): the same angle, without
            // arccos's loss of digits near n = 1 (the A = 0° positions).
            let theta_a_deg = l.hypot(m).atan2(n).to_degrees();
            let theta_b_deg = m.atan2(l).to_degrees();
            let defined = layout::detent_key(p.a_deg) != 0;
            let (u_a, u_b) = c.u_theta[k];
            Angles {
                a_deg: p.a_deg,
                b_deg: p.b_deg,
                cosines: c.cosines[k],
                theta_a_deg,
                theta_b_deg,
                d_a_arcsec: (theta_a_deg - p.a_deg) * ARCSEC_PER_DEG,
                d_b_arcsec: defined
                    .then(|| layout::wrap_deg(theta_b_deg - p.b_deg) * ARCSEC_PER_DEG),
                u_d_a_arcsec: u_a.to_degrees() * ARCSEC_PER_DEG,
                u_d_b_arcsec: defined.then(|| u_b.to_degrees() * ARCSEC_PER_DEG),
                residual_um: c.residuals[k] * UM_PER_MM,
            }
        })
        .collect();
    let u = |k: usize| c.covariance[(k, k)].max(0.0).sqrt();
    Ok(Indexing {
        frame: Frame {
            origin: c.centre,
            b_circle_centre: c.q,
            x: c.x,
            y: c.y,
            z: c.z,
        },
        radius_mm: c.radius,
        u_radius_mm: u(3),
        u_origin_mm: [u(0), u(1), u(2)],
        noise_mm: c.sigma,
        condition: c.condition,
        angles,
        layout,
    })
}
