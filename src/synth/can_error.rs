//! Why a synthetic CAN log could not be made: a bad bus or truth parameter (naming its topic,
//! column and value), or a failed MCAP, ingest or Parquet step.

use crate::ingest::IngestError;
use crate::io::OutputError;
use crate::units::UnitError;
use std::path::PathBuf;
use thiserror::Error;

/// Why a synthetic CAN log could not be made.
#[derive(Debug, Error)]
pub enum SynthError {
    /// A message rate that is not finite and positive.
    #[error("topic {topic}: rate {rate_hz} Hz must be finite and > 0")]
    BadRate {
        /// MCAP topic.
        topic: String,
        /// The rate given, Hz.
        rate_hz: f64,
    },
    /// A resolution that is not finite and positive.
    #[error("channel {column}: resolution {resolution} (wire units) must be finite and > 0")]
    BadResolution {
        /// Canonical column.
        column: String,
        /// The resolution given, wire units.
        resolution: f64,
    },
    /// Another channel parameter out of its domain.
    #[error("channel {column}: {parameter} = {value} must be {requirement}")]
    BadChannel {
        /// Canonical column.
        column: String,
        /// Parameter name (with its unit).
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// A message parameter out of its domain.
    #[error("topic {topic}: {parameter} = {value} must be {requirement}")]
    BadMessage {
        /// MCAP topic.
        topic: String,
        /// Parameter name (with its unit).
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// A reference torque that is not finite and positive.
    #[error("{which} reference torque {value_nm} N·m must be finite and > 0")]
    BadReferenceTorque {
        /// `engine` or `retarder`.
        which: &'static str,
        /// The value given, N·m.
        value_nm: f64,
    },
    /// The same topic, field or column twice, or a column that is not canonical.
    #[error("{what} `{name}`")]
    BadName {
        /// What is wrong (`duplicate topic`, `unknown canonical column`, …).
        what: &'static str,
        /// The name.
        name: String,
    },
    /// A wire unit that cannot be converted into the column's SI unit.
    #[error("channel {column}: {source}")]
    Unit {
        /// Canonical column.
        column: String,
        /// Cause.
        #[source]
        source: UnitError,
    },
    /// Truth times that are too few, not finite or not strictly increasing.
    #[error("truth time sample {index} = {t_s} s: {problem}")]
    BadTruthTime {
        /// Sample index.
        index: usize,
        /// The time, s from the start.
        t_s: f64,
        /// What is wrong.
        problem: &'static str,
    },
    /// A NaN or infinite truth value.
    #[error("truth column {column}, sample {index} at {t_s} s: value {value} is not finite")]
    NonFiniteTruth {
        /// Canonical column.
        column: String,
        /// Sample index.
        index: usize,
        /// Its time, s from the start.
        t_s: f64,
        /// The value.
        value: f64,
    },
    /// A truth column whose length differs from the time axis.
    #[error("truth column {column} has {len} samples, the time axis {expected}")]
    RaggedTruth {
        /// Canonical column.
        column: String,
        /// Its length.
        len: usize,
        /// Length of the time axis.
        expected: usize,
    },
    /// A truth column no channel of the bus carries.
    #[error("truth column {column} is not carried by any channel of the bus")]
    UnknownTruthColumn {
        /// The column.
        column: String,
    },
    /// File-system error writing the MCAP.
    #[error("writing {path}: {source}")]
    Io {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// MCAP encoder error.
    #[error("writing {path}: {source}")]
    Mcap {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: Box<mcap::McapError>,
    },
    /// A chunk compression level the encoder does not have.
    #[error("MCAP {compression} compression level {level} must be 0 (default) … {max}")]
    BadCompressionLevel {
        /// `zstd` or `lz4`.
        compression: &'static str,
        /// The level given.
        level: u32,
        /// The highest level.
        max: u32,
    },
    /// The bus's mapping did not parse, or the written MCAP did not ingest.
    #[error(transparent)]
    Ingest(Box<IngestError>),
    /// The canonical Parquet could not be written.
    #[error(transparent)]
    Output(#[from] OutputError),
}

impl From<IngestError> for SynthError {
    fn from(e: IngestError) -> Self {
        SynthError::Ingest(Box::new(e))
    }
}
