//! Vehicle models and their parameter files.

pub mod vehicle;
