//! `fleetdyn run`: a pipeline over its drives into a partitioned dataset and a run report.

use super::failure::{input, io, Failure};
use super::progress::{on_terminal, Progress};
use fleetdyn::pipeline::run::{run_plan, DriveOutcome, DriveStatus, RunError, RunOptions, Shard};
use fleetdyn::pipeline::spec::Plan;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::Instant;

/// A resolved `run`.
pub struct Job {
    /// The planned pipeline.
    pub plan: Plan,
    /// Output root.
    pub out_root: PathBuf,
    /// Worker threads.
    pub jobs: usize,
    /// Only this shard's inputs.
    pub shard: Option<Shard>,
    /// Recompute drives whose outputs are up to date.
    pub force: bool,
}

/// Counts of the drives done so far, for the progress line.
struct Tally {
    done: usize,
    failed: usize,
    rows: u64,
    t0: Instant,
}

/// Runs it; a failed drive exits 1 after every other drive is done.
pub fn run(job: Job) -> Result<(), Failure> {
    let plan = &job.plan;
    let shard = job.shard;
    let mine = plan
        .inputs
        .iter()
        .filter(|it| shard.is_none_or(|s| s.owns(&it.path)))
        .count();
    let tty = on_terminal();
    if !tty {
        let _ = tracing_subscriber::fmt()
            .with_writer(std::io::stderr)
            .with_target(false)
            .try_init();
    }
    say!(
        "pipeline {} (model {}): {} of {} drives{}, stages {} -> {} ({} jobs)",
        plan.spec.name,
        plan.spec.model_version,
        mine,
        plan.inputs.len(),
        shard.map_or(String::new(), |s| format!(
            " in shard {}/{}",
            s.index, s.count
        )),
        plan.spec.stages.join(" > "),
        job.out_root.display(),
        job.jobs
    );
    let bar = Progress::bar(mine as u64, "drives");
    let tally = Mutex::new(Tally {
        done: 0,
        failed: 0,
        rows: 0,
        t0: Instant::now(),
    });
    let on_drive = |o: &DriveOutcome| {
        let mut c = tally.lock().unwrap_or_else(|p| p.into_inner());
        if o.status == DriveStatus::Failed {
            c.failed += 1;
        } else {
            c.done += 1;
        }
        if o.status == DriveStatus::Ok {
            c.rows += o.record.as_ref().map_or(0, |r| r.metrics.rows);
        }
        let rate = c.rows as f64 / c.t0.elapsed().as_secs_f64().max(1e-9);
        if bar.is_drawn() {
            bar.message(format!("({} failed, {:.0} rows/s)", c.failed, rate));
            if let Some(e) = &o.error {
                bar.println(format!(
                    "FAILED {} at {}: {e}",
                    o.drive_id,
                    o.failed_stage.unwrap_or("?")
                ));
            }
            bar.inc();
            return;
        }
        match &o.error {
            None => tracing::info!(
                "{} {} {:.3} s ({}/{} done, {} failed, {:.0} rows/s) {}",
                o.status.name(),
                o.drive_id,
                o.elapsed_s,
                c.done + c.failed,
                mine,
                c.failed,
                rate,
                o.input
            ),
            Some(e) => tracing::warn!(
                "FAILED {} at {}: {e} ({}/{} done)",
                o.drive_id,
                o.failed_stage.unwrap_or("?"),
                c.done + c.failed,
                mine
            ),
        }
    };
    let opts = RunOptions {
        out_root: job.out_root.clone(),
        jobs: job.jobs,
        shard,
        force: job.force,
    };
    let report = run_plan(plan, &opts, &on_drive).map_err(|e| match e {
        // the environment, not a drive: an output root that cannot be made or written
        e @ RunError::OutputFolder { .. } => io(e),
        e => input(e),
    })?;
    drop(bar);
    say!(
        "{} processed, {} reused (up to date), {} failed in {:.2} s; report {}",
        report.ok,
        report.reused,
        report.failed,
        report.elapsed_s,
        std::path::Path::new(&report.report_dir)
            .join("summary.md")
            .display()
    );
    if let Some(f) = &report.fleet {
        say!(
            "fleet evidence: {} vehicles, {} drives, {} flagged, {} changes; {}",
            f.vehicles,
            f.drives,
            f.flagged,
            f.changes,
            std::path::Path::new(&f.dir).join("fleet.html").display()
        );
    }
    for d in report
        .drives
        .iter()
        .filter(|d| d.status == DriveStatus::Failed)
    {
        say!(
            "  FAILED  {:<24} at {}: {}",
            d.drive_id,
            d.failed_stage.unwrap_or("?"),
            d.error.as_deref().unwrap_or("")
        );
    }
    if report.failed > 0 {
        return Err(input(anyhow::anyhow!(
            "{} of {} drives failed",
            report.failed,
            report.drives.len()
        )));
    }
    Ok(())
}
