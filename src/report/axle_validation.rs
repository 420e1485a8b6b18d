//! The axle-load validation table (`axle_validation`, schemas/outputs/axle-validation.toml) and
//! its printed summary.

use crate::io::{config_hash, write_table, OutColumn, OutData, OutputError, TableMeta};
use crate::model::axle::Axle;
use crate::sim::axle_validate::{AxleMetric, AxleValidation, Segment};
use crate::table::DriveLog;
use std::fmt::Write as _;
use std::path::Path;

const SEGMENTS: [Segment; 4] = [
    Segment::All,
    Segment::Acceleration,
    Segment::Braking,
    Segment::Steady,
];

fn find<'a>(v: &'a AxleValidation, prefix: &str, a: Axle, s: Segment) -> Option<&'a AxleMetric> {
    v.metrics
        .iter()
        .find(|m| m.axle == a && m.segment == s && m.signal.starts_with(prefix))
}

/// Table metadata of an axle-model output of `log`.
pub fn axle_meta(table: &str, log: &DriveLog, fp: &str, v: &AxleValidation) -> TableMeta {
    TableMeta {
        table: table.into(),
        drive_id: log.meta.drive_id.clone(),
        vehicle_id: log.meta.vehicle_id.clone(),
        source_file: log.meta.source_file.clone(),
        config_hash: config_hash(&[fp.as_bytes()]),
        extra: vec![
            (
                "slope_column".into(),
                v.recorded
                    .slope_column
                    .clone()
                    .unwrap_or_else(|| "none (flat road)".into()),
            ),
            ("acceleration_source".into(), v.recorded.accel_source.into()),
            (
                "longitudinal_inputs".into(),
                if v.recorded.torque_inputs {
                    "torques (drive, auxiliary, service brake); remainder at resistance_height_m"
                } else {
                    "acceleration only: the driven axle takes the longitudinal force"
                }
                .into(),
            ),
        ],
    }
}

/// Writes the validation table to `path` (atomically).
///
/// # Errors
/// [`OutputError`].
pub fn write_axle_validation(
    path: &Path,
    log: &DriveLog,
    v: &AxleValidation,
    fp: &str,
) -> Result<(), OutputError> {
    write_table(
        path,
        &axle_meta("axle_validation", log, fp, v),
        &axle_validation_columns(v),
    )
}

/// The validation table's columns in schema order: one row per axle and segment.
pub fn axle_validation_columns(v: &AxleValidation) -> Vec<OutColumn> {
    let mut rows: Vec<(Axle, Segment)> = Vec::new();
    for a in Axle::ALL {
        for s in SEGMENTS {
            if find(v, "bellow_pressure", a, s).is_some() {
                rows.push((a, s));
            }
        }
    }
    let mut cols = vec![
        OutColumn {
            name: "axle".into(),
            unit: "1".into(),
            data: OutData::Str(rows.iter().map(|r| r.0.name().to_string()).collect()),
        },
        OutColumn {
            name: "segment".into(),
            unit: "1".into(),
            data: OutData::Str(rows.iter().map(|r| r.1.name().to_string()).collect()),
        },
    ];
    for (sig, unit) in [("bellow_pressure", "Pa"), ("suspension_travel", "m")] {
        let get = |f: fn(&AxleMetric) -> f64| -> Vec<f64> {
            rows.iter()
                .map(|&(a, s)| find(v, sig, a, s).map_or(f64::NAN, f))
                .collect()
        };
        cols.push(OutColumn::f64(
            &format!("{sig}_samples"),
            "1",
            get(|m| m.samples as f64),
        ));
        cols.push(OutColumn::f64(&format!("{sig}_mae"), unit, get(|m| m.mae)));
        cols.push(OutColumn::f64(
            &format!("{sig}_rmse"),
            unit,
            get(|m| m.rmse),
        ));
        cols.push(OutColumn::f64(
            &format!("{sig}_fit"),
            "%",
            get(|m| m.fit_percent),
        ));
        cols.push(OutColumn::f64(
            &format!("{sig}_bias"),
            unit,
            get(|m| m.bias),
        ));
    }
    cols
}

/// The bellow-pressure rows of the validation table as text (kPa).
pub fn axle_summary(v: &AxleValidation) -> String {
    let mut s = String::from(
        "axle  segment       samples | bellow pressure: mae [kPa]  rmse [kPa]  fit [%]  bias [kPa]\n",
    );
    for a in Axle::ALL {
        for seg in SEGMENTS {
            if let Some(m) = find(v, "bellow_pressure", a, seg) {
                let _ = writeln!(
                    s,
                    "{:<5} {:<13} {:>7} | {:>27.2} {:>11.2} {:>8.1} {:>11.2}",
                    a.name(),
                    seg.name(),
                    m.samples,
                    m.mae / 1e3,
                    m.rmse / 1e3,
                    m.fit_percent,
                    m.bias / 1e3
                );
            }
        }
    }
    s
}
