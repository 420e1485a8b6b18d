//! Simulation: integrators, inputs, the hybrid driveline model (docs/models/driveline.md) and
//! the half-truck axle-load model (docs/models/axle.md).

pub mod axle;
pub mod axle_coupling;
pub mod axle_recorded;
pub mod axle_scenarios;
pub mod axle_summary;
pub mod axle_validate;
pub mod dopri;
pub mod fast;
pub mod fast_inputs;
pub mod fast_span;
pub mod hybrid;
pub mod inputs;
pub mod recorded;
pub mod scenarios;
pub mod slope_shuffle;
pub mod validate;
