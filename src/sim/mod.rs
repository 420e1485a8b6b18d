//! Simulation: integrators, inputs and the hybrid driveline model (physics.md §1).

pub mod dopri;
pub mod fast;
pub mod hybrid;
pub mod inputs;
pub mod recorded;
pub mod scenarios;
pub mod validate;
