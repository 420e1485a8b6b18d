//! Why a synthetic drive could not be made ([`DriveError`], one variant per stage: vehicle
//! file, road, driveline and axle simulation, CAN log, hidden effect, export), and the check of
//! a configuration value every stage shares.

use super::can_error::SynthError as CanError;
use super::effects::EffectError;
use super::export::ExportError;
use super::road_source::RoadSourceError;
use super::track::TrackError;
use crate::model::vehicle::VehicleError;
use crate::road::rules::RulesError;
use crate::road::synth::SynthError as RoadError;
use crate::sim::hybrid::SimError;
use crate::sim::inputs::PiecewiseError;
use std::path::PathBuf;
use thiserror::Error;

/// Why a synthetic drive could not be made.
#[derive(Debug, Error)]
pub enum DriveError {
    /// The vehicle file could not be read or lacks a part.
    #[error(transparent)]
    Vehicle(#[from] VehicleError),
    /// The road rules could not be resolved.
    #[error(transparent)]
    Rules(#[from] RulesError),
    /// The road could not be generated.
    #[error(transparent)]
    Road(#[from] RoadError),
    /// The driveline simulation failed.
    #[error("driveline: {0}")]
    Sim(#[from] SimError),
    /// Axle-model inputs could not be built.
    #[error("axle inputs: {0}")]
    Piecewise(#[from] PiecewiseError),
    /// The CAN log could not be written.
    #[error(transparent)]
    Can(#[from] CanError),
    /// The hidden effect could not be injected or its answer written.
    #[error(transparent)]
    Effect(#[from] EffectError),
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
    /// A road file could not be used.
    #[error(transparent)]
    RoadFile(#[from] RoadSourceError),
    /// A GNSS setting out of its domain.
    #[error(transparent)]
    Track(#[from] TrackError),
    /// The log or the truth table could not be written.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// Speed limits along the road were asked for, but the road has none.
    #[error("road {road}: no speed limits along the road (only a VECTO cycle's <v> gives them)")]
    NoSpeedLimits {
        /// The road's label.
        road: String,
    },
    /// No cruise speed: no speed limit given and the road has no design speed.
    #[error("road {road}: no cruise speed — give a speed limit (the road has no design speed)")]
    NoCruiseSpeed {
        /// The road's label.
        road: String,
    },
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

/// A [`DriveError::BadConfig`] unless `ok`.
pub(super) fn check(parameter: &'static str, value: f64, ok: bool) -> Result<(), DriveError> {
    if ok {
        Ok(())
    } else {
        Err(DriveError::BadConfig {
            parameter,
            value,
            requirement: "finite and > 0 (sample step a whole fraction of the control step)",
        })
    }
}
