//! Generators of probe-method data with known truth (`trinocular synth
//! probe …`): measured values as an instrument would report them, from a
//! configurable truth with noise, and the truth beside them.

pub mod indexing;
pub mod rotary;
pub mod tracer;
pub mod volumetric;
