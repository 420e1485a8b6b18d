//! `fleetdyn prove`: the diagnosis proof over synthetic drives with concealed effects.

use super::failure::{io, model, usage, Failure};
use super::progress::Progress;
use fleetdyn::proof::{run_proof, ProofConfig, ProveError};
use std::path::PathBuf;

/// A resolved `prove`.
pub struct Job {
    /// The plan.
    pub cfg: ProofConfig,
    /// Nominal vehicle file.
    pub vehicle: PathBuf,
    /// Output folder.
    pub output: PathBuf,
    /// Worker threads.
    pub jobs: usize,
}

fn category(e: ProveError) -> Failure {
    match e {
        ProveError::Vehicle(_) => usage(e),
        ProveError::Pool(_) => model(e),
        ProveError::Io { .. } | ProveError::Output(_) => io(e),
    }
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let t0 = std::time::Instant::now();
    let planned = if job.cfg.only.is_empty() {
        job.cfg.drives
    } else {
        job.cfg.only.len()
    };
    let bar = Progress::bar(planned as u64, "drives");
    let progress = |done: usize, total: usize| {
        if bar.is_drawn() {
            bar.set_position(done as u64);
        } else {
            eprintln!(
                "prove: {done}/{total} drives ({:.0} s)",
                t0.elapsed().as_secs_f64()
            );
        }
    };
    let run =
        run_proof(&job.cfg, &job.vehicle, &job.output, job.jobs, &progress).map_err(category)?;
    drop(bar);
    say!("{}", run.summary.to_markdown());
    for f in &run.failed {
        say!(
            "case {} ({}) failed at {}: {}",
            f.index,
            f.hidden,
            f.stage,
            f.error
        );
    }
    say!(
        "wrote     {} ({} drives, {} jobs, {:.0} s)",
        job.output.join("proof.md").display(),
        run.summary.drives,
        job.jobs,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
