//! The probe-based methods of the field, on the geometry core of
//! trinocular: rotary-table error identification with a standard ball
//! ([`rotary`]), probe-head indexing errors ([`indexing`]), CMM volumetric
//! correction by laser-tracer multilateration ([`tracer`]) and the 21-error
//! volumetric model with error-curve fits and a circular-test prediction
//! ([`volumetric`]).
//!
//! Each method takes plain measured values, returns plain results with their
//! uncertainties and a report (the `report.json` types of
//! `formats::probe::<method>::report`, filled here and re-exported, and the
//! HTML page); the binary reads and writes the files. `probe` does no I/O.
//!
//! # Entry points
//! - [`rotary::solve`] of a [`rotary::Measurement`] (centres, or probed
//!   points through [`rotary::Measurement::from_points`]);
//!   [`rotary::report::report()`] and [`rotary::html`] for its report.
//! - [`indexing::solve`] of [`indexing::Position`]s (checked first by
//!   [`indexing::layout::check`]); [`indexing::report`], [`indexing::html`].
//! - [`tracer::solve`] of a [`tracer::Network`]; [`tracer::report`],
//!   [`tracer::html`], and [`tracer::CorrectionGrid`] for corrections
//!   anywhere in the grid.
//! - [`volumetric::analyse`] of [`volumetric::MeasuredAxis`] curves under a
//!   [`volumetric::Setup`]; [`volumetric::html`]; the curves of a vision
//!   campaign by [`volumetric::campaign::from_evaluate`].
//!
//! # Conventions
//! - Lengths in millimetres, angles in radians, all geometry in `f64`;
//!   reports give micrometres (`_um`), microradians (`_urad`) or
//!   arc-seconds (`_arcsec`).
//! - Small error rotations act as `δ + ε × p` (first order), as in
//!   `geom::transform`.
//! - Bad or degenerate input is a [`ProbeError`] naming the value, count or
//!   condition number at fault, never a panic.

#![deny(missing_docs)]

mod error;

pub mod indexing;
pub mod rotary;
pub mod tracer;
pub mod uncertainty;
pub mod volumetric;

pub use error::{
    CampaignFault, CentreFault, ChainFault, Conditioning, CurveFault, LatticeFault, ProbeError,
    Result, RotaryFault, TracerFault, Unsolvable, VolumetricFault,
};
