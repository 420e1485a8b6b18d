//! Validation of the driveline model against the fixture recordings.

use crate::common::*;
use fleetdyn::ingest::{ingest_file, IngestOptions};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::schema::Stage;
use fleetdyn::sim::validate::{validate_shuffle, ValidationConfig, ValidationError};

#[test]
fn fixture_drives_validate_with_finite_metrics_and_no_nan() {
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let p = veh.driveline.as_ref().unwrap();
    for file in [
        "fixtures/drives/truck-0001.mcap",
        "fixtures/drives/truck-0003-export.parquet",
    ] {
        let opts = IngestOptions {
            stages: vec![Stage::Driveline],
            ..Default::default()
        };
        let log = ingest_file(&fixture(file), &opts).unwrap().log;
        let v = validate_shuffle(
            &log,
            p,
            &veh.gearbox.ratios,
            None,
            &ValidationConfig::default(),
        )
        .unwrap();
        for m in v.metrics.iter().filter(|m| m.gear.is_none()) {
            println!(
                "{file}: {} rmse {:.3} mae {:.3} fit {:.1} % ({} samples)",
                m.signal, m.rmse, m.mae, m.fit_percent, m.samples
            );
        }
        for m in &v.metrics {
            assert!(
                m.rmse.is_finite() && m.mae.is_finite() && m.fit_percent.is_finite(),
                "{m:?}"
            );
        }
        for col in [
            &v.vehicle_speed,
            &v.engine_speed,
            &v.shaft_torques[2],
            &v.clutch_locked,
            &v.shuffle_indicator,
        ] {
            assert!(
                col.iter().all(|x| x.is_finite()),
                "{file}: NaN in a simulated output"
            );
        }
    }
}

#[test]
fn a_drive_that_stands_still_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("parked.parquet");
    let mut d = Drive::new(300);
    d.speed = vec![Some(0.0); 300];
    write_parquet(
        &p,
        vec![
            ("timestamp", ts(&d.t_ns)),
            ("vehicle_speed", f64_opt(&d.speed)),
            ("engine_speed", f64s(&vec![62.8; 300])),
            ("engine_torque", f64s(&vec![50.0; 300])),
            ("gear", i16s(&vec![1; 300])),
        ],
    );
    let log = ingest_file(&p, &IngestOptions::default()).unwrap().log;
    let veh = VehicleFile::load(&fixture("fixtures/vehicles/truck-40t.toml")).unwrap();
    let e = validate_shuffle(
        &log,
        veh.driveline.as_ref().unwrap(),
        &veh.gearbox.ratios,
        None,
        &ValidationConfig::default(),
    )
    .unwrap_err();
    assert!(matches!(e, ValidationError::NeverMoves { .. }), "{e}");
}

#[test]
fn simulate_shuffle_command_writes_both_tables() {
    let dir = tempfile::tempdir().unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .args(["simulate", "shuffle", "--drive"])
        .arg(fixture("fixtures/drives/truck-0004-long.parquet"))
        .arg("--vehicle")
        .arg(fixture("fixtures/vehicles/truck-40t.toml"))
        .arg("-o")
        .arg(dir.path())
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("re-initialised from the measured state"));
    for f in ["shuffle_sim.parquet", "validation.parquet"] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    // a gear the gearbox lacks fails the drive with exit 1 and leaves nothing
    let bad = dir.path().join("bad");
    std::fs::create_dir(&bad).unwrap();
    let p = bad.join("g.parquet");
    let d = Drive::new(100);
    write_parquet(
        &p,
        vec![
            ("timestamp", ts(&d.t_ns)),
            ("vehicle_speed", f64_opt(&d.speed)),
            ("engine_speed", f64s(&vec![120.0; 100])),
            ("engine_torque", f64s(&vec![500.0; 100])),
            ("road_slope", f64_opt(&d.slope)),
            ("gear", i16s(&[14; 100])),
        ],
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .args(["simulate", "shuffle", "--drive"])
        .arg(&p)
        .arg("--vehicle")
        .arg(fixture("fixtures/vehicles/truck-40t.toml"))
        .arg("-o")
        .arg(bad.join("out"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("gear"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(!bad.join("out").exists());
}
