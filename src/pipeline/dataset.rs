//! The output dataset of a pipeline: hive-partitioned tables, done-markers for idempotent
//! re-runs, and the run reports.
//!
//! ```text
//! OUT/<table>/model_version=<M>/vehicle_id=<V>/date=<YYYY-MM-DD>/<drive_id>.parquet
//! OUT/_state/model_version=<M>/<aa>/<key>.json    done-marker of one input (key: hash of its
//!                                                 content hash and its path as listed)
//! OUT/_reports/<pipeline>/model_version=<M>[/shard-<i>-of-<N>]/  run report, fleet tables, plots
//! OUT/_reports/diagnose/model_version=<M>/vehicle_id=<V>/<drive_id>/  a drive's diagnosis report
//! ```
//!
//! Each table folder reads as one table (polars `scan_parquet(hive_partitioning=True)`, DuckDB
//! `read_parquet(..., hive_partitioning = true)`, pyarrow `dataset(partitioning="hive")`, Spark):
//! the partition keys become columns, every file also holds a `drive_id` column. `date` is the
//! UTC date of the drive's first sample. Partition values and file names are escaped like Hive
//! does (`%XX` for anything but letters, digits, `-`, `_` and `.`). Readers skip the `_state` and
//! `_reports` folders and the hidden temporary files of writes in progress (`.name.tmp-…`, which
//! never end in `.parquet`).
//!
//! **Commit protocol.** A drive's tables are each written atomically (temporary name, rename),
//! `drive_summary` last, then the done-marker, also atomically. The marker is the drive's commit:
//! it records the input's content hash, the drive's configuration hash and its outputs. A re-run
//! skips an input (same path, same bytes) whose marker has the same configuration hash and whose
//! outputs all exist; anything else is
//! processed again (deterministic outputs overwrite identical bytes), and files the previous
//! configuration wrote but the new one does not are removed. Temporary files a killed run left
//! are removed before a target is written again.

use super::record::DriveRecord;
use sha2::{Digest, Sha256};
use std::io::Read;
use std::path::{Path, PathBuf};

pub use crate::io::escape;

/// Hex SHA-256 of a file's bytes, streamed.
///
/// # Errors
/// I/O errors reading the file.
pub fn file_sha256(path: &Path) -> std::io::Result<String> {
    let mut f = std::fs::File::open(path)?;
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = f.read(&mut buf)?;
        if n == 0 {
            break;
        }
        h.update(&buf[..n]);
    }
    Ok(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

pub use crate::time_fmt::utc_date;

/// The dataset under one output root, for one model version.
#[derive(Debug, Clone)]
pub struct Dataset {
    /// Output root.
    pub root: PathBuf,
    /// Model version (partition key).
    pub model_version: String,
}

impl Dataset {
    /// Checks, before any drive is read, that files can be created in the output root (creating
    /// the root if needed): a hidden probe file is created and removed. A read-only or
    /// unwritable root then fails the run once, naming the folder, instead of failing every
    /// drive at its write stage. (A full disk is only seen when data is written: those drives
    /// fail at `write`, naming the file, and leave nothing behind.)
    ///
    /// # Errors
    /// The I/O error of creating the root or the probe.
    pub fn check_writable(&self) -> std::io::Result<()> {
        crate::io::AtomicFile::create(&self.root.join(".fleetdyn-write-probe")).map(drop)
    }

    /// Path of a drive's table, relative to the root.
    pub fn table_rel(&self, table: &str, vehicle_id: &str, date: &str, drive_id: &str) -> PathBuf {
        PathBuf::from(table)
            .join(format!("model_version={}", escape(&self.model_version)))
            .join(format!("vehicle_id={}", escape(vehicle_id)))
            .join(format!("date={date}"))
            .join(format!("{}.parquet", escape(drive_id)))
    }

    /// Folder of a drive's diagnosis report (`diagnosis.json`, `report.md`, plots), relative to
    /// the root.
    pub fn diagnosis_rel(&self, vehicle_id: &str, drive_id: &str) -> PathBuf {
        PathBuf::from("_reports")
            .join("diagnose")
            .join(format!("model_version={}", escape(&self.model_version)))
            .join(format!("vehicle_id={}", escape(vehicle_id)))
            .join(escape(drive_id))
    }

    /// Path of the done-marker with key `key` (hex), relative to the root.
    pub fn marker_rel(&self, key: &str) -> PathBuf {
        PathBuf::from("_state")
            .join(format!("model_version={}", escape(&self.model_version)))
            .join(&key[..2])
            .join(format!("{key}.json"))
    }

    /// Folder of a run's report.
    pub fn report_dir(&self, pipeline: &str, shard: Option<(usize, usize)>) -> PathBuf {
        let d = self
            .root
            .join("_reports")
            .join(escape(pipeline))
            .join(format!("model_version={}", escape(&self.model_version)));
        match shard {
            Some((i, n)) => d.join(format!("shard-{i}-of-{n}")),
            None => d,
        }
    }

    /// The marker with key `key`, if present and readable.
    pub fn read_marker(&self, key: &str) -> Option<DriveRecord> {
        let text = std::fs::read(self.root.join(self.marker_rel(key))).ok()?;
        serde_json::from_slice(&text).ok()
    }
}

/// Removes temporary files of earlier, interrupted writes of `target` (`.name.tmp-*` beside
/// it). Only called for targets this process owns (its shard's drives), so no live writer of
/// another process is disturbed.
pub fn sweep_temps(target: &Path) {
    let (Some(dir), Some(name)) = (target.parent(), target.file_name()) else {
        return;
    };
    let prefix = format!(".{}.tmp-", name.to_string_lossy());
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        if e.file_name().to_string_lossy().starts_with(&prefix) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_are_utc_calendar_days() {
        assert_eq!(utc_date(0), "1970-01-01");
        // 2026-03-02T23:59:59.999Z and one ms later
        let t = 1_772_495_999_999_000_000;
        assert_eq!(utc_date(t), "2026-03-02");
        assert_eq!(utc_date(t + 1_000_000), "2026-03-03");
        assert_eq!(utc_date(951_782_400_000_000_000), "2000-02-29");
        assert_eq!(utc_date(-1), "1969-12-31");
    }

    #[test]
    fn escaping_keeps_safe_names_and_hides_nothing() {
        assert_eq!(escape("TRK-0001"), "TRK-0001");
        assert_eq!(escape("a/b=c"), "a%2Fb%3Dc");
        assert_eq!(escape(".hidden"), "%2Ehidden");
        assert_eq!(escape(""), "%00");
    }
}
