//! Batch pipelines: plan validation, failure isolation, determinism across thread counts, sharding
//! into separate processes, resume after `kill -9`, idempotent re-runs and side-by-side model
//! versions. Every run goes through the real binary.

use crate::common::*;
use fleetdyn::model::catalogue::Effect;
use fleetdyn::pipeline::spec::PipelineSpec;
use parquet::file::reader::{FileReader, SerializedFileReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fleetdyn(args: &[&str], extra: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .current_dir(fixture(""))
        .args(args)
        .args(extra)
        .output()
        .unwrap()
}

pub fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut v = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else {
        return v;
    };
    for e in rd {
        let p = e.unwrap().path();
        if p.is_dir() {
            v.extend(walk(&p));
        } else {
            v.push(p);
        }
    }
    v.sort();
    v
}

/// Files of a run that are a function of inputs and configuration only (everything but the
/// two report files holding wall-clock times), relative to the root.
pub fn deterministic_files(root: &Path) -> Vec<PathBuf> {
    walk(root)
        .into_iter()
        .map(|p| p.strip_prefix(root).unwrap().to_path_buf())
        .filter(|p| {
            let n = p.file_name().unwrap().to_string_lossy();
            n != "run_report.json" && n != "summary.md"
        })
        .collect()
}

pub fn assert_same_bytes(a: &Path, b: &Path, files: &[PathBuf]) {
    for rel in files {
        let (x, y) = (a.join(rel), b.join(rel));
        assert!(y.is_file(), "{rel:?} missing in {}", b.display());
        assert!(
            std::fs::read(&x).unwrap() == std::fs::read(&y).unwrap(),
            "{rel:?} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

pub fn report(root: &Path, pipeline: &str, model: &str) -> serde_json::Value {
    let p = root
        .join("_reports")
        .join(pipeline)
        .join(format!("model_version={model}"))
        .join("run_report.json");
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

fn run_ok(args: &[&str], out: &Path) -> Output {
    let o = fleetdyn(args, &[Path::new("--out"), out]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn kv(path: &Path) -> std::collections::HashMap<String, String> {
    parquet_kv(path)
}

#[test]
fn nightly_runs_every_fixture_with_skips_recorded_and_partitioned_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = run_ok(&["run", "pipelines/nightly.toml", "--jobs", "2"], &out);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("summary.md"), "{stdout}");
    let r = report(&out, "nightly", "2026.1");
    assert_eq!((r["ok"].as_u64(), r["failed"].as_u64()), (Some(5), Some(0)));
    let drives = r["drives"].as_array().unwrap();
    let stages = |id: &str| {
        drives.iter().find(|d| d["drive_id"] == id).unwrap()["record"]["stages"]
            .as_array()
            .unwrap()
            .clone()
    };
    // the 40 t tractors: no [axles]; the 6x2: no [driveline]. Skipped with the reason, not failed.
    let ax = stages("truck-0001");
    let axle = ax.iter().find(|s| s["stage"] == "axle").unwrap();
    assert_eq!(axle["status"], "skipped");
    assert!(axle["reason"].as_str().unwrap().contains("[axles]"));
    let sh = stages("truck-0005-axle");
    let shuffle = sh.iter().find(|s| s["stage"] == "shuffle").unwrap();
    assert!(shuffle["reason"].as_str().unwrap().contains("[driveline]"));
    assert!(sh
        .iter()
        .any(|s| s["stage"] == "axle" && s["status"] == "ran"));
    // drive id in the file name and in the metadata; hive partitions
    let p = out.join(
        "shuffle_validation/model_version=2026.1/vehicle_id=TRK-0001/date=2026-03-02/truck-0001.parquet",
    );
    let m = kv(&p);
    assert_eq!(m["drive_id"], "truck-0001");
    assert_eq!(m["table"], "validation");
    // every column's unit in the file-level metadata too, as JSON in column order
    let dl = kv(&out.join(
        "drive_log/model_version=2026.1/vehicle_id=TRK-0001/date=2026-03-02/truck-0001.parquet",
    ));
    let units: serde_json::Value = serde_json::from_str(&dl["units"]).unwrap();
    assert_eq!(units["timestamp"], "ns");
    assert_eq!(units["vehicle_speed"], "m/s");
    assert_eq!(units["engine_torque"], "N*m");
    assert!(
        dl["units"].starts_with("{\"timestamp\":\"ns\""),
        "{}",
        dl["units"]
    );
    assert!(out
        .join("axle_validation/model_version=2026.1/vehicle_id=SEED002-6X2/date=2026-05-12/truck-0005-axle.parquet")
        .is_file());
    let rep = out.join("_reports/nightly/model_version=2026.1");
    for f in [
        "drive_validation.parquet",
        "fleet_validation.parquet",
        "summary.md",
        "shuffle_energy.svg",
        "slope_shuffle_by_gear.svg",
        "error_metrics.svg",
    ] {
        assert!(rep.join(f).is_file(), "{f}");
    }
    // per gear, the shuffle the slope filter removes (raw-slope minus filtered-slope run) beside
    // all shuffle with the raw slope, on every drive the shuffle stage ran on
    let t1 = r["drives"]
        .as_array()
        .unwrap()
        .iter()
        .find(|d| d["drive_id"] == "truck-0001")
        .unwrap();
    let by_gear = t1["record"]["metrics"]["slope_shuffle_by_gear"]
        .as_array()
        .unwrap();
    assert!(by_gear.len() >= 3, "{by_gear:?}");
    let gears: Vec<i64> = by_gear
        .iter()
        .map(|g| g["gear"].as_i64().unwrap())
        .collect();
    assert!(gears.windows(2).all(|w| w[0] < w[1]) && gears[0] >= 1);
    for g in by_gear {
        let removed = g["ms_slope_m2_per_s2"].as_f64().unwrap();
        let total = g["ms_total_m2_per_s2"].as_f64().unwrap();
        assert!(g["samples"].as_u64().unwrap() > 0);
        assert!(removed > 0.0 && total > 0.0 && removed.is_finite(), "{g}");
    }
    // the diagnose stage: each 40 t drive's mismatches, findings and parameter estimates in the
    // dataset with its verdict, and its report folder; the 6x2 (no [driveline], no model the
    // recording can drive) skipped with the reason
    for (n, date) in [(1, "03-02"), (2, "03-02"), (3, "03-03"), (4, "03-03")] {
        let part = format!(
            "model_version=2026.1/vehicle_id=TRK-000{n}/date=2026-{date}/truck-000{n}.parquet"
        );
        let folder = out.join(format!(
            "_reports/diagnose/model_version=2026.1/vehicle_id=TRK-000{n}/truck-000{n}"
        ));
        let j: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(folder.join("diagnosis.json")).unwrap())
                .unwrap();
        for t in ["mismatch", "findings", "parameter_estimates"] {
            let m = kv(&out.join(t).join(&part));
            assert_eq!(m["table"], t);
            assert_eq!(
                m["verdict"],
                j["verdict"].as_str().unwrap(),
                "{t} of truck-000{n}"
            );
        }
        assert!(folder.join("report.md").is_file());
        let d = stages(&format!("truck-000{n}"));
        assert!(d
            .iter()
            .any(|s| s["stage"] == "diagnose" && s["status"] == "ran"));
    }
    // the fleet stage: one row per diagnosed vehicle, the page, one drive each (too few to judge)
    let fleet = rep.join("fleet");
    let rows = |t: &str| {
        SerializedFileReader::new(std::fs::File::open(fleet.join(t)).unwrap())
            .unwrap()
            .metadata()
            .file_metadata()
            .num_rows()
    };
    assert_eq!(rows("fleet_vehicles.parquet"), 4);
    // a vehicle's persistent parameters are those its drive informs: an estimate with an
    // interval of some width (a linearised estimate the data push beyond its fit domain has
    // one of none, at the domain's end), not a per-trip mass and not a switch
    let pooled = {
        let f = std::fs::File::open(fleet.join("fleet_parameters.parquet")).unwrap();
        let r = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(f)
            .unwrap()
            .build()
            .unwrap();
        let mut v: Vec<(String, String)> = Vec::new();
        for b in r {
            let b = b.unwrap();
            let col = |name: &str| {
                arrow::compute::cast(
                    b.column_by_name(name).unwrap(),
                    &arrow::datatypes::DataType::Utf8,
                )
                .unwrap()
            };
            let (ids, ps) = (col("vehicle_id"), col("parameter"));
            let (ids, ps) = (
                ids.as_any()
                    .downcast_ref::<arrow::array::StringArray>()
                    .unwrap(),
                ps.as_any()
                    .downcast_ref::<arrow::array::StringArray>()
                    .unwrap(),
            );
            for i in 0..b.num_rows() {
                v.push((ids.value(i).to_string(), ps.value(i).to_string()));
            }
        }
        v
    };
    for (n, date) in [(1, "03-02"), (2, "03-02"), (3, "03-03"), (4, "03-03")] {
        let (est, _) = fleetdyn::fleet::series::read_parameter_estimates(&out.join(format!(
            "parameter_estimates/model_version=2026.1/vehicle_id=TRK-000{n}/date=2026-{date}/truck-000{n}.parquet"
        )))
        .unwrap();
        let mut informed: Vec<String> = est
            .iter()
            .filter(|r| {
                !["vehicle_mass", "cg_position", "slope_quantization"].contains(&r.effect.as_str())
                    && r.value.is_finite()
                    && r.ci_high > r.ci_low
            })
            .map(|r| Effect::from_id(&r.effect).unwrap().parameter().to_string())
            .collect();
        let mut got: Vec<String> = pooled
            .iter()
            .filter(|(id, _)| *id == format!("TRK-000{n}"))
            .map(|(_, p)| p.clone())
            .collect();
        informed.sort();
        got.sort();
        assert!(informed.len() >= 6, "TRK-000{n}: {informed:?}");
        assert_eq!(got, informed, "TRK-000{n}");
    }
    assert_eq!(rows("fleet_changes.parquet"), 0);
    // each 40 t drive informs its trip's mass: one row per drive, never pooled
    assert_eq!(rows("fleet_trips.parquet"), 4);
    let html = std::fs::read_to_string(fleet.join("fleet.html")).unwrap();
    assert!(html.contains("TRK-0004") && !html.contains("SEED002-6X2"));
    assert!(
        !fleet.join("suggested").exists(),
        "a suggestion from one drive"
    );
    assert_eq!(r["fleet"]["vehicles"].as_u64(), Some(4));
    let diag = sh.iter().find(|s| s["stage"] == "diagnose").unwrap();
    assert_eq!(diag["status"], "skipped");
    assert!(diag["reason"]
        .as_str()
        .unwrap()
        .contains("nothing to diagnose"));
    let md = std::fs::read_to_string(rep.join("summary.md")).unwrap();
    for needle in [
        "Slowest drives",
        "Failures (0)",
        "vehicle_speed_rmse",
        "shuffle_energy.svg",
        "## Shuffle the slope filter removes, per gear",
        "slope_shuffle_by_gear.svg",
    ] {
        assert!(md.contains(needle), "{needle} not in summary.md");
    }
    // no temporary file anywhere
    assert!(walk(&out)
        .iter()
        .all(|p| !p.to_string_lossy().contains(".tmp-")));

    // an immediate re-run reuses every drive and rewrites nothing of the dataset
    let before: Vec<_> = deterministic_files(&out)
        .into_iter()
        .map(|p| {
            (
                std::fs::metadata(out.join(&p)).unwrap().modified().unwrap(),
                p,
            )
        })
        .collect();
    run_ok(&["run", "pipelines/nightly.toml"], &out);
    let r = report(&out, "nightly", "2026.1");
    assert_eq!((r["ok"].as_u64(), r["reused"].as_u64()), (Some(0), Some(5)));
    for (t, p) in before.iter().filter(|(_, p)| !p.starts_with("_reports")) {
        assert_eq!(
            std::fs::metadata(out.join(p)).unwrap().modified().unwrap(),
            *t,
            "{p:?} rewritten"
        );
    }
    // --force recomputes, to the same bytes
    let copy = dir.path().join("copy");
    std::fs::create_dir(&copy).unwrap();
    for p in deterministic_files(&out) {
        std::fs::create_dir_all(copy.join(&p).parent().unwrap()).unwrap();
        std::fs::copy(out.join(&p), copy.join(&p)).unwrap();
    }
    run_ok(&["run", "pipelines/nightly.toml", "--force"], &out);
    assert_eq!(report(&out, "nightly", "2026.1")["ok"].as_u64(), Some(5));
    assert_same_bytes(&copy, &out, &deterministic_files(&copy));
}

#[test]
fn same_bytes_for_one_and_three_jobs() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    run_ok(&["run", "pipelines/nightly.toml", "--jobs", "1"], &a);
    run_ok(&["run", "pipelines/nightly.toml", "--jobs", "3"], &b);
    let files = deterministic_files(&a);
    assert!(files.len() > 40, "{}", files.len());
    assert_eq!(files, deterministic_files(&b));
    assert_same_bytes(&a, &b, &files);
}

#[test]
fn shards_in_separate_processes_union_to_the_unsharded_run() {
    let dir = tempfile::tempdir().unwrap();
    let (whole, sharded) = (dir.path().join("whole"), dir.path().join("sharded"));
    run_ok(&["run", "pipelines/nightly.toml"], &whole);
    // three processes at once into one output root, as a Kubernetes Indexed Job would
    let children: Vec<_> = (0..3)
        .map(|i| {
            Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
                .current_dir(fixture(""))
                .args(["run", "pipelines/nightly.toml", "--jobs", "1", "--shard"])
                .arg(format!("{i}/3"))
                .arg("--out")
                .arg(&sharded)
                .output()
                .unwrap()
        })
        .collect();
    let mut per_shard = Vec::new();
    for (i, c) in children.iter().enumerate() {
        assert_eq!(
            c.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&c.stderr)
        );
        let p = sharded.join(format!(
            "_reports/nightly/model_version=2026.1/shard-{i}-of-3/run_report.json"
        ));
        let r: serde_json::Value = serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
        per_shard.push(r["drives"].as_array().unwrap().len());
    }
    assert_eq!(per_shard.iter().sum::<usize>(), 5, "{per_shard:?}");
    // the dataset and the done-markers: the same files, the same bytes
    let data: Vec<PathBuf> = deterministic_files(&whole)
        .into_iter()
        .filter(|p| !p.starts_with("_reports"))
        .collect();
    let data_sharded: Vec<PathBuf> = deterministic_files(&sharded)
        .into_iter()
        .filter(|p| !p.starts_with("_reports"))
        .collect();
    assert_eq!(data, data_sharded);
    assert_same_bytes(&whole, &sharded, &data);
    // the reduce step: an unsharded run reuses every drive and writes the fleet report, whose
    // tables equal the unsharded run's
    run_ok(&["run", "pipelines/nightly.toml"], &sharded);
    assert_eq!(
        report(&sharded, "nightly", "2026.1")["reused"].as_u64(),
        Some(5)
    );
    let rep = PathBuf::from("_reports/nightly/model_version=2026.1");
    let tables: Vec<PathBuf> = deterministic_files(&whole)
        .into_iter()
        .filter(|p| p.starts_with(&rep))
        .collect();
    assert!(tables.len() >= 4, "{tables:?}");
    assert_same_bytes(&whole, &sharded, &tables);
}

/// `n` canonical drives of `rows` samples at 10 Hz, each with its own slope profile, and a
/// manifest naming their vehicles.
pub fn synthetic_fleet(dir: &Path, n: usize, rows: usize) -> PathBuf {
    let inputs = dir.join("in");
    std::fs::create_dir_all(&inputs).unwrap();
    let mut manifest = String::from("path,vehicle_id\n");
    for k in 0..n {
        let mut d = Drive::new(rows);
        for (i, s) in d.slope.iter_mut().enumerate() {
            *s = Some(0.01 * (((i / (200 + 37 * k)) % 5) as f64 - 2.0));
        }
        let name = format!("drive-{k:02}.parquet");
        d.write(&inputs.join(&name));
        manifest.push_str(&format!("in/{name},TRK-{}\n", k % 3));
    }
    let m = dir.join("drives.csv");
    std::fs::write(&m, manifest).unwrap();
    m
}

/// Done-markers (committed drives) under an output root.
pub fn markers(root: &Path) -> usize {
    walk(&root.join("_state"))
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .count()
}

/// What a reader of the output root may see: only whole Parquet files, and no temporary file
/// under a visible name (temporaries are hidden names that do not end in .parquet).
pub fn assert_only_whole_files(root: &Path) {
    for f in walk(root) {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        if name.ends_with(".parquet") {
            SerializedFileReader::new(std::fs::File::open(&f).unwrap())
                .unwrap_or_else(|e| panic!("{f:?} is visible but not whole: {e}"));
        } else if name.contains(".tmp-") {
            assert!(name.starts_with('.'), "visible temporary {f:?}");
        }
    }
}

/// `pipelines/nightly.toml` moved to another folder: its paths (relative to its own folder)
/// made absolute, so that the copy reads the same fixtures.
pub fn nightly_elsewhere() -> String {
    let text = std::fs::read_to_string(fixture("pipelines/nightly.toml")).unwrap();
    text.replace("\"../", &format!("\"{}/", fixture("").display()))
}

/// `pipelines/nightly.toml` with a default vehicle file (`truck-40t.toml`), written to
/// `dir/name`: drives without a vehicle id then reach their own stages.
pub fn nightly_with_default_vehicle(dir: &Path, name: &str) -> PathBuf {
    let p = dir.join(name);
    let vehicle = fixture("fixtures/vehicles/truck-40t.toml");
    std::fs::write(
        &p,
        nightly_elsewhere().replace(
            "[vehicles]",
            &format!("vehicle = {:?}\n[vehicles]", vehicle.display().to_string()),
        ),
    )
    .unwrap();
    p
}

pub fn fleet_pipeline(dir: &Path, manifest: &Path) -> PathBuf {
    let p = dir.join("fleet.toml");
    std::fs::write(
        &p,
        format!(
            "name = \"fleet\"\nmodel_version = \"t1\"\nstages = [\"ingest\", \"resample\", \"slope\", \"shuffle\", \"spectrum\", \"validate\", \"write\"]\ninputs = [{:?}]\noutput_dir = \"unused\"\nvehicle = {:?}\n[spectrum]\nsegment_length_m = 1024.0\n",
            manifest.display().to_string(),
            fixture("fixtures/vehicles/truck-40t.toml").display().to_string()
        ),
    )
    .unwrap();
    p
}

#[test]
fn a_killed_run_resumes_to_the_bytes_of_a_clean_run() {
    let dir = tempfile::tempdir().unwrap();
    let manifest = synthetic_fleet(dir.path(), 16, 20_000);
    let pipeline = fleet_pipeline(dir.path(), &manifest);
    let (clean, killed) = (dir.path().join("clean"), dir.path().join("killed"));
    let p = pipeline.to_str().unwrap();
    run_ok(&["run", p, "--jobs", "1"], &clean);
    assert_eq!(report(&clean, "fleet", "t1")["ok"].as_u64(), Some(16));

    let mut child = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .current_dir(fixture(""))
        .args(["run", p, "--jobs", "1", "--out"])
        .arg(&killed)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // wait for the first finished drive, then kill -9 mid-run
    loop {
        if markers(&killed) >= 1 || child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let done = markers(&killed);
    assert!(done < 16, "the run finished before it could be killed");
    // what a reader sees meanwhile: only whole Parquet files
    assert_only_whole_files(&killed);
    let o = run_ok(&["run", p, "--jobs", "2"], &killed);
    let r = report(&killed, "fleet", "t1");
    assert_eq!(
        r["reused"].as_u64(),
        Some(done as u64),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert_eq!(r["ok"].as_u64(), Some(16 - done as u64));
    let files = deterministic_files(&clean);
    assert_eq!(files, deterministic_files(&killed), "no file more or less");
    assert_same_bytes(&clean, &killed, &files);
    assert!(walk(&killed)
        .iter()
        .all(|p| !p.to_string_lossy().contains(".tmp-")));
}

#[test]
fn a_corrupt_drive_fails_alone_with_its_stage_and_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let inputs = dir.path().join("in");
    std::fs::create_dir_all(inputs.join("sub")).unwrap();
    std::fs::copy(
        fixture("fixtures/drives/truck-0001.mcap"),
        inputs.join("truck-0001.mcap"),
    )
    .unwrap();
    let bytes = std::fs::read(fixture("fixtures/drives/truck-0002-lz4.mcap")).unwrap();
    std::fs::write(
        inputs.join("sub/truck-0002-cut.mcap"),
        &bytes[..bytes.len() / 2],
    )
    .unwrap();
    let mut d = Drive::new(600);
    d.speed = vec![Some(0.0); 600];
    d.write(&inputs.join("sub/parked.parquet"));
    let out = dir.path().join("out");
    let o = fleetdyn(
        &["run", "pipelines/nightly.toml", "--input"],
        &[&inputs, Path::new("--out"), &out],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{stdout}");
    assert!(stdout.contains("FAILED"), "{stdout}");
    let r = report(&out, "nightly", "2026.1");
    assert_eq!((r["ok"].as_u64(), r["failed"].as_u64()), (Some(1), Some(2)));
    let drives = r["drives"].as_array().unwrap();
    let by = |id: &str| drives.iter().find(|d| d["drive_id"] == id).unwrap().clone();
    assert_eq!(by("truck-0002-cut")["failed_stage"], "ingest");
    // the parked drive has no vehicle id, and nightly has no default vehicle file
    assert_eq!(by("parked")["failed_stage"], "ingest");
    assert!(by("parked")["error"]
        .as_str()
        .unwrap()
        .contains("names no vehicle_id and the pipeline has no default vehicle file"));
    // failed drives leave no output; the good one has all of its tables
    let files: Vec<String> = walk(&out)
        .iter()
        .map(|p| p.strip_prefix(&out).unwrap().display().to_string())
        .collect();
    assert!(files
        .iter()
        .all(|f| !f.contains("parked") && !f.contains("truck-0002")));
    assert_eq!(
        files
            .iter()
            .filter(|f| f.ends_with("truck-0001.parquet"))
            .count(),
        10,
        "{files:?}"
    );
    // the per-drive report table has every input, failures included
    let rep = out.join("_reports/nightly/model_version=2026.1/drive_validation.parquet");
    let rd = SerializedFileReader::new(std::fs::File::open(rep).unwrap()).unwrap();
    assert_eq!(rd.metadata().file_metadata().num_rows(), 3);
    let md = std::fs::read_to_string(out.join("_reports/nightly/model_version=2026.1/summary.md"))
        .unwrap();
    assert!(md.contains("Failures (2)"), "{md}");

    // with a default vehicle file the parked drive gets to resample, and fails there
    let p = nightly_with_default_vehicle(dir.path(), "with-default.toml");
    let o = fleetdyn(
        &["run", p.to_str().unwrap(), "--input"],
        &[&inputs.join("sub/parked.parquet"), Path::new("--out"), &out],
    );
    assert_eq!(o.status.code(), Some(1));
    let r = report(&out, "nightly", "2026.1");
    assert_eq!(r["drives"][0]["failed_stage"], "resample");
}

#[test]
fn every_plan_problem_is_reported_before_any_drive_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("m.csv");
    std::fs::write(
        &m,
        format!(
            "{},TRK-NOBODY\n",
            fixture("fixtures/drives/truck-0001.mcap").display()
        ),
    )
    .unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(
        &p,
        format!(
            r#"name = "x"
stages = ["ingest", "slope", "shuffle", "teleport", "write"]
inputs = ["/nonexistent/*.mcap", {m:?}]
output_dir = "o"
vehicle_dir = "/nonexistent/vehicles"
[vehicles]
"TRK-0001" = {v:?}
[slope]
cutoff_per_m = 0.7
[axle]
missing = "skip"
[shuffle]
window_s = 0.001
[write]
tables = ["axle_sim"]
"#,
            m = m.display().to_string(),
            v = fixture("fixtures/vehicles/seed002-6x2.toml")
                .display()
                .to_string()
        ),
    )
    .unwrap();
    let o = fleetdyn(&["run"], &[&p]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    for needle in [
        "teleport",
        "slope needs resample",
        "/nonexistent/vehicles",
        "/nonexistent/*.mcap",
        "[axle] configures stage axle",
        "no vehicle file has a [driveline] section",
        "shuffle.window_s",
        "write.tables: axle_sim",
        "TRK-NOBODY",
        "cutoff_per_m",
    ] {
        assert!(e.contains(needle), "{needle} missing from:\n{e}");
    }
    // unknown keys, at any level
    for text in [
        "name = \"x\"\nstages = [\"ingest\", \"write\"]\ninputs = []\noutput_dir = \"o\"\nspeed_limit = 3\n",
        "name = \"x\"\nstages = [\"ingest\", \"shuffle\", \"write\"]\ninputs = []\noutput_dir = \"o\"\n[shuffle]\nwindow = 3\n",
    ] {
        std::fs::write(&p, text).unwrap();
        let o = fleetdyn(&["run"], &[&p]);
        assert_eq!(o.status.code(), Some(2));
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(e.contains("unknown field"), "{e}");
    }
    // the library's plan holds every problem as a list
    std::fs::write(
        &p,
        "name = \"x\"\nstages = [\"write\", \"ingest\"]\ninputs = [\"/nonexistent\"]\noutput_dir = \"o\"\nmax_drives_in_flight = 0\n",
    )
    .unwrap();
    let err = PipelineSpec::load(&p)
        .unwrap()
        .plan("bad.toml", None)
        .unwrap_err();
    assert!(err.problems.len() >= 4, "{:?}", err.problems);
    // bad flags
    let o = fleetdyn(&["run", "pipelines/nightly.toml", "--shard", "3/3"], &[]);
    assert_eq!(o.status.code(), Some(2));
    let o = fleetdyn(&["run", "pipelines/nightly.toml", "--jobs", "0"], &[]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn model_versions_sit_side_by_side_and_the_spectrum_study_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fleet");
    run_ok(&["run", "pipelines/nightly.toml"], &out);
    run_ok(&["run", "pipelines/reprocess.toml"], &out);
    for v in ["2026.1", "2026.2"] {
        let d = out.join(format!("drive_summary/model_version={v}/vehicle_id=TRK-0003/date=2026-03-03/truck-0003.parquet"));
        assert!(d.is_file(), "{d:?}");
    }
    let r = report(&out, "reprocess", "2026.2");
    assert_eq!(r["ok"].as_u64(), Some(5));
    // a different model version: new results, not a reuse of the old ones
    assert_ne!(
        std::fs::read(out.join("drive_summary/model_version=2026.1/vehicle_id=TRK-0003/date=2026-03-03/truck-0003.parquet")).unwrap(),
        std::fs::read(out.join("drive_summary/model_version=2026.2/vehicle_id=TRK-0003/date=2026-03-03/truck-0003.parquet")).unwrap()
    );
    let study = dir.path().join("study");
    run_ok(&["run", "pipelines/road-spectrum-study.toml"], &study);
    let rep = study.join("_reports/road-spectrum-study/model_version=1");
    assert!(rep.join("fleet_spectrum.svg").is_file());
    let m = kv(&rep.join("fleet_spectrum.parquet"));
    assert_eq!(m["drives"], "5");
    let k90: f64 = m["knee_90_of_mean_per_m"].parse().unwrap();
    assert!(k90 > 0.0 && k90 < 0.5, "{k90}");
}
