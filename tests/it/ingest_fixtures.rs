//! The bundled fixture drives ingest into the canonical table, and the result matches the truth
//! the generator recorded before sensor effects.

use crate::common::*;
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::schema::Stage;

fn opts() -> IngestOptions {
    IngestOptions {
        stages: vec![Stage::Slope, Stage::Driveline],
        ..Default::default()
    }
}

#[test]
fn every_fixture_ingests_with_canonical_units() {
    for (file, format) in [
        ("fixtures/drives/truck-0001.mcap", "mcap-json"),
        ("fixtures/drives/truck-0002-lz4.mcap", "mcap-json"),
        ("fixtures/drives/truck-0003-export.parquet", "parquet-wide"),
        ("fixtures/drives/truck-0004-long.parquet", "parquet-long"),
    ] {
        let ing = ingest_file(&fixture(file), &opts()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ing.report.format, format, "{file}");
        let log = &ing.log;
        assert!(log.timestamp_ns.windows(2).all(|w| w[1] > w[0]), "{file}");
        let schema = fleetdyn::schema::drive_log();
        for s in &log.signals {
            if let Some(c) = schema.column(&s.name) {
                assert_eq!(s.unit, c.unit, "{file}: {}", s.name);
            }
        }
        // whole-percent slope sensor, as the generator wrote it
        let q = fleetdyn::signal::quantization::estimate_quantization(
            log.signal("road_slope").unwrap(),
        )
        .unwrap();
        assert!((q.step - 0.01).abs() < 1e-9, "{file}: {q:?}");
        // speeds of a truck in m/s, engine in rad/s
        let vmax = log
            .signal("vehicle_speed")
            .unwrap()
            .iter()
            .cloned()
            .fold(0.0, f64::max);
        assert!((15.0..=25.0).contains(&vmax), "{file}: vmax {vmax}");
        let wmax = log
            .signal("engine_speed")
            .unwrap()
            .iter()
            .cloned()
            .fold(0.0, f64::max);
        assert!(
            (150.0..=230.0).contains(&wmax),
            "{file}: engine max {wmax} rad/s"
        );
    }
}

#[test]
fn multi_rate_mcap_aligns_on_the_fastest_rate() {
    let ing = ingest_file(&fixture("fixtures/drives/truck-0001.mcap"), &opts()).unwrap();
    assert_eq!(ing.report.time_base_hz, Some(50.0));
    let rates: Vec<_> = ing
        .report
        .channel_rates
        .iter()
        .map(|c| (c.0.as_str(), c.2.round()))
        .collect();
    assert!(
        rates.contains(&("vehicle_speed", 10.0)) && rates.contains(&("engine_speed", 50.0)),
        "{rates:?}"
    );
    // gear is held: only whole gears on the 50 Hz grid
    assert!(ing
        .log
        .signal("gear")
        .unwrap()
        .iter()
        .all(|g| g.fract() == 0.0));
}

#[test]
fn drive_and_vehicle_ids_come_from_the_source_metadata() {
    // MCAP: the metadata record "drive" written by the generator (fixtures/gen/make_drives.sh)
    let ing = ingest_file(&fixture("fixtures/drives/truck-0002-lz4.mcap"), &opts()).unwrap();
    assert_eq!(ing.log.meta.drive_id, "truck-0002");
    assert_eq!(ing.log.meta.vehicle_id.as_deref(), Some("TRK-0002"));
    // Parquet key-value metadata
    let ing = ingest_file(
        &fixture("fixtures/drives/truck-0003-export.parquet"),
        &opts(),
    )
    .unwrap();
    assert_eq!(ing.log.meta.vehicle_id.as_deref(), Some("TRK-0003"));
    // an explicit id wins
    let o = IngestOptions {
        drive_id: Some("custom".into()),
        ..opts()
    };
    assert_eq!(
        ingest_file(&fixture("fixtures/drives/truck-0001.mcap"), &o)
            .unwrap()
            .log
            .meta
            .drive_id,
        "custom"
    );
}

#[test]
fn a_written_drive_log_reads_back_identically() {
    let ing = ingest_file(
        &fixture("fixtures/drives/truck-0003-export.parquet"),
        &opts(),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("drive_log.parquet");
    fleetdyn::pipeline::ingest_stage::write(&p, &ing.log, "test").unwrap();
    // our own output is canonical input: units from the field metadata, ids from the metadata
    let back = ingest_file(&p, &IngestOptions::default()).unwrap();
    assert_eq!(back.report.mapping, "canonical");
    assert_eq!(back.log.timestamp_ns, ing.log.timestamp_ns);
    assert_eq!(back.log.meta.drive_id, ing.log.meta.drive_id);
    assert_eq!(back.log.meta.vehicle_id, ing.log.meta.vehicle_id);
    assert_eq!(back.log.signals.len(), ing.log.signals.len());
    for (a, b) in ing.log.signals.iter().zip(&back.log.signals) {
        assert_eq!((&a.name, &a.unit), (&b.name, &b.unit));
        let same = a
            .values
            .iter()
            .zip(&b.values)
            .all(|(x, y)| x == y || (x.is_nan() && y.is_nan()));
        assert!(same, "{} changed on the round trip", a.name);
    }
}
