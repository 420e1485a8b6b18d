//! Paths that travel: a pipeline file's relative paths resolve against the file's own folder, so
//! the configuration can live elsewhere (a Kubernetes config map under `/config`, data under
//! `/data`) and the job can start in any working directory.

use crate::batch_pipeline::{deterministic_files, walk};
use crate::common::fixture;
use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
use std::path::Path;
use std::process::Command;

/// Columns that hold the paths a run was given (they differ by where the files are).
const PATH_COLUMNS: [&str; 3] = ["source_file", "vehicle_file", "source"];

/// A stage status without its reason, which may name a path ("skipped: vehicle file … has no
/// [driveline] section").
fn status_word(a: &arrow::array::ArrayRef) -> arrow::array::ArrayRef {
    use arrow::array::{Array, AsArray, StringArray};
    let s = a.as_string::<i32>();
    let words: StringArray = (0..s.len())
        .map(|i| (!s.is_null(i)).then(|| s.value(i).split(':').next().unwrap().to_string()))
        .collect();
    std::sync::Arc::new(words)
}

/// The columns of a Parquet file but the path columns and the stage statuses' reasons, without
/// the schema metadata (which records the input path the drive was read from).
fn data(p: &Path) -> Vec<(String, arrow::array::ArrayRef)> {
    let r = ParquetRecordBatchReaderBuilder::try_new(std::fs::File::open(p).unwrap())
        .unwrap()
        .build()
        .unwrap();
    r.flat_map(|b| {
        let b = b.unwrap();
        let names: Vec<String> = b
            .schema()
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect();
        names
            .into_iter()
            .zip(b.columns().to_vec())
            .filter(|(n, _)| !PATH_COLUMNS.contains(&n.as_str()))
            .map(|(n, a)| {
                let a = if n.ends_with("_status") {
                    status_word(&a)
                } else {
                    a
                };
                (n, a)
            })
            .collect::<Vec<_>>()
    })
    .collect()
}

#[test]
fn a_pipeline_under_another_folder_runs_from_any_working_directory() {
    let dir = tempfile::tempdir().unwrap();
    let (config, data_dir, elsewhere) = (
        dir.path().join("config"),
        dir.path().join("data"),
        dir.path().join("work/elsewhere"),
    );
    for d in [&config.join("vehicles"), &data_dir.join("in"), &elsewhere] {
        std::fs::create_dir_all(d).unwrap();
    }
    // the Kubernetes layout: pipeline and vehicle files under config/, drives under data/in
    for f in std::fs::read_dir(fixture("fixtures/drives")).unwrap() {
        let f = f.unwrap().path();
        if f.is_file() {
            std::fs::copy(&f, data_dir.join("in").join(f.file_name().unwrap())).unwrap();
        }
    }
    for v in ["truck-40t.toml", "seed002-6x2.toml"] {
        std::fs::copy(
            fixture("fixtures/vehicles").join(v),
            config.join("vehicles").join(v),
        )
        .unwrap();
    }
    let nightly = std::fs::read_to_string(fixture("pipelines/nightly.toml"))
        .unwrap()
        .replace("\"../fixtures/drives/", "\"../data/in/")
        .replace("\"../fixtures/vehicles/", "\"vehicles/")
        .replace("\"../out/fleet\"", "\"../data/fleet\"");
    std::fs::write(config.join("nightly.toml"), nightly).unwrap();

    // started two folders away, the pipeline named by a relative path
    let o = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .current_dir(&elsewhere)
        .args(["run", "../../config/nightly.toml", "--jobs", "2"])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let out = data_dir.join("fleet");
    assert!(
        walk(&elsewhere).is_empty(),
        "nothing written where it started"
    );

    // the same dataset as the bundled pipeline run from the repository top
    let reference = dir.path().join("reference");
    let o = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .current_dir(fixture(""))
        .args(["run", "pipelines/nightly.toml", "--jobs", "2", "-o"])
        .arg(&reference)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // the done-markers are named by a hash of the input path, which differs
    let listed = |root: &Path| -> Vec<std::path::PathBuf> {
        deterministic_files(root)
            .into_iter()
            .filter(|f| !f.starts_with("_state"))
            .collect()
    };
    let files = listed(&reference);
    assert!(files.len() > 40, "{}", files.len());
    assert!(listed(&out) == files, "the two runs wrote different files");
    let mut tables = 0;
    for rel in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "parquet") && !f.starts_with("_reports"))
    {
        assert_eq!(data(&out.join(rel)), data(&reference.join(rel)), "{rel:?}");
        tables += 1;
    }
    assert!(tables >= 40, "{tables} tables compared");
}
