//! `fleetdyn run`.

use super::common::jobs;
use crate::commands::failure::{usage, usage_msg, Failure};
use crate::commands::run;
use clap::Args;
use fleetdyn::pipeline::run::Shard;
use fleetdyn::pipeline::spec::PipelineSpec;
use std::path::PathBuf;

/// Run a pipeline file (pipelines/*.toml) over its inputs, in parallel, into a hive-partitioned
/// dataset with a run report; drives already done with the same input and configuration are
/// reused. Exit 1 if any drive failed.
#[derive(Args, Debug)]
pub struct RunCmd {
    /// Pipeline file.
    pipeline: PathBuf,
    /// Inputs instead of the pipeline's: files, folders (recursive), `*` globs, manifest files
    /// (`path,vehicle_id` per line). Repeatable.
    #[arg(long)]
    input: Vec<PathBuf>,
    /// Output root instead of the pipeline's output_dir.
    #[arg(short, long, alias = "out")]
    output: Option<PathBuf>,
    /// Worker threads (default: all cores); outputs are the same bytes for any number.
    #[arg(long)]
    jobs: Option<usize>,
    /// Process only shard I of N (0-based, e.g. 2/8): inputs split by a hash of their path.
    #[arg(long)]
    shard: Option<String>,
    /// Recompute drives whose outputs are up to date.
    #[arg(long)]
    force: bool,
}

impl RunCmd {
    /// The job: the planned pipeline and how to run it. Plan errors (every problem listed) are
    /// usage errors.
    pub fn resolve(self) -> Result<run::Job, Failure> {
        let shard = self
            .shard
            .map(|s| Shard::parse(&s))
            .transpose()
            .map_err(usage_msg)?;
        let jobs = jobs(self.jobs)?;
        let spec = PipelineSpec::load(&self.pipeline).map_err(usage)?;
        let inputs = (!self.input.is_empty()).then_some(self.input.as_slice());
        let plan = spec
            .plan(&self.pipeline.display().to_string(), inputs)
            .map_err(usage)?;
        Ok(run::Job {
            out_root: self.output.unwrap_or_else(|| plan.spec.output_dir.clone()),
            plan,
            jobs,
            shard,
            force: self.force,
        })
    }
}
