//! The input of the fleet evidence: one drive's `parameter_estimates` table with the drive's
//! identity ([`DriveEstimates`]), read from a dataset file ([`read_parameter_estimates`]).

use arrow::array::{Array, AsArray, RecordBatch};
use arrow::datatypes::Float64Type;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a drive's estimates could not be read.
#[derive(Debug, Error)]
pub enum FleetError {
    /// The file could not be opened or decoded.
    #[error("{path}: {message}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
    /// A column the table must have is missing or of another type.
    #[error("{path}: column {column} is missing or not of type {dtype}")]
    Column {
        /// The file.
        path: PathBuf,
        /// The column.
        column: &'static str,
        /// The type it must have.
        dtype: &'static str,
    },
    /// An output could not be written.
    #[error(transparent)]
    Output(#[from] crate::io::OutputError),
    /// Another I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
}

/// One row of a drive's `parameter_estimates` table (schema `parameter_estimates`); in JSON a
/// non-finite number is `null`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EstimateRow {
    /// Catalogue id.
    pub effect: String,
    /// SI unit of the values.
    pub unit: String,
    /// Estimate.
    #[serde(with = "crate::io::json_f64")]
    pub value: f64,
    /// 95 % interval, lower end.
    #[serde(with = "crate::io::json_f64")]
    pub ci_low: f64,
    /// 95 % interval, upper end.
    #[serde(with = "crate::io::json_f64")]
    pub ci_high: f64,
    /// The vehicle file's value.
    #[serde(with = "crate::io::json_f64")]
    pub nominal: f64,
    /// Tolerance band, lower end.
    #[serde(with = "crate::io::json_f64")]
    pub tolerance_low: f64,
    /// Tolerance band, upper end.
    #[serde(with = "crate::io::json_f64")]
    pub tolerance_high: f64,
    /// `named`, `fitted` or `linearised`.
    pub method: String,
}

impl EstimateRow {
    /// The standard error the 95 % interval implies, `(ci_high − ci_low) / (2 · 1.96)`.
    pub fn standard_error(&self) -> f64 {
        (self.ci_high - self.ci_low) / (2.0 * Z_975)
    }
}

/// The standard normal 97.5 % quantile.
pub const Z_975: f64 = 1.959_963_984_540_054;

/// One drive's estimates with its identity.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveEstimates {
    /// Vehicle id.
    pub vehicle_id: String,
    /// Drive id.
    pub drive_id: String,
    /// Time of the drive's first sample, ns since the Unix epoch.
    pub start_ns: i64,
    /// The diagnosis's verdict.
    pub verdict: String,
    /// The drive's `parameter_estimates` file, as the report links it (relative to the dataset).
    pub source: String,
    /// The rows.
    pub rows: Vec<EstimateRow>,
}

/// Reads a `parameter_estimates` table: its rows and the verdict from the file metadata.
///
/// # Errors
/// [`FleetError::Read`] for a file that cannot be decoded, [`FleetError::Column`] for a missing
/// column.
pub fn read_parameter_estimates(path: &Path) -> Result<(Vec<EstimateRow>, String), FleetError> {
    let read = |message: String| FleetError::Read {
        path: path.to_path_buf(),
        message,
    };
    let file = std::fs::File::open(path).map_err(|e| read(e.to_string()))?;
    let builder =
        ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| read(e.to_string()))?;
    let verdict = builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .and_then(|kv| kv.iter().find(|e| e.key == "verdict"))
        .and_then(|e| e.value.clone())
        .unwrap_or_default();
    let reader = builder.build().map_err(|e| read(e.to_string()))?;
    let mut rows = Vec::new();
    for batch in reader {
        let b = batch.map_err(|e| read(e.to_string()))?;
        rows.extend(rows_of(&b, path)?);
    }
    Ok((rows, verdict))
}

fn rows_of(b: &RecordBatch, path: &Path) -> Result<Vec<EstimateRow>, FleetError> {
    let missing = |column: &'static str, dtype: &'static str| FleetError::Column {
        path: path.to_path_buf(),
        column,
        dtype,
    };
    let text = |c: &'static str| {
        b.column_by_name(c)
            .and_then(|a| a.as_string_opt::<i32>())
            .ok_or_else(|| missing(c, "string"))
    };
    let num = |c: &'static str| {
        b.column_by_name(c)
            .and_then(|a| a.as_primitive_opt::<Float64Type>())
            .ok_or_else(|| missing(c, "f64"))
    };
    let (effect, unit, method) = (text("effect")?, text("parameter_unit")?, text("method")?);
    let (value, lo, hi) = (num("value")?, num("ci_low")?, num("ci_high")?);
    let (nominal, tl, th) = (
        num("nominal")?,
        num("tolerance_low")?,
        num("tolerance_high")?,
    );
    let f = |a: &arrow::array::PrimitiveArray<Float64Type>, i: usize| {
        if a.is_null(i) {
            f64::NAN
        } else {
            a.value(i)
        }
    };
    Ok((0..b.num_rows())
        .map(|i| EstimateRow {
            effect: effect.value(i).to_string(),
            unit: unit.value(i).to_string(),
            value: f(value, i),
            ci_low: f(lo, i),
            ci_high: f(hi, i),
            nominal: f(nominal, i),
            tolerance_low: f(tl, i),
            tolerance_high: f(th, i),
            method: method.value(i).to_string(),
        })
        .collect())
}
