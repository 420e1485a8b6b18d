//! The `ingest` stage: a file becomes the canonical drive log (`drive_log.parquet`).

use crate::ingest::{
    ingest, ingest_file, BadSamples, IngestError, IngestOptions, Ingested, Mapping, OnGap,
    Recording, TimeBase, TimeRepair, DEFAULT_MIN_SEGMENT_M, DEFAULT_MIN_SEGMENT_S,
};
use crate::io::{config_hash, drive_log_columns, write_table, OutputError, TableMeta};
use crate::model::vehicle::VehicleFile;
use crate::schema::Stage;
use crate::table::DriveLog;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// `[ingest]` settings of a pipeline file (also the `fleetdyn ingest` flags).
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct IngestConfig {
    /// Mapping file; automatic selection when absent.
    pub mapping: Option<PathBuf>,
    /// Aligned time base for multi-rate sources, Hz; the fastest channel's rate when absent.
    pub time_base_hz: Option<f64>,
    /// Longest accepted run of missing values in a required column, s; a longer one is a hole
    /// (`on_gap`).
    pub max_nan_run_s: f64,
    /// `error` (default) or `sort` for time going backwards.
    pub time_repair: TimeRepair,
    /// `mask` (default) or `error` for isolated bad samples (not finite, outside the physical
    /// range, a speed spike) and timestamps repeated with another value.
    pub bad_samples: BadSamples,
    /// `split` (default) or `error` when a required signal stops for longer than
    /// `max_nan_run_s` (a logger pause): the recording becomes one drive per segment.
    pub on_gap: OnGap,
    /// Segments of a split recording shorter than this are skipped, s.
    pub min_segment_s: f64,
    /// Segments of a split recording in which the vehicle travels less are skipped, m.
    pub min_segment_m: f64,
}

impl Default for IngestConfig {
    fn default() -> Self {
        Self {
            mapping: None,
            time_base_hz: None,
            max_nan_run_s: 2.0,
            time_repair: TimeRepair::Error,
            bad_samples: BadSamples::Mask,
            on_gap: OnGap::Split,
            min_segment_s: DEFAULT_MIN_SEGMENT_S,
            min_segment_m: DEFAULT_MIN_SEGMENT_M,
        }
    }
}

impl IngestConfig {
    /// Resolves the configuration into ingest options for `stages` (loads the mapping once).
    ///
    /// # Errors
    /// A setting out of range, or a mapping file that cannot be read or is invalid.
    pub fn options(
        &self,
        stages: &[Stage],
        vehicle: Option<&VehicleFile>,
    ) -> Result<IngestOptions, IngestError> {
        let setting = |key: &str, value: f64, rule: &str| IngestError::Setting {
            key: key.into(),
            value: value.to_string(),
            rule: rule.into(),
        };
        if let Some(hz) = self.time_base_hz {
            if !(hz.is_finite() && hz > 0.0) {
                return Err(setting("time_base_hz", hz, "must be a positive rate"));
            }
        }
        for (key, v) in [
            ("max_nan_run_s", self.max_nan_run_s),
            ("min_segment_s", self.min_segment_s),
            ("min_segment_m", self.min_segment_m),
        ] {
            if v.is_nan() || v < 0.0 {
                return Err(setting(key, v, "must be >= 0"));
            }
        }
        let mapping = match &self.mapping {
            Some(p) => Some(Mapping::load(p)?),
            None => None,
        };
        Ok(IngestOptions {
            mapping,
            stages: stages.to_vec(),
            time_base: self
                .time_base_hz
                .map_or(TimeBase::Fastest, TimeBase::RateHz),
            max_nan_run_s: self.max_nan_run_s,
            gear_range: vehicle.map(VehicleFile::gear_range),
            time_repair: self.time_repair,
            bad_samples: self.bad_samples,
            on_gap: self.on_gap,
            min_segment_s: self.min_segment_s,
            min_segment_m: self.min_segment_m,
            drive_id: None,
            vehicle_id: None,
        })
    }

    /// Canonical text of the settings that change the output, for the config hash. An explicit
    /// mapping enters with the hash of its text; automatically chosen mappings are embedded in
    /// the binary, whose version every output records.
    pub fn fingerprint(&self, opts: &IngestOptions) -> String {
        crate::io::canonical(
            "ingest:v3",
            &serde_json::json!({
                "mapping": opts.mapping.as_ref().map(|m| (&m.name, &m.text_sha256)),
                "time_base_hz": self.time_base_hz,
                "max_nan_run_s": self.max_nan_run_s,
                "time_repair": self.time_repair,
                "bad_samples": self.bad_samples,
                "on_gap": self.on_gap,
                "min_segment_s": self.min_segment_s,
                "min_segment_m": self.min_segment_m,
                "stages": opts.stages,
                "gears": opts.gear_range,
            }),
        )
    }
}

/// Ingests `input` with `opts` as one drive (single-drive commands).
///
/// # Errors
/// See [`ingest_file`].
pub fn run(input: &Path, opts: &IngestOptions) -> Result<Ingested, IngestError> {
    ingest_file(input, opts)
}

/// Ingests `input` with `opts`: its drives, split at logger pauses.
///
/// # Errors
/// See [`ingest`].
pub fn run_recording(input: &Path, opts: &IngestOptions) -> Result<Recording, IngestError> {
    ingest(input, opts)
}

/// Writes the canonical drive log as Parquet (atomically, with units and metadata).
///
/// # Errors
/// [`OutputError`]; nothing is left at `path` on error.
pub fn write(path: &Path, log: &DriveLog, config_fingerprint: &str) -> Result<(), OutputError> {
    let meta = TableMeta {
        table: "drive_log".into(),
        drive_id: log.meta.drive_id.clone(),
        vehicle_id: log.meta.vehicle_id.clone(),
        source_file: log.meta.source_file.clone(),
        config_hash: config_hash(&[config_fingerprint.as_bytes()]),
        extra: log
            .meta
            .segment
            .as_ref()
            .map(|s| s.kv())
            .unwrap_or_default(),
    };
    write_table(path, &meta, &drive_log_columns(log))
}
