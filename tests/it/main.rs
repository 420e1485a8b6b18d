//! fleetdyn integration tests (one binary, one module per area).

mod axle_bad_input;
mod axle_coupling;
mod axle_estimate;
mod axle_model;
mod axle_reference;
mod axle_scenarios;
mod axle_static_table;
mod axle_validate;
mod common;
mod driveline_fast;
mod driveline_hybrid;
mod driveline_linear;
mod driveline_reference;
mod driveline_validate;
mod ingest_errors;
mod ingest_fixtures;
mod real_data;
mod resample_props;
mod resample_truth;
mod road_profile;
mod road_study;
mod road_synth;
mod seed_slope_step;
mod slope_pipeline;
mod synth_can;
mod synth_drive;
