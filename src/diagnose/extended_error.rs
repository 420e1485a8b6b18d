//! Why an extended model ([`super::extended`], docs/diagnosis/method.md, step 3) cannot be built
//! or run: inputs the recording lacks, a parameter outside its physical domain, a failed
//! simulation, or no model the recording can drive.

use crate::sim::recorded::RecordedError;
use thiserror::Error;

/// Why an extended model cannot be built or run.
#[derive(Debug, Error)]
pub enum ExtendedError {
    /// The recording lacks inputs or has bad ones.
    #[error(transparent)]
    Recorded(#[from] RecordedError),
    /// A parameter value outside its physical domain.
    #[error(transparent)]
    Parameter(#[from] crate::model::extended_vehicle::ParameterError),
    /// The driveline simulation failed.
    #[error("{file}: driveline simulation: {source}")]
    Sim {
        /// Source file.
        file: String,
        /// Cause.
        #[source]
        source: crate::sim::hybrid::SimError,
    },
    /// A column the model compares with is missing.
    #[error("{file}: column {column} is missing or empty")]
    Missing {
        /// Source file.
        file: String,
        /// Column.
        column: String,
    },
    /// Neither model can be driven by the recording with this vehicle file.
    #[error("{file}: nothing to diagnose: longitudinal model: {longitudinal}; axle model: {axle}")]
    NoModel {
        /// Source file.
        file: String,
        /// Why the longitudinal model does not apply.
        longitudinal: String,
        /// Why the axle model does not apply.
        axle: String,
    },
}
