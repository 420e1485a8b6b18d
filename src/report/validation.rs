//! Writers of the driveline simulation of a recorded drive (`shuffle_sim`) and its validation
//! table (`validation`), plus the printed summary.

use crate::io::{
    config_hash, write_column_refs_with_constants, write_table, ColumnRef, DataRef, OutColumn,
    OutData, OutputError, TableMeta,
};
use crate::sim::validate::{Metric, ShuffleValidation};
use crate::table::DriveLog;
use std::fmt::Write as _;
use std::path::Path;

fn meta(table: &str, log: &DriveLog, fp: &str, v: &ShuffleValidation) -> TableMeta {
    TableMeta {
        table: table.into(),
        drive_id: log.meta.drive_id.clone(),
        vehicle_id: log.meta.vehicle_id.clone(),
        source_file: log.meta.source_file.clone(),
        config_hash: config_hash(&[fp.as_bytes()]),
        extra: vec![
            (
                "slope_column".into(),
                v.slope_column
                    .clone()
                    .unwrap_or_else(|| "none (flat road)".into()),
            ),
            (
                "drift_handling".into(),
                "re-initialised from the measured state every window".into(),
            ),
        ],
    }
}

/// The two tables of a shuffle validation, ready to write: (`shuffle_sim` metadata and columns,
/// borrowed from `log` and `v`; `validation` metadata and columns).
pub fn tables<'a>(
    log: &'a DriveLog,
    v: &'a ShuffleValidation,
    fp: &str,
) -> ((TableMeta, Vec<ColumnRef<'a>>), (TableMeta, Vec<OutColumn>)) {
    let meas = |c: &'a str, unit: &'a str| ColumnRef {
        name: c,
        unit,
        data: log
            .signal(c)
            .map_or(DataRef::NullF64(log.len()), DataRef::F64),
    };
    let i16 = |name: &'a str, values: &'a [f64]| ColumnRef {
        name,
        unit: "1",
        data: DataRef::I16(values),
    };
    let sim = vec![
        ColumnRef::timestamp(&v.timestamp_ns),
        meas("vehicle_speed", "m/s"),
        ColumnRef::f64("vehicle_speed_sim", "m/s", &v.vehicle_speed),
        meas("engine_speed", "rad/s"),
        ColumnRef::f64("engine_speed_sim", "rad/s", &v.engine_speed),
        ColumnRef::f64("clutch_torque_sim", "N*m", &v.shaft_torques[0]),
        ColumnRef::f64("propeller_torque_sim", "N*m", &v.shaft_torques[1]),
        ColumnRef::f64("drive_shaft_torque_sim", "N*m", &v.shaft_torques[2]),
        ColumnRef::f64("clutch_torsion_sim", "rad", &v.torsions[0]),
        ColumnRef::f64("propeller_torsion_sim", "rad", &v.torsions[1]),
        ColumnRef::f64("drive_shaft_torsion_sim", "rad", &v.torsions[2]),
        i16("clutch_locked", &v.clutch_locked),
        ColumnRef::f64("shuffle_indicator", "m/s", &v.shuffle_indicator),
        i16("window", &v.window),
    ];
    let gears = gear_rows(&v.metrics);
    let pick = |signal: &str, g: usize, f: fn(&Metric) -> f64| -> f64 {
        v.metrics
            .iter()
            .find(|m| m.signal == signal && m.gear.unwrap_or(0) == g)
            .map_or(f64::NAN, f)
    };
    let col = |name: &str, unit: &str, signal: &'static str, f: fn(&Metric) -> f64| {
        OutColumn::f64(
            name,
            unit,
            gears.iter().map(|&g| pick(signal, g, f)).collect(),
        )
    };
    let table = vec![
        OutColumn {
            name: "gear".into(),
            unit: "1".into(),
            data: OutData::I16(gears.iter().map(|&g| g as f64).collect()),
        },
        col("samples", "1", "vehicle_speed", |m| m.samples as f64),
        col("vehicle_speed_rmse", "m/s", "vehicle_speed", |m| m.rmse),
        col("vehicle_speed_mae", "m/s", "vehicle_speed", |m| m.mae),
        col("vehicle_speed_fit", "%", "vehicle_speed", |m| m.fit_percent),
        col("engine_speed_rmse", "rad/s", "engine_speed", |m| m.rmse),
        col("engine_speed_mae", "rad/s", "engine_speed", |m| m.mae),
        col("engine_speed_fit", "%", "engine_speed", |m| m.fit_percent),
    ];
    (
        (meta("shuffle_sim", log, fp, v), sim),
        (meta("validation", log, fp, v), table),
    )
}

/// Writes `shuffle_sim.parquet` and `validation.parquet` into `dir`; both or neither.
///
/// # Errors
/// [`OutputError`].
pub fn write(
    dir: &Path,
    log: &DriveLog,
    v: &ShuffleValidation,
    fp: &str,
) -> Result<(), OutputError> {
    let ((ma, sim), (mb, table)) = tables(log, v, fp);
    let (a, b) = (
        dir.join("shuffle_sim.parquet"),
        dir.join("validation.parquet"),
    );
    write_column_refs_with_constants(&a, &ma, &sim, &[])?;
    write_table(&b, &mb, &table).inspect_err(|_| {
        let _ = std::fs::remove_file(&a);
    })
}

fn gear_rows(metrics: &[Metric]) -> Vec<usize> {
    let mut g: Vec<usize> = metrics.iter().map(|m| m.gear.unwrap_or(0)).collect();
    g.sort_unstable();
    g.dedup();
    g
}

/// The validation table as text (one line per gear, 0 = all).
pub fn summary(v: &ShuffleValidation) -> String {
    let mut s = String::from("gear  samples | v: rmse [m/s]  mae [m/s]  fit [%] | w_e: rmse [rad/s]  mae [rad/s]  fit [%]\n");
    for g in gear_rows(&v.metrics) {
        let get = |sig: &str| {
            v.metrics
                .iter()
                .find(|m| m.signal == sig && m.gear.unwrap_or(0) == g)
        };
        if let (Some(a), Some(b)) = (get("vehicle_speed"), get("engine_speed")) {
            let label = if g == 0 {
                "all".to_string()
            } else {
                g.to_string()
            };
            let _ = writeln!(
                s,
                "{label:>4} {:>8} | {:>13.3} {:>10.3} {:>8.1} | {:>17.2} {:>12.2} {:>8.1}",
                a.samples, a.rmse, a.mae, a.fit_percent, b.rmse, b.mae, b.fit_percent
            );
        }
    }
    s
}
