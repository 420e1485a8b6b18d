//! Parquet writer for every fleetdyn table.
//!
//! Conventions of every file we write:
//! - zstd compression (level 3), one row group per 1 Mi rows;
//! - every field carries a `unit` metadata entry (SI units inside fleetdyn);
//! - key–value metadata: `table` (output schema name), `drive_id`, `vehicle_id`,
//!   `schema_version`, `source_file`, `fleetdyn_version`, `config_hash`, `units` (every
//!   column's unit as one JSON object), plus stage extras;
//! - missing values are Parquet nulls (NaN inside fleetdyn ↔ null on disk);
//! - the table is checked against its output schema (`schemas/outputs/`) before a byte is
//!   written, and the file appears atomically (temporary name + rename) or not at all.

use super::AtomicFile;
use crate::schema::{drive_log, output_schema, Dtype, SchemaError};
use crate::table::{DriveLog, Signal};
use arrow::array::{
    ArrayRef, BooleanArray, Float64Array, Int16Array, StringArray, TimestampNanosecondArray,
    UInt64Array,
};
use arrow::datatypes::{DataType, Field, Schema, TimeUnit};
use arrow::record_batch::RecordBatch;
use parquet::arrow::ArrowWriter;
use parquet::basic::{Compression, Encoding, ZstdLevel};
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use parquet::schema::types::ColumnPath;
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

/// Rows converted to Arrow and handed to the Parquet writer at a time.
const WRITE_SLICE_ROWS: usize = 64 * 1024;

/// Column data to write.
#[derive(Debug, Clone, PartialEq)]
pub enum OutData {
    /// ns since the Unix epoch, written as `timestamp[ns, UTC]`.
    Timestamp(Vec<i64>),
    /// Floats; NaN is written as null.
    F64(Vec<f64>),
    /// Integers held as floats (NaN → null), written as `int16`; values are rounded.
    I16(Vec<f64>),
    /// Labels, written as `utf8`.
    Str(Vec<String>),
    /// Unsigned integers (seeds, counts), written as `uint64`.
    U64(Vec<u64>),
    /// Flags, written as `bool`.
    Bool(Vec<bool>),
}

/// Column data borrowed for writing: what [`OutData`] holds, without owning it, plus columns of
/// nulls that need no values at all. Writing from borrowed data lets a large table (a 10-hour
/// drive's `drive_log` is ~290 MB of columns) go to disk without a copy
/// (docs/validation/benchmarks.md).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DataRef<'a> {
    /// ns since the Unix epoch, written as `timestamp[ns, UTC]`.
    Timestamp(&'a [i64]),
    /// Floats; NaN is written as null.
    F64(&'a [f64]),
    /// Integers held as floats (NaN → null), written as `int16`; values are rounded.
    I16(&'a [f64]),
    /// Labels, written as `utf8`.
    Str(&'a [String]),
    /// Unsigned integers, written as `uint64`.
    U64(&'a [u64]),
    /// Flags, written as `bool`.
    Bool(&'a [bool]),
    /// A float column of this many rows, every one null (as an `F64` of NaN).
    NullF64(usize),
    /// An `int16` column of this many rows, every one null (as an `I16` of NaN).
    NullI16(usize),
}

impl DataRef<'_> {
    fn len(&self) -> usize {
        match self {
            DataRef::Timestamp(v) => v.len(),
            DataRef::F64(v) | DataRef::I16(v) => v.len(),
            DataRef::Str(v) => v.len(),
            DataRef::U64(v) => v.len(),
            DataRef::Bool(v) => v.len(),
            DataRef::NullF64(n) | DataRef::NullI16(n) => *n,
        }
    }
    fn dtype(&self) -> Dtype {
        match self {
            DataRef::Timestamp(_) => Dtype::TimestampNsUtc,
            DataRef::F64(_) | DataRef::NullF64(_) => Dtype::F64,
            DataRef::I16(_) | DataRef::NullI16(_) => Dtype::I16,
            DataRef::Str(_) => Dtype::Str,
            DataRef::U64(_) => Dtype::U64,
            DataRef::Bool(_) => Dtype::Bool,
        }
    }
}

/// One named column with its unit, its data borrowed ([`OutColumn`] owns its data).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColumnRef<'a> {
    /// Column name.
    pub name: &'a str,
    /// Unit for the `unit` field metadata.
    pub unit: &'a str,
    /// Values.
    pub data: DataRef<'a>,
}

impl<'a> ColumnRef<'a> {
    /// A float column.
    pub fn f64(name: &'a str, unit: &'a str, values: &'a [f64]) -> Self {
        Self {
            name,
            unit,
            data: DataRef::F64(values),
        }
    }
    /// A `timestamp[ns, UTC]` column named `timestamp`.
    pub fn timestamp(values: &'a [i64]) -> Self {
        Self {
            name: "timestamp",
            unit: "ns",
            data: DataRef::Timestamp(values),
        }
    }
    /// The column with its data copied (null columns as NaN).
    pub fn to_owned_column(&self) -> OutColumn {
        let data = match self.data {
            DataRef::Timestamp(v) => OutData::Timestamp(v.to_vec()),
            DataRef::F64(v) => OutData::F64(v.to_vec()),
            DataRef::I16(v) => OutData::I16(v.to_vec()),
            DataRef::Str(v) => OutData::Str(v.to_vec()),
            DataRef::U64(v) => OutData::U64(v.to_vec()),
            DataRef::Bool(v) => OutData::Bool(v.to_vec()),
            DataRef::NullF64(n) => OutData::F64(vec![f64::NAN; n]),
            DataRef::NullI16(n) => OutData::I16(vec![f64::NAN; n]),
        };
        OutColumn {
            name: self.name.to_string(),
            unit: self.unit.to_string(),
            data,
        }
    }
}

/// One named column with its unit.
#[derive(Debug, Clone, PartialEq)]
pub struct OutColumn {
    /// Column name.
    pub name: String,
    /// Unit for the `unit` field metadata.
    pub unit: String,
    /// Values.
    pub data: OutData,
}

impl OutColumn {
    /// A float column.
    pub fn f64(name: &str, unit: &str, values: Vec<f64>) -> Self {
        Self {
            name: name.into(),
            unit: unit.into(),
            data: OutData::F64(values),
        }
    }
    /// A drive-log signal with its name, unit and schema dtype (`i16` columns as integers).
    pub fn from_signal(s: &Signal) -> Self {
        let data = match s.dtype() {
            Dtype::I16 => OutData::I16(s.values.clone()),
            _ => OutData::F64(s.values.clone()),
        };
        Self {
            name: s.name.clone(),
            unit: s.unit.clone(),
            data,
        }
    }
    /// A `timestamp[ns, UTC]` column named `timestamp`.
    pub fn timestamp(values: Vec<i64>) -> Self {
        Self {
            name: "timestamp".into(),
            unit: "ns".into(),
            data: OutData::Timestamp(values),
        }
    }
    /// The column borrowed.
    pub fn as_column_ref(&self) -> ColumnRef<'_> {
        let data = match &self.data {
            OutData::Timestamp(v) => DataRef::Timestamp(v),
            OutData::F64(v) => DataRef::F64(v),
            OutData::I16(v) => DataRef::I16(v),
            OutData::Str(v) => DataRef::Str(v),
            OutData::U64(v) => DataRef::U64(v),
            OutData::Bool(v) => DataRef::Bool(v),
        };
        ColumnRef {
            name: &self.name,
            unit: &self.unit,
            data,
        }
    }
}

fn column_refs(cols: &[OutColumn]) -> Vec<ColumnRef<'_>> {
    cols.iter().map(OutColumn::as_column_ref).collect()
}

/// Table-level metadata.
#[derive(Debug, Clone, Default)]
pub struct TableMeta {
    /// Output schema name (`schemas/outputs/`), or `drive_log` for the canonical table.
    pub table: String,
    /// Drive identifier.
    pub drive_id: String,
    /// Vehicle identifier, if known.
    pub vehicle_id: Option<String>,
    /// Source file of the drive.
    pub source_file: String,
    /// Hash of the configuration that produced the table (see [`config_hash`]).
    pub config_hash: String,
    /// Further stage-specific entries (e.g. filter settings, measured gains).
    pub extra: Vec<(String, String)>,
}

/// Why a table could not be written.
#[derive(Debug, Error)]
pub enum OutputError {
    /// The table does not match its schema (a bug, reported instead of writing a bad file).
    #[error(transparent)]
    Schema(#[from] SchemaError),
    /// Columns of unequal length.
    #[error("table {table}: column {column} has {len} rows, expected {expected}")]
    Ragged {
        /// Output table.
        table: String,
        /// Offending column.
        column: String,
        /// Its length.
        len: usize,
        /// Length of the first column.
        expected: usize,
    },
    /// File-system error.
    #[error("writing {path}: {source}")]
    Io {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Arrow/Parquet encoder error.
    #[error("writing {path}: {source}")]
    Parquet {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: parquet::errors::ParquetError,
    },
}

/// The column units as one JSON object in column order, `{"timestamp":"ns","vehicle_speed":"m/s",
/// …}`: the file-level `units` entry, for readers that show key–value metadata but not field
/// metadata (DuckDB's `parquet_kv_metadata`, polars' `read_parquet_metadata`).
fn units_json(fields: &[Field]) -> String {
    let entries: Vec<String> = fields
        .iter()
        .map(|f| {
            let unit = f.metadata().get("unit").map_or("", String::as_str);
            format!(
                "{}:{}",
                serde_json::to_string(f.name()).expect("a string serialises"),
                serde_json::to_string(unit).expect("a string serialises")
            )
        })
        .collect();
    format!("{{{}}}", entries.join(","))
}

/// Hex SHA-256 of configuration text (the canonical serialisation the caller chose), used in
/// file metadata so results can be matched to the configuration that made them.
pub fn config_hash(parts: &[&[u8]]) -> String {
    let mut h = Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The canonical drive log as output columns: `timestamp`, then every signal with its schema
/// dtype and unit.
pub fn drive_log_columns(log: &DriveLog) -> Vec<OutColumn> {
    let mut cols = Vec::with_capacity(log.signals.len() + 1);
    cols.push(OutColumn::timestamp(log.timestamp_ns.clone()));
    cols.extend(log.signals.iter().map(OutColumn::from_signal));
    cols
}

fn check_drive_log(cols: &[(&str, Dtype, &str)]) -> Result<(), SchemaError> {
    let dl = drive_log();
    let mismatch = |message: String| SchemaError::Mismatch {
        table: "drive_log".into(),
        message,
    };
    if cols.first().map(|c| c.0) != Some("timestamp") {
        return Err(mismatch("first column must be timestamp".into()));
    }
    for (name, dtype, unit) in cols {
        match dl.column(name) {
            Some(c) if c.dtype != *dtype || c.unit != *unit => {
                return Err(mismatch(format!(
                    "{name} as {dtype} [{unit}], schema says {} [{}]",
                    c.dtype, c.unit
                )))
            }
            None if *dtype != Dtype::F64 => {
                return Err(mismatch(format!("pass-through column {name} must be f64")))
            }
            _ => {}
        }
    }
    Ok(())
}

/// How a table's pages are encoded and compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableEncoding {
    /// zstd level (1…22).
    pub zstd_level: i32,
    /// Float columns as BYTE_STREAM_SPLIT without dictionaries and timestamps as
    /// DELTA_BINARY_PACKED (smaller for smooth, full-precision signals such as simulation
    /// output), instead of the writer's defaults.
    pub split_floats: bool,
}

impl Default for TableEncoding {
    /// zstd level 3, the writer's default encodings: the settings of every fleetdyn table.
    fn default() -> Self {
        Self {
            zstd_level: 3,
            split_floats: false,
        }
    }
}

/// Writes `cols` as a Parquet file at `path`, atomically.
///
/// # Errors
/// [`OutputError::Schema`] if the columns do not match the schema named by `meta.table`
/// (`drive_log` checks against the canonical schema); [`OutputError::Ragged`] for unequal
/// lengths; I/O and encoder errors. On any error no file is left at `path`.
pub fn write_table(path: &Path, meta: &TableMeta, cols: &[OutColumn]) -> Result<(), OutputError> {
    write_table_full(
        path,
        meta,
        &column_refs(cols),
        &[],
        TableEncoding::default(),
    )
}

/// [`write_table`] with the page encoding and compression chosen.
///
/// # Errors
/// As [`write_table`]; an invalid zstd level is an encoder error.
pub fn write_table_with(
    path: &Path,
    meta: &TableMeta,
    cols: &[OutColumn],
    encoding: TableEncoding,
) -> Result<(), OutputError> {
    write_table_full(path, meta, &column_refs(cols), &[], encoding)
}

/// [`write_table`], then `constants` appended as `utf8` columns holding one value on every row
/// (unit `1`), after the schema check: the identity columns of a dataset table (`drive_id`),
/// so that files read together as one table still say which drive each row belongs to.
///
/// # Errors
/// As [`write_table`]; nothing is left at `path` on error.
pub fn write_table_with_constants(
    path: &Path,
    meta: &TableMeta,
    cols: &[OutColumn],
    constants: &[(&str, &str)],
) -> Result<(), OutputError> {
    write_table_full(
        path,
        meta,
        &column_refs(cols),
        constants,
        TableEncoding::default(),
    )
}

/// [`write_table_with_constants`] from borrowed columns: the same file, written without copying
/// the columns first.
///
/// # Errors
/// As [`write_table`]; nothing is left at `path` on error.
pub fn write_column_refs_with_constants(
    path: &Path,
    meta: &TableMeta,
    cols: &[ColumnRef<'_>],
    constants: &[(&str, &str)],
) -> Result<(), OutputError> {
    write_table_full(path, meta, cols, constants, TableEncoding::default())
}

fn write_table_full(
    path: &Path,
    meta: &TableMeta,
    cols: &[ColumnRef<'_>],
    constants: &[(&str, &str)],
    encoding: TableEncoding,
) -> Result<(), OutputError> {
    let described: Vec<(&str, Dtype, &str)> = cols
        .iter()
        .map(|c| (c.name, c.data.dtype(), c.unit))
        .collect();
    if meta.table == "drive_log" {
        check_drive_log(&described)?;
    } else {
        let schema = output_schema(&meta.table).ok_or_else(|| SchemaError::Mismatch {
            table: meta.table.clone(),
            message: "no such output schema".into(),
        })?;
        schema.check(&described)?;
    }
    let n = cols.first().map(|c| c.data.len()).unwrap_or(0);
    for c in cols {
        if c.data.len() != n {
            return Err(OutputError::Ragged {
                table: meta.table.clone(),
                column: c.name.to_string(),
                len: c.data.len(),
                expected: n,
            });
        }
    }

    let unit_meta = |u: &str| HashMap::from([("unit".to_string(), u.to_string())]);
    let fields: Vec<Field> =
        cols.iter()
            .map(|c| {
                let dt = match c.data.dtype() {
                    Dtype::TimestampNsUtc => {
                        DataType::Timestamp(TimeUnit::Nanosecond, Some("UTC".into()))
                    }
                    Dtype::F64 => DataType::Float64,
                    Dtype::I16 => DataType::Int16,
                    Dtype::Str => DataType::Utf8,
                    Dtype::U64 => DataType::UInt64,
                    Dtype::Bool => DataType::Boolean,
                };
                let nullable = !matches!(c.data, DataRef::Timestamp(_));
                Field::new(c.name, dt, nullable).with_metadata(unit_meta(c.unit))
            })
            .chain(constants.iter().map(|(name, _)| {
                Field::new(*name, DataType::Utf8, true).with_metadata(unit_meta("1"))
            }))
            .collect();
    // Arrow arrays of rows `r` of every column (constants repeated): built one slice at a time,
    // so writing holds one slice of Arrow data beside the columns, not a second whole table.
    let slice = |r: std::ops::Range<usize>| -> Vec<ArrayRef> {
        cols.iter()
            .map(|c| -> ArrayRef {
                match c.data {
                    DataRef::Timestamp(v) => Arc::new(
                        TimestampNanosecondArray::from(v[r.clone()].to_vec()).with_timezone("UTC"),
                    ),
                    DataRef::F64(v) => Arc::new(Float64Array::from_iter(
                        v[r.clone()].iter().map(|x| (!x.is_nan()).then_some(*x)),
                    )),
                    DataRef::I16(v) => Arc::new(Int16Array::from_iter(
                        v[r.clone()]
                            .iter()
                            .map(|x| (x.is_finite()).then(|| x.round() as i16)),
                    )),
                    DataRef::Str(v) => Arc::new(StringArray::from_iter_values(v[r.clone()].iter())),
                    DataRef::U64(v) => Arc::new(UInt64Array::from(v[r.clone()].to_vec())),
                    DataRef::Bool(v) => Arc::new(BooleanArray::from(v[r.clone()].to_vec())),
                    // built as the NaN columns they stand for are, so the bytes are the same
                    DataRef::NullF64(_) => Arc::new(Float64Array::from_iter(std::iter::repeat_n(
                        None::<f64>,
                        r.len(),
                    ))),
                    DataRef::NullI16(_) => Arc::new(Int16Array::from_iter(std::iter::repeat_n(
                        None::<i16>,
                        r.len(),
                    ))),
                }
            })
            .chain(constants.iter().map(|(_, value)| -> ArrayRef {
                Arc::new(StringArray::from_iter_values(std::iter::repeat_n(
                    *value,
                    r.len(),
                )))
            }))
            .collect()
    };
    let io_err = |source| OutputError::Io {
        path: path.to_path_buf(),
        source,
    };
    let pq_err = |source| OutputError::Parquet {
        path: path.to_path_buf(),
        source,
    };

    let mut kv = vec![
        ("table", meta.table.clone()),
        ("drive_id", meta.drive_id.clone()),
        ("schema_version", drive_log().schema_version.clone()),
        ("source_file", meta.source_file.clone()),
        ("fleetdyn_version", env!("CARGO_PKG_VERSION").to_string()),
        ("config_hash", meta.config_hash.clone()),
    ];
    if let Some(v) = &meta.vehicle_id {
        kv.push(("vehicle_id", v.clone()));
    }
    kv.push(("units", units_json(&fields)));
    let mut kv: Vec<KeyValue> = kv
        .into_iter()
        .map(|(k, v)| KeyValue::new(k.to_string(), v))
        .collect();
    kv.extend(
        meta.extra
            .iter()
            .map(|(k, v)| KeyValue::new(k.clone(), v.clone())),
    );
    // The same entries go into the Arrow schema metadata, so readers that surface only the
    // embedded Arrow schema (pyarrow's `schema.metadata`) see them too.
    let schema = Arc::new(
        Schema::new(fields).with_metadata(
            kv.iter()
                .map(|e| (e.key.clone(), e.value.clone().unwrap_or_default()))
                .collect::<HashMap<String, String>>(),
        ),
    );
    let level = ZstdLevel::try_new(encoding.zstd_level).map_err(pq_err)?;
    let mut props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(level))
        .set_max_row_group_row_count(Some(1 << 20))
        .set_key_value_metadata(Some(kv));
    if encoding.split_floats {
        for c in cols.iter() {
            let col = ColumnPath::from(c.name);
            props = match c.data.dtype() {
                Dtype::F64 => props
                    .set_column_dictionary_enabled(col.clone(), false)
                    .set_column_encoding(col, Encoding::BYTE_STREAM_SPLIT),
                Dtype::TimestampNsUtc | Dtype::I16 => props
                    .set_column_dictionary_enabled(col.clone(), false)
                    .set_column_encoding(col, Encoding::DELTA_BINARY_PACKED),
                _ => props,
            };
        }
    }
    let props = props.build();

    let tmp = AtomicFile::create(path).map_err(io_err)?;
    let handle = tmp.try_clone_file().map_err(io_err)?;
    let mut writer = ArrowWriter::try_new(handle, schema.clone(), Some(props)).map_err(pq_err)?;
    // One empty batch for an empty table (its schema still written), else slices of
    // WRITE_SLICE_ROWS: a multiple of the writer's 1024-row mini-batches, so pages and row
    // groups fall where one whole batch would put them.
    let mut start = 0;
    loop {
        let end = (start + WRITE_SLICE_ROWS).min(n);
        let batch = RecordBatch::try_new(schema.clone(), slice(start..end))
            .map_err(|e| pq_err(parquet::errors::ParquetError::General(e.to_string())))?;
        writer.write(&batch).map_err(pq_err)?;
        start = end;
        if start >= n {
            break;
        }
    }
    writer.close().map_err(pq_err)?;
    tmp.commit().map_err(io_err)
}
