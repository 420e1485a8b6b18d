//! Vehicle models and their parameter files.

pub mod axle;
pub mod axle_estimation;
pub mod axle_measurement;
pub mod driveline;
pub mod linear;
pub mod resonance;
pub mod vehicle;
