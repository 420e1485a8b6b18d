//! Our Parquet as users read it: a nightly dataset read with DuckDB, polars and pyarrow by
//! `fixtures/gen/check_dataset.py` (versions pinned in `fixtures/gen/readers-requirements.txt`):
//! every table folder as one hive-partitioned table with the partition columns and the rows of
//! its files, and every file's `units` entry as DuckDB and polars return it equal to its fields'
//! units. The row counts the script prints are checked here against the files' footers.
//!
//! The Python with those packages comes from `FLEETDYN_PYTHON`; without it the check is skipped
//! with a printed reason, unless `FLEETDYN_REQUIRE_READERS=1` (as `.ci/run` sets after
//! installing them).

use crate::batch_pipeline::walk;
use crate::common::fixture;
use parquet::file::reader::{FileReader, SerializedFileReader};
use std::path::Path;
use std::process::Command;

/// Rows of every Parquet file under `dir`, by the file footers.
fn rows_under(dir: &Path) -> i64 {
    walk(dir)
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "parquet"))
        .map(|p| {
            SerializedFileReader::new(std::fs::File::open(p).unwrap())
                .unwrap()
                .metadata()
                .file_metadata()
                .num_rows()
        })
        .sum()
}

#[test]
fn duckdb_polars_and_pyarrow_read_rows_partitions_and_units() {
    let Ok(python) = std::env::var("FLEETDYN_PYTHON") else {
        let required = std::env::var("FLEETDYN_REQUIRE_READERS").is_ok_and(|v| v == "1");
        assert!(
            !required,
            "FLEETDYN_REQUIRE_READERS=1 and no FLEETDYN_PYTHON"
        );
        eprintln!(
            "readers: FLEETDYN_PYTHON not set (a Python with fixtures/gen/readers-requirements.txt), DuckDB and polars check skipped"
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fleet");
    let o = Command::new(env!("CARGO_BIN_EXE_fleetdyn"))
        .current_dir(fixture(""))
        .args(["run", "pipelines/nightly.toml", "--jobs", "2", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = Command::new(python)
        .arg(fixture("fixtures/gen/check_dataset.py"))
        .arg(&out)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    eprintln!("{text}");
    assert!(
        o.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(text.contains("all tables read as one table in polars, DuckDB and pyarrow"));
    // the script's row counts are the files' own
    let mut tables = 0;
    for line in text.lines().filter(|l| l.trim_end().ends_with(" ok")) {
        let w: Vec<&str> = line.split_whitespace().collect();
        let (table, rows) = (w[0], w[3].parse::<i64>().unwrap());
        assert_eq!(rows, rows_under(&out.join(table)), "{table}");
        tables += 1;
    }
    assert!(tables >= 10, "{tables} tables checked");
}
