//! How a synthetic drive is logged: the file format (multi-rate MCAP with zstd or LZ4 chunks,
//! the wide fleet-portal export or the long J1939 export, [`super::export`]), the logger's
//! timestamp jitter, CAN dropouts on chosen signals, and the drive's ids and start time.
//!
//! # Conventions
//! - **Jitter** ([`jitter_frames`]): a logger stamps each frame when it is received, so its log
//!   time is the nominal sample time plus a delay that varies; modelled as uniform on
//!   `[−j, j]` (j = [`LogOptions::timestamp_jitter_s`]) in whole µs, drawn per frame from one
//!   stream per topic (seeded from the drive's seed and the topic), after the values were
//!   sampled at the nominal time. `j` must be below half the shortest message period, so each
//!   topic's frames stay in order; frames are then sorted by log time (ties in bus order).
//! - **Dropouts** ([`apply_dropouts`]): [`super::can::Dropouts`] on every message that carries
//!   one of the named canonical columns (a CAN frame carries all its fields, so all of them drop
//!   together).
//! - **Files** in the drive's folder: the log ([`LogFormat::file_name`]), the canonical drive
//!   log `drive.parquet` that ingest makes of it with the format's mapping (the bus's own for
//!   MCAP, the bundled `fleet-portal-export` or `j1939-long-export` for the exports), and on
//!   request the truth table ([`super::truth_file`]). If ingest or the Parquet step fails, the
//!   log is removed again: the pair appears together or not at all.

use super::can::{
    sample, stream, write_mcap_with, CanBus, CanFrame, Dropouts, McapCompression, SynthOptions,
    Truth,
};
use super::export::{
    bundled_mapping, write_long_export, write_portal_export, ExportError, Series, LONG_MAPPING,
    PORTAL_MAPPING,
};
use crate::ingest::{ingest_file, IngestOptions};
use crate::io::{config_hash, drive_log_columns, write_table, TableMeta};
use crate::table::DriveLog;
use std::path::Path;

/// File format of a drive's log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogFormat {
    /// Multi-rate MCAP, one JSON topic per CAN message ([`super::can::write_mcap_with`]).
    Mcap(McapCompression),
    /// Wide fleet-portal export at 20 Hz ([`super::export::write_portal_export`]).
    PortalExport,
    /// Long J1939 export ([`super::export::write_long_export`]).
    LongExport,
}

impl Default for LogFormat {
    /// MCAP with zstd chunks.
    fn default() -> Self {
        LogFormat::Mcap(McapCompression::Zstd)
    }
}

impl LogFormat {
    /// Name of the log file in the drive's folder: `drive.mcap`, `drive-export.parquet` or
    /// `drive-long.parquet`.
    pub fn file_name(&self) -> &'static str {
        match self {
            LogFormat::Mcap(_) => "drive.mcap",
            LogFormat::PortalExport => "drive-export.parquet",
            LogFormat::LongExport => "drive-long.parquet",
        }
    }
}

/// Dropouts on the messages carrying some canonical columns.
#[derive(Debug, Clone, PartialEq)]
pub struct DropoutSpec {
    /// Canonical columns (e.g. `vehicle_speed`, `road_slope`).
    pub columns: Vec<String>,
    /// The dropout process of those messages.
    pub dropouts: Dropouts,
}

/// How a synthetic drive is logged. SI units, units in the names.
#[derive(Debug, Clone, PartialEq)]
pub struct LogOptions {
    /// File format.
    pub format: LogFormat,
    /// MCAP chunk compression level (0: the encoder's default; see
    /// [`super::can::write_mcap_with`]).
    pub mcap_compression_level: u32,
    /// Drive id; `None`: `synth-<road>-<length>km-seed<seed>`.
    pub drive_id: Option<String>,
    /// Vehicle id; `None`: the vehicle file's.
    pub vehicle_id: Option<String>,
    /// Epoch time of the drive's start, ns; `None`: [`super::drive::DRIVE_START_NS`].
    pub start_ns: Option<i64>,
    /// Logger timestamp jitter j, s (uniform on ±j, whole µs; 0: none).
    pub timestamp_jitter_s: f64,
    /// CAN dropouts on chosen signals; `None`: none.
    pub dropouts: Option<DropoutSpec>,
    /// Rate of the truth table `truth.parquet`, Hz (a whole divisor of the sample rate);
    /// `None`: no truth table.
    pub truth_rate_hz: Option<f64>,
}

impl Default for LogOptions {
    /// MCAP with zstd chunks at the default level, default ids and start, no jitter, no
    /// dropouts, no truth table.
    fn default() -> Self {
        Self {
            format: LogFormat::default(),
            mcap_compression_level: 0,
            drive_id: None,
            vehicle_id: None,
            start_ns: None,
            timestamp_jitter_s: 0.0,
            dropouts: None,
            truth_rate_hz: None,
        }
    }
}

impl LogOptions {
    /// Checks the dropout process, when there is one: a start probability in [0, 1] and a
    /// finite, non-negative mean length.
    pub fn validate(&self) -> Result<(), crate::settings::InvalidSetting> {
        use crate::settings::require;
        if let Some(spec) = &self.dropouts {
            let p = spec.dropouts.start_probability;
            require(
                (0.0..=1.0).contains(&p),
                "dropout_start_probability",
                p,
                "must be in [0, 1]",
            )?;
            let m = spec.dropouts.mean_length_s;
            require(
                m.is_finite() && m >= 0.0,
                "dropout_mean_length_s",
                m,
                "must be finite and >= 0",
            )?;
        }
        Ok(())
    }
}

/// Sets `spec.dropouts` on every message of `bus` carrying one of `spec.columns`.
///
/// # Errors
/// [`ExportError::BadInput`] for a column no channel of the bus carries.
pub fn apply_dropouts(bus: &mut CanBus, spec: &DropoutSpec) -> Result<(), ExportError> {
    for col in &spec.columns {
        let m = bus
            .messages
            .iter_mut()
            .find(|m| m.channels.iter().any(|c| &c.column == col))
            .ok_or_else(|| ExportError::BadInput {
                what: format!("dropouts: no message of the bus carries the column `{col}`"),
            })?;
        m.dropouts = spec.dropouts;
    }
    Ok(())
}

/// Adds the logger's timestamp jitter to `frames` (module doc) and sorts them by log time
/// (ties in bus order).
///
/// # Errors
/// [`ExportError::BadInput`] for a jitter that is negative, not finite, or not below half the
/// shortest message period of the bus.
pub fn jitter_frames(
    frames: &mut [CanFrame],
    bus: &CanBus,
    jitter_s: f64,
    seed: u64,
) -> Result<(), ExportError> {
    let max_rate = bus.messages.iter().fold(0.0f64, |m, x| m.max(x.rate_hz));
    let limit = if max_rate > 0.0 {
        0.5 / max_rate
    } else {
        f64::INFINITY
    };
    if !(jitter_s.is_finite() && jitter_s >= 0.0 && jitter_s < limit) {
        return Err(ExportError::BadInput {
            what: format!(
                "timestamp jitter {jitter_s} s must be finite, >= 0 and below half the shortest message period ({limit} s)"
            ),
        });
    }
    if jitter_s == 0.0 {
        return Ok(());
    }
    let j_us = (jitter_s * 1e6).round();
    for m in &bus.messages {
        let mut rng = stream(seed, &format!("jitter:{}", m.topic));
        for f in frames.iter_mut().filter(|f| f.topic == m.topic) {
            let d_us = rng
                .uniform(-j_us - 0.5, j_us + 0.5)
                .round()
                .clamp(-j_us, j_us);
            f.log_time_ns = f.log_time_ns.saturating_add(d_us as i64 * 1000);
        }
    }
    let order = |topic: &str| bus.messages.iter().position(|m| m.topic == topic);
    frames.sort_by_key(|f| (f.log_time_ns, order(&f.topic)));
    Ok(())
}

/// Samples `truth` on `bus`, jitters the frames ([`LogOptions::timestamp_jitter_s`]), writes
/// the log in [`LogOptions::format`] at `log_path`,
/// ingests it with the format's mapping and writes the canonical drive log at `parquet_path`
/// (module doc). `fuel_lph` feeds the portal export's fuel-rate column. Returns the drive log.
///
/// # Errors
/// [`ExportError`] from sampling ([`ExportError::Can`]), the writers, the jitter, ingest
/// ([`ExportError::Ingest`] naming the mapping) and the Parquet step
/// ([`ExportError::Output`]); the log is removed again if a later step fails.
#[allow(clippy::too_many_arguments)]
pub fn write_drive_log(
    log_path: &Path,
    parquet_path: &Path,
    bus: &CanBus,
    truth: &Truth,
    fuel_lph: Option<Series<'_>>,
    opts: &SynthOptions,
    log: &LogOptions,
) -> Result<DriveLog, ExportError> {
    let (format, jitter_s) = (log.format, log.timestamp_jitter_s);
    let mut frames = sample(bus, truth, opts.start_ns, opts.seed)?;
    jitter_frames(&mut frames, bus, jitter_s, opts.seed)?;
    let t_end = truth.t_s.last().copied().unwrap_or(0.0);
    let (mapping, name) = match format {
        LogFormat::Mcap(c) => {
            let m = bus.mapping()?;
            write_mcap_with(log_path, bus, &frames, opts, c, log.mcap_compression_level)?;
            (m, "synth-can (the bus's own)")
        }
        LogFormat::PortalExport => {
            let m = bundled_mapping(PORTAL_MAPPING)?;
            write_portal_export(log_path, bus, &frames, fuel_lph, t_end, opts)?;
            (m, PORTAL_MAPPING)
        }
        LogFormat::LongExport => {
            let m = bundled_mapping(LONG_MAPPING)?;
            write_long_export(log_path, bus, &frames, opts)?;
            (m, LONG_MAPPING)
        }
    };
    let rest = || -> Result<DriveLog, ExportError> {
        let ingest = IngestOptions {
            mapping: Some(mapping),
            ..IngestOptions::default()
        };
        let log = ingest_file(log_path, &ingest)
            .map_err(|e| ExportError::Ingest {
                mapping: name,
                source: Box::new(e),
            })?
            .log;
        let meta = TableMeta {
            table: "drive_log".into(),
            drive_id: log.meta.drive_id.clone(),
            vehicle_id: log.meta.vehicle_id.clone(),
            source_file: log.meta.source_file.clone(),
            config_hash: config_hash(&[format!(
                "synth-log:v1 seed={} format={format:?} jitter_s={jitter_s} bus={bus:?}",
                opts.seed
            )
            .as_bytes()]),
            extra: vec![("synth_seed".into(), opts.seed.to_string())],
        };
        write_table(parquet_path, &meta, &drive_log_columns(&log))?;
        Ok(log)
    };
    rest().inspect_err(|_| {
        let _ = std::fs::remove_file(log_path);
    })
}
