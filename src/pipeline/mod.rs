//! Pipelines: stages over many drives. A pipeline file (`spec`) is validated into a plan before
//! any drive is read, then run (`run`) in parallel with isolated failures into a partitioned,
//! idempotent dataset (`dataset`). Each stage kind is one file with its configuration (TOML keys
//! with units in their names), its run function and its output writer.

pub mod axle_stage;
pub mod dataset;
pub mod drive_job;
pub mod drive_stages;
pub mod drive_tables;
pub mod fleet_stage;
pub mod ingest_stage;
pub mod inputs;
pub mod paths;
pub mod record;
pub mod resample_stage;
pub mod run;
pub mod run_report;
mod run_summary;
pub mod slope_stage;
pub mod spec;
pub mod spec_check;
pub mod spec_sections;
pub mod vehicles;
