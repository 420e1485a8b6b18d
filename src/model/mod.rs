//! Vehicle models and their parameter files.

pub mod axle;
pub mod axle_estimate;
pub mod axle_estimate_output;
pub mod axle_estimation;
pub mod axle_measurement;
pub mod catalogue;
pub mod catalogue_table;
pub mod driveline;
pub mod extended_vehicle;
pub mod linear;
pub mod resonance;
pub mod tolerance;
pub mod tyre_warm_up;
pub mod vehicle;
