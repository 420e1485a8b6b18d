//! The truth of a synthetic drive as a Parquet table: the plant's signals before any sensor
//! effect, for checking what ingest and the stages recover from the drive's log.
//!
//! # Table
//! A canonical wide drive log (`schemas/drive-log.toml`: canonical names, SI units in every
//! field's `unit` metadata, `gear` as int16), so ingest reads it back as `canonical`, plus the
//! pass-through column `distance` (m, travelled distance: the trapezoidal integral of the wheel
//! speed at the 100 Hz step). Rows are every `every`-th sample of the drive's 100 Hz
//! trajectory from its first (e.g. `every = 2`: 50 Hz), `timestamp` = start + round(t·10⁹) ns.
//!
//! Columns, in the schema's order: `vehicle_speed` (m/s, `r_w ω_w`), `road_slope` (tan α of
//! the road under the truck), `engine_speed` (rad/s), `engine_torque` (N·m, the torque the
//! engine delivers), `gear` (the gear input: the target gear from the AMT's gear change on),
//! `clutch_position` (0 engaged … 1 open), `brake_force` (N, the service brake's force at the
//! ground; at standstill the force that holds the truck, see [`super::drive`]),
//! `retarder_torque` (N·m at the propeller shaft, ≥ 0 brakes); where the vehicle has axles the
//! three bellow gauge pressures (Pa) of the axle model; with GNSS the true `latitude`,
//! `longitude` (deg WGS84) and `altitude` (m, the road's elevation) of the track — the
//! receiver's error is a sensor effect and is not in the truth; then `distance`.
//!
//! With a hidden effect ([`super::effects`]) these are the signals of the truth model, so the
//! truth table belongs with the answer, not with the drive handed out.
//!
//! zstd level 19 with floats byte-stream split (full-precision simulation output compresses
//! poorly otherwise). Key-value metadata: as every fleetdyn table (`table` = `drive_log`, `drive_id`,
//! `vehicle_id`, …) plus `truth` (what the table is), `truth_rate_hz`, `seed` and `road`.

use super::track::GnssTrack;
use super::trajectory::DriveTrajectory;
use crate::io::{
    config_hash, write_table_with, OutColumn, OutData, OutputError, TableEncoding, TableMeta,
};
use crate::sim::axle::AxleTrajectory;
use std::path::Path;

/// The truth columns of a drive (module doc), every `every`-th sample (≥ 1), with `start_ns`
/// the epoch time of drive time 0.
pub fn truth_columns(
    drive: &DriveTrajectory,
    axles: Option<&AxleTrajectory>,
    gnss: Option<&GnssTrack>,
    start_ns: i64,
    every: usize,
) -> Vec<OutColumn> {
    let every = every.max(1);
    let pick = |v: &[f64]| -> Vec<f64> { v.iter().step_by(every).copied().collect() };
    let mut cols = vec![OutColumn::timestamp(
        drive
            .t_s
            .iter()
            .step_by(every)
            .map(|t| start_ns.saturating_add((t * 1e9).round() as i64))
            .collect(),
    )];
    let f = |name: &str, unit: &str, v: &[f64]| OutColumn::f64(name, unit, pick(v));
    cols.push(f("vehicle_speed", "m/s", &drive.speed_mps));
    cols.push(f("road_slope", "1", &drive.slope));
    cols.push(f("engine_speed", "rad/s", &drive.engine_speed_rad_s));
    cols.push(f("engine_torque", "N*m", &drive.engine_torque_nm));
    cols.push(OutColumn {
        name: "gear".into(),
        unit: "1".into(),
        data: OutData::I16(pick(&drive.gear)),
    });
    cols.push(f("clutch_position", "1", &drive.clutch_position));
    cols.push(f("brake_force", "N", &drive.brake_n));
    cols.push(f("retarder_torque", "N*m", &drive.retarder_torque_nm));
    if let Some(a) = axles {
        for (name, p) in [
            "bellow_pressure_front",
            "bellow_pressure_rear",
            "bellow_pressure_tag",
        ]
        .iter()
        .zip(&a.pressure_pa)
        {
            cols.push(f(name, "Pa", p));
        }
    }
    if let Some(g) = gnss {
        cols.push(f("latitude", "deg", &g.latitude_deg));
        cols.push(f("longitude", "deg", &g.longitude_deg));
        cols.push(f("altitude", "m", &g.altitude_m));
    }
    cols.push(f("distance", "m", &drive.distance_m));
    cols
}

/// Provenance of a truth table.
#[derive(Debug, Clone)]
pub struct TruthMeta {
    /// Drive id.
    pub drive_id: String,
    /// Vehicle id, if any.
    pub vehicle_id: Option<String>,
    /// Seed of the drive.
    pub seed: u64,
    /// The road (label and window).
    pub road: String,
    /// Row rate, Hz.
    pub rate_hz: f64,
}

/// Writes `cols` ([`truth_columns`]) as the truth table at `path`, atomically.
///
/// # Errors
/// [`OutputError`] if the columns break the canonical schema, or on I/O and encoder errors (no
/// file is left then).
pub fn write_truth(path: &Path, cols: &[OutColumn], meta: &TruthMeta) -> Result<(), OutputError> {
    let table = TableMeta {
        table: "drive_log".into(),
        drive_id: meta.drive_id.clone(),
        vehicle_id: meta.vehicle_id.clone(),
        source_file: "fleetdyn synth drive (truth)".into(),
        config_hash: config_hash(&[format!(
            "synth-truth:v1 drive={} seed={} road={} rate_hz={}",
            meta.drive_id, meta.seed, meta.road, meta.rate_hz
        )
        .as_bytes()]),
        extra: vec![
            (
                "truth".into(),
                "pre-sensor signals of a fleetdyn synthetic drive (truth model)".into(),
            ),
            ("truth_rate_hz".into(), meta.rate_hz.to_string()),
            ("seed".into(), meta.seed.to_string()),
            ("road".into(), meta.road.clone()),
        ],
    };
    write_table_with(
        path,
        &table,
        cols,
        TableEncoding {
            zstd_level: 19,
            split_floats: true,
        },
    )
}
