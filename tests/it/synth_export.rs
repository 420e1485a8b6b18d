//! Synthetic drive logs for the bundled fixtures: the wide fleet-portal and long J1939 exports,
//! MCAP with LZ4 chunks, logger jitter, dropouts on chosen signals, the truth table, vehicles
//! without axles, the road's own speed limits, and ids and start times of one's own. Drives of
//! 1–3.5 km.

use crate::common::fixture;
use arrow::array::{Array, AsArray};
use arrow::datatypes::{
    DataType, Float32Type, Float64Type, Int8Type, TimeUnit, TimestampMicrosecondType,
    TimestampMillisecondType,
};
use arrow::record_batch::RecordBatch;
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::synth::drive::{synth_drive_logged, DriveConfig, DriveError, SynthDrive};
use fleetdyn::synth::export::{write_long_export, ExportError};
use fleetdyn::synth::log_writer::{DropoutSpec, LogFormat, LogOptions};
use fleetdyn::synth::road_source::RoadSource;
use fleetdyn::synth::{CanBus, Dropouts, McapCompression, SynthError, SynthOptions};
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::collections::BTreeMap;
use std::path::Path;

const DIESEL: &str = "fixtures/vehicles/seed002-6x2-diesel.toml";
const TRACTOR: &str = "fixtures/vehicles/truck-40t.toml";
const VECTO: &str = "fixtures/real/vecto/LongHaul.vdri";

fn city(km: f64) -> RoadSource {
    RoadSource::Rules {
        rules: "city-se".into(),
        length_km: km,
    }
}

fn drive(vehicle: &str, road: &RoadSource, dir: &Path, log: &LogOptions) -> SynthDrive {
    synth_drive_logged(
        &fixture(vehicle),
        road,
        5,
        dir,
        &DriveConfig::default(),
        None,
        log,
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

fn with_format(format: LogFormat) -> LogOptions {
    LogOptions {
        format,
        ..LogOptions::default()
    }
}

fn read_parquet(path: &Path) -> (RecordBatch, BTreeMap<String, String>) {
    let b = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(path).unwrap()).unwrap();
    let kv = b
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .map(|v| {
            v.iter()
                .map(|e| (e.key.clone(), e.value.clone().unwrap_or_default()))
                .collect()
        })
        .unwrap_or_default();
    let schema = b.schema().clone();
    let batches: Vec<RecordBatch> = b.build().unwrap().map(|x| x.unwrap()).collect();
    (
        arrow::compute::concat_batches(&schema, &batches).unwrap(),
        kv,
    )
}

/// A frame's log time (ns) and its fields.
type TimedFields = (i64, BTreeMap<String, f64>);

/// MCAP frames: (topic, schema name, log time ns, field → value), in file order.
type McapFrame = (String, String, i64, BTreeMap<String, f64>);

fn mcap_frames(path: &Path) -> Vec<McapFrame> {
    let bytes = std::fs::read(path).unwrap();
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
            let fields = v
                .as_object()
                .unwrap()
                .iter()
                .map(|(k, x)| (k.clone(), x.as_f64().unwrap()))
                .collect();
            let schema = m.channel.schema.as_ref().unwrap().name.clone();
            (m.channel.topic.clone(), schema, m.log_time as i64, fields)
        })
        .collect()
}

#[test]
fn portal_export_holds_the_latest_can_frame_on_a_20_hz_grid_in_the_mappings_units() {
    let dir = tempfile::tempdir().unwrap();
    let road = city(1.5);
    let m = drive(DIESEL, &road, &dir.path().join("m"), &LogOptions::default());
    let e = drive(
        DIESEL,
        &road,
        &dir.path().join("e"),
        &with_format(LogFormat::PortalExport),
    );
    assert!(e.log_file.ends_with("drive-export.parquet"));
    // the same seed, no jitter: the export is made of exactly the MCAP's frames
    let frames = mcap_frames(&m.log_file);
    let (batch, kv) = read_parquet(&e.log_file);
    let names: Vec<String> = batch
        .schema()
        .fields()
        .iter()
        .map(|f| f.name().clone())
        .collect();
    assert_eq!(
        names,
        [
            "Time",
            "VehSpd_kmh",
            "Slope_pct",
            "EngSpd_rpm",
            "EngTrq_Nm",
            "Gear",
            "ClutchPos_pct",
            "BellowP_front_kPa",
            "BellowP_rear_bar",
            "BellowP_tag_bar",
            "Lat_deg",
            "Lon_deg",
            "Alt_m",
            "FuelRate_lph"
        ]
    );
    assert_eq!(kv["drive_id"], "synth-city-se-1.5km-seed5");
    assert_eq!(kv["vehicle_id"], "SEED002-6X2-DIESEL");
    let time = batch.column(0).as_primitive::<TimestampMillisecondType>();
    assert_eq!(
        batch.schema().field(0).data_type(),
        &DataType::Timestamp(TimeUnit::Millisecond, Some("UTC".into()))
    );
    let start_ms = fleetdyn::synth::drive::DRIVE_START_NS / 1_000_000;
    for (k, t) in time.values().iter().enumerate() {
        assert_eq!(*t, start_ms + 50 * (k as i64 + 1));
    }
    // (column, topic, field, rate Hz, export value per wire value)
    let cols: [(&str, &str, &str, f64, f64); 11] = [
        (
            "VehSpd_kmh",
            "/can/ccvs1",
            "WheelBasedVehicleSpeed",
            10.0,
            1.0,
        ),
        ("Slope_pct", "/can/slope", "RoadSlope", 10.0, 1.0),
        ("EngSpd_rpm", "/can/eec1", "EngineSpeed", 50.0, 1.0),
        (
            "EngTrq_Nm",
            "/can/eec1",
            "ActualEnginePercentTorque",
            50.0,
            26.0,
        ),
        ("Gear", "/can/etc2", "TransmissionCurrentGear", 10.0, 1.0),
        (
            "ClutchPos_pct",
            "/can/clutch",
            "ClutchActuatorPosition",
            10.0,
            1.0,
        ),
        (
            "BellowP_front_kPa",
            "/can/asc4",
            "BellowPressureFrontAxle",
            10.0,
            1.0,
        ),
        (
            "BellowP_rear_bar",
            "/can/asc4",
            "BellowPressureRearAxle",
            10.0,
            0.01,
        ),
        (
            "BellowP_tag_bar",
            "/can/asc4",
            "BellowPressureTagAxle",
            10.0,
            0.01,
        ),
        ("Lat_deg", "/gnss/fix", "latitude", 1.0, 1.0),
        ("Alt_m", "/gnss/fix", "altitude", 1.0, 1.0),
    ];
    for (name, topic, field, rate, factor) in cols {
        let samples: Vec<(i64, f64)> = frames
            .iter()
            .filter(|f| f.0 == topic)
            .map(|f| (f.2, f.3[field]))
            .collect();
        let col = batch.column_by_name(name).unwrap();
        let value = |k: usize| -> Option<f64> {
            if col.is_null(k) {
                return None;
            }
            Some(match col.data_type() {
                DataType::Float32 => f64::from(col.as_primitive::<Float32Type>().value(k)),
                DataType::Int8 => f64::from(col.as_primitive::<Int8Type>().value(k)),
                _ => col.as_primitive::<Float64Type>().value(k),
            })
        };
        let mut nulls = 0;
        for (k, &t_ms) in time.values().iter().enumerate() {
            let t = t_ms * 1_000_000;
            let latest = samples.iter().rev().find(|s| s.0 <= t);
            let want = latest
                .filter(|s| (t - s.0) as f64 <= 1.5e9 / rate)
                .map(|s| s.1 * factor);
            match (value(k), want) {
                (None, None) => nulls += 1,
                (Some(v), Some(w)) => {
                    let tol = if col.data_type() == &DataType::Float32 {
                        1e-4
                    } else {
                        1e-9 * w.abs().max(1.0)
                    };
                    assert!((v - w).abs() <= tol, "{name} row {k}: {v} vs {w}");
                }
                (v, w) => panic!("{name} row {k}: {v:?} vs {w:?}"),
            }
        }
        assert_eq!(nulls, 0, "{name}: no dropouts configured");
    }
    // the CAN resolutions survive the unit changes exactly: 1 % = 26 N·m, 0.1 kPa = 0.001 bar
    let trq = batch
        .column_by_name("EngTrq_Nm")
        .unwrap()
        .as_primitive::<Float64Type>();
    assert!(trq.values().iter().all(|v| (v / 26.0).fract() == 0.0));
    let rear = batch
        .column_by_name("BellowP_rear_bar")
        .unwrap()
        .as_primitive::<Float64Type>();
    assert!(rear
        .values()
        .iter()
        .all(|v| ((v * 1000.0).round() / 1000.0) == *v));
    let fuel = batch
        .column_by_name("FuelRate_lph")
        .unwrap()
        .as_primitive::<Float64Type>();
    assert!(fuel
        .values()
        .iter()
        .all(|v| (0.0..120.0).contains(v) && ((v * 20.0).round() / 20.0) == *v));
    // ingest picks the bundled mapping by itself and gives the very log the drive wrote
    let ing = ingest_file(&e.log_file, &IngestOptions::default()).unwrap();
    assert_eq!(ing.report.mapping, "fleet-portal-export");
    assert_eq!(ing.report.passthrough, vec!["FuelRate_lph".to_string()]);
    assert_eq!(ing.log.timestamp_ns, e.log.timestamp_ns);
    for s in &e.log.signals {
        let b = ing.log.signal(&s.name).unwrap();
        assert!(
            s.values
                .iter()
                .zip(b)
                .all(|(x, y)| x == y || (x.is_nan() && y.is_nan())),
            "{}",
            s.name
        );
    }
    // kPa and bar both arrive in Pa: each ingested bellow pressure is its CAN frame's kPa ×
    // 1000, and the frames are the axle model's truth at their own time to within half a
    // 0.1 kPa step plus 5σ of the 1 kPa wire noise
    let truth = e.axles.as_ref().unwrap();
    let start = fleetdyn::synth::drive::DRIVE_START_NS;
    for (i, (col, field)) in [
        ("bellow_pressure_front", "BellowPressureFrontAxle"),
        ("bellow_pressure_rear", "BellowPressureRearAxle"),
        ("bellow_pressure_tag", "BellowPressureTagAxle"),
    ]
    .into_iter()
    .enumerate()
    {
        let asc4: Vec<(i64, f64)> = frames
            .iter()
            .filter(|f| f.0 == "/can/asc4")
            .map(|f| (f.2, f.3[field] * 1000.0))
            .collect();
        let p = e.log.signal(col).unwrap();
        for (v, t) in p.iter().zip(&e.log.timestamp_ns) {
            let f = asc4.iter().rev().find(|f| f.0 <= *t).unwrap();
            assert!(
                (v - f.1).abs() <= 1e-9 * f.1.abs(),
                "{col} at {t}: {v} Pa vs {} Pa",
                f.1
            );
        }
        let worst = asc4
            .iter()
            .map(|(t, v)| {
                let x = (t - start) as f64 / 1e7; // 100 Hz samples
                let k = (x.floor() as usize).min(truth.pressure_pa[i].len() - 2);
                let w = x - k as f64;
                let p = &truth.pressure_pa[i];
                (v - (p[k] + w * (p[k + 1] - p[k]))).abs()
            })
            .fold(0.0f64, f64::max);
        println!("{col}: worst |frame − truth| {worst:.0} Pa");
        assert!(worst <= 50.0 + 5.0 * 1000.0, "{col}: {worst} Pa");
    }
}

#[test]
fn long_export_has_one_row_per_logged_field_in_wire_units() {
    let dir = tempfile::tempdir().unwrap();
    let road = city(1.0);
    let m = drive(DIESEL, &road, &dir.path().join("m"), &LogOptions::default());
    let l = drive(
        DIESEL,
        &road,
        &dir.path().join("l"),
        &with_format(LogFormat::LongExport),
    );
    let mut want: Vec<(i64, String, f64)> = mcap_frames(&m.log_file)
        .into_iter()
        .flat_map(|(_, schema, t, fields)| {
            fields
                .into_iter()
                .map(move |(f, v)| (t / 1000, format!("{schema}.{f}"), v))
        })
        .collect();
    want.sort_by(|a, b| (a.0, &a.1).cmp(&(b.0, &b.1)));
    let (batch, kv) = read_parquet(&l.log_file);
    assert_eq!(kv["drive_id"], m.log.meta.drive_id);
    let ts = batch.column(0).as_primitive::<TimestampMicrosecondType>();
    let sig = batch.column(1).as_string::<i32>();
    let val = batch.column(2).as_primitive::<Float64Type>();
    assert_eq!(batch.num_rows(), want.len());
    for (k, w) in want.iter().enumerate() {
        assert_eq!(
            (ts.value(k), sig.value(k), val.value(k)),
            (w.0, w.1.as_str(), w.2)
        );
    }
    assert!(want.iter().any(|w| w.1 == "EEC1.ActualEnginePercentTorque"));
    assert!(want.iter().any(|w| w.1 == "ASC4.BellowPressureRearAxle"));
    // the bundled mapping reads five of them and skips the rest
    let ing = ingest_file(&l.log_file, &IngestOptions::default()).unwrap();
    assert_eq!(ing.report.mapping, "j1939-long-export");
    for c in [
        "vehicle_speed",
        "engine_torque",
        "gear",
        "road_slope",
        "engine_speed",
    ] {
        assert!(ing.log.signal(c).is_some(), "{c}");
    }
    assert!(ing.log.signal("bellow_pressure_rear").is_none());
    // a bus whose percent torque means something else than the mapping says is refused
    let e = write_long_export(
        &dir.path().join("x.parquet"),
        &CanBus::j1939_truck(3000.0),
        &[],
        &SynthOptions {
            start_ns: 0,
            seed: 0,
            drive_id: "x".into(),
            vehicle_id: None,
        },
    )
    .unwrap_err();
    assert!(matches!(e, ExportError::Mismatch { .. }), "{e}");
    assert!(
        e.to_string().contains("EEC1.ActualEnginePercentTorque") && e.to_string().contains("3000"),
        "{e}"
    );
    assert!(!dir.path().join("x.parquet").exists());
}

#[test]
fn truth_table_is_a_canonical_log_of_the_trajectory_at_its_rate() {
    let dir = tempfile::tempdir().unwrap();
    let log = LogOptions {
        truth_rate_hz: Some(50.0),
        drive_id: Some("truck-9".into()),
        vehicle_id: Some("TRK-9".into()),
        start_ns: Some(fleetdyn::time_fmt::parse_rfc3339_utc_ns("2026-03-02T06:00:00Z").unwrap()),
        ..LogOptions::default()
    };
    let d = drive(DIESEL, &city(1.0), &dir.path().join("d"), &log);
    let path = d.truth_file.clone().unwrap();
    let t = ingest_file(&path, &IngestOptions::default()).unwrap();
    assert_eq!(t.report.mapping, "canonical");
    assert_eq!(t.log.meta.drive_id, "truck-9");
    assert_eq!(t.log.meta.vehicle_id.as_deref(), Some("TRK-9"));
    assert_eq!(d.log.meta.drive_id, "truck-9");
    assert_eq!(t.log.timestamp_ns[0], 1_772_431_200_000_000_000);
    assert!(t
        .log
        .timestamp_ns
        .windows(2)
        .all(|w| w[1] - w[0] == 20_000_000));
    assert_eq!(t.log.len(), d.drive.t_s.len().div_ceil(2));
    for (col, v) in [
        ("vehicle_speed", &d.drive.speed_mps),
        ("road_slope", &d.drive.slope),
        ("engine_torque", &d.drive.engine_torque_nm),
        ("brake_force", &d.drive.brake_n),
        ("distance", &d.drive.distance_m),
        (
            "bellow_pressure_tag",
            &d.axles.as_ref().unwrap().pressure_pa[2],
        ),
        ("latitude", &d.gnss.as_ref().unwrap().latitude_deg),
    ] {
        let got = t.log.signal(col).unwrap_or_else(|| panic!("{col}"));
        assert!(
            got.iter().zip(v.iter().step_by(2)).all(|(a, b)| a == b),
            "{col} is not the trajectory's every other sample"
        );
    }
    // a rate that does not divide the 100 Hz samples is refused before anything is written
    for bad in [30.0, 0.0, 200.0, f64::NAN] {
        let o = LogOptions {
            truth_rate_hz: Some(bad),
            ..LogOptions::default()
        };
        let e = synth_drive_logged(
            &fixture(DIESEL),
            &city(1.0),
            5,
            &dir.path().join("bad"),
            &DriveConfig::default(),
            None,
            &o,
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                DriveError::BadConfig {
                    parameter: "truth_rate_hz",
                    ..
                }
            ),
            "{e}"
        );
        assert!(!dir.path().join("bad").exists());
    }
}

#[test]
fn a_vehicle_without_axles_drives_with_no_bellow_channels() {
    let dir = tempfile::tempdir().unwrap();
    let log = LogOptions {
        truth_rate_hz: Some(50.0),
        ..LogOptions::default()
    };
    let d = drive(TRACTOR, &city(1.0), &dir.path().join("d"), &log);
    assert!(d.axles.is_none());
    let topics: std::collections::BTreeSet<String> =
        mcap_frames(&d.log_file).into_iter().map(|f| f.0).collect();
    assert!(!topics.contains("/can/asc4"), "{topics:?}");
    assert!(topics.contains("/can/brake") && topics.contains("/gnss/fix"));
    assert!(d.log.signal("bellow_pressure_front").is_none());
    let t = ingest_file(d.truth_file.as_ref().unwrap(), &IngestOptions::default()).unwrap();
    assert!(t.log.signal("bellow_pressure_front").is_none());
    assert_eq!(d.log.meta.vehicle_id.as_deref(), Some("TRK-40T"));
    assert!(topics.contains("/can/erc1"));
    // and a truck without a retarder has no ERC1 message
    let mut cfg = DriveConfig::default();
    cfg.driver.retarder = None;
    let r = synth_drive_logged(
        &fixture(TRACTOR),
        &city(1.0),
        5,
        &dir.path().join("r"),
        &cfg,
        None,
        &LogOptions::default(),
    )
    .unwrap();
    assert!(!mcap_frames(&r.log_file).iter().any(|f| f.0 == "/can/erc1"));
    assert!(r.log.signal("retarder_torque").is_none());
    // an axle effect needs axles
    let e = synth_drive_logged(
        &fixture(TRACTOR),
        &city(1.0),
        5,
        &dir.path().join("e"),
        &DriveConfig::default(),
        Some(&fleetdyn::synth::drive::HiddenEffect {
            choice: fleetdyn::synth::effects::EffectChoice::parse("tyre_stiffness").unwrap(),
            answer_path: dir.path().join("answer.json"),
        }),
        &LogOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, DriveError::Effect(_)), "{e}");
}

#[test]
fn jitter_moves_log_times_by_whole_microseconds_within_its_bound() {
    let dir = tempfile::tempdir().unwrap();
    let road = city(1.0);
    let a = drive(DIESEL, &road, &dir.path().join("a"), &LogOptions::default());
    let jittered = LogOptions {
        timestamp_jitter_s: 0.001,
        ..LogOptions::default()
    };
    let b = drive(DIESEL, &road, &dir.path().join("b"), &jittered);
    let group = |p: &Path| {
        let mut by: BTreeMap<String, Vec<TimedFields>> = BTreeMap::new();
        for f in mcap_frames(p) {
            by.entry(f.0).or_default().push((f.2, f.3));
        }
        by
    };
    let (ga, gb) = (group(&a.log_file), group(&b.log_file));
    assert_eq!(ga.keys().collect::<Vec<_>>(), gb.keys().collect::<Vec<_>>());
    let mut moved = 0usize;
    for (topic, fa) in &ga {
        let fb = &gb[topic];
        assert_eq!(fa.len(), fb.len(), "{topic}");
        assert!(
            fb.windows(2).all(|w| w[1].0 > w[0].0),
            "{topic} out of order"
        );
        for (x, y) in fa.iter().zip(fb) {
            let d = y.0 - x.0;
            assert!(d.abs() <= 1_000_000 && d % 1000 == 0, "{topic}: {d} ns");
            assert_eq!(x.1, y.1, "{topic}: values must not change");
            moved += usize::from(d != 0);
        }
    }
    assert!(moved > 1000, "{moved}");
    // a jitter of half the 50 Hz period could swap frames: refused
    let too_much = LogOptions {
        timestamp_jitter_s: 0.01,
        ..LogOptions::default()
    };
    let e = synth_drive_logged(
        &fixture(DIESEL),
        &road,
        5,
        &dir.path().join("c"),
        &DriveConfig::default(),
        None,
        &too_much,
    )
    .unwrap_err();
    assert!(
        matches!(e, DriveError::Export(ExportError::BadInput { .. })),
        "{e}"
    );
    assert!(!dir.path().join("c/drive.mcap").exists());
}

#[test]
fn dropouts_blank_only_the_named_signals() {
    let dir = tempfile::tempdir().unwrap();
    let log = LogOptions {
        format: LogFormat::PortalExport,
        dropouts: Some(DropoutSpec {
            columns: vec!["vehicle_speed".into()],
            dropouts: Dropouts {
                start_probability: 0.01,
                mean_length_s: 0.3,
            },
        }),
        ..LogOptions::default()
    };
    let d = drive(DIESEL, &city(1.5), &dir.path().join("d"), &log);
    let (batch, _) = read_parquet(&d.log_file);
    let nulls = |c: &str| batch.column_by_name(c).unwrap().null_count();
    println!("VehSpd_kmh nulls: {}", nulls("VehSpd_kmh"));
    assert!(nulls("VehSpd_kmh") > 10);
    for c in [
        "Slope_pct",
        "EngSpd_rpm",
        "Gear",
        "BellowP_front_kPa",
        "Lat_deg",
    ] {
        assert_eq!(nulls(c), 0, "{c}");
    }
    let bad = LogOptions {
        dropouts: Some(DropoutSpec {
            columns: vec!["warp_speed".into()],
            dropouts: Dropouts::NONE,
        }),
        ..LogOptions::default()
    };
    let e = synth_drive_logged(
        &fixture(DIESEL),
        &city(1.0),
        5,
        &dir.path().join("e"),
        &DriveConfig::default(),
        None,
        &bad,
    )
    .unwrap_err();
    assert!(e.to_string().contains("warp_speed"), "{e}");
}

#[test]
fn lz4_chunks_carry_the_same_messages_as_zstd() {
    let dir = tempfile::tempdir().unwrap();
    let road = city(1.0);
    let z = drive(DIESEL, &road, &dir.path().join("z"), &LogOptions::default());
    let lz4 = LogOptions {
        format: LogFormat::Mcap(McapCompression::Lz4),
        mcap_compression_level: 9,
        ..LogOptions::default()
    };
    let l = drive(DIESEL, &road, &dir.path().join("l"), &lz4);
    let (bz, bl) = (
        std::fs::read(&z.log_file).unwrap(),
        std::fs::read(&l.log_file).unwrap(),
    );
    assert_ne!(bz, bl);
    assert!(bl.windows(3).any(|w| w == b"lz4") && !bl.windows(4).any(|w| w == b"zstd"));
    assert_eq!(mcap_frames(&z.log_file), mcap_frames(&l.log_file));
    assert_eq!(z.log.timestamp_ns, l.log.timestamp_ns);
    for bad in [(McapCompression::Zstd, 23), (McapCompression::Lz4, 13)] {
        let o = LogOptions {
            format: LogFormat::Mcap(bad.0),
            mcap_compression_level: bad.1,
            ..LogOptions::default()
        };
        let e = synth_drive_logged(
            &fixture(DIESEL),
            &road,
            5,
            &dir.path().join("bad"),
            &DriveConfig::default(),
            None,
            &o,
        )
        .unwrap_err();
        assert!(
            matches!(
                e,
                DriveError::Export(ExportError::Can(SynthError::BadCompressionLevel { .. }))
            ),
            "{e}"
        );
    }
}

#[test]
fn road_speed_limits_slow_the_truck_before_each_lower_limit() {
    // VECTO Long Haul 54.0 … 57.5 km: <v> 85, 75, 60, 30, 60, 75, 85 km/h (from 54 862 m,
    // 54 934 m, 55 437 m, 56 144 m, 56 550 m, 56 945 m), capped at 80 km/h
    let dir = tempfile::tempdir().unwrap();
    let road = RoadSource::File {
        path: fixture(VECTO),
        start_m: 54_000.0,
        length_km: Some(3.5),
    };
    let mut cfg = DriveConfig::default();
    cfg.driver.speed_limit_mps = Some(80.0 / 3.6);
    cfg.driver.stop_every_m = None;
    cfg.road_speed_limits = true;
    let d = synth_drive_logged(
        &fixture(TRACTOR),
        &road,
        2,
        &dir.path().join("d"),
        &cfg,
        None,
        &LogOptions::default(),
    )
    .unwrap();
    let limits = d.road.speed_limit_mps.as_ref().unwrap();
    let limit_at = |x: f64| limits[(x.max(0.0) as usize).min(limits.len() - 1)].min(80.0 / 3.6);
    // worst excess of the speed over the limit in force (the driver's P control and tip-ins),
    // and the speed where each lower limit begins
    let excess = d
        .drive
        .speed_mps
        .iter()
        .zip(&d.drive.distance_m)
        .map(|(v, x)| v - limit_at(*x))
        .fold(f64::NEG_INFINITY, f64::max);
    let at = |x0: f64| {
        let k = d.drive.distance_m.partition_point(|&x| x < x0);
        d.drive.speed_mps[k] * 3.6
    };
    let (v75, v60, v30) = (at(862.0), at(934.0), at(1437.0));
    let slowest = d
        .drive
        .speed_mps
        .iter()
        .zip(&d.drive.distance_m)
        .filter(|(_, x)| (1500.0..2100.0).contains(*x))
        .map(|(v, _)| v * 3.6)
        .fold(f64::INFINITY, f64::min);
    println!(
        "max excess over the limit {excess:.3} m/s; at the limit changes {v75:.1} (75), {v60:.1} (60), {v30:.1} (30) km/h; slowest in the 30 km/h section {slowest:.1} km/h"
    );
    // a speed controller with k_v = 0.5 1/s and ±5 % torque tip-ins holds its target within a
    // few tenths of a m/s; 1 m/s (3.6 km/h) would mean it ignored a limit
    assert!(excess < 1.0, "{excess} m/s above the limit");
    assert!(v60 < 60.0 + 3.6 && v30 < 30.0 + 3.6, "{v60} {v30}");
    assert!(
        slowest > 25.0,
        "crawled through the 30 km/h section at {slowest} km/h"
    );
    // speed limits on a road that has none
    let cfg = DriveConfig {
        road_speed_limits: true,
        ..DriveConfig::default()
    };
    let e = synth_drive_logged(
        &fixture(TRACTOR),
        &city(1.0),
        2,
        &dir.path().join("e"),
        &cfg,
        None,
        &LogOptions::default(),
    )
    .unwrap_err();
    assert!(matches!(e, DriveError::NoSpeedLimits { .. }), "{e}");
}

#[test]
fn synth_drive_cli_writes_exports_and_truth_and_refuses_bad_log_options() {
    let dir = tempfile::tempdir().unwrap();
    let bin = env!("CARGO_BIN_EXE_fleetdyn");
    let base = |out: &Path| {
        let mut c = std::process::Command::new(bin);
        c.args(["synth", "drive", "--vehicle"])
            .arg(fixture(TRACTOR))
            .args(["--rules", "city-se", "--length-km", "1", "-o"])
            .arg(out);
        c
    };
    let out = dir.path().join("ok");
    let o = base(&out)
        .args([
            "--log-format",
            "long-export",
            "--truth-rate-hz",
            "25",
            "--drive-id",
            "t-1",
            "--start-utc",
            "2026-03-03T13:05:00Z",
        ])
        .output()
        .unwrap();
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("drive-long.parquet") && stdout.contains("truth.parquet"),
        "{stdout}"
    );
    let ing = ingest_file(&out.join("drive-long.parquet"), &IngestOptions::default()).unwrap();
    assert_eq!(ing.log.meta.drive_id, "t-1");
    assert!(ing.log.timestamp_ns[0] >= 1_772_543_100_000_000_000);
    for (args, needle) in [
        (vec!["--start-utc", "2026-03-03 13:05"], "RFC 3339"),
        (vec!["--truth-rate-hz", "30"], "truth_rate_hz"),
        (vec!["--mcap-compression-level", "40"], "level 40"),
        (vec!["--timestamp-jitter-s", "0.5"], "jitter"),
        (
            vec!["--dropout-start-probability", "0.1"],
            "--dropout-columns",
        ),
        (vec!["--dropout-columns", "no_such"], "no_such"),
        (vec!["--road-speed-limits"], "no speed limits"),
        (vec!["--stop-dwell-s", "-1"], "--stop-dwell-s"),
    ] {
        let bad = dir.path().join("bad");
        let o = base(&bad).args(&args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!bad.join("drive.mcap").exists(), "{args:?} left a log");
    }
}
