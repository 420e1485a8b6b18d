//! The canonical drive log in memory: one time axis and SI signal columns.
//!
//! All signal columns are held as `f64` with NaN for "no value"; integer columns of the schema
//! (gear) are converted at the Parquet edge (NaN → null). Columns follow the canonical order of
//! `schemas/drive-log.toml`, then pass-through columns in source order.

use crate::schema::{drive_log, Dtype};

/// Where a drive came from and what it is called.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DriveMeta {
    /// Drive identifier (from the source's metadata, else the file stem).
    pub drive_id: String,
    /// Vehicle identifier, when the source or the mapping names one.
    pub vehicle_id: Option<String>,
    /// Path of the source file as given.
    pub source_file: String,
    /// Where the drive sits in its recording, when the recording was split at logger pauses.
    pub segment: Option<Segment>,
}

/// Where a drive sits in the recording it was split from (Parquet key–value metadata
/// `segment` = `k/N`, `recording_drive_id`, `segment_start`, `segment_end`).
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Segment {
    /// Number of the segment, 1-based, in time order.
    pub index: usize,
    /// Segments the recording was split into (skipped ones included).
    pub count: usize,
    /// Drive id of the whole recording.
    pub recording_drive_id: String,
    /// First sample, ns since the Unix epoch.
    pub start_ns: i64,
    /// Last sample, ns since the Unix epoch.
    pub end_ns: i64,
}

impl Segment {
    /// Key–value metadata entries of the segment (times RFC 3339, UTC).
    pub fn kv(&self) -> Vec<(String, String)> {
        vec![
            ("segment".into(), format!("{}/{}", self.index, self.count)),
            ("recording_drive_id".into(), self.recording_drive_id.clone()),
            (
                "segment_start".into(),
                crate::time_fmt::rfc3339_ns(self.start_ns),
            ),
            (
                "segment_end".into(),
                crate::time_fmt::rfc3339_ns(self.end_ns),
            ),
        ]
    }
}

/// One signal column.
#[derive(Debug, Clone, PartialEq)]
pub struct Signal {
    /// Column name (canonical, or the source name for pass-through columns).
    pub name: String,
    /// Unit (SI for canonical columns; as declared by the source for pass-through ones).
    pub unit: String,
    /// Values in `unit`, NaN where missing.
    pub values: Vec<f64>,
}

impl Signal {
    /// The column's type in the canonical schema (`f64` for pass-through columns).
    pub fn dtype(&self) -> Dtype {
        drive_log()
            .column(&self.name)
            .map(|c| c.dtype)
            .unwrap_or(Dtype::F64)
    }

    /// True when the column is part of the canonical schema.
    pub fn is_canonical(&self) -> bool {
        drive_log().column(&self.name).is_some()
    }
}

/// A drive on one time base, in canonical form.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DriveLog {
    /// Identification and provenance.
    pub meta: DriveMeta,
    /// Sample times, ns since the Unix epoch (UTC), strictly increasing.
    pub timestamp_ns: Vec<i64>,
    /// Signal columns, each as long as `timestamp_ns`.
    pub signals: Vec<Signal>,
}

impl DriveLog {
    /// A log on an evenly spaced time base from 0 (`step_ns` apart) with the columns
    /// `(name, unit, values)`, all as long as the first; no metadata. For logs built in code
    /// (tests, studies); a reader builds its log from the file instead.
    pub fn from_columns(step_ns: i64, columns: Vec<(&str, &str, Vec<f64>)>) -> DriveLog {
        let n = columns.first().map_or(0, |c| c.2.len());
        DriveLog {
            timestamp_ns: (0..n as i64).map(|k| k * step_ns).collect(),
            signals: columns
                .into_iter()
                .map(|(name, unit, values)| Signal {
                    name: name.into(),
                    unit: unit.into(),
                    values,
                })
                .collect(),
            ..DriveLog::default()
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.timestamp_ns.len()
    }

    /// True when the log has no rows.
    pub fn is_empty(&self) -> bool {
        self.timestamp_ns.is_empty()
    }

    /// A copy with the columns `keep` alone (`None`: every column), in the log's order; the
    /// time stamps and metadata copied whole. What a consumer that reads a few columns of a
    /// long drive copies instead of the whole log.
    pub fn with_columns(&self, keep: Option<&[&str]>) -> DriveLog {
        DriveLog {
            meta: self.meta.clone(),
            timestamp_ns: self.timestamp_ns.clone(),
            signals: self
                .signals
                .iter()
                .filter(|s| keep.is_none_or(|k| k.contains(&s.name.as_str())))
                .cloned()
                .collect(),
        }
    }

    /// Values of a column by name.
    pub fn signal(&self, name: &str) -> Option<&[f64]> {
        self.signals
            .iter()
            .find(|s| s.name == name)
            .map(|s| s.values.as_slice())
    }

    /// Values of a column to change in place, if present.
    pub fn signal_mut(&mut self, name: &str) -> Option<&mut [f64]> {
        self.signals
            .iter_mut()
            .find(|s| s.name == name)
            .map(|s| s.values.as_mut_slice())
    }

    /// Time of every row from the first, s (empty for an empty log).
    pub fn seconds_from_start(&self) -> Vec<f64> {
        let t0 = self.timestamp_ns.first().copied().unwrap_or(0);
        self.timestamp_ns
            .iter()
            .map(|&x| (x - t0) as f64 * 1e-9)
            .collect()
    }

    /// Duration from the first to the last sample, s.
    pub fn duration_s(&self) -> f64 {
        match (self.timestamp_ns.first(), self.timestamp_ns.last()) {
            (Some(a), Some(b)) => (b - a) as f64 * 1e-9,
            _ => 0.0,
        }
    }

    /// Sorts the signal columns into canonical order, pass-through columns last (stable).
    pub fn sort_columns(&mut self) {
        let schema = drive_log();
        self.signals
            .sort_by_key(|s| schema.position(&s.name).unwrap_or(usize::MAX));
    }
}

/// A log read with some of its columns replaced: what a consumer that corrects a few columns
/// of a long drive reads, instead of a copy of every column with the few corrected (each
/// column of a 10-hour drive at 50 Hz is 14.4 MB).
#[derive(Debug, Clone, Copy)]
pub struct LogView<'a> {
    /// The log: its time stamps, metadata and every column not replaced.
    pub log: &'a DriveLog,
    /// Columns read instead of the log's of the same name, each as long as the log.
    pub replaced: &'a [Signal],
}

impl<'a> LogView<'a> {
    /// The log as it is.
    pub fn of(log: &'a DriveLog) -> Self {
        Self { log, replaced: &[] }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.log.len()
    }

    /// True when the log has no rows.
    pub fn is_empty(&self) -> bool {
        self.log.is_empty()
    }

    /// Values of a column by name: the replacement, else the log's.
    pub fn signal(&self, name: &str) -> Option<&'a [f64]> {
        match self.replaced.iter().find(|s| s.name == name) {
            Some(s) => Some(s.values.as_slice()),
            None => self.log.signal(name),
        }
    }
}
