//! `fleetdyn diagnose` end to end: a synthetic drive with a hidden torque-reaction effect diagnosed
//! through the CLI writes the contract's files — diagnosis.json with exactly the contract's keys,
//! mismatch.parquet, findings.parquet and parameter_estimates.parquet with `unit` field metadata,
//! report.md with the residual plots — and names the effect; a recording neither model can use fails with exit 1, a clear
//! message and nothing written; a missing vehicle is a usage error (exit 2).
//! `fleetdyn prove --driving` records its choice and rejects an unknown one.

use crate::common::fixture;
use arrow::array::AsArray;
use arrow::datatypes::Float64Type;
use fleetdyn::model::catalogue::Effect;
use fleetdyn::synth::drive::{synth_drive, DriveConfig, HiddenEffect};
use fleetdyn::synth::effects::EffectChoice;
use parquet::file::reader::{FileReader, SerializedFileReader};
use std::collections::BTreeSet;
use std::path::Path;
use std::process::Command;

const VEHICLE: &str = "fixtures/vehicles/seed002-6x2-diesel.toml";

fn fleetdyn(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

fn keys(v: &serde_json::Value) -> BTreeSet<String> {
    v.as_object().unwrap().keys().cloned().collect()
}

fn set(k: &[&str]) -> BTreeSet<String> {
    k.iter().map(|s| s.to_string()).collect()
}

fn read_table(p: &Path) -> arrow::record_batch::RecordBatch {
    let f = std::fs::File::open(p).unwrap();
    let r = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f)
        .unwrap()
        .build()
        .unwrap();
    let batches: Vec<_> = r.map(|b| b.unwrap()).collect();
    arrow::compute::concat_batches(&batches[0].schema(), &batches).unwrap()
}

fn parquet_units(p: &Path) -> (i64, Vec<(String, Option<String>)>) {
    let r = SerializedFileReader::new(std::fs::File::open(p).unwrap()).unwrap();
    let rows = r.metadata().file_metadata().num_rows();
    let schema = parquet::arrow::parquet_to_arrow_schema(
        r.metadata().file_metadata().schema_descr(),
        r.metadata().file_metadata().key_value_metadata(),
    )
    .unwrap();
    let units = schema
        .fields()
        .iter()
        .map(|f| (f.name().clone(), f.metadata().get("unit").cloned()))
        .collect();
    (rows, units)
}

#[test]
fn diagnose_writes_the_contract_and_names_the_effect() {
    let dir = tempfile::tempdir().unwrap();
    let d = synth_drive(
        &fixture(VEHICLE),
        "city-se",
        3.0,
        11,
        &dir.path().join("drive"),
        &DriveConfig::default(),
        Some(&HiddenEffect {
            choice: EffectChoice::Given(Effect::BogieTorqueReaction, Some(0.4)),
            answer_path: dir.path().join("answer.json"),
        }),
    )
    .unwrap();
    let out = dir.path().join("diag");
    let o = fleetdyn(&[
        "diagnose",
        "--drive",
        d.log_file.to_str().unwrap(),
        "--vehicle",
        d.vehicle.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    eprintln!("{stdout}");
    // diagnosis.json: the contract's keys, no more
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("diagnosis.json")).unwrap()).unwrap();
    assert_eq!(
        keys(&j),
        set(&[
            "drive_id",
            "verdict",
            "noise_floor",
            "mismatch",
            "findings",
            "estimates"
        ])
    );
    assert_eq!(j["verdict"], "explained");
    let floors = keys(&j["noise_floor"]);
    for s in [
        "vehicle_speed",
        "engine_speed",
        "bellow_pressure_front",
        "bellow_pressure_rear",
        "bellow_pressure_tag",
    ] {
        assert!(floors.contains(s), "{s}");
        assert!(j["noise_floor"][s].as_f64().unwrap() > 0.0);
    }
    let mismatch = j["mismatch"].as_array().unwrap();
    assert!(!mismatch.is_empty());
    for m in mismatch {
        assert_eq!(
            keys(m),
            set(&[
                "signal",
                "start_s",
                "end_s",
                "start_m",
                "end_m",
                "band_hz",
                "condition",
                "rms_residual",
                "significance"
            ])
        );
        assert!(m["end_s"].as_f64() >= m["start_s"].as_f64());
        assert!(m["significance"].as_f64().unwrap() <= 0.01);
    }
    let f = &j["findings"][0];
    assert_eq!(
        keys(f),
        set(&["effect", "ambiguous_with", "sentence", "parameters", "fit"])
    );
    assert_eq!(f["effect"], "bogie_torque_reaction");
    let p = &f["parameters"]["torque_reaction_fraction"];
    assert_eq!(keys(p), set(&["value", "ci_low", "ci_high", "unit"]), "{p}");
    let v = p["value"].as_f64().unwrap();
    assert!((v - 0.4).abs() <= 0.08, "fitted {v} for 0.4");
    for (_, e) in f["fit"].as_object().unwrap() {
        assert_eq!(
            keys(e),
            set(&[
                "train_before",
                "train_after",
                "heldout_before",
                "heldout_after",
                "metric"
            ])
        );
        assert_eq!(e["metric"], "rmse");
    }
    // the same as Parquet tables, one row per stretch / per finding × parameter × signal
    let (rows, units) = parquet_units(&out.join("mismatch.parquet"));
    assert_eq!(rows as usize, mismatch.len());
    assert!(units.iter().all(|(_, u)| u.is_some()), "{units:?}");
    assert!(units.contains(&("start_s".into(), Some("s".into()))));
    let (rows, units) = parquet_units(&out.join("findings.parquet"));
    let fit_rows: usize = j["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f["parameters"].as_object().unwrap().len() * f["fit"].as_object().unwrap().len())
        .sum();
    assert_eq!(rows as usize, fit_rows);
    assert!(units.iter().all(|(_, u)| u.is_some()), "{units:?}");
    // every parameter the drive informs, the named one among them with the fitted interval
    let pe = out.join("parameter_estimates.parquet");
    let (rows, units) = parquet_units(&pe);
    assert!(rows >= 10, "{rows} parameter rows");
    assert!(units.iter().all(|(_, u)| u.is_some()), "{units:?}");
    let t = read_table(&pe);
    let effect = t
        .column_by_name("effect")
        .unwrap()
        .as_string::<i32>()
        .clone();
    let method = t
        .column_by_name("method")
        .unwrap()
        .as_string::<i32>()
        .clone();
    let f64s = |n: &str| {
        t.column_by_name(n)
            .unwrap()
            .as_primitive::<Float64Type>()
            .clone()
    };
    let (value, lo, hi) = (f64s("value"), f64s("ci_low"), f64s("ci_high"));
    let consistent = t
        .column_by_name("consistent_with_file")
        .unwrap()
        .as_boolean()
        .clone();
    let named = j["findings"][0]["effect"].as_str().unwrap();
    let mut seen = BTreeSet::new();
    let mut measured = BTreeSet::new();
    for i in 0..t.num_rows() {
        assert!(
            seen.insert(effect.value(i).to_string()),
            "one row per parameter"
        );
        assert!(lo.value(i) <= value.value(i) && value.value(i) <= hi.value(i));
        if effect.value(i) == named {
            assert_eq!(method.value(i), "named");
            let p = &j["findings"][0]["parameters"];
            let (_, p) = p.as_object().unwrap().iter().next().unwrap();
            assert_eq!(value.value(i), p["value"].as_f64().unwrap());
            assert!(!consistent.value(i));
        } else if method.value(i) == "measured" {
            // measured outside the models, inside the file's own band
            assert!(consistent.value(i));
            measured.insert(effect.value(i).to_string());
        } else {
            assert!(["fitted", "linearised"].contains(&method.value(i)));
        }
    }
    assert!(seen.contains(named));
    // the drive logs an altitude and idles declutched at its stops: the slope sensor's and
    // the torque channel's offsets are measured, not fitted
    assert_eq!(
        measured,
        set(&["grade_offset", "engine_torque_offset"]),
        "{}",
        std::fs::read_to_string(out.join("detail.json")).unwrap()
    );
    // the report with its plots, MAE and fit %
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("**Verdict: explained**"));
    assert!(report.contains("MAE [kPa]") && report.contains("fit [%]"));
    for s in ["vehicle_speed", "bellow_pressure_rear"] {
        let svg = format!("residual_{s}.svg");
        assert!(report.contains(&svg), "{svg}");
        assert!(std::fs::read_to_string(out.join(&svg))
            .unwrap()
            .starts_with("<svg"));
    }
    assert!(out.join("detail.json").exists());
    // nothing staged is left behind
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn unusable_recordings_fail_clearly_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("diag");
    // an axle-only recording with a vehicle file without [axles]: neither model applies
    let o = fleetdyn(&[
        "diagnose",
        "--drive",
        "fixtures/drives/truck-0005-axle.parquet",
        "--vehicle",
        "fixtures/vehicles/truck-40t.toml",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("truck-0005-axle.parquet")
            && err.contains("nothing to diagnose")
            && err.contains("engine_speed")
            && err.contains("[axles]"),
        "{err}"
    );
    assert!(!out.exists() || std::fs::read_dir(&out).unwrap().next().is_none());
    // no vehicle file: a usage error
    let o = fleetdyn(&[
        "diagnose",
        "--drive",
        "fixtures/drives/truck-0001.mcap",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--vehicle"));
}

/// `fleetdyn prove --driving`: the choice reaches the plan and is recorded where a rerun reads
/// it (proof.json, the command line in proof.md, proof_cases.parquet's metadata); an unknown
/// driving is a usage error (exit 2) that writes nothing.
#[test]
fn prove_records_its_driving_and_rejects_an_unknown_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("proof");
    let o = out.to_str().unwrap();
    // case 16 of the default plan: a clean drive, the quickest to diagnose
    let run = fleetdyn(&["prove", "--driving", "fixed", "--cases", "16", "-o", o]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let written: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("proof.json")).unwrap()).unwrap();
    assert_eq!(written["driving"], "fixed");
    assert_eq!(written["scores"].as_array().unwrap().len(), 1);
    assert!(std::fs::read_to_string(out.join("proof.md"))
        .unwrap()
        .contains("--driving fixed"));
    let r =
        SerializedFileReader::new(std::fs::File::open(out.join("proof_cases.parquet")).unwrap())
            .unwrap();
    let driving = r
        .metadata()
        .file_metadata()
        .key_value_metadata()
        .unwrap()
        .iter()
        .find(|kv| kv.key == "driving")
        .and_then(|kv| kv.value.clone());
    assert_eq!(driving.as_deref(), Some("fixed"));

    let other = dir.path().join("other");
    let bad = fleetdyn(&["prove", "--driving", "bogus", "-o", other.to_str().unwrap()]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("drawn, fixed"));
    assert!(!other.exists());
}

/// The columns the diagnosis does not read (`UNREAD_COLUMNS`, which the command drops before
/// diagnosing) change nothing in it: a drive diagnosed with and without its GNSS columns gives
/// the same diagnosis.json, bit for bit.
#[test]
fn the_gnss_columns_change_nothing_in_a_diagnosis() {
    use fleetdyn::diagnose::run::{diagnose, DiagnoseConfig, UNREAD_COLUMNS};
    use fleetdyn::model::vehicle::VehicleFile;
    let dir = tempfile::tempdir().unwrap();
    let d = synth_drive(
        &fixture(VEHICLE),
        "city-se",
        1.5,
        5,
        &dir.path().join("drive"),
        &DriveConfig::default(),
        None,
    )
    .unwrap();
    let vf = VehicleFile::load(&d.vehicle).unwrap();
    let mut without = d.log.clone();
    without
        .signals
        .retain(|c| !UNREAD_COLUMNS.contains(&c.name.as_str()));
    assert_eq!(
        d.log.signals.len(),
        without.signals.len() + UNREAD_COLUMNS.len(),
        "the synthetic drive records every GNSS column"
    );
    let json = |log: &fleetdyn::table::DriveLog| {
        let r = diagnose(log, &vf, &DiagnoseConfig::default()).unwrap();
        serde_json::to_string(&fleetdyn::report::contract::assemble(&r)).unwrap()
    };
    assert_eq!(json(&d.log), json(&without));
}
