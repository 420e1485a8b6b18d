//! Pipelines: stages over drives. Each stage kind is one file with its configuration (TOML keys
//! with units in their names), its run function and its output writer.

pub mod axle_stage;
pub mod ingest_stage;
pub mod resample_stage;
pub mod run;
pub mod slope_stage;
pub mod spec;
