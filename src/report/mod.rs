//! Reports: human-readable summaries, tables and plots of one command's results (a pipeline's
//! run report is `pipeline::run_report`).

pub mod axle_plot;
pub mod axle_scenario;
pub mod axle_sim;
pub mod axle_validation;
pub mod bode;
pub mod contract;
pub mod diagnosis;
pub mod diagnosis_files;
pub mod fleet_files;
pub mod fleet_html;
pub mod ingest_summary;
pub mod plot_points;
pub mod road_compare;
pub mod road_plot;
pub mod road_spectra;
pub mod sentences;
pub mod spectrum;
pub mod validation;

pub use ingest_summary::IngestSummary;
