//! Schemas as code: the canonical drive-log schema and the output table schemas.
//!
//! The machine-readable files live in `schemas/` at the repository top; they are embedded at
//! build time (so the binary needs no data files) and parsed once. Ingest enforces the drive-log
//! schema (required columns per stage, dtypes, units, value bounds, interpolation kind); every
//! Parquet writer checks its table against an output schema before anything reaches disk.

mod drive_log;
mod output;
pub mod reference;

pub use drive_log::{drive_log, ColumnSpec, DriveLogSchema, Interpolation, Stage};
pub use output::{output_schema, OutputColumn, OutputSchema};

use thiserror::Error;

/// Logical column type of a schema column.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
pub enum Dtype {
    /// `timestamp[ns, UTC]`.
    #[serde(rename = "timestamp_ns_utc")]
    TimestampNsUtc,
    /// 64-bit float.
    #[serde(rename = "f64")]
    F64,
    /// 16-bit signed integer (nullable).
    #[serde(rename = "i16")]
    I16,
    /// UTF-8 string (labels in result tables: axle, segment, signal).
    #[serde(rename = "str")]
    Str,
    /// 64-bit unsigned integer (seeds and counts in result tables).
    #[serde(rename = "u64")]
    U64,
    /// Boolean flag.
    #[serde(rename = "bool")]
    Bool,
}

impl Dtype {
    /// The type's name as the schema files write it: `timestamp_ns_utc`, `f64`, `i16`, `str`,
    /// `u64`, `bool`.
    pub fn name(self) -> &'static str {
        match self {
            Dtype::TimestampNsUtc => "timestamp_ns_utc",
            Dtype::F64 => "f64",
            Dtype::I16 => "i16",
            Dtype::Str => "str",
            Dtype::U64 => "u64",
            Dtype::Bool => "bool",
        }
    }
}

impl std::fmt::Display for Dtype {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A schema file that does not parse or contradicts itself. These are build-time assets, so
/// this only shows up if someone edits `schemas/` wrongly; the tests load every schema.
#[derive(Debug, Error)]
pub enum SchemaError {
    /// TOML syntax or shape error.
    #[error("schema {name}: {source}")]
    Parse {
        /// Schema file name.
        name: String,
        /// Parser error.
        #[source]
        source: toml::de::Error,
    },
    /// An inconsistency inside a schema file.
    #[error("schema {name}: {message}")]
    Invalid {
        /// Schema file name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A table does not match the output schema it is written under.
    #[error("table {table} does not match its schema: {message}")]
    Mismatch {
        /// Output schema name.
        table: String,
        /// What differs.
        message: String,
    },
}
