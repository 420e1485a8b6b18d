//! Ingest errors: each names the file, and where it applies the column, row, time and value.

use crate::time_fmt::rfc3339_ns;
use crate::units::UnitError;
use std::path::PathBuf;
use thiserror::Error;

fn t(ns: &i64) -> String {
    rfc3339_ns(*ns)
}

/// Why a file could not become a canonical drive log.
#[derive(Debug, Error)]
pub enum IngestError {
    /// The file could not be opened or read.
    #[error("{file}: {source}")]
    Io {
        /// Input file.
        file: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Neither Parquet (`PAR1`) nor MCAP magic at the start of the file.
    #[error("{file}: not a Parquet or MCAP file (first bytes {head})")]
    UnknownFormat {
        /// Input file.
        file: PathBuf,
        /// First bytes, hex.
        head: String,
    },
    /// The Parquet reader rejected the file (truncated, corrupt, not Parquet).
    #[error("{file}: invalid Parquet: {source}")]
    Parquet {
        /// Input file.
        file: PathBuf,
        /// Cause.
        #[source]
        source: parquet::errors::ParquetError,
    },
    /// The MCAP reader rejected the file (bad magic, truncated record or chunk, CRC mismatch).
    #[error("{file}: invalid MCAP after {messages} messages: {source}")]
    Mcap {
        /// Input file.
        file: PathBuf,
        /// Messages read before the error.
        messages: u64,
        /// Cause.
        #[source]
        source: mcap::McapError,
    },
    /// A JSON message that does not parse.
    #[error(
        "{file}: topic {topic}, message {index} at {}: bad JSON: {source}",
        t(time_ns)
    )]
    Json {
        /// Input file.
        file: PathBuf,
        /// MCAP topic.
        topic: String,
        /// Message index within the topic.
        index: u64,
        /// Message log time.
        time_ns: i64,
        /// Cause.
        #[source]
        source: serde_json::Error,
    },
    /// A mapping file that cannot be used.
    #[error("mapping {mapping}: {message}")]
    Mapping {
        /// Mapping file (or `<embedded:name>`).
        mapping: String,
        /// What is wrong.
        message: String,
    },
    /// An ingest setting out of its range.
    #[error("ingest setting {key} = {value}: {rule}")]
    Setting {
        /// Setting name (TOML key / CLI flag).
        key: String,
        /// Value given.
        value: String,
        /// The rule it breaks.
        rule: String,
    },
    /// A unit the mapping names that fleetdyn cannot convert.
    #[error("mapping {mapping}: column {column}: {source}")]
    Unit {
        /// Mapping file.
        mapping: String,
        /// Canonical column.
        column: String,
        /// Cause.
        #[source]
        source: UnitError,
    },
    /// A column required by a requested stage is absent.
    #[error("{file}: missing column {column} (source {source_name}), needed by stage {stage}")]
    MissingColumn {
        /// Input file.
        file: PathBuf,
        /// Canonical column.
        column: String,
        /// Where the mapping looked for it.
        source_name: String,
        /// Stage that needs it.
        stage: String,
    },
    /// A column of a type that cannot hold the signal.
    #[error("{file}: column {column} has type {found}, expected {expected}")]
    WrongDtype {
        /// Input file.
        file: PathBuf,
        /// Source column or field.
        column: String,
        /// Type found.
        found: String,
        /// Type expected.
        expected: String,
    },
    /// Time goes backwards.
    #[error(
        "{file}: {column}: time goes backwards at row {row}: {} after {}",
        t(time_ns),
        t(previous_ns)
    )]
    NonMonotonicTime {
        /// Input file.
        file: PathBuf,
        /// Column / channel.
        column: String,
        /// Source row (Parquet row, or message index within the MCAP topic).
        row: u64,
        /// Offending time.
        time_ns: i64,
        /// Time of the row before.
        previous_ns: i64,
    },
    /// Two samples at the same time with different values.
    #[error("{file}: {column}: duplicate timestamp {} at row {row} with a different value ({value} vs {previous})", t(time_ns))]
    DuplicateTimestamp {
        /// Input file.
        file: PathBuf,
        /// Column / channel.
        column: String,
        /// Source row.
        row: u64,
        /// The repeated time.
        time_ns: i64,
        /// Value at this row (SI).
        value: f64,
        /// Value at the row before (SI).
        previous: f64,
    },
    /// A physically impossible value.
    #[error(
        "{file}: {column} = {value} {unit} at row {row} ({}) is outside [{min}, {max}]",
        t(time_ns)
    )]
    OutOfRange {
        /// Input file.
        file: PathBuf,
        /// Canonical column.
        column: String,
        /// Source row.
        row: u64,
        /// Sample time.
        time_ns: i64,
        /// Value (SI).
        value: f64,
        /// Unit of value, min and max.
        unit: String,
        /// Smallest allowed.
        min: f64,
        /// Largest allowed.
        max: f64,
    },
    /// A run of missing values longer than the configured limit in a required column.
    #[error("{file}: {column}: {samples} missing values ({seconds:.2} s) from row {row} ({}), limit {limit_s} s", t(time_ns))]
    NanRun {
        /// Input file.
        file: PathBuf,
        /// Canonical column.
        column: String,
        /// First row of the run (row of the aligned table).
        row: u64,
        /// Time of that row.
        time_ns: i64,
        /// Length of the run in rows.
        samples: u64,
        /// Length in seconds.
        seconds: f64,
        /// Configured limit.
        limit_s: f64,
    },
    /// No sample of a required column for longer than the missing-value limit: a hole in a
    /// channel's time stamps (the aligned grid would be NaN there), or between two rows of a
    /// wide table. Checked before any grid is built, so a year-long hole costs no memory.
    #[error(
        "{file}: {column}: no sample for {seconds:.2} s before row {row} ({}, previous sample {}), limit {limit_s} s (--max-nan-run-s)",
        t(time_ns),
        t(previous_ns)
    )]
    TimeGap {
        /// Input file.
        file: PathBuf,
        /// Canonical column (`timestamp` for a wide table's rows).
        column: String,
        /// Source row after the hole (Parquet row, or message index within the MCAP topic).
        row: u64,
        /// Time of that row.
        time_ns: i64,
        /// Time of the sample before the hole.
        previous_ns: i64,
        /// Length of the hole, s.
        seconds: f64,
        /// Configured limit, s.
        limit_s: f64,
    },
    /// The aligned time base would hold far more rows than the file has samples (a channel
    /// sampled much faster than the rest for a moment, or a hostile time-base rate): refused
    /// before allocation.
    #[error("{file}: a {period_ns} ns time base over {seconds:.1} s would make {rows} rows from at most {samples} samples per channel (limit {limit} rows); set --time-base-hz")]
    GridTooLarge {
        /// Input file.
        file: PathBuf,
        /// Grid period, ns.
        period_ns: i64,
        /// Span of the grid, s.
        seconds: f64,
        /// Rows the grid would have.
        rows: u64,
        /// Samples of the densest channel.
        samples: u64,
        /// Largest grid accepted for that many samples.
        limit: u64,
    },
    /// A single-drive command given a recording that splits at logger pauses into several drives.
    #[error("{file}: the recording splits into {drives} drives at pauses in its signals ({pauses}); `fleetdyn ingest --output` writes each, a pipeline runs each, or set on_gap to `error` (--on-gap error)")]
    Segmented {
        /// Input file.
        file: PathBuf,
        /// Drives it splits into.
        drives: usize,
        /// Start and length of each pause.
        pauses: String,
    },
    /// Every segment of a recording split at pauses is too short to be a drive.
    #[error("{file}: no usable segment among {found} (split at {pauses}): {reasons}")]
    NoUsableSegment {
        /// Input file.
        file: PathBuf,
        /// Segments found.
        found: usize,
        /// Start and length of each pause.
        pauses: String,
        /// Why each was skipped.
        reasons: String,
    },
    /// Nothing usable in the file.
    #[error("{file}: {what}")]
    NoData {
        /// Input file.
        file: PathBuf,
        /// What is missing.
        what: String,
    },
    /// An MDF4 file of raw CAN frames given without DBC files to decode it.
    #[error("{file}: an MDF4 log of raw CAN frames; decode it with --dbc FILE.dbc (see `fleetdyn ingest --help`)")]
    NeedsDbc {
        /// Input file.
        file: PathBuf,
    },
    /// Raw CAN input (MDF4, DBC) that could not be read or decoded.
    #[error(transparent)]
    Can(#[from] crate::ingest::can::CanError),
}
