//! `fleetdyn resample`: a recording on a uniform distance grid.

use super::failure::{input, io, Failure};
use fleetdyn::ingest::IngestOptions;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::pipeline::resample_stage;
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use std::path::PathBuf;

/// A resolved `resample`.
pub struct Job {
    /// Recording.
    pub input: PathBuf,
    /// Output Parquet file (distance log).
    pub output: PathBuf,
    /// Ingest settings.
    pub cfg: IngestConfig,
    /// The options they give.
    pub opts: IngestOptions,
    /// The distance grid.
    pub resample: ResampleConfig,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let ing = ingest_stage::run(&job.input, &job.opts).map_err(input)?;
    let d = resample_to_distance(&ing.log, &job.resample).map_err(input)?;
    let fp = format!(
        "{}\n{}",
        job.cfg.fingerprint(&job.opts),
        resample_stage::fingerprint(&job.resample)
    );
    resample_stage::write(&job.output, &d, &fp).map_err(io)?;
    say!(
        "{}: {:.3} km on a {} m grid ({} points, distance from {}, {} samples collapsed) -> {}",
        d.meta.drive_id,
        d.map.total_m() / 1000.0,
        d.step_m,
        d.distance_m.len(),
        d.map.source.name(),
        d.collapsed_samples,
        job.output.display()
    );
    Ok(())
}
