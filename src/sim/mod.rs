//! Simulation: integrators, inputs, the hybrid driveline model (physics.md §1) and the
//! half-truck axle-load model (§3).

pub mod axle;
pub mod axle_coupling;
pub mod axle_recorded;
pub mod axle_scenarios;
pub mod axle_summary;
pub mod axle_validate;
pub mod dopri;
pub mod fast;
pub mod hybrid;
pub mod inputs;
pub mod recorded;
pub mod scenarios;
pub mod validate;
