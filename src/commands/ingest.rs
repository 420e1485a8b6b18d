//! `fleetdyn ingest`: one recording (or one raw CAN session) into the canonical drive log.

use super::failure::{input, io, usage, Failure};
use fleetdyn::ingest::IngestOptions;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::report::IngestSummary;
use std::path::PathBuf;

/// A resolved `ingest`.
pub struct Job {
    /// One recording, or with `dbc` the MDF4 files of one session.
    pub inputs: Vec<PathBuf>,
    /// DBC files decoding raw CAN frames.
    pub dbc: Vec<PathBuf>,
    /// Output Parquet file; `None`: summary only.
    pub output: Option<PathBuf>,
    /// Ingest settings.
    pub cfg: IngestConfig,
    /// The options they give.
    pub opts: IngestOptions,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let mut fingerprint = job.cfg.fingerprint(&job.opts);
    let ing = if job.dbc.is_empty() {
        ingest_stage::run(&job.inputs[0], &job.opts).map_err(input)?
    } else {
        let texts = job
            .dbc
            .iter()
            .map(std::fs::read)
            .collect::<Result<Vec<_>, _>>()
            .map_err(usage)?;
        let parts: Vec<&[u8]> = texts.iter().map(Vec::as_slice).collect();
        fingerprint.push_str(&format!("\ndbc {}", fleetdyn::io::config_hash(&parts)));
        fleetdyn::ingest::can::ingest_session(&job.inputs, &job.dbc, &job.opts).map_err(input)?
    };
    say_raw!("{}", IngestSummary::new(&ing));
    if let Some(out) = job.output {
        ingest_stage::write(&out, &ing.log, &fingerprint).map_err(io)?;
        say!("wrote     {}", out.display());
    }
    Ok(())
}
