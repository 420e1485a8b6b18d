//! Parquet sources: the canonical wide layout, mapped wide exports and the long layout.
//!
//! Reading streams record batches (64 Ki rows) with a column projection, so memory holds only
//! the columns the mapping asks for (long layout: only the rows of mapped signals), converted to
//! SI as they arrive — never the source file as a whole.

use super::channel::{BadSamples, Channel, TimeRepair};
use super::mapping::{Mapping, ResolvedSignal, SourceFormat};
use super::IngestError;
use crate::schema::drive_log;
use crate::units::{conversion, Conversion};
use arrow::array::{Array, AsArray};
use arrow::compute::cast;
use arrow::datatypes::{DataType, Float64Type, Int64Type, Schema, TimeUnit};
use parquet::arrow::arrow_reader::{ParquetRecordBatchReader, ParquetRecordBatchReaderBuilder};
use parquet::arrow::ProjectionMask;
use std::collections::HashMap;
use std::fs::File;
use std::path::Path;

const BATCH_ROWS: usize = 64 * 1024;

/// What a Parquet file yielded.
#[derive(Debug)]
pub struct ParquetRead {
    /// Wide layout: already on one time base (times, rows, channels sharing them).
    pub wide: Option<WideTable>,
    /// Long layout: one channel per mapped signal.
    pub channels: Vec<Channel>,
    /// Rows in the source file.
    pub source_rows: u64,
    /// File key–value metadata.
    pub kv: HashMap<String, String>,
    /// Unmapped columns passed through (wide) with their units.
    pub passthrough: Vec<String>,
    /// Columns or signals ignored (non-numeric or unmapped in long layout).
    pub ignored: Vec<String>,
}

/// A wide table as read: one time column and signal columns on it.
#[derive(Debug)]
pub struct WideTable {
    /// Times, ns since the epoch.
    pub t_ns: Vec<i64>,
    /// Source row of each time.
    pub rows: Vec<u64>,
    /// (column, unit, values) in SI.
    pub columns: Vec<(String, String, Vec<f64>)>,
}

fn open(path: &Path) -> Result<ParquetRecordBatchReaderBuilder<File>, IngestError> {
    let file = File::open(path).map_err(|e| IngestError::Io {
        file: path.into(),
        source: e,
    })?;
    let len = file.metadata().map(|m| m.len()).unwrap_or(u64::MAX);
    let builder =
        ParquetRecordBatchReaderBuilder::try_new(file).map_err(|e| IngestError::Parquet {
            file: path.into(),
            source: e,
        })?;
    check_chunks(builder.metadata(), len).map_err(|message| IngestError::Parquet {
        file: path.into(),
        source: parquet::errors::ParquetError::General(message),
    })?;
    Ok(builder)
}

/// Every column chunk the footer declares must lie inside the file: the parquet crate asserts
/// (panics) on a negative offset or length while reading (found by `cargo fuzz`, target
/// `ingest_parquet`; docs/validation/robustness.md), so a corrupt footer is refused here instead.
fn check_chunks(
    meta: &parquet::file::metadata::ParquetMetaData,
    file_len: u64,
) -> Result<(), String> {
    for (r, rg) in meta.row_groups().iter().enumerate() {
        for (c, col) in rg.columns().iter().enumerate() {
            let start = col
                .dictionary_page_offset()
                .unwrap_or(col.data_page_offset());
            let len = col.compressed_size();
            let inside = u64::try_from(start)
                .ok()
                .zip(u64::try_from(len).ok())
                .and_then(|(s, l)| s.checked_add(l))
                .is_some_and(|end| end <= file_len);
            if !inside {
                return Err(format!(
                    "row group {r}, column {} ({}): chunk at byte {start}, length {len}, is outside the file ({file_len} bytes)",
                    c,
                    col.column_path().string()
                ));
            }
        }
    }
    Ok(())
}

/// A batch reader over the root columns `roots` only.
fn projected(
    path: &Path,
    builder: ParquetRecordBatchReaderBuilder<File>,
    roots: Vec<usize>,
) -> Result<ParquetRecordBatchReader, IngestError> {
    let mask = ProjectionMask::roots(builder.parquet_schema(), roots);
    builder
        .with_projection(mask)
        .with_batch_size(BATCH_ROWS)
        .build()
        .map_err(|e| IngestError::Parquet {
            file: path.into(),
            source: e,
        })
}

thread_local! {
    /// Set while this thread decodes Parquet inside [`guarded`].
    static DECODING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs a Parquet read, turning a panic of the decoder into [`IngestError::Parquet`].
///
/// parquet 60.1 and arrow-buffer assert on some corrupt pages (e.g. definition levels that run past
/// their buffer: `offset + len out of bounds`, found by `cargo fuzz`, target `ingest_parquet`;
/// docs/validation/robustness.md) instead of returning an error. A corrupt file must fail its drive
/// with a typed error, not abort the process, so the read is unwound and reported. The panic
/// message is kept out of stderr by a hook that stays silent only while this thread is inside a
/// guarded read (other panics reach the previous hook).
fn guarded<T>(
    path: &Path,
    read: impl FnOnce() -> Result<T, IngestError>,
) -> Result<T, IngestError> {
    static HOOK: std::sync::Once = std::sync::Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !DECODING.with(std::cell::Cell::get) {
                previous(info);
            }
        }));
    });
    let outer = DECODING.with(|d| d.replace(true));
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(read));
    DECODING.with(|d| d.set(outer));
    r.unwrap_or_else(|payload| {
        let what = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown".into());
        Err(IngestError::Parquet {
            file: path.into(),
            source: parquet::errors::ParquetError::General(format!(
                "corrupt data: the decoder failed ({what})"
            )),
        })
    })
}

/// Column names of a Parquet file (for mapping detection).
///
/// # Errors
/// I/O or Parquet errors.
pub fn column_names(path: &Path) -> Result<Vec<String>, IngestError> {
    Ok(open(path)?
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect())
}

fn time_to_ns(
    path: &Path,
    column: &str,
    arr: &dyn Array,
    numeric_unit: Option<&str>,
    row0: u64,
    out: &mut Vec<i64>,
) -> Result<(), IngestError> {
    let null_err = |i: usize| IngestError::NoData {
        file: path.into(),
        what: format!("time column {column} is null at row {}", row0 + i as u64),
    };
    match arr.data_type() {
        DataType::Timestamp(_, _) => {
            let ns = cast(arr, &DataType::Timestamp(TimeUnit::Nanosecond, None)).map_err(|e| {
                IngestError::WrongDtype {
                    file: path.into(),
                    column: column.into(),
                    found: format!("{} ({e})", arr.data_type()),
                    expected: "timestamp".into(),
                }
            })?;
            let ns = ns.as_primitive::<arrow::datatypes::TimestampNanosecondType>();
            for i in 0..ns.len() {
                if ns.is_null(i) {
                    return Err(null_err(i));
                }
                out.push(ns.value(i));
            }
        }
        dt if dt.is_numeric() => {
            let scale = match numeric_unit {
                Some("s") => 1e9,
                Some("ms") => 1e6,
                Some("us") => 1e3,
                Some("ns") => 1.0,
                other => {
                    return Err(IngestError::WrongDtype {
                        file: path.into(),
                        column: column.into(),
                        found: format!(
                            "{dt} without a time unit ({})",
                            other.map_or("none given".to_string(), |u| format!("`{u}`"))
                        ),
                        expected: "timestamp, or a numeric time with [time] unit = s|ms|us|ns"
                            .into(),
                    })
                }
            };
            if dt.is_integer() && scale == 1.0 {
                let v = cast(arr, &DataType::Int64).expect("integer casts to i64");
                let v = v.as_primitive::<Int64Type>();
                for i in 0..v.len() {
                    if v.is_null(i) {
                        return Err(null_err(i));
                    }
                    out.push(v.value(i));
                }
            } else {
                let v = cast(arr, &DataType::Float64).expect("numeric casts to f64");
                let v = v.as_primitive::<Float64Type>();
                for i in 0..v.len() {
                    if v.is_null(i) {
                        return Err(null_err(i));
                    }
                    out.push((v.value(i) * scale).round() as i64);
                }
            }
        }
        other => {
            return Err(IngestError::WrongDtype {
                file: path.into(),
                column: column.into(),
                found: other.to_string(),
                expected: "timestamp".into(),
            })
        }
    }
    Ok(())
}

fn numeric_to_f64(
    path: &Path,
    column: &str,
    arr: &dyn Array,
    conv: Conversion,
    out: &mut Vec<f64>,
) -> Result<(), IngestError> {
    let dt = arr.data_type();
    if !(dt.is_numeric() || *dt == DataType::Boolean) {
        return Err(IngestError::WrongDtype {
            file: path.into(),
            column: column.into(),
            found: dt.to_string(),
            expected: "a numeric type".into(),
        });
    }
    let v = cast(arr, &DataType::Float64).expect("numeric casts to f64");
    let v = v.as_primitive::<Float64Type>();
    out.extend((0..v.len()).map(|i| {
        if v.is_null(i) {
            f64::NAN
        } else {
            conv.apply(v.value(i))
        }
    }));
    Ok(())
}

fn field_unit(schema: &Schema, name: &str) -> Option<String> {
    schema
        .field_with_name(name)
        .ok()
        .and_then(|f| f.metadata().get("unit").cloned())
}

/// Reads a wide Parquet file. `mapping = None` means the canonical layout: canonical column
/// names, units from the `unit` field metadata (converted if not SI; assumed SI if absent).
///
/// # Errors
/// I/O, Parquet, dtype and unit errors, naming the file and column.
pub fn read_wide(path: &Path, mapping: Option<&Mapping>) -> Result<ParquetRead, IngestError> {
    guarded(path, || read_wide_unguarded(path, mapping))
}

fn read_wide_unguarded(path: &Path, mapping: Option<&Mapping>) -> Result<ParquetRead, IngestError> {
    let builder = open(path)?;
    let schema = builder.schema().clone();
    let kv = kv_metadata(&builder);
    let canonical = drive_log();
    let time_col = mapping
        .and_then(|m| m.time.column.clone())
        .unwrap_or_else(|| "timestamp".into());
    let time_unit = mapping.and_then(|m| m.time.unit.clone());

    // (source column, canonical name, unit, conversion)
    let mut wanted: Vec<(String, String, String, Conversion)> = Vec::new();
    let mut passthrough = Vec::new();
    let mut ignored = Vec::new();
    let resolved: Vec<ResolvedSignal> = match mapping {
        Some(m) => m.resolve()?,
        None => Vec::new(),
    };
    for f in schema.fields() {
        let name = f.name();
        if *name == time_col {
            continue;
        }
        if let Some(r) = resolved.iter().find(|r| &r.source == name) {
            let spec = canonical
                .column(&r.column)
                .expect("resolved against schema");
            wanted.push((
                name.clone(),
                r.column.clone(),
                spec.unit.clone(),
                r.conversion,
            ));
        } else if let (None, Some(spec)) = (mapping, canonical.column(name)) {
            let conv = match field_unit(&schema, name) {
                Some(u) if u != spec.unit => {
                    conversion(&u, &spec.quantity, None).map_err(|e| IngestError::Unit {
                        mapping: format!("{} (field metadata)", path.display()),
                        column: name.clone(),
                        source: e,
                    })?
                }
                _ => Conversion::IDENTITY,
            };
            wanted.push((name.clone(), name.clone(), spec.unit.clone(), conv));
        } else if f.data_type().is_numeric() && canonical.column(name).is_none() {
            let unit = mapping
                .and_then(|m| m.passthrough_units.get(name).cloned())
                .or_else(|| field_unit(&schema, name))
                .unwrap_or_else(|| "unknown".into());
            passthrough.push(name.clone());
            wanted.push((name.clone(), name.clone(), unit, Conversion::IDENTITY));
        } else {
            ignored.push(name.clone());
        }
    }
    if schema.field_with_name(&time_col).is_err() {
        return Err(IngestError::MissingColumn {
            file: path.into(),
            column: "timestamp".into(),
            source_name: time_col,
            stage: "all".into(),
        });
    }
    let roots: Vec<usize> = schema
        .fields()
        .iter()
        .enumerate()
        .filter(|(_, f)| *f.name() == time_col || wanted.iter().any(|w| &w.0 == f.name()))
        .map(|(i, _)| i)
        .collect();
    let reader = projected(path, builder, roots)?;
    let mut t_ns = Vec::new();
    let mut columns: Vec<(String, String, Vec<f64>)> = wanted
        .iter()
        .map(|(_, c, u, _)| (c.clone(), u.clone(), Vec::new()))
        .collect();
    let mut rows = 0u64;
    for batch in reader {
        let batch = batch.map_err(|e| IngestError::Parquet {
            file: path.into(),
            source: e.into(),
        })?;
        let tcol = batch.column_by_name(&time_col).expect("projected");
        time_to_ns(
            path,
            &time_col,
            tcol.as_ref(),
            time_unit.as_deref(),
            rows,
            &mut t_ns,
        )?;
        for ((src, _, _, conv), (_, _, out)) in wanted.iter().zip(columns.iter_mut()) {
            let arr = batch.column_by_name(src).expect("projected");
            numeric_to_f64(path, src, arr.as_ref(), *conv, out)?;
        }
        rows += batch.num_rows() as u64;
    }
    Ok(ParquetRead {
        wide: Some(WideTable {
            rows: (0..t_ns.len() as u64).collect(),
            t_ns,
            columns,
        }),
        channels: Vec::new(),
        source_rows: rows,
        kv,
        passthrough,
        ignored,
    })
}

/// Reads a long-layout Parquet file (time, signal, value) into one channel per mapped signal;
/// rows of unmapped signals are skipped while streaming and listed in `ignored`.
///
/// # Errors
/// I/O, Parquet and dtype errors.
pub fn read_long(path: &Path, mapping: &Mapping) -> Result<ParquetRead, IngestError> {
    guarded(path, || read_long_unguarded(path, mapping))
}

fn read_long_unguarded(path: &Path, mapping: &Mapping) -> Result<ParquetRead, IngestError> {
    debug_assert_eq!(mapping.format, SourceFormat::ParquetLong);
    let long = mapping.long.as_ref().expect("checked by Mapping::resolve");
    let builder = open(path)?;
    let schema = builder.schema().clone();
    let kv = kv_metadata(&builder);
    let time_col = mapping
        .time
        .column
        .clone()
        .unwrap_or_else(|| "timestamp".into());
    for (c, stage) in [
        (&time_col, "all"),
        (&long.signal_column, "all"),
        (&long.value_column, "all"),
    ] {
        if schema.field_with_name(c).is_err() {
            return Err(IngestError::MissingColumn {
                file: path.into(),
                column: c.clone(),
                source_name: c.clone(),
                stage: stage.into(),
            });
        }
    }
    let resolved = mapping.resolve()?;
    let mut channels = Channel::for_signals(&resolved);
    let by_name: HashMap<&str, usize> = resolved
        .iter()
        .enumerate()
        .map(|(i, r)| (r.source.as_str(), i))
        .collect();
    let mut ignored: Vec<String> = Vec::new();
    let roots: Vec<usize> = [&time_col, &long.signal_column, &long.value_column]
        .iter()
        .map(|c| schema.index_of(c).expect("checked"))
        .collect();
    let reader = projected(path, builder, roots)?;
    let mut rows = 0u64;
    let mut t_batch = Vec::new();
    let mut v_batch = Vec::new();
    for batch in reader {
        let batch = batch.map_err(|e| IngestError::Parquet {
            file: path.into(),
            source: e.into(),
        })?;
        t_batch.clear();
        v_batch.clear();
        time_to_ns(
            path,
            &time_col,
            batch.column_by_name(&time_col).expect("projected").as_ref(),
            mapping.time.unit.as_deref(),
            rows,
            &mut t_batch,
        )?;
        numeric_to_f64(
            path,
            &long.value_column,
            batch
                .column_by_name(&long.value_column)
                .expect("projected")
                .as_ref(),
            Conversion::IDENTITY,
            &mut v_batch,
        )?;
        let sig = batch
            .column_by_name(&long.signal_column)
            .expect("projected");
        let sig = cast(sig, &DataType::Utf8).map_err(|_| IngestError::WrongDtype {
            file: path.into(),
            column: long.signal_column.clone(),
            found: sig.data_type().to_string(),
            expected: "string".into(),
        })?;
        let sig = sig.as_string::<i32>();
        for i in 0..batch.num_rows() {
            let name = if sig.is_null(i) { "" } else { sig.value(i) };
            match by_name.get(name) {
                Some(&k) => {
                    let v = resolved[k].conversion.apply(v_batch[i]);
                    channels[k].push(t_batch[i], v, rows + i as u64);
                }
                None => {
                    if !ignored.iter().any(|s| s == name) {
                        ignored.push(name.to_string());
                    }
                }
            }
        }
        rows += batch.num_rows() as u64;
    }
    Ok(ParquetRead {
        wide: None,
        channels,
        source_rows: rows,
        kv,
        passthrough: Vec::new(),
        ignored,
    })
}

fn kv_metadata(builder: &ParquetRecordBatchReaderBuilder<File>) -> HashMap<String, String> {
    builder
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .map(|kv| {
            kv.iter()
                .filter_map(|e| e.value.clone().map(|v| (e.key.clone(), v)))
                .collect()
        })
        .unwrap_or_default()
}

/// Drops exact duplicate rows of a wide table and enforces increasing time; a repeated time with
/// other values keeps the later row under [`BadSamples::Mask`]. Returns the number of exact
/// duplicates dropped and the times of the rows replaced by a later one.
///
/// # Errors
/// [`IngestError::NonMonotonicTime`] (unless `repair` sorts) and, with [`BadSamples::Error`],
/// [`IngestError::DuplicateTimestamp`] naming the first column that differs.
pub fn order_wide(
    path: &Path,
    w: &mut WideTable,
    repair: TimeRepair,
    bad: BadSamples,
) -> Result<(u64, Vec<i64>), IngestError> {
    if repair == TimeRepair::Sort && w.t_ns.windows(2).any(|p| p[1] < p[0]) {
        let mut idx: Vec<usize> = (0..w.t_ns.len()).collect();
        idx.sort_by_key(|&i| w.t_ns[i]);
        w.t_ns = idx.iter().map(|&i| w.t_ns[i]).collect();
        w.rows = idx.iter().map(|&i| w.rows[i]).collect();
        for c in &mut w.columns {
            c.2 = idx.iter().map(|&i| c.2[i]).collect();
        }
    }
    // the usual case, strictly increasing times: nothing to check further or to move
    if w.t_ns.windows(2).all(|p| p[1] > p[0]) {
        return Ok((0, Vec::new()));
    }
    let same = |a: f64, b: f64| a == b || (a.is_nan() && b.is_nan());
    let mut keep = 0usize;
    let (mut dropped, mut replaced) = (0, Vec::new());
    for i in 0..w.t_ns.len() {
        if keep > 0 {
            let (tp, t) = (w.t_ns[keep - 1], w.t_ns[i]);
            if t < tp {
                return Err(IngestError::NonMonotonicTime {
                    file: path.into(),
                    column: "timestamp".into(),
                    row: w.rows[i],
                    time_ns: t,
                    previous_ns: tp,
                });
            }
            if t == tp {
                let differs = w.columns.iter().any(|c| !same(c.2[i], c.2[keep - 1]));
                if differs && bad == BadSamples::Mask {
                    // the later row wins
                    w.rows[keep - 1] = w.rows[i];
                    for c in &mut w.columns {
                        c.2[keep - 1] = c.2[i];
                    }
                    replaced.push(t);
                    continue;
                }
                if let Some(c) = w.columns.iter().find(|c| !same(c.2[i], c.2[keep - 1])) {
                    return Err(IngestError::DuplicateTimestamp {
                        file: path.into(),
                        column: c.0.clone(),
                        row: w.rows[i],
                        time_ns: t,
                        value: c.2[i],
                        previous: c.2[keep - 1],
                    });
                }
                dropped += 1;
                continue;
            }
        }
        w.t_ns[keep] = w.t_ns[i];
        w.rows[keep] = w.rows[i];
        for c in &mut w.columns {
            c.2[keep] = c.2[i];
        }
        keep += 1;
    }
    w.t_ns.truncate(keep);
    w.rows.truncate(keep);
    for c in &mut w.columns {
        c.2.truncate(keep);
    }
    Ok((dropped, replaced))
}
