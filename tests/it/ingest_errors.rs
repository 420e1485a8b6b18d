//! Bad input gets a clear, typed error naming file, column, row and value — and never a panic
//! or a partial output file.

use crate::common::*;
use fleetdyn::ingest::{
    ingest_file, BadSamples, IngestError, IngestOptions, Mapping, OnGap, TimeRepair,
};
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig, ResampleError};
use std::path::Path;
use std::process::Command;

/// Options for the slope stage that reject bad samples (the errors under test; the default
/// masks isolated ones, `isolated_glitches_are_masked_and_counted_by_default`).
fn slope_opts() -> IngestOptions {
    IngestOptions {
        stages: vec![Stage::Slope],
        bad_samples: BadSamples::Error,
        ..Default::default()
    }
}

fn ingest_err(path: &Path, opts: &IngestOptions) -> IngestError {
    match ingest_file(path, opts) {
        Ok(_) => panic!("{} was accepted", path.display()),
        Err(e) => e,
    }
}

#[test]
fn missing_file() {
    let e = ingest_err(Path::new("/nonexistent/drive.mcap"), &slope_opts());
    assert!(matches!(e, IngestError::Io { .. }), "{e}");
    assert!(e.to_string().contains("/nonexistent/drive.mcap"));
}

#[test]
fn parquet_that_is_not_parquet() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("notes.parquet");
    std::fs::write(&p, "timestamp,vehicle_speed\n0,1\n").unwrap();
    let e = ingest_err(&p, &slope_opts());
    assert!(matches!(e, IngestError::UnknownFormat { .. }), "{e}");
    // right magic, garbage body
    std::fs::write(&p, b"PAR1 this is not a parquet body at all PAR1").unwrap();
    let e = ingest_err(&p, &slope_opts());
    assert!(matches!(e, IngestError::Parquet { .. }), "{e}");
    // a real Parquet file cut in half
    let good = dir.path().join("good.parquet");
    Drive::new(100).write(&good);
    let bytes = std::fs::read(&good).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let e = ingest_err(&p, &slope_opts());
    assert!(matches!(e, IngestError::Parquet { .. }), "{e}");
}

#[test]
fn mcap_bad_magic_truncated_and_crc() {
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("good.mcap");
    write_mcap(&good, &mcap_messages(), None);
    ingest_file(&good, &slope_opts()).expect("the unmodified file is valid");
    let bytes = std::fs::read(&good).unwrap();

    // bad start magic
    let p = dir.path().join("magic.mcap");
    let mut b = bytes.clone();
    b[1] = b'X';
    std::fs::write(&p, &b).unwrap();
    let e = ingest_err(&p, &slope_opts());
    assert!(matches!(e, IngestError::UnknownFormat { .. }), "{e}");

    // bad end magic
    let mut b = bytes.clone();
    let n = b.len();
    b[n - 2] = b'X';
    std::fs::write(&p, &b).unwrap();
    let e = ingest_err(&p, &slope_opts());
    assert!(matches!(e, IngestError::Mcap { .. }), "{e}");

    // truncated inside a chunk
    let p = dir.path().join("truncated.mcap");
    std::fs::write(&p, &bytes[..bytes.len() / 3]).unwrap();
    let e = ingest_err(&p, &slope_opts());
    assert!(matches!(e, IngestError::Mcap { .. }), "{e}");
    assert!(e.to_string().contains("truncated.mcap"));

    // CRC mismatch: change one digit of a speed value inside an (uncompressed) chunk, so the
    // JSON stays valid and only the chunk CRC can tell.
    let p = dir.path().join("crc.mcap");
    let needle = b"\"WheelBasedVehicleSpeed\": 54";
    let at = bytes
        .windows(needle.len())
        .position(|w| w == needle)
        .expect("payload present");
    let mut b = bytes.clone();
    b[at + needle.len() - 1] = b'5';
    std::fs::write(&p, &b).unwrap();
    let e = ingest_err(&p, &slope_opts());
    assert!(matches!(e, IngestError::Mcap { .. }), "{e}");
    assert!(e.to_string().to_lowercase().contains("crc"), "{e}");
}

#[test]
fn committed_mcap_fixture_truncated_and_corrupted() {
    // the zstd fixture (fleetdyn synth drive, fixtures/gen/make_drives.sh), cut and bit-flipped
    let bytes = std::fs::read(fixture("fixtures/drives/truck-0001.mcap")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("cut.mcap");
    std::fs::write(&p, &bytes[..bytes.len() * 2 / 3]).unwrap();
    assert!(matches!(
        ingest_err(&p, &slope_opts()),
        IngestError::Mcap { .. }
    ));
    // flip one byte in the middle of the third chunk's compressed records
    let mut b = bytes.clone();
    let at = chunk_payload_offsets(&b)[2];
    b[at.0 + at.1 / 2] ^= 0x55;
    std::fs::write(&p, &b).unwrap();
    assert!(matches!(
        ingest_err(&p, &slope_opts()),
        IngestError::Mcap { .. }
    ));
}

/// (offset, length) of each Chunk record's compressed records field (MCAP spec: after the
/// magic, records are opcode u8 + length u64 LE; a Chunk (0x06) holds start/end time u64,
/// uncompressed size u64, CRC u32, compression string (u32 length + bytes), then the records
/// (u64 length + bytes)).
pub fn chunk_payload_offsets(b: &[u8]) -> Vec<(usize, usize)> {
    let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap()) as usize;
    let mut out = Vec::new();
    let mut i = 8;
    while i + 9 <= b.len() {
        let (op, len) = (b[i], u64_at(i + 1));
        let body = i + 9;
        if op == 0x06 {
            let clen = u32::from_le_bytes(b[body + 28..body + 32].try_into().unwrap()) as usize;
            let rec = body + 32 + clen;
            out.push((rec + 8, u64_at(rec)));
        }
        if op == 0x02 {
            break; // footer
        }
        i = body + len;
    }
    out
}

#[test]
fn missing_required_column_names_the_stage() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("noslope.parquet");
    let d = Drive::new(50);
    write_parquet(
        &p,
        vec![
            ("timestamp", ts(&d.t_ns)),
            ("vehicle_speed", f64_opt(&d.speed)),
        ],
    );
    let e = ingest_err(&p, &slope_opts());
    match &e {
        IngestError::MissingColumn { column, stage, .. } => {
            assert_eq!((column.as_str(), stage.as_str()), ("road_slope", "slope"))
        }
        other => panic!("{other}"),
    }
    // the ingest stage alone does not need the slope
    ingest_file(&p, &IngestOptions::default()).unwrap();
}

#[test]
fn wrong_dtype() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("strings.parquet");
    let d = Drive::new(3);
    write_parquet(
        &p,
        vec![
            ("timestamp", ts(&d.t_ns)),
            ("vehicle_speed", strs(&["fast", "faster", "fastest"])),
            ("road_slope", f64_opt(&d.slope)),
        ],
    );
    let e = ingest_err(&p, &slope_opts());
    match &e {
        IngestError::WrongDtype { column, found, .. } => {
            assert_eq!(column, "vehicle_speed");
            assert!(found.contains("Utf8"), "{found}");
        }
        other => panic!("{other}"),
    }
}

#[test]
fn unknown_unit_in_a_mapping() {
    let text = std::fs::read_to_string(fixture("schemas/mappings/fleet-portal-export.toml"))
        .unwrap()
        .replace("unit = \"bar\"", "unit = \"atm-ish\"");
    let e = Mapping::parse(&text, "my-mapping.toml").unwrap_err();
    assert!(matches!(e, IngestError::Unit { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("my-mapping.toml")
            && msg.contains("atm-ish")
            && msg.contains("bellow_pressure"),
        "{msg}"
    );
}

#[test]
fn non_monotonic_and_duplicate_timestamps() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.parquet");
    let mut d = Drive::new(50);
    d.t_ns.swap(20, 21);
    d.write(&p);
    match ingest_err(&p, &slope_opts()) {
        IngestError::NonMonotonicTime {
            row,
            time_ns,
            previous_ns,
            ..
        } => {
            assert_eq!(row, 21);
            assert!(time_ns < previous_ns);
        }
        other => panic!("{other}"),
    }
    // the repair option sorts it
    let opts = IngestOptions {
        time_repair: TimeRepair::Sort,
        ..slope_opts()
    };
    assert_eq!(ingest_file(&p, &opts).unwrap().log.len(), 50);

    // exact duplicate rows are dropped and counted; a conflicting duplicate is an error
    let mut d = Drive::new(50);
    d.t_ns[31] = d.t_ns[30];
    d.write(&p);
    let ing = ingest_file(&p, &slope_opts()).unwrap();
    assert_eq!((ing.log.len(), ing.report.duplicates_dropped), (49, 1));
    d.speed[31] = Some(16.0);
    d.write(&p);
    match ingest_err(&p, &slope_opts()) {
        IngestError::DuplicateTimestamp {
            row,
            column,
            value,
            previous,
            ..
        } => {
            assert_eq!(
                (row, column.as_str(), value, previous),
                (31, "vehicle_speed", 16.0, 15.0)
            );
        }
        other => panic!("{other}"),
    }
}

#[test]
fn nan_runs_beyond_the_limit() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("nan.parquet");
    let mut d = Drive::new(200);
    for k in 100..130 {
        d.slope[k] = None; // 3 s gap at 10 Hz
    }
    d.write(&p);
    let error_on_gap = IngestOptions {
        on_gap: OnGap::Error,
        ..slope_opts()
    };
    match ingest_err(&p, &error_on_gap) {
        IngestError::NanRun {
            column,
            row,
            samples,
            seconds,
            ..
        } => {
            assert_eq!((column.as_str(), row, samples), ("road_slope", 100, 30));
            assert!((seconds - 3.1).abs() < 1e-9, "{seconds}");
        }
        other => panic!("{other}"),
    }
    // a short dropout is accepted and counted
    let mut d = Drive::new(200);
    for k in 100..105 {
        d.slope[k] = None;
    }
    d.write(&p);
    let ing = ingest_file(&p, &slope_opts()).unwrap();
    let nan = fleetdyn::ingest::nan_counts(&ing.log);
    assert!(nan.contains(&("road_slope".to_string(), 5)), "{nan:?}");
}

#[test]
fn absurd_values_are_rejected_with_row_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("absurd.parquet");
    let mut d = Drive::new(50);
    d.slope[17] = Some(0.45);
    d.write(&p);
    match ingest_err(&p, &slope_opts()) {
        IngestError::OutOfRange {
            column, row, value, ..
        } => {
            assert_eq!((column.as_str(), row, value), ("road_slope", 17, 0.45))
        }
        other => panic!("{other}"),
    }
    let mut d = Drive::new(50);
    d.speed[9] = Some(-6.0);
    d.write(&p);
    match ingest_err(&p, &slope_opts()) {
        IngestError::OutOfRange { column, row, .. } => {
            assert_eq!((column.as_str(), row), ("vehicle_speed", 9))
        }
        other => panic!("{other}"),
    }
    // gear outside the vehicle's 12-speed gearbox
    let mut d = Drive::new(50);
    d.gear[40] = 14;
    d.write(&p);
    ingest_file(&p, &slope_opts()).expect("without a vehicle file 14 is a possible gear");
    let opts = IngestOptions {
        gear_range: Some((-2, 12)),
        ..slope_opts()
    };
    match ingest_err(&p, &opts) {
        IngestError::OutOfRange {
            column,
            row,
            value,
            max,
            ..
        } => {
            assert_eq!((column.as_str(), row, value, max), ("gear", 40, 14.0, 12.0))
        }
        other => panic!("{other}"),
    }
}

#[test]
fn a_drive_that_never_moves() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("parked.parquet");
    let mut d = Drive::new(600);
    d.speed = vec![Some(0.0); 600];
    d.write(&p);
    let ing = ingest_file(&p, &slope_opts()).unwrap();
    let e = resample_to_distance(&ing.log, &ResampleConfig::default()).unwrap_err();
    assert!(matches!(e, ResampleError::NoDistance { .. }), "{e}");
    assert!(e.to_string().contains("parked.parquet"), "{e}");
}

#[test]
fn isolated_glitches_are_masked_and_counted_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("glitches.parquet");
    let mut d = Drive::new(50);
    d.slope[17] = Some(0.45); // outside the physical range
    d.speed[9] = Some(f64::INFINITY); // not finite
    d.speed[30] = Some(40.0); // a 25 m/s spike in 0.1 s
    d.t_ns[41] = d.t_ns[40]; // a repeated timestamp with another value: the later row wins
    d.speed[41] = Some(15.3);
    d.write(&p);
    let opts = IngestOptions {
        stages: vec![Stage::Slope],
        ..Default::default()
    };
    assert_eq!(opts.bad_samples, BadSamples::Mask);
    let ing = ingest_file(&p, &opts).unwrap();
    assert_eq!(ing.report.masked["road_slope"], 1);
    assert_eq!(ing.report.masked["vehicle_speed"], 2);
    assert_eq!(ing.report.conflicts_resolved, 1);
    let v = ing.log.signal("vehicle_speed").unwrap();
    assert_eq!(ing.log.len(), 49);
    assert!(v[9].is_nan() && v[30].is_nan());
    assert_eq!(v[40], 15.3, "the later sample of the repeated time");
    assert!(ing.log.signal("road_slope").unwrap()[17].is_nan());
    // masking is bounded by the gap limit: 30 bad samples in a row (3 s) are a hole, an error
    // with on_gap = "error"; split, the 10 s drive leaves two pieces too short to keep
    let mut d = Drive::new(100);
    for k in 20..50 {
        d.slope[k] = Some(0.9);
    }
    d.write(&p);
    let error_on_gap = IngestOptions {
        on_gap: OnGap::Error,
        ..opts.clone()
    };
    match ingest_file(&p, &error_on_gap) {
        Err(IngestError::NanRun { column, .. }) => assert_eq!(column, "road_slope"),
        other => panic!("{:?}", other.map(|i| i.report)),
    }
    match ingest_file(&p, &opts) {
        Err(IngestError::NoUsableSegment { found, reasons, .. }) => {
            assert_eq!(found, 2);
            assert!(reasons.contains("shorter than min_segment_s"), "{reasons}");
        }
        other => panic!("{:?}", other.map(|i| i.report)),
    }
}

#[test]
fn cli_failure_leaves_no_output_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("absurd.parquet");
    let mut d = Drive::new(50);
    d.slope[3] = Some(0.9);
    d.write(&bad);
    let out_dir = dir.path().join("out");
    std::fs::create_dir(&out_dir).unwrap();
    for sub in ["ingest", "resample"] {
        let out = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
            .args([sub, bad.to_str().unwrap(), "-o"])
            .arg(out_dir.join("x.parquet"))
            .args(["--stages", "slope", "--bad-samples", "error"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(1), "{sub}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            stderr.contains("road_slope") && stderr.contains("row 3") && stderr.contains("0.9"),
            "{stderr}"
        );
        assert_eq!(
            std::fs::read_dir(&out_dir).unwrap().count(),
            0,
            "{sub} left a file behind"
        );
    }
    // usage errors exit 2
    let out = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .args(["ingest", bad.to_str().unwrap(), "--stages", "warp"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let out = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .args(["frobnicate"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn every_subcommand_has_help() {
    for sub in ["ingest", "resample", "slope", "spectrum", "run"] {
        let out = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
            .args([sub, "--help"])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{sub}");
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains("Usage: fleetdyn") && text.contains(sub),
            "{sub}: {text}"
        );
    }
}
