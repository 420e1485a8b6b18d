//! An independent truth plant — a "virtual truck" — for proving the diagnosis against physics it
//! was not built from.
//!
//! The plant is written from physics and shares no code with the nominal driveline model
//! ([`crate::sim`]) or the diagnosis. It has more structure than the nominal model: a clutch
//! damper with a two-stage spring and friction hysteresis, a clutch whose capacity is a plant
//! parameter (a worn one slips at full load), gearbox input and output sides with a neutral
//! phase and a synchroniser, a propeller shaft, an open differential with left and right drive
//! shafts, left and right tyres with slip and relaxation, an engine whose produced torque lags
//! the reported one and a reported torque with a map error, wind with gusts, and rolling
//! resistance that falls as the tyres warm.
//!
//! - [`integrator`]: fixed-step RK4 with located events (mode switches are not smoothed);
//! - [`plant`]: states, modes and equations; [`clutch`], [`engine`], [`tyre`], [`resistance`]:
//!   the element laws;
//! - [`params`]: the truck's parameters and their per-drive draw within tolerances;
//! - [`driver`], [`amt`]: the driver and the automated gearbox;
//! - [`gnss`]: the GNSS receiver's altitude and its errors;
//! - [`effects`]: concealed effects (catalogue and out-of-catalogue);
//! - [`drive`]: a whole drive, its CAN truth and log;
//! - [`linear`]: numerical linearisation and mode extraction (verification).
//!
//! Conventions: SI units; speeds forward-positive; torques positive when driving; see each
//! module. The equations are collected in docs/models/truth-plant.md.

pub mod amt;
pub mod clutch;
pub mod drive;
pub mod driver;
pub mod effects;
pub mod engine;
pub mod gnss;
pub mod integrator;
pub mod linear;
pub mod params;
pub mod plant;
pub mod resistance;
pub mod tyre;

pub use drive::{
    answer_json, simulate_independent_drive, write_independent_drive, IndependentDrive,
    IndependentDriveConfig,
};
pub use effects::{Concealed, OutOfCatalogue, TruthEffect};
pub use params::TruckParams;

use std::path::PathBuf;
use thiserror::Error;

/// Why the truth plant could not simulate or write a drive.
#[derive(Debug, Error)]
pub enum TruthError {
    /// A plant parameter that is not finite or out of its physical domain.
    #[error("truth plant parameter {parameter} = {value} is not finite or out of its domain")]
    BadParameter {
        /// Parameter name.
        parameter: &'static str,
        /// The value.
        value: f64,
    },
    /// A configuration value out of its domain.
    #[error("{parameter} = {value} must be {requirement}")]
    BadConfig {
        /// Parameter name with unit.
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// The vehicle file has no `[driveline]` section.
    #[error("vehicle {vehicle_id}: no [driveline] section, the truth plant needs one")]
    NoDriveline {
        /// Vehicle id.
        vehicle_id: String,
    },
    /// An effect id outside the longitudinal catalogue.
    #[error("unknown effect `{id}`; the truth plant conceals: {known}")]
    UnknownEffect {
        /// The id given.
        id: String,
        /// The known ids, comma separated.
        known: String,
    },
    /// Road rules could not be resolved.
    #[error(transparent)]
    Rules(#[from] crate::road::rules::RulesError),
    /// The road could not be generated.
    #[error(transparent)]
    Road(#[from] crate::road::synth::SynthError),
    /// The integration failed.
    #[error("integration: {0}")]
    Integrator(#[from] integrator::IntegratorError),
    /// Sampling, MCAP writing or ingest failed.
    #[error(transparent)]
    Can(#[from] crate::synth::can::SynthError),
    /// The truck did not reach the road end in time.
    #[error("the truck did not finish within {max_s} s (at {x_m:.0} m of {length_m:.0} m)")]
    Timeout {
        /// Time limit, s.
        max_s: f64,
        /// Distance reached, m.
        x_m: f64,
        /// Road length, m.
        length_m: f64,
    },
    /// File I/O.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}
