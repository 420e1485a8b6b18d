//! A recording in canonical form: the drives it gives (one, or one per segment when it was split
//! at pauses, [`super::segment`]), what happened on the way, and the one drive a single-drive
//! command works on ([`single`]).

use super::error::IngestError;
use super::segment::{check_nan_runs, distance_m, split_rows, Pause, SkippedSegment};
use crate::table::{DriveLog, DriveMeta, Segment, Signal};
use std::collections::BTreeMap;
use std::path::Path;

/// Facts about one ingest, for the summary and the run report.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct IngestReport {
    /// `parquet-wide`, `parquet-long`, `mcap-json`, or for raw CAN sessions `mdf4-can` / `mcap-can`.
    pub format: String,
    /// Mapping used (`canonical` for the canonical layout).
    pub mapping: String,
    /// Rows (Parquet) or messages (MCAP) in the source.
    pub source_rows: u64,
    /// Exact duplicates dropped (all channels).
    pub duplicates_dropped: u64,
    /// Raw CAN frame records or messages that could not be decoded, skipped (a corrupted
    /// record costs that frame, not the file).
    pub corrupt_records: u64,
    /// Samples replaced by a later one with the same time and another value (all channels;
    /// [`super::BadSamples::Mask`]).
    pub conflicts_resolved: u64,
    /// Per column, samples masked to missing: not finite, outside the physical range, or a speed
    /// spike ([`super::BadSamples::Mask`]).
    pub masked: BTreeMap<String, u64>,
    /// Per mapped channel: (column, samples, median rate Hz) — multi-rate sources only.
    pub channel_rates: Vec<(String, usize, f64)>,
    /// Rate of the aligned time base, Hz (multi-rate sources only).
    pub time_base_hz: Option<f64>,
    /// Non-canonical columns kept.
    pub passthrough: Vec<String>,
    /// Columns, signals or topics not used.
    pub ignored: Vec<String>,
}

/// A drive in canonical form, with what happened on the way.
#[derive(Debug, Clone)]
pub struct Ingested {
    /// The canonical table.
    pub log: DriveLog,
    /// Ingest facts (the masked and conflicting samples those of this drive's time span).
    pub report: IngestReport,
}

/// A recording in canonical form: one drive, or the drives it was split into at pauses.
#[derive(Debug, Clone)]
pub struct Recording {
    /// The drives, in time order.
    pub drives: Vec<Ingested>,
    /// Holes the recording was split or trimmed at, in time order.
    pub pauses: Vec<Pause>,
    /// Segments not kept as drives, with the reason.
    pub skipped: Vec<SkippedSegment>,
}

/// Where the masked and the replaced samples were (so each segment counts its own).
#[derive(Debug, Default)]
pub(crate) struct Marks {
    pub(crate) masked: BTreeMap<String, Vec<i64>>,
    conflicts: Vec<i64>,
}

impl Marks {
    pub(crate) fn conflicts(&mut self, times: Vec<i64>) {
        self.conflicts.extend(times);
    }
}

/// The tables a source gave, before they become drives.
pub(crate) struct Pieces {
    pub(crate) tables: Vec<(Vec<i64>, Vec<Signal>)>,
    pub(crate) pauses: Vec<Pause>,
}

/// The one drive of `rec`, else [`IngestError::Segmented`].
///
/// # Errors
/// [`IngestError::Segmented`] naming the pauses.
pub fn single(path: &Path, mut rec: Recording) -> Result<Ingested, IngestError> {
    if rec.drives.len() == 1 {
        return Ok(rec.drives.remove(0));
    }
    Err(IngestError::Segmented {
        file: path.into(),
        drives: rec.drives.len(),
        pauses: pause_list(&rec.pauses),
    })
}

/// `<start> for <s> s (what)`, comma separated.
fn pause_list(pauses: &[Pause]) -> String {
    pauses
        .iter()
        .map(|p| {
            format!(
                "{} for {:.1} s ({})",
                crate::time_fmt::rfc3339_ns(p.start_ns),
                p.seconds(),
                match &p.column {
                    None => "no samples".to_string(),
                    Some(c) => format!("no valid {c}"),
                }
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Splits one table at the holes of its `required` columns ([`split_rows`]); the whole
/// table moves, not copies, when it is one segment.
///
/// # Errors
/// [`IngestError::NanRun`] when nothing is left (a required column without any valid value).
pub(crate) fn split_table(
    path: &Path,
    t_ns: Vec<i64>,
    signals: Vec<Signal>,
    required: &[(&str, &str)],
    limit_s: f64,
) -> Result<Pieces, IngestError> {
    let req: Vec<&str> = required.iter().map(|r| r.0).collect();
    let (ranges, pauses) = split_rows(&t_ns, &signals, &req, limit_s);
    if ranges.is_empty() {
        check_nan_runs(path, &t_ns, &signals, required, limit_s)?;
    }
    if ranges.len() == 1 && ranges[0] == (0..t_ns.len()) {
        return Ok(Pieces {
            tables: vec![(t_ns, signals)],
            pauses,
        });
    }
    let tables = ranges
        .into_iter()
        .map(|r| {
            let sig = signals
                .iter()
                .map(|s| Signal {
                    name: s.name.clone(),
                    unit: s.unit.clone(),
                    values: s.values[r.clone()].to_vec(),
                })
                .collect();
            (t_ns[r].to_vec(), sig)
        })
        .collect();
    Ok(Pieces { tables, pauses })
}

/// The drives of a recording from its pieces (module [`super::segment`]): one piece keeps the
/// recording's id; several are numbered, those shorter than `min_segment_s` (s) or covering less
/// than `min_segment_m` (m) skipped.
///
/// # Errors
/// [`IngestError::NoUsableSegment`] when nothing is left.
pub(crate) fn drives(
    path: &Path,
    meta: DriveMeta,
    report: IngestReport,
    pieces: Pieces,
    marks: &Marks,
    (min_segment_s, min_segment_m): (f64, f64),
) -> Result<Recording, IngestError> {
    let Pieces { tables, pauses } = pieces;
    let count = tables.len();
    let counted = |lo: i64, hi: i64| {
        let mut r = report.clone();
        let inside = |v: &[i64]| v.iter().filter(|t| (lo..=hi).contains(*t)).count() as u64;
        r.masked = marks
            .masked
            .iter()
            .map(|(c, v)| (c.clone(), inside(v)))
            .filter(|(_, n)| *n > 0)
            .collect();
        r.conflicts_resolved = inside(&marks.conflicts);
        r
    };
    if count == 1 {
        let (t_ns, signals) = tables.into_iter().next().expect("one piece");
        let r = counted(t_ns[0], t_ns[t_ns.len() - 1]);
        return Ok(Recording {
            drives: vec![assemble(meta, t_ns, signals, r)],
            pauses,
            skipped: Vec::new(),
        });
    }
    let mut drives = Vec::new();
    let mut skipped = Vec::new();
    let mut reasons = Vec::new();
    for (k, (t_ns, signals)) in tables.into_iter().enumerate() {
        let (t0, t1) = (t_ns[0], t_ns[t_ns.len() - 1]);
        let duration_s = (t1 - t0) as f64 * 1e-9;
        let distance_m = distance_m(&t_ns, &signals);
        let drive_id = format!("{}-s{}", meta.drive_id, k + 1);
        let reason = if duration_s < min_segment_s {
            Some(format!(
                "{duration_s:.0} s long, shorter than min_segment_s = {} s",
                min_segment_s
            ))
        } else if distance_m < min_segment_m {
            Some(format!(
                "the vehicle travels {distance_m:.0} m, less than min_segment_m = {} m",
                min_segment_m
            ))
        } else {
            None
        };
        if let Some(reason) = reason {
            reasons.push(format!("segment {}: {reason}", k + 1));
            skipped.push(SkippedSegment {
                index: k + 1,
                drive_id,
                start_ns: t0,
                duration_s,
                distance_m,
                reason,
            });
            continue;
        }
        let m = DriveMeta {
            drive_id,
            segment: Some(Segment {
                index: k + 1,
                count,
                recording_drive_id: meta.drive_id.clone(),
                start_ns: t0,
                end_ns: t1,
            }),
            ..meta.clone()
        };
        drives.push(assemble(m, t_ns, signals, counted(t0, t1)));
    }
    if drives.is_empty() {
        return Err(IngestError::NoUsableSegment {
            file: path.into(),
            found: count,
            pauses: pause_list(&pauses),
            reasons: reasons.join("; "),
        });
    }
    Ok(Recording {
        drives,
        pauses,
        skipped,
    })
}

/// The canonical log from aligned signals: unnamed (unmapped) signals dropped, columns in
/// schema order.
pub(crate) fn assemble(
    meta: DriveMeta,
    timestamp_ns: Vec<i64>,
    mut signals: Vec<Signal>,
    report: IngestReport,
) -> Ingested {
    signals.retain(|s| !s.name.is_empty());
    let mut log = DriveLog {
        meta,
        timestamp_ns,
        signals,
    };
    log.sort_columns();
    Ingested { log, report }
}
