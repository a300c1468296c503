//! The 21-error volumetric model of a three-axis machine (docs/probe-volumetric.md,
//! seed 004): per linear axis six error motions (positioning, two
//! straightnesses, roll, pitch, yaw) — eighteen curves — plus three
//! squareness errors; each curve modelled by a Fourier series and by a
//! polynomial with as many coefficients, compared by R², SSE, RMSE and e_max;
//! the volumetric error of the tool point through the exact chain of
//! homogeneous transforms of any kinematic chain; the circular test
//! (ISO 230-4) it predicts, before and after compensation; LinuxCNC pitch
//! compensation tables; and the error curves of a vision campaign evaluated
//! by `trinocular evaluate`, converted to these conventions.
//!
//! - [`MeasuredAxis`], [`measured_axes`], [`AxisCurves`]: the measured
//!   curves, checked, straightness lines removed.
//! - [`Series`], [`SeriesFit`], [`Figures`]: Fourier and polynomial fits,
//!   figures, leave-one-out order choice.
//! - [`ErrorModel`], [`Model`], [`Order`]: the curves at any position inside
//!   the travel under a model.
//! - [`Chain`], [`Squareness`], [`Machine`]: chain strings, squareness,
//!   carriage transforms, volumetric error.
//! - [`predict_circle`], [`CirclePrediction`]: the predicted circular test.
//! - [`campaign`]: a vision campaign's error motions in the conventions here.
//! - [`analyse`] and [`report`]: the whole analysis ([`Analysis`], with the
//!   LinuxCNC `COMP_FILE` pitch-compensation tables) and its `report.json`;
//!   [`uncertainty()`]: U (k = 2) of its figures by Monte Carlo;
//!   [`html`]: `report.html`.
//!
//! # Conventions
//! - Carriage displacement `q` (mm) along its axis; an error curve gives, at
//!   `q`, the error motion of the carriage relative to the body it rides on:
//!   translations δ = (ex, ey, ez) along, rotations ε = (ea, eb, ec) (rad)
//!   about, the machine X, Y, Z, rotations about the machine origin (the
//!   reference point, carried by the carriage). For axis X: ex = EXX
//!   (positioning), ey = EYX, ez = EZX (straightness), ea = EAX (roll),
//!   eb = EBX (pitch), ec = ECX (yaw); likewise Y and Z.
//! - Straightness curves have their least-squares line `v = k·q + b`
//!   removed; the slopes k are reported (they belong to squareness).
//! - `T_j(q) = Trans(q·a_j + δ_j(q))·Rot(ε_j(q))`, Rot by Rodrigues' formula
//!   (exact, not first order); `a_X = (1, 0, 0)`,
//!   `a_Y = (−sin EC0Y, cos EC0Y, 0)`, `a_Z = Ry(EB0Z)·Rx(EA0Z)·(0, 0, 1)`.
//! - Chain `W a1 … ak F b1 … bl T` (default `WXYFZT`): `T_W = T_ak ⋯ T_a1`,
//!   `T_T = T_b1 ⋯ T_bl`; the tool point t in the workpiece frame is
//!   `w = T_W⁻¹·T_T·t`; the volumetric error is w minus the same with every
//!   error and squareness zero (mm, workpiece frame).
//! - Series over the measured travel `[q₀, q₀ + L]`: Fourier
//!   `a0 + Σ (aₙ sin nω(q − q₀) + bₙ cos nω(q − q₀))`, `ω = 2π/L`, order N
//!   (default 3); polynomial of degree 2N. `R² = 1 − SSE/SST`,
//!   `RMSE = √(SSE/n)`, `e_max = max |r|`. Outside the measured travel is an
//!   error, never an extrapolation.
//! - Lengths mm and angles rad in files; µm and µrad in reports.

pub mod campaign;
mod chain;
mod circle;
mod compensation;
mod curves;
mod html;
mod model;
mod plot;
pub mod report;
mod series;
mod uncertainty;

pub use chain::{Chain, DEFAULT_CHAIN, Machine, Side, Squareness};
pub use circle::{CirclePoint, CirclePrediction, CircleSpec, predict as predict_circle};
pub use curves::{AxisCurves, MeasuredAxis, Motion, measured_axes};
pub use html::render as html;
pub use model::{DEFAULT_ORDER, ErrorModel, Evaluation, Model, Order};
pub use report::{Analysis, POOR_R2, ReadingsU, Setup, analyse};
pub use series::{Figures, POINTS_PER_COEFFICIENT, Series, SeriesFit};
pub use uncertainty::{
    CURVES_NOT_GIVEN, ERRORS_NEED_U, Inputs as UncertaintyInputs, REPORT_GIVES_NO_U, uncertainty,
};
