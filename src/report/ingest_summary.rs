//! The summary `fleetdyn ingest` prints: what was read, how long and far the drive is, what is
//! missing, and the slope sensor's resolution.

use crate::ingest::{nan_counts, Ingested, Recording};
use crate::signal::distance::{DistanceMap, ResampleConfig};
use crate::signal::quantization::{estimate_quantization, Quantization};
use crate::table::Segment;
use crate::time_fmt::rfc3339_ns;
use std::fmt;

/// Facts about an ingested drive.
#[derive(Debug, Clone)]
pub struct IngestSummary {
    /// Drive id.
    pub drive_id: String,
    /// Vehicle id.
    pub vehicle_id: Option<String>,
    /// Where the drive sits in its recording, when that was split at pauses.
    pub segment: Option<Segment>,
    /// Source file.
    pub source_file: String,
    /// Detected format.
    pub format: String,
    /// Mapping used.
    pub mapping: String,
    /// Source rows or messages.
    pub source_rows: u64,
    /// Rows of the canonical table.
    pub rows: usize,
    /// First sample time, ns.
    pub start_ns: i64,
    /// Duration, s.
    pub duration_s: f64,
    /// Distance from ∫v dt (or odometer), m; `None` when the drive did not move.
    pub distance_m: Option<f64>,
    /// Aligned time base, Hz (multi-rate sources).
    pub time_base_hz: Option<f64>,
    /// (column, samples, median rate Hz) per source channel (multi-rate sources).
    pub channel_rates: Vec<(String, usize, f64)>,
    /// Exact duplicates dropped.
    pub duplicates_dropped: u64,
    /// Raw CAN frame records that could not be decoded, skipped.
    pub corrupt_records: u64,
    /// Samples replaced by a later one at the same time with another value.
    pub conflicts_resolved: u64,
    /// Samples masked to missing, per column (not finite, outside the range, a speed spike).
    pub masked: Vec<(String, u64)>,
    /// Missing values per column.
    pub nan_counts: Vec<(String, usize)>,
    /// Column units, in column order.
    pub units: Vec<(String, String)>,
    /// Estimated slope-sensor quantisation step, tan α.
    pub slope_resolution: Option<Quantization>,
    /// Non-canonical columns kept.
    pub passthrough: Vec<String>,
    /// Source columns/signals/topics not used.
    pub ignored: Vec<String>,
}

impl IngestSummary {
    /// Summarises an ingest.
    pub fn new(ing: &Ingested) -> Self {
        let log = &ing.log;
        let distance_m = DistanceMap::from_log(
            log,
            &ResampleConfig {
                min_distance_m: 0.0,
                ..Default::default()
            },
        )
        .ok()
        .map(|m| m.total_m());
        Self {
            drive_id: log.meta.drive_id.clone(),
            vehicle_id: log.meta.vehicle_id.clone(),
            segment: log.meta.segment.clone(),
            source_file: log.meta.source_file.clone(),
            format: ing.report.format.clone(),
            mapping: ing.report.mapping.clone(),
            source_rows: ing.report.source_rows,
            rows: log.len(),
            start_ns: log.timestamp_ns.first().copied().unwrap_or(0),
            duration_s: log.duration_s(),
            distance_m,
            time_base_hz: ing.report.time_base_hz,
            channel_rates: ing.report.channel_rates.clone(),
            duplicates_dropped: ing.report.duplicates_dropped,
            corrupt_records: ing.report.corrupt_records,
            conflicts_resolved: ing.report.conflicts_resolved,
            masked: ing
                .report
                .masked
                .iter()
                .map(|(c, n)| (c.clone(), *n))
                .collect(),
            nan_counts: nan_counts(log),
            units: log
                .signals
                .iter()
                .map(|s| (s.name.clone(), s.unit.clone()))
                .collect(),
            slope_resolution: log.signal("road_slope").and_then(estimate_quantization),
            passthrough: ing.report.passthrough.clone(),
            ignored: ing.report.ignored.clone(),
        }
    }
}

impl fmt::Display for IngestSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "drive     {} (vehicle {})",
            self.drive_id,
            self.vehicle_id.as_deref().unwrap_or("unknown")
        )?;
        if let Some(s) = &self.segment {
            writeln!(
                f,
                "segment   {} of {} of recording {}",
                s.index, s.count, s.recording_drive_id
            )?;
        }
        writeln!(
            f,
            "source    {} [{}, mapping {}], {} source rows",
            self.source_file, self.format, self.mapping, self.source_rows
        )?;
        writeln!(f, "start     {}", rfc3339_ns(self.start_ns))?;
        write!(f, "duration  {:.1} s, {} rows", self.duration_s, self.rows)?;
        if let Some(hz) = self.time_base_hz {
            write!(f, " on a {hz:.1} Hz time base")?;
        }
        writeln!(f)?;
        match self.distance_m {
            Some(d) => writeln!(f, "distance  {:.3} km", d / 1000.0)?,
            None => writeln!(f, "distance  none (the vehicle did not move)")?,
        }
        match &self.slope_resolution {
            Some(q) => writeln!(
                f,
                "slope     sensor resolution {:.4} ({:.2} %), {} distinct values",
                q.step,
                q.step * 100.0,
                q.distinct
            )?,
            None if self.units.iter().any(|u| u.0 == "road_slope") => {
                writeln!(f, "slope     not quantised (continuous)")?
            }
            None => writeln!(f, "slope     no road_slope column")?,
        }
        if self.duplicates_dropped > 0 {
            writeln!(
                f,
                "dropped   {} exact duplicate samples",
                self.duplicates_dropped
            )?;
        }
        if self.corrupt_records > 0 {
            writeln!(
                f,
                "corrupt   {} frame records that could not be decoded skipped",
                self.corrupt_records
            )?;
        }
        if self.conflicts_resolved > 0 {
            writeln!(
                f,
                "replaced  {} samples by a later one at the same time with another value",
                self.conflicts_resolved
            )?;
        }
        if !self.masked.is_empty() {
            let list: Vec<String> = self
                .masked
                .iter()
                .map(|(c, n)| format!("{c} {n}"))
                .collect();
            writeln!(
                f,
                "masked    bad samples made missing: {} (not finite, outside the physical range, or a speed spike)",
                list.join(", ")
            )?;
        }
        if !self.channel_rates.is_empty() {
            writeln!(f, "channels  (source samples, median rate)")?;
            for (c, n, hz) in &self.channel_rates {
                writeln!(f, "  {c:<28} {n:>8} {hz:>8.2} Hz")?;
            }
        }
        writeln!(f, "columns   (unit, missing values)")?;
        for ((c, u), (_, nan)) in self.units.iter().zip(&self.nan_counts) {
            writeln!(f, "  {c:<28} {u:<8} {nan:>8}")?;
        }
        if !self.passthrough.is_empty() {
            writeln!(f, "kept      {}", self.passthrough.join(", "))?;
        }
        if !self.ignored.is_empty() {
            writeln!(f, "ignored   {}", self.ignored.join(", "))?;
        }
        Ok(())
    }
}

/// The lines `fleetdyn ingest` prints about a recording's pauses and skipped segments (empty when
/// it is one drive without holes).
pub fn split_lines(rec: &Recording) -> String {
    let mut out = String::new();
    for p in &rec.pauses {
        let what = match &p.column {
            None => "no samples (logger pause)".to_string(),
            Some(c) => format!("no valid {c}"),
        };
        out.push_str(&format!(
            "pause     {} for {:.1} s: {what}\n",
            rfc3339_ns(p.start_ns),
            p.seconds()
        ));
    }
    for s in &rec.skipped {
        out.push_str(&format!(
            "skipped   segment {} ({}, {}): {}\n",
            s.index,
            s.drive_id,
            rfc3339_ns(s.start_ns),
            s.reason
        ));
    }
    if rec.drives.len() > 1 {
        out.push_str(&format!(
            "split     {} drives: {}\n",
            rec.drives.len(),
            rec.drives
                .iter()
                .map(|d| d.log.meta.drive_id.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    out
}
