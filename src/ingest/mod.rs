//! Ingest: every supported input becomes the canonical drive log (`schemas/drive-log.toml`).
//!
//! Formats (detected from the file's magic bytes, not its name):
//! - Parquet, canonical wide layout (canonical names; `unit` field metadata converted if not SI);
//! - Parquet exports with other names and units, wide or long (time, signal, value), through a
//!   mapping file (`schemas/mappings/*.toml`, see [`mapping`]);
//! - MCAP with JSON messages, one topic per CAN message group at its own rate, through a topic
//!   mapping;
//! - raw CAN frames (MDF4 bus logging, MCAP frame channels) with DBC files: [`can`].
//!
//! Multi-rate sources are aligned onto one time base ([`align`]); wide tables keep their own.
//! Checks, each an [`IngestError`] naming file, column, row, time and value: required columns of
//! the requested stages, dtypes, units, time order and duplicates, physical ranges (the vehicle's
//! gearbox narrows the gear range), and, with [`OnGap::Error`], runs of missing values longer
//! than the limit (by default such a hole splits the recording, below). A vehicle that never
//! moves is refused by resampling ([`crate::signal::distance`]). Nothing is written here; a failed
//! drive leaves no output.
//!
//! Identification: `drive_id` and `vehicle_id` come from the source's metadata (Parquet
//! key–value metadata; MCAP metadata records), else the drive id is the file stem; explicit
//! options override both.
//!
//! Logger pauses: a recording whose required signals stop for longer than the missing-value
//! limit is split into drives of their own, `<drive_id>-s<k>` ([`segment`], [`OnGap`]);
//! [`ingest`] returns them all, [`ingest_file`] the one drive a single-drive command works on.

pub mod align;
pub mod can;
pub mod channel;
mod error;
pub mod mapping;
mod mcap_source;
mod parquet_source;
mod recording;
pub mod segment;

pub use align::TimeBase;
pub use channel::{BadSamples, TimeRepair};
pub use error::IngestError;
pub use mapping::{Mapping, SourceFormat};
pub(crate) use recording::{drives, split_table, Marks, Pieces};
pub use recording::{single, IngestReport, Ingested, Recording};
use segment::check_row_gaps;
pub use segment::{check_nan_runs, OnGap, Pause, SkippedSegment};

use crate::schema::{drive_log, Stage};
use crate::table::{DriveLog, DriveMeta, Signal};
use channel::{bad_samples, check_range, Channel};
use std::io::Read;
use std::path::Path;

/// Ingest settings.
#[derive(Debug, Clone)]
pub struct IngestOptions {
    /// Mapping to use; `None` selects one automatically (see [`ingest_file`]).
    pub mapping: Option<Mapping>,
    /// Stages the drive is read for; their `needed_by` columns are required.
    pub stages: Vec<Stage>,
    /// Time base for multi-rate sources.
    pub time_base: TimeBase,
    /// Longest run of missing values accepted in a required column, s; a longer one is a hole
    /// that splits the recording or fails it (`on_gap`).
    pub max_nan_run_s: f64,
    /// Valid gear range (from the vehicle file); the schema's wide range when `None`.
    pub gear_range: Option<(i16, i16)>,
    /// Backwards time handling.
    pub time_repair: TimeRepair,
    /// Isolated bad samples and conflicting repeated timestamps: masked (default) or an error.
    pub bad_samples: BadSamples,
    /// A required signal stopping for longer than `max_nan_run_s`: split the recording there
    /// (default) or an error ([`segment`]).
    pub on_gap: OnGap,
    /// Segments of a split recording shorter than this are skipped, s.
    pub min_segment_s: f64,
    /// Segments of a split recording in which the vehicle travels less are skipped, m.
    pub min_segment_m: f64,
    /// Drive id override (default: the source's metadata — Parquet key–value `drive_id`, MCAP
    /// metadata record entry `drive_id` — else the file stem).
    pub drive_id: Option<String>,
    /// Vehicle id override.
    pub vehicle_id: Option<String>,
}

impl Default for IngestOptions {
    fn default() -> Self {
        Self {
            mapping: None,
            stages: vec![Stage::Ingest],
            time_base: TimeBase::Fastest,
            max_nan_run_s: 2.0,
            gear_range: None,
            time_repair: TimeRepair::Error,
            bad_samples: BadSamples::Mask,
            on_gap: OnGap::Split,
            min_segment_s: DEFAULT_MIN_SEGMENT_S,
            min_segment_m: DEFAULT_MIN_SEGMENT_M,
            drive_id: None,
            vehicle_id: None,
        }
    }
}

/// Default shortest segment of a split recording kept as a drive, s: a minute holds a few
/// shuffle periods and a launch, less is a logger waking for a moment.
pub const DEFAULT_MIN_SEGMENT_S: f64 = 60.0;
/// Default least distance a segment of a split recording must cover, m: less is a truck
/// manoeuvring at a rest stop, not a drive.
pub const DEFAULT_MIN_SEGMENT_M: f64 = 100.0;

const PARQUET_MAGIC: &[u8] = b"PAR1";
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// Reads one file into the canonical drive log: the single drive of a recording that does not
/// split at pauses, or that keeps one segment (see [`ingest`]).
///
/// # Errors
/// Any [`IngestError`] of [`ingest`], and [`IngestError::Segmented`] when the recording splits
/// into several drives.
pub fn ingest_file(path: &Path, opts: &IngestOptions) -> Result<Ingested, IngestError> {
    single(path, ingest(path, opts)?)
}

/// Reads one file into the canonical drive log, split at pauses into drives of their own
/// ([`segment`]).
///
/// Mapping selection when `opts.mapping` is `None`: a Parquet file with `timestamp` and
/// `vehicle_speed` columns is canonical; otherwise the first embedded mapping whose
/// `detect_columns` are all present; an MCAP file uses the embedded `mcap-json` mapping.
///
/// # Errors
/// Any [`IngestError`]; the message names the file and, where it applies, column, row, time
/// and value. [`IngestError::NoUsableSegment`] when every segment is skipped.
pub fn ingest(path: &Path, opts: &IngestOptions) -> Result<Recording, IngestError> {
    let mut head = [0u8; 8];
    let n = std::fs::File::open(path)
        .and_then(|mut f| f.read(&mut head))
        .map_err(|e| IngestError::Io {
            file: path.into(),
            source: e,
        })?;
    let head = &head[..n];
    let is_parquet = head.starts_with(PARQUET_MAGIC);
    let is_mcap = head.starts_with(MCAP_MAGIC);
    if head.starts_with(b"MDF     ") || head.starts_with(b"UnFinMF ") {
        return Err(IngestError::NeedsDbc { file: path.into() });
    }
    if !is_parquet && !is_mcap {
        return Err(IngestError::UnknownFormat {
            file: path.into(),
            head: head
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<Vec<_>>()
                .join(" "),
        });
    }
    let mapping = match &opts.mapping {
        Some(m) => {
            let fits = match m.format {
                SourceFormat::McapJson => is_mcap,
                SourceFormat::CanDbc => false,
                _ => is_parquet,
            };
            if !fits {
                return Err(IngestError::Mapping {
                    mapping: m.origin.clone(),
                    message: format!(
                        "is for {} sources but {} is {}",
                        m.format.name(),
                        path.display(),
                        if is_mcap { "MCAP" } else { "Parquet" }
                    ),
                });
            }
            Some(m.clone())
        }
        None => auto_mapping(path, is_mcap)?,
    };

    let mut report = IngestReport {
        mapping: mapping
            .as_ref()
            .map_or_else(|| "canonical".into(), |m| m.name.clone()),
        ..Default::default()
    };
    let required = required_columns(&opts.stages);
    if let Some(m) = &mapping {
        for (col, stage) in &required {
            if !m.signals.contains_key(*col) {
                return Err(IngestError::MissingColumn {
                    file: path.into(),
                    column: (*col).into(),
                    source_name: format!("<not in mapping {}>", m.name),
                    stage: (*stage).into(),
                });
            }
        }
    }

    let kv;
    let mut marks = Marks::default();
    let pieces = match mapping.as_ref().map(|m| m.format) {
        None | Some(SourceFormat::ParquetWide) => {
            report.format = "parquet-wide".into();
            let mut read = parquet_source::read_wide(path, mapping.as_ref())?;
            report.source_rows = read.source_rows;
            report.passthrough = read.passthrough;
            report.ignored = read.ignored;
            kv = read.kv;
            let mut w = read.wide.take().expect("wide read");
            for (col, stage) in &required {
                if !w.columns.iter().any(|c| c.0 == *col) {
                    let source_name = mapping
                        .as_ref()
                        .and_then(|m| m.signals.get(*col))
                        .and_then(|s| s.source.clone())
                        .unwrap_or_else(|| (*col).into());
                    return Err(IngestError::MissingColumn {
                        file: path.into(),
                        column: (*col).into(),
                        source_name,
                        stage: (*stage).into(),
                    });
                }
            }
            let (dropped, replaced) =
                parquet_source::order_wide(path, &mut w, opts.time_repair, opts.bad_samples)?;
            report.duplicates_dropped = dropped;
            marks.conflicts(replaced);
            for (name, unit, values) in &mut w.columns {
                let bad = screen(path, name, unit, &w.t_ns, values, Some(&w.rows), opts)?;
                let mut at = Vec::new();
                for ((v, b), t) in values.iter_mut().zip(&bad).zip(&w.t_ns) {
                    if *b {
                        *v = f64::NAN;
                        at.push(*t);
                    }
                }
                if !at.is_empty() {
                    marks.masked.insert(name.clone(), at);
                }
            }
            let signals: Vec<Signal> = w
                .columns
                .into_iter()
                .map(|(name, unit, values)| Signal { name, unit, values })
                .collect();
            if w.t_ns.is_empty() {
                return Err(IngestError::NoData {
                    file: path.into(),
                    what: "no rows: the source holds no samples".into(),
                });
            }
            wide_pieces(path, w.t_ns, signals, &w.rows, &required, opts)?
        }
        Some(fmt) => {
            let m = mapping.as_ref().expect("mapped format");
            let (channels, ignored, rows) = if fmt == SourceFormat::McapJson {
                report.format = "mcap-json".into();
                let r = mcap_source::read_mcap(path, m)?;
                kv = r.metadata;
                (r.channels, r.ignored, r.messages)
            } else {
                report.format = "parquet-long".into();
                let r = parquet_source::read_long(path, m)?;
                kv = r.kv;
                (r.channels, r.ignored, r.source_rows)
            };
            report.source_rows = rows;
            report.ignored = ignored;
            align_channels(path, channels, &required, opts, m, &mut report, &mut marks)?
        }
    };
    let file_stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let meta = DriveMeta {
        drive_id: opts
            .drive_id
            .clone()
            .or_else(|| kv.get("drive_id").cloned())
            .unwrap_or(file_stem),
        vehicle_id: opts
            .vehicle_id
            .clone()
            .or_else(|| kv.get("vehicle_id").cloned())
            .or_else(|| mapping.as_ref().and_then(|m| m.vehicle_id.clone())),
        source_file: path.display().to_string(),
        segment: None,
    };
    drives(
        path,
        meta,
        report,
        pieces,
        &marks,
        (opts.min_segment_s, opts.min_segment_m),
    )
}

/// The wide table's pieces: the whole table after the gap checks ([`OnGap::Error`]), or its
/// segments ([`segment::split_rows`]).
fn wide_pieces(
    path: &Path,
    t_ns: Vec<i64>,
    signals: Vec<Signal>,
    rows: &[u64],
    required: &[(&str, &str)],
    opts: &IngestOptions,
) -> Result<Pieces, IngestError> {
    if opts.on_gap == OnGap::Error || required.is_empty() {
        check_nan_runs(path, &t_ns, &signals, required, opts.max_nan_run_s)?;
        if !required.is_empty() {
            check_row_gaps(path, &t_ns, rows, opts.max_nan_run_s)?;
        }
        return Ok(Pieces {
            tables: vec![(t_ns, signals)],
            pauses: Vec::new(),
        });
    }
    split_table(path, t_ns, signals, required, opts.max_nan_run_s)
}

/// (column, stage) of every column the stages require.
pub(crate) fn required_columns(stages: &[Stage]) -> Vec<(&'static str, &'static str)> {
    let schema = drive_log();
    let mut required: Vec<(&str, &str)> = Vec::new();
    for stage in stages {
        for c in schema.required_for(&[*stage]) {
            if !required.iter().any(|r| r.0 == c.name) {
                required.push((&c.name, stage.name()));
            }
        }
    }
    required
}

fn auto_mapping(path: &Path, is_mcap: bool) -> Result<Option<Mapping>, IngestError> {
    let embedded = Mapping::embedded();
    if is_mcap {
        let mut mcap = embedded
            .into_iter()
            .filter(|m| m.format == SourceFormat::McapJson);
        return match (mcap.next(), mcap.next()) {
            (Some(m), None) => Ok(Some(m)),
            _ => Err(IngestError::Mapping {
                mapping: "<auto>".into(),
                message: "MCAP input needs a topic mapping: pass --mapping".into(),
            }),
        };
    }
    let names = parquet_source::column_names(path)?;
    let has = |c: &str| names.iter().any(|n| n == c);
    if has("timestamp") && has("vehicle_speed") {
        return Ok(None);
    }
    embedded
        .into_iter()
        .find(|m| !m.detect_columns.is_empty() && m.detect_columns.iter().all(|c| has(c)))
        .map(Some)
        .ok_or_else(|| {
            // the canonical column the file lacks: a canonical file needs both
            let column = if has("timestamp") {
                "vehicle_speed"
            } else {
                "timestamp"
            };
            IngestError::MissingColumn {
                file: path.into(),
                column: column.into(),
                source_name: format!(
                    "not canonical and no bundled mapping fits the columns [{}]; pass --mapping",
                    names.join(", ")
                ),
                stage: "all".into(),
            }
        })
}

/// The bad samples of a column ([`bad_samples`]) to mask, per `opts.bad_samples`: with
/// [`BadSamples::Error`] the first one is an error and nothing is masked.
fn screen(
    path: &Path,
    name: &str,
    unit: &str,
    t_ns: &[i64],
    values: &[f64],
    rows: Option<&[u64]>,
    opts: &IngestOptions,
) -> Result<Vec<bool>, IngestError> {
    let Some(spec) = drive_log().column(name) else {
        return Ok(vec![false; values.len()]);
    };
    let (mut lo, mut hi) = (
        spec.valid_min.unwrap_or(f64::NEG_INFINITY),
        spec.valid_max.unwrap_or(f64::INFINITY),
    );
    if let (Some((g0, g1)), "gear") = (opts.gear_range, name) {
        lo = f64::from(g0);
        hi = f64::from(g1);
    }
    match opts.bad_samples {
        BadSamples::Error => {
            check_range(path, name, unit, t_ns, values, rows, lo, hi)?;
            Ok(vec![false; values.len()])
        }
        BadSamples::Mask => Ok(bad_samples(name, t_ns, values, lo, hi)),
    }
}

/// Checks and aligns multi-rate channels: the aligned table after the gap checks
/// ([`OnGap::Error`]), or the aligned segments (cut at the channels' holes, each piece aligned and
/// split again at its aligned rows' holes).
pub(crate) fn align_channels(
    path: &Path,
    mut channels: Vec<Channel>,
    required: &[(&str, &str)],
    opts: &IngestOptions,
    mapping: &Mapping,
    report: &mut IngestReport,
    marks: &mut Marks,
) -> Result<Pieces, IngestError> {
    for c in &mut channels {
        let (dropped, replaced) = c.order_and_dedup(path, opts.time_repair, opts.bad_samples)?;
        report.duplicates_dropped += dropped;
        marks.conflicts(replaced);
        let bad = screen(
            path,
            &c.column,
            &c.unit,
            &c.t_ns,
            &c.values,
            Some(&c.rows),
            opts,
        )?;
        let at: Vec<i64> = c
            .t_ns
            .iter()
            .zip(&bad)
            .filter(|(_, b)| **b)
            .map(|(t, _)| *t)
            .collect();
        if !at.is_empty() {
            c.drop_samples(&bad);
            marks.masked.entry(c.column.clone()).or_default().extend(at);
        }
    }
    for (col, stage) in required {
        let present = channels
            .iter()
            .any(|c| c.column == *col && c.values.iter().any(|v| !v.is_nan()));
        if !present {
            let src = &mapping.signals[*col];
            let source_name = match (&src.topic, &src.field) {
                (Some(t), Some(f)) => format!("{t}:{f}"),
                _ => src.source.clone().unwrap_or_default(),
            };
            return Err(IngestError::MissingColumn {
                file: path.into(),
                column: (*col).into(),
                source_name,
                stage: (*stage).into(),
            });
        }
    }
    // Mapped optional signals absent from this file are dropped, not kept as all-NaN columns.
    channels.retain(|c| !c.is_empty());
    report.channel_rates = channels
        .iter()
        .map(|c| {
            let p = c.median_period_ns();
            (
                c.column.clone(),
                c.len(),
                if p > 0 { 1e9 / p as f64 } else { 0.0 },
            )
        })
        .collect();
    let req: Vec<&str> = required.iter().map(|r| r.0).collect();
    if opts.on_gap == OnGap::Error {
        align::check_gaps(path, &channels, &req, opts.max_nan_run_s)?;
        let a = align::align(path, &channels, &req, opts.time_base)?;
        report.time_base_hz = Some(1e9 / a.period_ns as f64);
        check_nan_runs(path, &a.t_ns, &a.signals, required, opts.max_nan_run_s)?;
        return Ok(Pieces {
            tables: vec![(a.t_ns, a.signals)],
            pauses: Vec::new(),
        });
    }
    let span = align::span(path, &channels, &req)?;
    let (windows, mut pauses) = segment::channel_windows(&channels, &req, opts.max_nan_run_s, span);
    let mut tables = Vec::new();
    for (lo, hi) in windows {
        let part: Vec<Channel> = if pauses.is_empty() {
            std::mem::take(&mut channels)
        } else {
            channels.iter().map(|c| c.window(lo, hi)).collect()
        };
        let a = match align::align(path, &part, &req, opts.time_base) {
            Ok(a) => a,
            // a sliver between two holes where the required signals do not overlap
            Err(IngestError::NoData { .. }) if !pauses.is_empty() => continue,
            Err(e) => return Err(e),
        };
        report.time_base_hz.get_or_insert(1e9 / a.period_ns as f64);
        let p = split_table(path, a.t_ns, a.signals, required, opts.max_nan_run_s)?;
        tables.extend(p.tables);
        pauses.extend(p.pauses);
    }
    pauses.sort_by_key(|p| p.start_ns);
    Ok(Pieces { tables, pauses })
}

/// Missing values per column, in column order.
pub fn nan_counts(log: &DriveLog) -> Vec<(String, usize)> {
    log.signals
        .iter()
        .map(|s| {
            (
                s.name.clone(),
                s.values.iter().filter(|v| v.is_nan()).count(),
            )
        })
        .collect()
}
