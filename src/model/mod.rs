//! Vehicle models and their parameter files.

pub mod driveline;
pub mod linear;
pub mod resonance;
pub mod vehicle;
