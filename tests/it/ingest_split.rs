//! Logger pauses split a recording into drives of their own: in the library (wide and multi-rate
//! sources), through the single-drive commands, and in a pipeline run (segment drives, skipped
//! segments in the run report, provenance in the metadata, reuse and clean-up on re-runs).

use crate::common::*;
use fleetdyn::ingest::{ingest, ingest_file, IngestError, IngestOptions, OnGap};
use fleetdyn::schema::Stage;
use std::path::{Path, PathBuf};

const HOUR_NS: i64 = 3_600_000_000_000;

/// 400 s at 10 Hz (15 m/s), the logger asleep for two hours after 200 s, half an hour after 350 s:
/// segments of 200 s, 150 s and 50 s.
fn three_stretches(path: &Path) {
    let mut d = Drive::new(4000);
    for t in &mut d.t_ns[2000..] {
        *t += 2 * HOUR_NS;
    }
    for t in &mut d.t_ns[3500..] {
        *t += HOUR_NS / 2;
    }
    d.write(path);
}

fn slope_opts() -> IngestOptions {
    IngestOptions {
        stages: vec![Stage::Slope],
        ..Default::default()
    }
}

#[test]
fn a_wide_recording_splits_into_numbered_drives_and_skips_the_short_one() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("day.parquet");
    three_stretches(&p);
    let rec = ingest(&p, &slope_opts()).unwrap();
    let ids: Vec<&str> = rec
        .drives
        .iter()
        .map(|d| d.log.meta.drive_id.as_str())
        .collect();
    assert_eq!(ids, ["day-s1", "day-s2"]);
    assert_eq!(rec.drives[0].log.len(), 2000);
    assert_eq!(rec.drives[1].log.len(), 1500);
    let s2 = rec.drives[1].log.meta.segment.as_ref().unwrap();
    assert_eq!((s2.index, s2.count), (2, 3));
    assert_eq!(s2.recording_drive_id, "day");
    assert_eq!(s2.start_ns, T0_NS + 2000 * 100_000_000 + 2 * HOUR_NS);
    assert_eq!(rec.pauses.len(), 2);
    assert!(rec.pauses.iter().all(|p| p.column.is_none()));
    assert!((rec.pauses[0].seconds() - 7200.1).abs() < 1e-6);
    assert_eq!(rec.skipped.len(), 1);
    assert_eq!(rec.skipped[0].index, 3);
    assert_eq!(rec.skipped[0].drive_id, "day-s3");
    assert!(
        rec.skipped[0]
            .reason
            .contains("50 s long, shorter than min_segment_s = 60 s"),
        "{}",
        rec.skipped[0].reason
    );
    // with a lower minimum the third is a drive too
    let all = ingest(
        &p,
        &IngestOptions {
            min_segment_s: 30.0,
            ..slope_opts()
        },
    )
    .unwrap();
    assert_eq!(all.drives.len(), 3);
    assert!(all.skipped.is_empty());
    // a minimum distance skips a parked segment: 50 s at 15 m/s is 750 m
    let far = ingest(
        &p,
        &IngestOptions {
            min_segment_s: 30.0,
            min_segment_m: 1000.0,
            ..slope_opts()
        },
    )
    .unwrap();
    assert_eq!(far.drives.len(), 2);
    assert!(
        far.skipped[0]
            .reason
            .contains("less than min_segment_m = 1000 m"),
        "{:?}",
        far.skipped
    );
    // on_gap = "error": the first pause is the error, naming the row after it
    match ingest(
        &p,
        &IngestOptions {
            on_gap: OnGap::Error,
            ..slope_opts()
        },
    ) {
        Err(IngestError::TimeGap { row, seconds, .. }) => {
            assert_eq!(row, 2000);
            assert!((seconds - 7200.1).abs() < 1e-6);
        }
        other => panic!("{:?}", other.map(|r| r.drives.len())),
    }
    // a single-drive reader is told the recording is several drives
    let e = ingest_file(&p, &slope_opts()).unwrap_err();
    assert!(matches!(e, IngestError::Segmented { drives: 2, .. }), "{e}");
    assert!(e.to_string().contains("splits into 2 drives"), "{e}");
}

#[test]
fn segments_keep_their_own_masked_counts() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("glitchy.parquet");
    let mut d = Drive::new(4000);
    for t in &mut d.t_ns[2000..] {
        *t += 2 * HOUR_NS;
    }
    d.speed[100] = Some(f64::INFINITY);
    d.speed[2500] = Some(f64::INFINITY);
    d.speed[2600] = Some(f64::INFINITY);
    d.write(&p);
    let rec = ingest(&p, &slope_opts()).unwrap();
    assert_eq!(rec.drives.len(), 2);
    assert_eq!(rec.drives[0].report.masked["vehicle_speed"], 1);
    assert_eq!(rec.drives[1].report.masked["vehicle_speed"], 2);
}

#[test]
fn a_multi_rate_recording_is_cut_before_alignment() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("rest.mcap");
    // 10 Hz topics for 120 s, a year of silence, 120 s more: aligned whole, the grid would be
    // a year at 10 Hz
    let year = 365 * 24 * HOUR_NS;
    let m = mcap_messages_at(
        (0..2400i64).map(|k| T0_NS + k * 100_000_000 + if k >= 1200 { year } else { 0 }),
    );
    write_mcap(&p, &m, None);
    let rec = ingest(&p, &slope_opts()).unwrap();
    assert_eq!(rec.drives.len(), 2);
    for d in &rec.drives {
        // 120 s at 10 Hz on the common span of the three topics
        assert!((1195..=1200).contains(&d.log.len()), "{}", d.log.len());
        assert!(d
            .log
            .signals
            .iter()
            .all(|s| s.values.iter().all(|v| v.is_finite())));
    }
    assert_eq!(rec.pauses.len(), 1);
    assert_eq!(rec.pauses[0].column, None, "every topic stopped");
}

#[test]
fn a_single_drive_command_names_the_split_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("day.parquet");
    three_stretches(&p);
    let out = dir.path().join("distance.parquet");
    let o = fleetdyn_at_top(&["resample", p.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("splits into 2 drives"), "{err}");
    assert!(err.contains("fleetdyn ingest --output"), "{err}");
    assert!(
        !err.contains('"') && !err.contains("Some("),
        "debug formatting: {err}"
    );
    assert!(!out.exists());
    // ingest writes one file per drive, each with its provenance
    let o = fleetdyn_at_top(&["ingest", p.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0));
    let kv = parquet_kv(&dir.path().join("distance-s2.parquet"));
    assert_eq!(kv["segment"], "2/3");
    assert_eq!(kv["recording_drive_id"], "day");
    assert_eq!(kv["drive_id"], "day-s2");
    assert_eq!(kv["segment_start"], "2026-03-02T08:03:20.000Z");
    assert!(!dir.path().join("distance-s3.parquet").exists());
}

fn pipeline(dir: &Path, min_segment_s: f64) -> PathBuf {
    let p = dir.join("split.toml");
    std::fs::write(
        &p,
        format!(
            "name = \"split\"\nmodel_version = \"t1\"\nstages = [\"ingest\", \"resample\", \"slope\", \"validate\", \"write\"]\ninputs = [\"day.parquet\"]\noutput_dir = \"out\"\n[ingest]\nmin_segment_s = {min_segment_s:?}\n"
        ),
    )
    .unwrap();
    p
}

fn report(out: &Path) -> serde_json::Value {
    serde_json::from_slice(
        &std::fs::read(out.join("_reports/split/model_version=t1/run_report.json")).unwrap(),
    )
    .unwrap()
}

fn files(dir: &Path) -> Vec<String> {
    crate::batch_pipeline::walk(dir)
        .iter()
        .map(|p| p.display().to_string())
        .collect()
}

#[test]
fn a_pipeline_runs_each_segment_as_a_drive_and_keeps_the_dataset_in_step() {
    let dir = tempfile::tempdir().unwrap();
    three_stretches(&dir.path().join("day.parquet"));
    let out = dir.path().join("out");
    let p = pipeline(dir.path(), 60.0);
    let o = fleetdyn_at_top(&["run", p.to_str().unwrap()]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r = report(&out);
    let drives = r["drives"].as_array().unwrap();
    let ids: Vec<&str> = drives
        .iter()
        .map(|d| d["drive_id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["day-s1", "day-s2"]);
    assert!(drives.iter().all(|d| d["status"] == "ok"));
    assert_eq!(r["skipped_segments"][0]["index"], 3);
    assert_eq!(r["skipped_segments"][0]["drive_id"], "day-s3");
    let summary_md =
        std::fs::read_to_string(out.join("_reports/split/model_version=t1/summary.md")).unwrap();
    assert!(
        summary_md.contains("## Recordings split at pauses (3 segments)"),
        "{summary_md}"
    );
    assert!(summary_md.contains("skipped: 50 s long"), "{summary_md}");
    // the segment's tables carry its provenance; its summary row names the recording
    let written = files(&out);
    let log_s2 = written
        .iter()
        .find(|f| f.contains("/drive_log/") && f.ends_with("/day-s2.parquet"))
        .unwrap();
    let m = parquet_kv(Path::new(log_s2));
    assert_eq!(
        (m["segment"].as_str(), m["recording_drive_id"].as_str()),
        ("2/3", "day")
    );
    let sum_s2 = written
        .iter()
        .find(|f| f.contains("/drive_summary/") && f.ends_with("/day-s2.parquet"))
        .unwrap();
    let b = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(
        std::fs::File::open(sum_s2).unwrap(),
    )
    .unwrap()
    .build()
    .unwrap()
    .next()
    .unwrap()
    .unwrap();
    let col = |n: &str| b.column(b.schema().index_of(n).unwrap()).clone();
    let rid = col("recording_drive_id");
    let rid = rid
        .as_any()
        .downcast_ref::<arrow::array::StringArray>()
        .unwrap();
    assert_eq!(rid.value(0), "day");
    let seg = col("segment");
    let seg = seg
        .as_any()
        .downcast_ref::<arrow::array::UInt64Array>()
        .unwrap();
    assert_eq!(seg.value(0), 2);

    // a re-run reuses both drives and reports the skipped segment again
    let o = fleetdyn_at_top(&["run", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0));
    let r = report(&out);
    assert_eq!(r["reused"], 2, "{r}");
    assert_eq!(r["ok"], 0);
    assert_eq!(r["skipped_segments"][0]["index"], 3);

    // a higher minimum keeps only the first segment: the second's outputs are removed
    let p = pipeline(dir.path(), 180.0);
    let o = fleetdyn_at_top(&["run", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0));
    let r = report(&out);
    assert_eq!(r["drives"].as_array().unwrap().len(), 1);
    assert_eq!(r["skipped_segments"].as_array().unwrap().len(), 2);
    let written = files(&out);
    assert!(!written.iter().any(|f| f.contains("day-s2")), "{written:?}");
    // the one drive left is still a numbered segment of its recording
    assert!(written
        .iter()
        .any(|f| f.contains("/drive_log/") && f.ends_with("/day-s1.parquet")));
}
