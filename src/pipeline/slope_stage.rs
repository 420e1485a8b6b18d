//! The `slope` stage: filtered road slope on the distance grid (`slope_distance.parquet`) and
//! mapped back onto the drive's time axis (`slope_time.parquet`), with the filter's measured
//! gains and the sensor's quantisation step in the file metadata.

use crate::io::{
    config_hash, write_column_refs_with_constants, ColumnRef, DataRef, OutputError, TableMeta,
};
use crate::road::slope_filter::{SlopeFilterConfig, SlopeFiltered};
use crate::signal::distance::DistanceLog;
use crate::table::DriveLog;
use std::path::Path;

/// Canonical text of the slope settings, for the config hash.
pub fn fingerprint(cfg: &SlopeFilterConfig) -> String {
    crate::io::canonical("slope:v2", cfg)
}

/// Table metadata of a slope table (`slope_distance` or `slope_time`).
pub fn meta(
    table: &str,
    d: &DistanceLog,
    f: &SlopeFiltered,
    cfg: &SlopeFilterConfig,
    fp: &str,
) -> TableMeta {
    TableMeta {
        table: table.into(),
        drive_id: d.meta.drive_id.clone(),
        vehicle_id: d.meta.vehicle_id.clone(),
        source_file: d.meta.source_file.clone(),
        config_hash: config_hash(&[fp.as_bytes()]),
        extra: vec![
            ("cutoff_per_m".into(), cfg.cutoff_per_m.to_string()),
            ("zero_phase_order".into(), cfg.order.to_string()),
            ("causal_order".into(), f.causal_order.to_string()),
            ("edge".into(), cfg.edge.name().into()),
            ("stop_per_m".into(), cfg.stop_per_m.to_string()),
            (
                "design_gain_at_stop_db".into(),
                format!("{:.3}", f.design_gain_at_stop_db),
            ),
            (
                "zero_phase_gain_at_stop_db".into(),
                format!("{:.3}", f.zero_phase_gain_at_stop_db),
            ),
            (
                "causal_gain_at_stop_db".into(),
                format!("{:.3}", f.causal_gain_at_stop_db),
            ),
            (
                "slope_quantization_step".into(),
                f.quantization
                    .map_or("none".into(), |q| format!("{}", q.step)),
            ),
            ("step_m".into(), d.step_m.to_string()),
        ],
    }
}

/// The two slope tables, ready to write: (distance-domain columns, time-domain columns),
/// borrowed from the stage's results (no copy of a long drive's columns).
pub fn tables<'a>(
    log: &'a DriveLog,
    d: &'a DistanceLog,
    f: &'a SlopeFiltered,
) -> (Vec<ColumnRef<'a>>, Vec<ColumnRef<'a>>) {
    let dist = vec![
        ColumnRef::f64("distance", "m", &d.distance_m),
        ColumnRef::timestamp(&d.timestamp_ns),
        ColumnRef::f64("road_slope", "1", &f.raw),
        ColumnRef::f64("road_slope_zero_phase", "1", &f.zero_phase),
        ColumnRef::f64("road_slope_causal", "1", &f.causal),
    ];
    let time = vec![
        ColumnRef::timestamp(&log.timestamp_ns),
        ColumnRef::f64("distance", "m", &d.map.x_m),
        ColumnRef {
            name: "road_slope",
            unit: "1",
            data: DataRef::F64(log.signal("road_slope").unwrap_or_default()),
        },
        ColumnRef::f64("road_slope_zero_phase", "1", &f.zero_phase_time),
        ColumnRef::f64("road_slope_causal", "1", &f.causal_time),
    ];
    (dist, time)
}

/// Writes both slope tables.
///
/// # Errors
/// [`OutputError`]; both files are written or neither.
pub fn write(
    distance_path: &Path,
    time_path: &Path,
    log: &DriveLog,
    d: &DistanceLog,
    f: &SlopeFiltered,
    cfg: &SlopeFilterConfig,
    fp: &str,
) -> Result<(), OutputError> {
    let (dist, time) = tables(log, d, f);
    let write = |path: &Path, table: &str, cols: &[ColumnRef<'_>]| {
        write_column_refs_with_constants(path, &meta(table, d, f, cfg, fp), cols, &[])
    };
    write(distance_path, "slope_distance", &dist)?;
    write(time_path, "slope_time", &time).inspect_err(|_| {
        let _ = std::fs::remove_file(distance_path);
    })
}

/// Name of the filtered road-slope column that [`add_filtered_slope`] adds to a drive log.
pub const FILTERED_SLOPE_COLUMN: &str = "road_slope_filtered";

/// Why the filtered slope could not be added to a drive log.
#[derive(Debug, thiserror::Error)]
pub enum FilteredSlopeError {
    /// The drive could not be resampled to distance.
    #[error(transparent)]
    Resample(#[from] crate::signal::distance::ResampleError),
    /// The slope could not be filtered.
    #[error(transparent)]
    Filter(#[from] crate::road::slope_filter::SlopeError),
}

/// Adds the zero-phase filtered road slope (default distance grid and filter,
/// [`SlopeFilterConfig::default`]; Myklebust & Eriksson 2012, §5), mapped back to the log's
/// time axis, as the column [`FILTERED_SLOPE_COLUMN`] (tan α, unit `1`) and returns its name;
/// `None`, and the log unchanged, when the log has no `road_slope`.
pub fn add_filtered_slope(log: &mut DriveLog) -> Result<Option<&'static str>, FilteredSlopeError> {
    use crate::road::slope_filter::filter_slope;
    use crate::signal::distance::{resample_to_distance, ResampleConfig};
    if log.signal("road_slope").is_none() {
        return Ok(None);
    }
    let d = resample_to_distance(log, &ResampleConfig::default())?;
    let f = filter_slope(&d, &SlopeFilterConfig::default())?;
    log.signals.push(crate::table::Signal {
        name: FILTERED_SLOPE_COLUMN.into(),
        unit: "1".into(),
        values: f.zero_phase_time,
    });
    Ok(Some(FILTERED_SLOPE_COLUMN))
}
