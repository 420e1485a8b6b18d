//! Fleet-portal exports of a synthetic drive: the CAN frames a logger recorded
//! ([`super::can::sample`]) written as the two Parquet layouts fleet portals deliver and the
//! bundled mappings read.
//!
//! # Wide "fleet portal export" ([`write_portal_export`])
//! One row every 50 ms ([`PORTAL_RATE_HZ`]) on the portal's clock: `Time` as `timestamp[ms,
//! UTC]` at whole multiples of 50 ms after the drive's start (start rounded up to a whole ms),
//! from the first tick after the start to the last tick within the truth's span. The columns,
//! their names and units are those of the bundled `fleet-portal-export` mapping
//! (`schemas/mappings/fleet-portal-export.toml`): every canonical column the mapping names and
//! the bus carries, in the drive-log schema's column order — e.g. `VehSpd_kmh` (float32),
//! `EngSpd_rpm`, `EngTrq_Nm`, `Gear` (int8), `Slope_pct`, `ClutchPos_pct`, the bellow
//! pressures (`BellowP_front_kPa`, `BellowP_rear_bar`, `BellowP_tag_bar`) where the vehicle has
//! axles, `Lat_deg`, `Lon_deg`, `Alt_m`; others float64. Channels the mapping does not name
//! (brake force, retarder torque) are not exported, as a portal exports a fixed selection.
//!
//! Each cell is the portal's snapshot of the latest CAN frame of that signal at or before the
//! tick (zero-order hold), converted from the wire unit to the column's unit through SI
//! (`EngTrq_Nm` = percent × reference torque / 100; kPa → bar) and snapped to the wire
//! resolution expressed in that unit (1 % of 2600 N·m = 26 N·m; 0.1 kPa = 0.001 bar), so the
//! values keep the CAN resolution exactly. A cell is **null** when the signal's latest frame is
//! older than 1.5 message periods (0.15 s at 10 Hz, 1.5 s for the 1 Hz GNSS fix) — a missed
//! frame, e.g. a CAN dropout ([`super::can::Dropouts`]) — or when no frame has arrived yet.
//!
//! `FuelRate_lph` (float64, l/h), a column the canonical schema does not know (the mapping
//! passes it through with its unit), is the engine's fuel rate as J1939 LFE1 sends it: sampled
//! from the truth at 10 Hz (phase 18 ms, after the bus's other topics) in 0.05 l/h steps and
//! held like the rest. Its truth is [`fuel_rate_lph`], a Willans line — a plausible signal,
//! not a validated consumption model.
//!
//! Snappy compression; key-value metadata `drive_id`, `vehicle_id` (if any) and `source`.
//!
//! # Long layout ([`write_long_export`])
//! One row per logged field: `ts` `timestamp[us, UTC]` (the frame's log time; logger times are
//! whole µs), `signal` = `<message>.<field>` with the bus's J1939 message names
//! (`CCVS1.WheelBasedVehicleSpeed`, `EEC1.EngineSpeed`, `GNSS.latitude`, …), `value` float64 in
//! the wire unit, sorted by `ts` then `signal`. Every frame of every topic is exported; the
//! bundled `j1939-long-export` mapping reads five signals and skips the rest (retarder, brake,
//! clutch, GNSS rows). Each mapped signal's wire unit and reference torque must be the
//! mapping's ([`ExportError::Mismatch`]), so the file means what the mapping says. Snappy;
//! key-value metadata as above.
//!
//! Both writers are deterministic (fixed writer settings, no clock) and atomic: the file appears
//! complete or not at all.

use super::can::{step_value, CanBus, CanChannel, CanFrame, SynthError, SynthOptions};
use crate::ingest::{IngestError, Mapping};
use crate::io::AtomicFile;
use crate::schema::drive_log;
use crate::units::{conversion, Conversion, UnitError};
use arrow::array::{
    ArrayRef, Float32Array, Float64Array, Int8Array, StringArray, TimestampMicrosecondArray,
    TimestampMillisecondArray,
};
use arrow::datatypes::{DataType, Field, Schema, TimeUnit};
use arrow::record_batch::RecordBatch;
use parquet::arrow::ArrowWriter;
use parquet::basic::Compression;
use parquet::file::metadata::KeyValue;
use parquet::file::properties::WriterProperties;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use thiserror::Error;

/// Name of the bundled mapping the wide export follows.
pub const PORTAL_MAPPING: &str = "fleet-portal-export";
/// Name of the bundled mapping the long export is checked against.
pub const LONG_MAPPING: &str = "j1939-long-export";
/// Row rate of the wide export, Hz.
pub const PORTAL_RATE_HZ: f64 = 20.0;
/// The wide export's fuel-rate column (not canonical; passed through by the mapping).
pub const FUEL_RATE_COLUMN: &str = "FuelRate_lph";
/// Fuel-rate message: rate (Hz), phase (s) and resolution (l/h) of J1939 LFE1 SPN 183.
const FUEL_RATE_HZ: f64 = 10.0;
const FUEL_PHASE_S: f64 = 0.018;
const FUEL_RESOLUTION_LPH: f64 = 0.05;
/// A cell is null when its latest frame is older than this many message periods.
const STALE_PERIODS: f64 = 1.5;

/// Why an export could not be written.
#[derive(Debug, Error)]
pub enum ExportError {
    /// A bundled mapping is missing or does not parse (a build defect, reported, not panicked).
    #[error("bundled mapping {name}: {problem}")]
    Mapping {
        /// Mapping name.
        name: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The bus sends a mapped signal in another unit or reference torque than the mapping
    /// reads it with.
    #[error("mapping {mapping}: {column} ({source_name}) is read as {mapping_unit}, but the bus sends {bus_unit}")]
    Mismatch {
        /// Mapping name.
        mapping: &'static str,
        /// Canonical column.
        column: String,
        /// The mapping's source name.
        source_name: String,
        /// Unit (and reference torque) the mapping assumes.
        mapping_unit: String,
        /// Unit (and reference torque) of the bus channel.
        bus_unit: String,
    },
    /// A unit that does not convert.
    #[error("{column}: {source}")]
    Unit {
        /// Column.
        column: String,
        /// Cause.
        #[source]
        source: UnitError,
    },
    /// A frame's field that is not a number.
    #[error("frame on {topic} at {log_time_ns} ns: field {field} is not a number")]
    NotANumber {
        /// Topic.
        topic: String,
        /// Log time, ns since the Unix epoch.
        log_time_ns: i64,
        /// Field.
        field: String,
    },
    /// A fuel-rate series whose length differs from its time axis, or a bad end time.
    #[error("{what}")]
    BadInput {
        /// What is wrong.
        what: String,
    },
    /// The bus is invalid, or sampling failed.
    #[error(transparent)]
    Can(#[from] SynthError),
    /// The written log did not ingest with its mapping.
    #[error("the written log does not ingest with mapping {mapping}: {source}")]
    Ingest {
        /// Mapping name.
        mapping: &'static str,
        /// Cause.
        #[source]
        source: Box<IngestError>,
    },
    /// The canonical drive log could not be written.
    #[error(transparent)]
    Output(#[from] crate::io::OutputError),
    /// File-system error.
    #[error("writing {path}: {source}")]
    Io {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// Arrow/Parquet encoder error.
    #[error("writing {path}: {source}")]
    Parquet {
        /// Target path.
        path: PathBuf,
        /// Cause.
        #[source]
        source: parquet::errors::ParquetError,
    },
}

/// A bundled mapping by name.
///
/// # Errors
/// [`ExportError::Mapping`] if it is not bundled.
pub fn bundled_mapping(name: &'static str) -> Result<Mapping, ExportError> {
    Mapping::embedded()
        .into_iter()
        .find(|m| m.name == name)
        .ok_or_else(|| ExportError::Mapping {
            name,
            problem: "not bundled".into(),
        })
}

/// Fuel rate of the truck's 13 l diesel, l/h, at engine speed `w_e_rad_s` (rad/s) and net
/// engine torque `m_e_nm` (N·m): a Willans line
/// `V̇ = V̇₀ ω_e/ω_idle + max(M_e, 0) ω_e / (η H_u ρ)` with `V̇₀` = 2.0 l/h at idle
/// (ω_idle = 600 rpm; friction and pumping grow with speed), marginal efficiency η = 0.45,
/// diesel `H_u` = 42.8 MJ/kg and ρ = 832 kg/m³ (≈ 200 g/kWh at full load, 71 l/h at 300 kW and
/// 1200 rpm); 0 in overrun (`M_e < 0`: fuel cut-off) and at a stopped engine.
pub fn fuel_rate_lph(w_e_rad_s: f64, m_e_nm: f64) -> f64 {
    const IDLE_LPH: f64 = 2.0;
    const W_IDLE: f64 = 600.0 * std::f64::consts::PI / 30.0;
    const ETA: f64 = 0.45;
    const H_U_J_PER_KG: f64 = 42.8e6;
    const RHO_KG_PER_M3: f64 = 832.0;
    if m_e_nm < 0.0 || w_e_rad_s <= 0.0 {
        return 0.0;
    }
    let p_w = m_e_nm * w_e_rad_s;
    IDLE_LPH * w_e_rad_s / W_IDLE + p_w / (ETA * H_U_J_PER_KG * RHO_KG_PER_M3) * 3.6e6
}

/// A truth series on its own time axis (s from the start).
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    /// Times, s from the start, increasing.
    pub t_s: &'a [f64],
    /// Values.
    pub values: &'a [f64],
}

/// The (log time, value) samples of one channel in the frames, in time order.
fn channel_samples(
    frames: &[CanFrame],
    topic: &str,
    field: &str,
) -> Result<Vec<(i64, f64)>, ExportError> {
    let mut out = Vec::new();
    for f in frames.iter().filter(|f| f.topic == topic) {
        if let Some(v) = f.fields.get(field) {
            let x = v.as_f64().ok_or_else(|| ExportError::NotANumber {
                topic: topic.into(),
                log_time_ns: f.log_time_ns,
                field: field.into(),
            })?;
            out.push((f.log_time_ns, x));
        }
    }
    out.sort_by_key(|s| s.0);
    Ok(out)
}

/// Zero-order hold of `samples` at `ticks_ns`: NaN before the first sample and where the
/// latest is older than `stale_ns`.
fn hold(samples: &[(i64, f64)], ticks_ns: &[i64], stale_ns: i64) -> Vec<f64> {
    let mut out = Vec::with_capacity(ticks_ns.len());
    let mut i = 0usize; // samples[..i] are at or before the tick
    for &t in ticks_ns {
        while i < samples.len() && samples[i].0 <= t {
            i += 1;
        }
        out.push(match i.checked_sub(1).map(|k| samples[k]) {
            Some((ts, v)) if t - ts <= stale_ns => v,
            _ => f64::NAN,
        });
    }
    out
}

fn linear_factor(c: Conversion) -> Option<f64> {
    match c {
        Conversion::Linear { factor, offset } if offset == 0.0 && factor != 0.0 => Some(factor),
        _ => None,
    }
}

/// Arrow type of a canonical column in the portal export.
fn portal_type(column: &str) -> DataType {
    match column {
        "vehicle_speed" => DataType::Float32,
        "gear" => DataType::Int8,
        _ => DataType::Float64,
    }
}

fn metadata(opts: &SynthOptions, source: &str) -> Vec<KeyValue> {
    let mut kv = vec![KeyValue::new("drive_id".into(), opts.drive_id.clone())];
    if let Some(v) = &opts.vehicle_id {
        kv.push(KeyValue::new("vehicle_id".into(), v.clone()));
    }
    kv.push(KeyValue::new("source".into(), source.to_string()));
    kv
}

fn write_parquet(
    path: &Path,
    schema: Schema,
    arrays: Vec<ArrayRef>,
    kv: Vec<KeyValue>,
) -> Result<(), ExportError> {
    let io_err = |source| ExportError::Io {
        path: path.to_path_buf(),
        source,
    };
    let pq_err = |source| ExportError::Parquet {
        path: path.to_path_buf(),
        source,
    };
    let schema = Arc::new(
        schema.with_metadata(
            kv.iter()
                .map(|e| (e.key.clone(), e.value.clone().unwrap_or_default()))
                .collect::<std::collections::HashMap<String, String>>(),
        ),
    );
    let batch = RecordBatch::try_new(schema.clone(), arrays)
        .map_err(|e| pq_err(parquet::errors::ParquetError::General(e.to_string())))?;
    let props = WriterProperties::builder()
        .set_compression(Compression::SNAPPY)
        .set_key_value_metadata(Some(kv))
        .build();
    let tmp = AtomicFile::create(path).map_err(io_err)?;
    let handle = tmp.try_clone_file().map_err(io_err)?;
    let mut w = ArrowWriter::try_new(handle, schema, Some(props)).map_err(pq_err)?;
    w.write(&batch).map_err(pq_err)?;
    w.close().map_err(pq_err)?;
    tmp.commit().map_err(io_err)
}

/// One exported column of the wide layout.
struct PortalColumn<'a> {
    column: String,
    name: String,
    channel: &'a CanChannel,
    rate_hz: f64,
    samples: Vec<(i64, f64)>,
    wire: Conversion,
    export: Conversion,
}

/// Writes the wide portal export of `frames` (logged on `bus`) at `path` (module doc), with
/// the fuel rate from `fuel_lph` (truth, l/h) when given, up to `t_end_s` (s from the start).
/// Returns the number of rows.
///
/// # Errors
/// [`ExportError`] for an invalid bus, a unit that does not convert, a non-numeric field, a bad
/// end time or fuel series, and I/O or encoder errors (no file is left then).
pub fn write_portal_export(
    path: &Path,
    bus: &CanBus,
    frames: &[CanFrame],
    fuel_lph: Option<Series<'_>>,
    t_end_s: f64,
    opts: &SynthOptions,
) -> Result<usize, ExportError> {
    bus.validate()?;
    if !(t_end_s.is_finite() && t_end_s > 0.0) {
        return Err(ExportError::BadInput {
            what: format!("export end {t_end_s} s must be finite and > 0"),
        });
    }
    let mapping = bundled_mapping(PORTAL_MAPPING)?;
    let schema = drive_log();
    let mut cols: Vec<PortalColumn> = Vec::new();
    for spec in &schema.columns {
        let Some(src) = mapping.signals.get(&spec.name) else {
            continue;
        };
        let Some(name) = src.source.clone() else {
            continue;
        };
        let Some((m, c)) = bus.channels().find(|(_, c)| c.column == spec.name) else {
            continue;
        };
        let samples = channel_samples(frames, &m.topic, &c.field)?;
        if samples.is_empty() {
            continue;
        }
        let export =
            conversion(&src.unit, &spec.quantity, src.reference_torque_nm).map_err(|source| {
                ExportError::Unit {
                    column: name.clone(),
                    source,
                }
            })?;
        cols.push(PortalColumn {
            column: spec.name.clone(),
            name,
            channel: c,
            rate_hz: m.rate_hz,
            samples,
            wire: bus.conversion(c)?,
            export,
        });
    }
    // ticks every 50 ms on whole ms after the start
    let start_ms = opts.start_ns.div_euclid(1_000_000) + i64::from(opts.start_ns % 1_000_000 != 0);
    let step_ms = (1000.0 / PORTAL_RATE_HZ).round() as i64;
    let end_ns = opts.start_ns.saturating_add((t_end_s * 1e9).round() as i64);
    let ticks_ms: Vec<i64> = (1..)
        .map(|k| start_ms + k * step_ms)
        .take_while(|&t| t.saturating_mul(1_000_000) <= end_ns)
        .collect();
    let ticks_ns: Vec<i64> = ticks_ms.iter().map(|t| t * 1_000_000).collect();

    let mut fields = vec![Field::new(
        "Time",
        DataType::Timestamp(TimeUnit::Millisecond, Some("UTC".into())),
        false,
    )];
    let mut arrays: Vec<ArrayRef> = vec![Arc::new(
        TimestampMillisecondArray::from(ticks_ms.clone()).with_timezone("UTC"),
    )];
    for pc in &cols {
        let stale_ns = (STALE_PERIODS / pc.rate_hz * 1e9).round() as i64;
        let wire = hold(&pc.samples, &ticks_ns, stale_ns);
        // the wire resolution in the export unit, where both conversions are plain scalings
        let res = match (linear_factor(pc.wire), linear_factor(pc.export)) {
            (Some(fw), Some(fe)) => Some(pc.channel.resolution * (fw / fe).abs()),
            _ => None,
        };
        let values: Vec<Option<f64>> = wire
            .iter()
            .map(|&w| {
                if w.is_nan() {
                    return None;
                }
                let x = super::can::to_wire(pc.export, pc.wire.apply(w));
                Some(match res {
                    Some(r) => step_value((x / r).round(), r),
                    None => x,
                })
            })
            .collect();
        let ty = portal_type(&pc.column);
        let array: ArrayRef = match ty {
            DataType::Float32 => Arc::new(Float32Array::from_iter(
                values.iter().map(|v| v.map(|x| x as f32)),
            )),
            DataType::Int8 => Arc::new(Int8Array::from_iter(
                values
                    .iter()
                    .map(|v| v.map(|x| x.round().clamp(-128.0, 127.0) as i8)),
            )),
            _ => Arc::new(Float64Array::from_iter(values.iter().copied())),
        };
        fields.push(Field::new(&pc.name, ty, true));
        arrays.push(array);
    }
    if let (Some(fuel), true) = (
        fuel_lph,
        mapping.passthrough_units.contains_key(FUEL_RATE_COLUMN),
    ) {
        if fuel.t_s.len() != fuel.values.len() || fuel.t_s.is_empty() {
            return Err(ExportError::BadInput {
                what: format!(
                    "fuel rate: {} values for {} times",
                    fuel.values.len(),
                    fuel.t_s.len()
                ),
            });
        }
        let t_last = fuel.t_s[fuel.t_s.len() - 1];
        let mut samples = Vec::new();
        let mut i = 0usize;
        for k in 0u64.. {
            let t = FUEL_PHASE_S + k as f64 / FUEL_RATE_HZ;
            if t > t_last {
                break;
            }
            while i + 1 < fuel.t_s.len() && fuel.t_s[i + 1] <= t {
                i += 1;
            }
            let v = if i + 1 < fuel.t_s.len() && t >= fuel.t_s[i] {
                let (t0, t1) = (fuel.t_s[i], fuel.t_s[i + 1]);
                fuel.values[i] + (fuel.values[i + 1] - fuel.values[i]) * (t - t0) / (t1 - t0)
            } else {
                fuel.values[i]
            };
            let q = (v.max(0.0) / FUEL_RESOLUTION_LPH).round();
            let log_time = opts.start_ns.saturating_add((t * 1e9).round() as i64);
            samples.push((log_time, step_value(q, FUEL_RESOLUTION_LPH)));
        }
        let stale_ns = (STALE_PERIODS / FUEL_RATE_HZ * 1e9).round() as i64;
        let v = hold(&samples, &ticks_ns, stale_ns);
        fields.push(Field::new(FUEL_RATE_COLUMN, DataType::Float64, true));
        arrays.push(Arc::new(Float64Array::from_iter(
            v.iter().map(|x| (!x.is_nan()).then_some(*x)),
        )));
    }
    let kv = metadata(
        opts,
        "fleet portal export (synthetic, fleetdyn synth drive)",
    );
    write_parquet(path, Schema::new(fields), arrays, kv)?;
    Ok(ticks_ms.len())
}

/// Writes the long export of `frames` (logged on `bus`) at `path` (module doc). Returns the
/// number of rows.
///
/// # Errors
/// [`ExportError::Mismatch`] when the bus sends a signal of the bundled long mapping in another
/// unit or reference torque; [`ExportError::NotANumber`]; I/O and encoder errors (no file is
/// left then).
pub fn write_long_export(
    path: &Path,
    bus: &CanBus,
    frames: &[CanFrame],
    opts: &SynthOptions,
) -> Result<usize, ExportError> {
    bus.validate()?;
    let mapping = bundled_mapping(LONG_MAPPING)?;
    for (column, src) in &mapping.signals {
        let Some(source_name) = &src.source else {
            continue;
        };
        let Some((m, c)) = bus
            .channels()
            .find(|(m, c)| format!("{}.{}", m.name, c.field) == *source_name)
        else {
            continue;
        };
        let bus_ref = bus.conversion(c)?;
        let reference = |r: Option<f64>| r.map(|r| format!(" of {r} N*m")).unwrap_or_default();
        let mapping_conv = conversion(
            &src.unit,
            &drive_log()
                .column(column)
                .map(|s| s.quantity.clone())
                .unwrap_or_default(),
            src.reference_torque_nm,
        )
        .map_err(|source| ExportError::Unit {
            column: column.clone(),
            source,
        })?;
        if c.column != *column || c.wire_unit != src.unit || bus_ref != mapping_conv {
            let bus_reference = match bus_ref {
                Conversion::Linear { factor, .. } if c.wire_unit == "%" => Some(factor * 100.0),
                _ => None,
            };
            return Err(ExportError::Mismatch {
                mapping: LONG_MAPPING,
                column: column.clone(),
                source_name: source_name.clone(),
                mapping_unit: format!("{}{}", src.unit, reference(src.reference_torque_nm)),
                bus_unit: format!("{} ({}){}", c.wire_unit, m.topic, reference(bus_reference)),
            });
        }
    }
    let mut rows: Vec<(i64, String, f64)> = Vec::new();
    for f in frames {
        let Some(m) = bus.messages.iter().find(|m| m.topic == f.topic) else {
            return Err(SynthError::BadName {
                what: "frame topic not on the bus",
                name: f.topic.clone(),
            }
            .into());
        };
        for (field, v) in &f.fields {
            let x = v.as_f64().ok_or_else(|| ExportError::NotANumber {
                topic: f.topic.clone(),
                log_time_ns: f.log_time_ns,
                field: field.clone(),
            })?;
            rows.push((
                f.log_time_ns.div_euclid(1000),
                format!("{}.{}", m.name, field),
                x,
            ));
        }
    }
    rows.sort_by(|a, b| (a.0, &a.1).cmp(&(b.0, &b.1)));
    let fields = vec![
        Field::new(
            "ts",
            DataType::Timestamp(TimeUnit::Microsecond, Some("UTC".into())),
            false,
        ),
        Field::new("signal", DataType::Utf8, false),
        Field::new("value", DataType::Float64, false),
    ];
    let arrays: Vec<ArrayRef> = vec![
        Arc::new(
            TimestampMicrosecondArray::from(rows.iter().map(|r| r.0).collect::<Vec<_>>())
                .with_timezone("UTC"),
        ),
        Arc::new(StringArray::from_iter_values(rows.iter().map(|r| &r.1))),
        Arc::new(Float64Array::from(
            rows.iter().map(|r| r.2).collect::<Vec<_>>(),
        )),
    ];
    let kv = metadata(opts, "J1939 long export (synthetic, fleetdyn synth drive)");
    write_parquet(path, Schema::new(fields), arrays, kv)?;
    Ok(rows.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hold_is_null_before_the_first_sample_and_when_stale() {
        let s = [(10, 1.0), (20, 2.0), (50, 5.0)];
        let v = hold(&s, &[5, 10, 15, 25, 36, 50, 70], 15);
        let want = [f64::NAN, 1.0, 1.0, 2.0, f64::NAN, 5.0, f64::NAN];
        for (a, b) in v.iter().zip(want) {
            assert!(a == &b || (a.is_nan() && b.is_nan()), "{v:?}");
        }
    }

    #[test]
    fn fuel_rate_is_plausible_for_a_13_l_diesel() {
        let rpm = std::f64::consts::PI / 30.0;
        // idle, no load: 2 l/h; 300 kW at 1200 rpm: ~71 l/h (≈ 200 g/kWh); overrun: 0
        assert!((fuel_rate_lph(600.0 * rpm, 0.0) - 2.0).abs() < 1e-12);
        let w = 1200.0 * rpm;
        let f = fuel_rate_lph(w, 300e3 / w);
        assert!((70.0..73.0).contains(&f), "{f}");
        assert_eq!(fuel_rate_lph(w, -200.0), 0.0);
    }

    #[test]
    fn bundled_mappings_are_found() {
        assert_eq!(
            bundled_mapping(PORTAL_MAPPING).unwrap().name,
            PORTAL_MAPPING
        );
        assert_eq!(bundled_mapping(LONG_MAPPING).unwrap().name, LONG_MAPPING);
        let m = bundled_mapping(PORTAL_MAPPING).unwrap();
        assert_eq!(
            m.passthrough_units
                .get(FUEL_RATE_COLUMN)
                .map(String::as_str),
            Some("l/h")
        );
    }
}
