//! Synthetic CAN logs (`fleetdyn::synth::can`): resolution, rate, noise, determinism, and that
//! the written MCAP and canonical Parquet pass ingest unchanged.

use crate::common::T0_NS;
use fleetdyn::ingest::{ingest_file, IngestOptions, Mapping};
use fleetdyn::synth::{
    sample, write_can_drive, write_mcap, CanBus, CanFrame, Dropouts, SynthError, SynthOptions,
    Truth,
};
use fleetdyn::table::DriveLog;
use std::collections::BTreeMap;

const REF_NM: f64 = 2600.0;

/// Linear ramps for every channel (SI), gear and slope constant; 0..`duration_s` at 100 Hz.
fn ramp_truth(duration_s: f64) -> Truth {
    let n = (duration_s * 100.0).round() as usize + 1;
    let t_s: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
    let col = |name: &str, f: &dyn Fn(f64) -> f64| {
        (name.to_string(), t_s.iter().map(|&t| f(t)).collect())
    };
    Truth {
        columns: vec![
            col("vehicle_speed", &|t| 5.0 + 0.1037 * t),
            col("engine_speed", &|t| 100.0 + 0.5113 * t),
            col("engine_torque", &|t| 300.0 + 15.31 * t),
            col("gear", &|_| 10.0),
            col("road_slope", &|_| 0.023),
            col("bellow_pressure_front", &|t| 400e3 + 517.0 * t),
            col("bellow_pressure_rear", &|t| 600e3 - 313.0 * t),
            col("bellow_pressure_tag", &|t| 350e3 + 101.3 * t),
            col("retarder_torque", &|t| 200.0 + 10.7 * t),
            col("brake_force", &|t| 1000.0 + 713.0 * t),
            col("clutch_position", &|t| 0.1 + 0.006 * t),
        ],
        t_s,
    }
}

fn opts(seed: u64) -> SynthOptions {
    SynthOptions {
        start_ns: T0_NS,
        seed,
        drive_id: "synth-0001".into(),
        vehicle_id: Some("TRUCK-SYN".into()),
    }
}

/// (topic, field) → (resolution, wire_min, wire_max, rate_hz)
fn channel_table(bus: &CanBus) -> BTreeMap<(String, String), (f64, f64, f64, f64)> {
    bus.channels()
        .map(|(m, c)| {
            (
                (m.topic.clone(), c.field.clone()),
                (c.resolution, c.wire_min, c.wire_max, m.rate_hz),
            )
        })
        .collect()
}

fn value(f: &CanFrame, field: &str) -> f64 {
    f.fields[field].as_f64().expect("numeric field")
}

#[test]
fn default_bus_uses_the_bundled_mapping_names_and_units() {
    let bus = CanBus::j1939_truck(REF_NM);
    bus.validate().unwrap();
    let bundled = Mapping::embedded()
        .into_iter()
        .find(|m| m.name == "j1939-json-mcap")
        .unwrap();
    let ours = bus.mapping().unwrap();
    assert_eq!(bus.channels().count(), 11);
    for (m, c) in bus.channels() {
        let b = &bundled.signals[&c.column];
        let o = &ours.signals[&c.column];
        assert_eq!(b.topic.as_deref(), Some(m.topic.as_str()), "{}", c.column);
        assert_eq!(b.field.as_deref(), Some(c.field.as_str()), "{}", c.column);
        assert_eq!(b.unit, c.wire_unit, "{}", c.column);
        // reference torques: exact (both are the same decimal literal)
        assert_eq!(b.reference_torque_nm, o.reference_torque_nm, "{}", c.column);
    }
}

#[test]
fn every_value_is_a_multiple_of_its_resolution_and_in_range() {
    let bus = CanBus::j1939_truck(REF_NM);
    let frames = sample(&bus, &ramp_truth(30.0), T0_NS, 7).unwrap();
    let table = channel_table(&bus);
    let mut checked = 0;
    for f in &frames {
        for (field, v) in &f.fields {
            let (res, lo, hi, _) = table[&(f.topic.clone(), field.clone())];
            let x = v.as_f64().unwrap();
            let q = x / res;
            // tolerance: 1e-9 relative to the step count
            assert!(
                (q - q.round()).abs() <= 1e-9 * q.abs().max(1.0),
                "{}.{field} = {x} is not a multiple of {res}",
                f.topic
            );
            assert!(
                (lo..=hi).contains(&x),
                "{}.{field} = {x} outside [{lo}, {hi}]",
                f.topic
            );
            checked += 1;
        }
    }
    // 30 s: CCVS1 (phase 0) 301 messages; ETC2, SLOPE, ERC1, BRAKE, CLUTCH (phases 4–14 ms)
    // 300 each; EEC1 (2 ms, 50 Hz) 1500 × 2 fields; ASC4 (8 ms) 300 × 3 fields
    assert_eq!(
        checked,
        301 + 5 * 300 + 1500 * 2 + 300 * 3,
        "fields written"
    );
}

#[test]
fn message_intervals_are_one_period_except_across_dropouts() {
    let truth = ramp_truth(120.0);
    let bus = CanBus::j1939_truck(REF_NM);
    let by_topic = |frames: &[CanFrame]| {
        let mut m: BTreeMap<String, Vec<i64>> = BTreeMap::new();
        for f in frames {
            m.entry(f.topic.clone()).or_default().push(f.log_time_ns);
        }
        m
    };
    let clean = by_topic(&sample(&bus, &truth, T0_NS, 1).unwrap());
    for m in &bus.messages {
        let t = &clean[&m.topic];
        let period = 1e9 / m.rate_hz;
        // first message at the phase, to the ns
        assert_eq!(
            t[0] - T0_NS,
            (m.phase_s * 1e9).round() as i64,
            "{}",
            m.topic
        );
        for w in t.windows(2) {
            // tolerance 1 ns (times are rounded to whole ns)
            assert!(
                ((w[1] - w[0]) as f64 - period).abs() <= 1.0,
                "{}: {w:?}",
                m.topic
            );
        }
        let expected = ((120.0 - m.phase_s) * m.rate_hz + 1e-9).floor() as usize + 1;
        assert_eq!(t.len(), expected, "{}", m.topic);
    }

    let lossy = bus.clone().with_dropouts(Dropouts {
        start_probability: 0.02,
        mean_length_s: 0.5,
    });
    let dropped = by_topic(&sample(&lossy, &truth, T0_NS, 1).unwrap());
    for m in &lossy.messages {
        let t = &dropped[&m.topic];
        let period = 1e9 / m.rate_hz;
        let mut gaps = 0;
        for w in t.windows(2) {
            let periods = (w[1] - w[0]) as f64 / period;
            // every interval is a whole number of periods (to 1 ns), gaps are longer
            assert!(
                ((w[1] - w[0]) as f64 - periods.round() * period).abs() <= 1.0
                    && periods.round() >= 1.0,
                "{}: {w:?}",
                m.topic
            );
            gaps += usize::from(periods.round() > 1.0);
        }
        // expected gaps ≈ 0.02 · messages / (1 + 0.02·(mean gap in messages)): 10 Hz → ~18,
        // 50 Hz → ~45; a loose bound that still proves dropouts happen and are not everywhere
        let sent = t.len() as f64 / clean[&m.topic].len() as f64;
        assert!(gaps >= 5, "{}: {gaps} gaps", m.topic);
        assert!((0.6..0.995).contains(&sent), "{}: {sent} sent", m.topic);
    }
}

#[test]
fn noise_free_ramp_reproduces_the_quantised_truth() {
    let truth = ramp_truth(20.0);
    let bus = CanBus::j1939_truck(REF_NM).without_noise();
    let frames = sample(&bus, &truth, T0_NS, 3).unwrap();
    let q = |x: f64, res: f64| (x / res).round() * res;
    let mut n = 0;
    for f in &frames {
        let t = (f.log_time_ns - T0_NS) as f64 * 1e-9;
        let want: Vec<(&str, f64, f64)> = match f.topic.as_str() {
            "/can/ccvs1" => vec![(
                "WheelBasedVehicleSpeed",
                (5.0 + 0.1037 * t) * 3.6,
                1.0 / 256.0,
            )],
            "/can/eec1" => vec![
                (
                    "EngineSpeed",
                    (100.0 + 0.5113 * t) * 60.0 / std::f64::consts::TAU,
                    0.125,
                ),
                (
                    "ActualEnginePercentTorque",
                    (300.0 + 15.31 * t) / REF_NM * 100.0,
                    1.0,
                ),
            ],
            "/can/etc2" => vec![("TransmissionCurrentGear", 10.0, 1.0)],
            "/can/slope" => vec![("RoadSlope", 2.3, 1.0)],
            "/can/asc4" => vec![
                ("BellowPressureFrontAxle", (400e3 + 517.0 * t) / 1e3, 0.1),
                ("BellowPressureRearAxle", (600e3 - 313.0 * t) / 1e3, 0.1),
                ("BellowPressureTagAxle", (350e3 + 101.3 * t) / 1e3, 0.1),
            ],
            "/can/erc1" => vec![(
                "ActualRetarderPercentTorque",
                (200.0 + 10.7 * t) / 3500.0 * 100.0,
                1.0,
            )],
            "/can/brake" => vec![("ServiceBrakeForce", (1000.0 + 713.0 * t) / 1e3, 0.1)],
            "/can/clutch" => vec![("ClutchActuatorPosition", (0.1 + 0.006 * t) * 100.0, 0.4)],
            other => panic!("unexpected topic {other}"),
        };
        for (field, x, res) in want {
            let got = value(f, field);
            // tolerance: 1e-9 of a step (float rounding of the step value only)
            assert!(
                (got - q(x, res)).abs() <= 1e-9 * res.max(got.abs() * 1e-3),
                "{} {field} at {t} s: {got} vs {}",
                f.topic,
                q(x, res)
            );
            n += 1;
        }
    }
    assert!(n > 2000, "{n} values checked");
}

#[test]
fn noise_sigma_is_recovered_within_statistical_bounds() {
    // constant engine speed between two steps; σ = 4 rpm, resolution 0.125 rpm
    let t_s = vec![0.0, 600.0];
    let truth = Truth {
        t_s,
        columns: vec![
            ("vehicle_speed".into(), vec![10.0, 10.0]),
            ("engine_speed".into(), vec![150.0, 150.0]),
        ],
    };
    let mut bus = CanBus::j1939_truck(REF_NM);
    bus.messages[1].channels[0].noise_sigma = 4.0;
    let frames = sample(&bus, &truth, T0_NS, 11).unwrap();
    let x: Vec<f64> = frames
        .iter()
        .filter(|f| f.topic == "/can/eec1")
        .map(|f| value(f, "EngineSpeed"))
        .collect();
    let n = x.len() as f64;
    assert_eq!(x.len(), 30_000);
    let mean = x.iter().sum::<f64>() / n;
    let sd = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let truth_rpm = 150.0 * 60.0 / std::f64::consts::TAU;
    // quantisation adds res²/12 to the variance; sample sd has relative standard error
    // 1/√(2n) ≈ 0.41 %, the mean standard error σ/√n ≈ 0.023 rpm: 5-standard-error bounds
    let expected_sd = (16.0f64 + 0.125f64.powi(2) / 12.0).sqrt();
    assert!(
        (sd / expected_sd - 1.0).abs() < 5.0 / (2.0 * n).sqrt(),
        "sd {sd}"
    );
    assert!(
        (mean - truth_rpm).abs() < 5.0 * 4.0 / n.sqrt(),
        "mean {mean} vs {truth_rpm}"
    );
}

#[test]
fn same_seed_gives_identical_mcap_bytes_and_another_seed_differs() {
    let dir = tempfile::tempdir().unwrap();
    let bus = CanBus::j1939_truck(REF_NM).with_dropouts(Dropouts {
        start_probability: 0.01,
        mean_length_s: 0.3,
    });
    let truth = ramp_truth(20.0);
    let write = |name: &str, seed: u64| {
        let p = dir.path().join(name);
        let frames = sample(&bus, &truth, T0_NS, seed).unwrap();
        write_mcap(&p, &bus, &frames, &opts(seed)).unwrap();
        std::fs::read(p).unwrap()
    };
    let a = write("a.mcap", 5);
    let b = write("b.mcap", 5);
    let c = write("c.mcap", 6);
    assert!(a.len() > 1000);
    assert_eq!(a, b, "same seed, same bytes");
    assert_ne!(a, c, "another seed, other bytes");
    // adding a channel leaves the other channels' values unchanged (one stream per channel)
    let mut fewer = truth.clone();
    fewer.columns.retain(|(c, _)| c != "engine_torque");
    let with = sample(&bus, &truth, T0_NS, 5).unwrap();
    let without = sample(&bus, &fewer, T0_NS, 5).unwrap();
    assert_eq!(with.len(), without.len());
    for (x, y) in with.iter().zip(&without) {
        assert_eq!(x.log_time_ns, y.log_time_ns);
        for (k, v) in &y.fields {
            assert_eq!(&x.fields[k], v, "{} {k}", x.topic);
        }
    }
}

fn truth_at(truth: &Truth, col: &str, t: f64) -> f64 {
    let v = &truth.columns.iter().find(|c| c.0 == col).unwrap().1;
    let i = ((t / 0.01).floor() as usize).min(v.len() - 2);
    v[i] + (v[i + 1] - v[i]) * (t - truth.t_s[i]) / 0.01
}

#[test]
fn mcap_ingests_with_the_bundled_mapping_within_one_step_of_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("synth.mcap");
    let bus = CanBus::j1939_truck(REF_NM).without_noise();
    let truth = ramp_truth(60.0);
    let frames = sample(&bus, &truth, T0_NS, 2).unwrap();
    write_mcap(&path, &bus, &frames, &opts(2)).unwrap();
    let ing = ingest_file(&path, &IngestOptions::default()).unwrap();
    assert_eq!(ing.report.mapping, "j1939-json-mcap");
    assert!(ing.report.ignored.is_empty(), "{:?}", ing.report.ignored);
    let log = &ing.log;
    assert_eq!(log.meta.drive_id, "synth-0001");
    assert_eq!(log.meta.vehicle_id.as_deref(), Some("TRUCK-SYN"));
    // grid: EEC1's 50 Hz, from the first CCVS1 message
    assert_eq!(log.timestamp_ns[0], T0_NS);
    assert_eq!(log.timestamp_ns[1] - log.timestamp_ns[0], 20_000_000);
    // one wire step in SI: (column, unit, step)
    let steps = [
        ("vehicle_speed", "m/s", 1.0 / 256.0 / 3.6),
        (
            "engine_speed",
            "rad/s",
            0.125 * std::f64::consts::TAU / 60.0,
        ),
        ("engine_torque", "N*m", 0.01 * REF_NM),
        ("gear", "1", 1.0),
        ("road_slope", "1", 0.01),
        ("bellow_pressure_front", "Pa", 100.0),
        ("bellow_pressure_rear", "Pa", 100.0),
        ("bellow_pressure_tag", "Pa", 100.0),
        ("retarder_torque", "N*m", 35.0),
        ("brake_force", "N", 100.0),
        ("clutch_position", "1", 0.004),
    ];
    assert_eq!(log.signals.len(), steps.len());
    for (col, unit, step) in steps {
        let s = log.signals.iter().find(|s| s.name == col).unwrap();
        assert_eq!(s.unit, unit, "{col}");
        let mut n = 0;
        for (k, v) in s.values.iter().enumerate() {
            if v.is_nan() {
                // only at the grid's edges: the grid spans CCVS1 (phase 0, 0…60 s); later-phased
                // topics start after its first row and end up to one 10 Hz period before its
                // last, and ingest does not extrapolate
                let t = (log.timestamp_ns[k] - T0_NS) as f64 * 1e-9;
                assert!(!(0.1..=59.9).contains(&t), "{col}: NaN at row {k}, {t} s");
                continue;
            }
            let t = (log.timestamp_ns[k] - T0_NS) as f64 * 1e-9;
            let want = truth_at(&truth, col, t);
            // tolerance: one resolution step (+1e-9 relative for float rounding)
            assert!(
                (v - want).abs() <= step * (1.0 + 1e-9),
                "{col} at {t} s: {v} vs truth {want}"
            );
            n += 1;
        }
        assert!(n + 6 >= log.len(), "{col}: {n} values");
    }
}

fn same_values(a: &DriveLog, b: &DriveLog) {
    assert_eq!(a.timestamp_ns, b.timestamp_ns);
    assert_eq!(a.meta.drive_id, b.meta.drive_id);
    assert_eq!(a.meta.vehicle_id, b.meta.vehicle_id);
    assert_eq!(a.signals.len(), b.signals.len());
    for (x, y) in a.signals.iter().zip(&b.signals) {
        assert_eq!((&x.name, &x.unit), (&y.name, &y.unit));
        // exact: bit-identical values, NaN where the other is NaN
        let same = x
            .values
            .iter()
            .zip(&y.values)
            .all(|(p, q)| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()));
        assert!(same, "{} differs", x.name);
    }
}

#[test]
fn written_parquet_ingests_back_to_the_identical_drive_log() {
    let dir = tempfile::tempdir().unwrap();
    let (mcap, pq) = (dir.path().join("d.mcap"), dir.path().join("d.parquet"));
    let bus = CanBus::j1939_truck(REF_NM).with_dropouts(Dropouts {
        start_probability: 0.005,
        mean_length_s: 0.3,
    });
    let log = write_can_drive(&mcap, &pq, &bus, &ramp_truth(60.0), &opts(9)).unwrap();
    assert!(log.len() > 2900);
    // some dropout made a NaN somewhere, so the round trip covers nulls
    assert!(log
        .signals
        .iter()
        .any(|s| s.values.iter().skip(1).any(|v| v.is_nan())));
    let back = ingest_file(&pq, &IngestOptions::default()).unwrap();
    assert_eq!(back.report.mapping, "canonical");
    same_values(&log, &back.log);
    // and the MCAP ingested again with the bundled mapping gives the same log
    let again = ingest_file(&mcap, &IngestOptions::default()).unwrap();
    same_values(&log, &again.log);
}

#[test]
fn bad_specs_and_truth_are_clear_errors() {
    let truth = ramp_truth(2.0);
    let mut bus = CanBus::j1939_truck(REF_NM);
    bus.messages[0].rate_hz = 0.0;
    let e = sample(&bus, &truth, T0_NS, 1).unwrap_err();
    assert!(
        matches!(&e, SynthError::BadRate { topic, rate_hz } if topic == "/can/ccvs1" && *rate_hz == 0.0)
    );
    assert!(e.to_string().contains("/can/ccvs1"), "{e}");
    bus.messages[0].rate_hz = -10.0;
    assert!(matches!(
        sample(&bus, &truth, T0_NS, 1),
        Err(SynthError::BadRate { .. })
    ));

    let mut bus = CanBus::j1939_truck(REF_NM);
    bus.messages[1].channels[0].resolution = 0.0;
    let e = sample(&bus, &truth, T0_NS, 1).unwrap_err();
    assert!(
        matches!(&e, SynthError::BadResolution { column, .. } if column == "engine_speed"),
        "{e}"
    );
    bus.messages[1].channels[0].resolution = -0.125;
    assert!(matches!(
        sample(&bus, &truth, T0_NS, 1),
        Err(SynthError::BadResolution { .. })
    ));

    let bus = CanBus::j1939_truck(REF_NM);
    let mut nan = truth.clone();
    nan.columns[1].1[17] = f64::NAN;
    let e = sample(&bus, &nan, T0_NS, 1).unwrap_err();
    assert!(
        matches!(&e, SynthError::NonFiniteTruth { column, index: 17, .. } if column == "engine_speed"),
        "{e}"
    );
    let mut back = truth.clone();
    back.t_s[5] = back.t_s[4];
    assert!(matches!(
        sample(&bus, &back, T0_NS, 1),
        Err(SynthError::BadTruthTime { index: 5, .. })
    ));
    let mut typo = truth.clone();
    typo.columns[0].0 = "vehicle_sped".into();
    assert!(matches!(
        sample(&bus, &typo, T0_NS, 1),
        Err(SynthError::UnknownTruthColumn { .. })
    ));

    // a failed drive leaves no file
    let dir = tempfile::tempdir().unwrap();
    let (mcap, pq) = (dir.path().join("x.mcap"), dir.path().join("x.parquet"));
    assert!(write_can_drive(&mcap, &pq, &bus, &nan, &opts(1)).is_err());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);

    // the MCAP is written but does not ingest (wheel speed silent for longer than ingest's 2 s
    // NaN-run limit): the pair is not left half-written
    let long = ramp_truth(60.0);
    let mut silent = CanBus::j1939_truck(REF_NM);
    silent.messages[0].dropouts = Dropouts {
        start_probability: 1.0,
        mean_length_s: 30.0,
    };
    let e = write_can_drive(&mcap, &pq, &silent, &long, &opts(1)).unwrap_err();
    assert!(matches!(e, SynthError::Ingest(_)), "{e}");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        0,
        "no MCAP left"
    );
}

#[test]
fn delay_shifts_the_truth_and_the_wire_range_saturates() {
    let truth = ramp_truth(10.0);
    let mut bus = CanBus::j1939_truck(REF_NM).without_noise();
    bus.messages[0].channels[0].delay_s = 0.5; // wheel speed
    bus.messages[1].channels[1].wire_max = 10.0; // torque saturates at 10 % = 260 N·m < truth
    let frames = sample(&bus, &truth, T0_NS, 4).unwrap();
    let mut n = 0;
    for f in &frames {
        let t = (f.log_time_ns - T0_NS) as f64 * 1e-9;
        match f.topic.as_str() {
            "/can/ccvs1" => {
                // before 0.5 s the first truth value is held; after, the truth 0.5 s earlier
                let want = (5.0 + 0.1037 * (t - 0.5).max(0.0)) * 3.6;
                let got = value(f, "WheelBasedVehicleSpeed");
                // tolerance: half a step (quantisation) + 1e-9
                assert!(
                    (got - want).abs() <= 0.5 / 256.0 + 1e-9,
                    "{t} s: {got} vs {want}"
                );
                n += 1;
            }
            "/can/eec1" => assert_eq!(value(f, "ActualEnginePercentTorque"), 10.0),
            _ => {}
        }
    }
    assert_eq!(n, 101);
}
