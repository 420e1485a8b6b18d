//! The `resample` stage: the drive on a uniform distance grid (`distance_log.parquet`).

use crate::io::{config_hash, write_table, OutColumn, OutputError, TableMeta};
use crate::signal::distance::{DistanceLog, ResampleConfig};
use std::path::Path;

/// Canonical text of the resample settings, for the config hash.
pub fn fingerprint(cfg: &ResampleConfig) -> String {
    crate::io::canonical("resample:v2", cfg)
}

/// Writes a distance log (schema `distance_log`).
///
/// # Errors
/// [`OutputError`]; nothing is left at `path` on error.
pub fn write(path: &Path, d: &DistanceLog, config_fingerprint: &str) -> Result<(), OutputError> {
    let (meta, cols) = table(d, config_fingerprint);
    write_table(path, &meta, &cols)
}

/// The distance log as a table: metadata and columns (`distance`, `timestamp`, then the
/// drive's signals).
pub fn table(d: &DistanceLog, config_fingerprint: &str) -> (TableMeta, Vec<OutColumn>) {
    let mut cols = vec![
        OutColumn::f64("distance", "m", d.distance_m.clone()),
        OutColumn::timestamp(d.timestamp_ns.clone()),
    ];
    cols.extend(d.signals.iter().map(OutColumn::from_signal));
    let meta = TableMeta {
        table: "distance_log".into(),
        drive_id: d.meta.drive_id.clone(),
        vehicle_id: d.meta.vehicle_id.clone(),
        source_file: d.meta.source_file.clone(),
        config_hash: config_hash(&[config_fingerprint.as_bytes()]),
        extra: vec![
            ("step_m".into(), d.step_m.to_string()),
            ("distance_source".into(), d.map.source.name().into()),
            ("collapsed_samples".into(), d.collapsed_samples.to_string()),
            ("reverse_samples".into(), d.map.reverse_samples.to_string()),
        ],
    };
    (meta, cols)
}
