//! Why a noise floor ([`super::noise`], docs/diagnosis/method.md, step 2) cannot be estimated:
//! an empty or mis-sized series, a setting outside its domain, a model that cannot be run on a
//! copy, or a sensor whose noise cannot be estimated.

use super::extended_error::ExtendedError;
use crate::signal::sensor_noise::SensorNoiseError;
use thiserror::Error;

/// Why a noise floor cannot be estimated.
#[derive(Debug, Error)]
pub enum NoiseError {
    /// A series without any finite value, or no rows at all.
    #[error("{what}: no finite value")]
    Empty {
        /// The series.
        what: String,
    },
    /// Series of different lengths.
    #[error("{what}: {got} values, expected {expected}")]
    Length {
        /// The series.
        what: String,
        /// Expected length.
        expected: usize,
        /// Length given.
        got: usize,
    },
    /// A setting outside its domain.
    #[error("{parameter} = {value} must be {requirement}")]
    BadConfig {
        /// Setting, with unit.
        parameter: &'static str,
        /// Value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// The models could not be run on the recording or a perturbed copy.
    #[error(transparent)]
    Model(#[from] ExtendedError),
    /// A sensor's noise could not be estimated.
    #[error(transparent)]
    Sensor(#[from] SensorNoiseError),
}
