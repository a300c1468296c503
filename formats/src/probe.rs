//! Files of the probe-based methods (`trinocular probe …`): inputs and
//! output tables of each method.

pub mod indexing;
pub mod rotary;
pub mod tracer;
pub mod volumetric;
