//! Shared by the ingest targets: ingest reads files (format by magic bytes, Parquet footer by
//! seek, MCAP streamed), so each input is written to one per-process scratch file on tmpfs and
//! read back through the same `ingest` the CLI and the batch runner use. A drive that
//! ingests is also resampled to distance and slope-filtered, the first stages every drive meets.

use fleetdyn::ingest::{ingest, IngestOptions};
use fleetdyn::road::slope_filter::{filter_slope, SlopeFilterConfig};
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use std::path::PathBuf;

/// One per-process scratch file with extension `ext` on tmpfs (else the temp folder).
pub fn scratch(ext: &str) -> PathBuf {
    let shm = std::path::Path::new("/dev/shm");
    let dir = if shm.is_dir() {
        shm.to_path_buf()
    } else {
        std::env::temp_dir()
    };
    dir.join(format!("fleetdyn-fuzz-{}.{ext}", std::process::id()))
}

// the MDF4 target shares `scratch` only
#[allow(dead_code)]
pub fn ingest_bytes(data: &[u8], ext: &str) {
    let path = scratch(ext);
    std::fs::write(&path, data).expect("scratch file");
    for stages in [vec![Stage::Ingest], vec![Stage::Slope]] {
        let opts = IngestOptions {
            stages,
            ..Default::default()
        };
        // every drive of the recording (split at pauses)
        let Ok(rec) = ingest(&path, &opts) else {
            continue;
        };
        for ing in &rec.drives {
            let Ok(d) = resample_to_distance(&ing.log, &ResampleConfig::default()) else {
                continue;
            };
            let _ = filter_slope(&d, &SlopeFilterConfig::default());
        }
    }
}
