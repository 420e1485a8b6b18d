//! `fleetdyn prove`: the diagnosis proof over synthetic drives with concealed effects.

use super::failure::{io, model, usage, Failure};
use super::progress::Progress;
use fleetdyn::proof::{
    rescore_fleet_proof, run_fleet_proof, run_proof, FleetProofConfig, FleetProofRun, ProofConfig,
    ProveError,
};
use std::path::{Path, PathBuf};

/// A resolved `prove`.
pub enum Job {
    /// The per-drive proof.
    Cases {
        /// The plan.
        cfg: ProofConfig,
        /// Nominal vehicle file.
        vehicle: PathBuf,
        /// Output folder.
        output: PathBuf,
        /// Worker threads.
        jobs: usize,
    },
    /// A saved fleet proof scored again (`--fleet --rescore`).
    Rescore {
        /// The saved proof's folder.
        saved: PathBuf,
        /// Output folder.
        output: PathBuf,
    },
    /// The fleet proof (`--fleet`).
    Fleet {
        /// The plan.
        cfg: FleetProofConfig,
        /// Nominal vehicle file.
        vehicle: PathBuf,
        /// Output folder.
        output: PathBuf,
        /// Worker threads.
        jobs: usize,
    },
}

fn category(e: ProveError) -> Failure {
    match e {
        ProveError::Vehicle(_) | ProveError::Saved { .. } => usage(e),
        ProveError::Pool(_) => model(e),
        ProveError::Io { .. } | ProveError::Output(_) => io(e),
    }
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    match job {
        Job::Cases {
            cfg,
            vehicle,
            output,
            jobs,
        } => run_cases(&cfg, &vehicle, &output, jobs),
        Job::Fleet {
            cfg,
            vehicle,
            output,
            jobs,
        } => run_fleet(&cfg, &vehicle, &output, jobs),
        Job::Rescore { saved, output } => {
            let run = rescore_fleet_proof(&saved, &output).map_err(category)?;
            say_fleet(&run, &output);
            Ok(())
        }
    }
}

/// Prints a fleet proof's summary and where it was written.
fn say_fleet(run: &FleetProofRun, output: &Path) {
    say!("{}", run.to_markdown());
    say!(
        "wrote     {} and {}",
        output.join("fleet_proof.md").display(),
        output.join("fleet").join("fleet.html").display()
    );
}

fn run_fleet(
    cfg: &FleetProofConfig,
    vehicle: &Path,
    output: &Path,
    jobs: usize,
) -> Result<(), Failure> {
    let t0 = std::time::Instant::now();
    let total = cfg.trucks * cfg.drives_per_truck;
    let bar = Progress::bar(total as u64, "drives");
    let progress = |done: usize, total: usize| {
        if bar.is_drawn() {
            bar.set_position(done as u64);
        } else if done.is_multiple_of(10) || done == total {
            eprintln!(
                "prove --fleet: {done}/{total} drives ({:.0} s)",
                t0.elapsed().as_secs_f64()
            );
        }
    };
    let run = run_fleet_proof(cfg, vehicle, output, jobs, &progress).map_err(category)?;
    drop(bar);
    say_fleet(&run, output);
    Ok(())
}

fn run_cases(cfg: &ProofConfig, vehicle: &Path, output: &Path, jobs: usize) -> Result<(), Failure> {
    let t0 = std::time::Instant::now();
    let planned = if cfg.only.is_empty() {
        cfg.drives
    } else {
        cfg.only.len()
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
    let run = run_proof(cfg, vehicle, output, jobs, &progress).map_err(category)?;
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
        output.join("proof.md").display(),
        run.summary.drives,
        jobs,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
