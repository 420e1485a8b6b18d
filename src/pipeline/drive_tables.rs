//! The tables of one drive as columns, built from its computed results: the canonical drive
//! log conformed to the schema (borrowed, not copied), the `drive_summary` row
//! (`schemas/outputs/drive-summary.toml`) with the drive's metrics, the road spectrum. Units are
//! in the column units; a metric a stage did not produce is null.

use super::drive_stages::{mean_square, Computed};
use super::record::{DriveMetrics, DriveRecord, StageNote};
use super::spec_sections::PipelineStage;
use crate::io::{ColumnRef, DataRef, OutColumn, OutData, TableMeta};
use crate::model::axle::Axle;
use crate::road::study::RoadSpectrum;
use crate::schema::{drive_log, Dtype};
use crate::sim::axle_validate::Segment;
use crate::table::{DriveLog, Signal};

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

/// The canonical columns in schema order, each present (null where the drive has none): one
/// schema for every file of a dataset table. Pass-through columns stay in the source. The
/// columns are borrowed from `signals`, not copied (copied and NaN-filled, a 10-hour drive's
/// `drive_log` table took ~290 MB).
pub(super) fn conformed(signals: &[Signal], n: usize) -> Vec<ColumnRef<'_>> {
    drive_log()
        .columns
        .iter()
        .skip(1)
        .map(|c| {
            let values = signals.iter().find(|s| s.name == c.name);
            ColumnRef {
                name: &c.name,
                unit: &c.unit,
                data: match (c.dtype, values) {
                    (Dtype::I16, Some(s)) => DataRef::I16(&s.values),
                    (Dtype::I16, None) => DataRef::NullI16(n),
                    (_, Some(s)) => DataRef::F64(&s.values),
                    (_, None) => DataRef::NullF64(n),
                },
            }
        })
        .collect()
}

/// The columns of one table of a drive: borrowed from the drive's results where they are
/// long, built where they are small.
pub(super) enum TableColumns<'a> {
    Borrowed(Vec<ColumnRef<'a>>),
    Built(Vec<OutColumn>),
}

pub(super) fn base_meta(table: &str, log: &DriveLog, hash: &str, vehicle_id: &str) -> TableMeta {
    TableMeta {
        table: table.into(),
        drive_id: log.meta.drive_id.clone(),
        vehicle_id: Some(vehicle_id.to_string()),
        source_file: log.meta.source_file.clone(),
        config_hash: hash.into(),
        extra: Vec::new(),
    }
}

fn str_col(name: &str, v: impl Into<String>) -> OutColumn {
    OutColumn {
        name: name.into(),
        unit: "1".into(),
        data: OutData::Str(vec![v.into()]),
    }
}

fn opt_col(name: &str, unit: &str, v: Option<f64>) -> OutColumn {
    OutColumn::f64(name, unit, vec![v.unwrap_or(f64::NAN)])
}

fn stage_status(notes: &[StageNote], stage: PipelineStage) -> String {
    notes.iter().find(|n| n.stage == stage.name()).map_or_else(
        || "not configured".to_string(),
        |n| match &n.reason {
            Some(r) => format!("skipped: {r}"),
            None => n.status.clone(),
        },
    )
}

/// The `drive_summary` row of a record (schema `schemas/outputs/drive-summary.toml`).
pub fn summary_columns(r: &DriveRecord) -> Vec<OutColumn> {
    let m = &r.metrics;
    let mut cols = vec![
        OutColumn::timestamp(vec![m.start_ns]),
        OutColumn::f64("duration", "s", vec![m.duration_s]),
        OutColumn {
            name: "rows".into(),
            unit: "1".into(),
            data: OutData::U64(vec![m.rows]),
        },
        OutColumn {
            name: "masked_samples".into(),
            unit: "1".into(),
            data: OutData::U64(vec![m.masked_samples.values().sum()]),
        },
        str_col(
            "masked_by_column",
            serde_json::to_string(&m.masked_samples).expect("a map of counts serialises"),
        ),
        OutColumn {
            name: "conflicts_resolved".into(),
            unit: "1".into(),
            data: OutData::U64(vec![m.conflicts_resolved]),
        },
        str_col(
            "recording_drive_id",
            r.segment
                .as_ref()
                .map_or(r.drive_id.as_str(), |g| g.recording_drive_id.as_str()),
        ),
        OutColumn {
            name: "segment".into(),
            unit: "1".into(),
            data: OutData::U64(vec![r.segment.as_ref().map_or(1, |g| g.index as u64)]),
        },
        OutColumn {
            name: "segments".into(),
            unit: "1".into(),
            data: OutData::U64(vec![r.segment.as_ref().map_or(1, |g| g.count as u64)]),
        },
        opt_col("distance", "m", m.distance_m),
        opt_col("slope_quantization_step", "1", m.slope_quantization_step),
        opt_col("vehicle_speed_rmse", "m/s", m.vehicle_speed_rmse_mps),
        opt_col("vehicle_speed_fit", "%", m.vehicle_speed_fit_percent),
        opt_col("engine_speed_rmse", "rad/s", m.engine_speed_rmse_rad_per_s),
        opt_col("engine_speed_fit", "%", m.engine_speed_fit_percent),
        opt_col("shuffle_ms", "m^2/s^2", m.shuffle_ms_m2_per_s2),
        opt_col(
            "shuffle_ms_raw_slope",
            "m^2/s^2",
            m.shuffle_ms_raw_slope_m2_per_s2,
        ),
    ];
    for (i, a) in ["front", "rear", "tag"].iter().enumerate() {
        cols.push(opt_col(
            &format!("bellow_pressure_mae_{a}"),
            "Pa",
            m.bellow_pressure_mae_pa[i],
        ));
    }
    for (i, a) in ["front", "rear", "tag"].iter().enumerate() {
        cols.push(opt_col(
            &format!("bellow_pressure_fit_{a}"),
            "%",
            m.bellow_pressure_fit_percent[i],
        ));
    }
    cols.push(opt_col("slope_knee_90", "1/m", m.slope_knee_90_per_m));
    cols.push(opt_col("slope_knee_99", "1/m", m.slope_knee_99_per_m));
    for st in [
        PipelineStage::Shuffle,
        PipelineStage::Axle,
        PipelineStage::Spectrum,
    ] {
        cols.push(str_col(
            &format!("{}_status", st.name()),
            stage_status(&r.stages, st),
        ));
    }
    cols.push(str_col(
        "vehicle_file",
        r.vehicle_file.clone().unwrap_or_default(),
    ));
    cols.push(str_col("source_file", r.input.clone()));
    cols.push(str_col("input_sha256", r.input_sha256.clone()));
    cols
}

pub(super) fn spectrum_columns(sp: &RoadSpectrum) -> Vec<OutColumn> {
    vec![
        OutColumn::f64("frequency", "1/m", sp.psd.freq_hz.clone()),
        OutColumn::f64("psd", "(1)^2/(1/m)", sp.psd.psd.clone()),
        OutColumn::f64("psd_lower", "(1)^2/(1/m)", sp.psd.lower.clone()),
        OutColumn::f64("psd_upper", "(1)^2/(1/m)", sp.psd.upper.clone()),
        OutColumn::f64("cumulative_power", "1", sp.cumulative.clone()),
        OutColumn::f64(
            "filter_zero_phase_gain",
            "dB",
            sp.filter.zero_phase_db.clone(),
        ),
        OutColumn::f64("filter_causal_gain", "dB", sp.filter.causal_db.clone()),
    ]
}

pub(super) fn metrics_of(c: &Computed) -> DriveMetrics {
    let log = &c.log;
    let mut m = DriveMetrics {
        rows: log.len() as u64,
        masked_samples: c.masked.clone(),
        conflicts_resolved: c.conflicts_resolved,
        start_ns: log.timestamp_ns[0],
        duration_s: log.duration_s(),
        distance_m: c.dist.as_ref().map(|d| d.map.total_m()),
        slope_quantization_step: c
            .slope
            .as_ref()
            .and_then(|f| f.quantization.map(|q| q.step)),
        ..Default::default()
    };
    if let Some(s) = &c.shuffle {
        let all = |sig: &str| {
            s.val
                .metrics
                .iter()
                .find(|x| x.signal == sig && x.gear.is_none())
        };
        if let Some(x) = all("vehicle_speed") {
            m.vehicle_speed_rmse_mps = finite(x.rmse);
            m.vehicle_speed_fit_percent = finite(x.fit_percent);
        }
        if let Some(x) = all("engine_speed") {
            m.engine_speed_rmse_rad_per_s = finite(x.rmse);
            m.engine_speed_fit_percent = finite(x.fit_percent);
        }
        m.shuffle_ms_m2_per_s2 = mean_square(&s.val.shuffle_indicator);
        m.shuffle_ms_raw_slope_m2_per_s2 = s.ms_raw;
        m.slope_shuffle_by_gear = s.slope_by_gear.clone();
    }
    if let Some(a) = &c.axle {
        for (i, axle) in Axle::ALL.into_iter().enumerate() {
            if let Some(x) = a.metrics.iter().find(|x| {
                x.axle == axle
                    && x.segment == Segment::All
                    && x.signal.starts_with("bellow_pressure")
            }) {
                m.bellow_pressure_mae_pa[i] = finite(x.mae);
                m.bellow_pressure_fit_percent[i] = finite(x.fit_percent);
            }
        }
    }
    if let Some(sp) = &c.spectrum {
        m.slope_knee_90_per_m = finite(sp.knee_90);
        m.slope_knee_99_per_m = finite(sp.knee_99);
        m.spectrum_freq_per_m = sp.psd.freq_hz.clone();
        m.spectrum_psd = sp.psd.psd.clone();
    }
    m
}
