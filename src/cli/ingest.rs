//! `fleetdyn ingest`.

use super::common::{RecordingArgs, ResampleArgs};
use crate::commands::failure::{usage_msg, Failure};
use crate::commands::{ingest, resample};
use clap::Args;
use fleetdyn::schema::Stage;
use std::path::PathBuf;

/// Read one MCAP or Parquet file (or, with --dbc, the MDF4 files of one raw CAN logging
/// session) into the canonical drive log and print a summary.
#[derive(Args, Debug)]
pub struct IngestCmd {
    /// Input file (MCAP or Parquet; format detected from its magic bytes); with --dbc, the
    /// session's MDF4 files, concatenated in time.
    #[arg(required = true, num_args = 1..)]
    inputs: Vec<PathBuf>,
    /// DBC file(s) decoding raw CAN frames (repeat for several buses / databases).
    #[arg(long)]
    dbc: Vec<PathBuf>,
    /// Output Parquet file (canonical drive log). Without it only the summary is printed.
    #[arg(short, long)]
    output: Option<PathBuf>,
    #[command(flatten)]
    recording: RecordingArgs,
}

impl IngestCmd {
    /// The job: inputs, DBC files, ingest settings.
    pub fn resolve(self) -> Result<ingest::Job, Failure> {
        let (cfg, opts) = self.recording.resolve(&[])?;
        if self.dbc.is_empty() && self.inputs.len() != 1 {
            return Err(usage_msg(format_args!(
                "{} inputs: several files are one raw CAN session and need --dbc",
                self.inputs.len()
            )));
        }
        Ok(ingest::Job {
            inputs: self.inputs,
            dbc: self.dbc,
            output: self.output,
            cfg,
            opts,
        })
    }
}

/// Ingest, then resample the drive to a uniform distance grid.
#[derive(Args, Debug)]
pub struct ResampleCmd {
    /// Input file (MCAP or Parquet).
    input: PathBuf,
    /// Output Parquet file (distance log).
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    recording: RecordingArgs,
    #[command(flatten)]
    resample: ResampleArgs,
}

impl ResampleCmd {
    /// The job: input, ingest and resampling settings.
    pub fn resolve(self) -> Result<resample::Job, Failure> {
        let (cfg, opts) = self.recording.resolve(&[Stage::Resample])?;
        Ok(resample::Job {
            input: self.input,
            output: self.output,
            cfg,
            opts,
            resample: self.resample.config(),
        })
    }
}
