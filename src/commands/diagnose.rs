//! `fleetdyn diagnose`: where one recording and the nominal model disagree, and why.

use super::failure::{input, io, model, Failure};
use super::progress::Progress;
use fleetdyn::diagnose::run::{diagnose, DiagnoseConfig, DiagnoseError, UNREAD_COLUMNS};
use fleetdyn::ingest::IngestOptions;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::report::diagnosis_files::write_outputs;
use std::path::PathBuf;

/// A resolved `diagnose`.
pub struct Job {
    /// Recording.
    pub drive: PathBuf,
    /// The nominal vehicle.
    pub vehicle: VehicleFile,
    /// Its path.
    pub vehicle_file: PathBuf,
    /// Output folder.
    pub output: PathBuf,
    /// Ingest settings.
    pub cfg: IngestConfig,
    /// The options they give.
    pub opts: IngestOptions,
    /// Diagnosis settings.
    pub diagnose: DiagnoseConfig,
}

/// A recording the models cannot be bound to is an input error; a failed noise floor, locate
/// or fit a model error.
fn category(e: DiagnoseError) -> Failure {
    match e {
        DiagnoseError::Setup(_) => input(e),
        _ => model(e),
    }
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let mut ing = ingest_stage::run(&job.drive, &job.opts).map_err(input)?;
    // the diagnosis reads no position: the GNSS columns go before it starts
    ing.log
        .signals
        .retain(|c| !UNREAD_COLUMNS.contains(&c.name.as_str()));
    let t0 = std::time::Instant::now();
    let spinner = Progress::spinner(&format!(
        "diagnosing {} ({:.0} s of drive)",
        ing.log.meta.drive_id,
        ing.log.duration_s()
    ));
    let d = diagnose(&ing.log, &job.vehicle, &job.diagnose).map_err(category)?;
    drop(spinner);
    let fp = format!(
        "{}\nvehicle {}\nmax_findings {}",
        job.cfg.fingerprint(&job.opts),
        job.vehicle_file.display(),
        job.diagnose.max_findings
    );
    let w = write_outputs(&job.output, &d, &ing.log, &fp).map_err(io)?;
    let dg = &fleetdyn::report::contract::assemble(&d);
    say!(
        "{}: {:.0} s of drive diagnosed in {:.1} s: {}",
        dg.drive_id,
        ing.log.duration_s(),
        t0.elapsed().as_secs_f64(),
        dg.verdict.as_str()
    );
    if !d.models.longitudinal {
        say!(
            "  longitudinal model not used: {}",
            d.models.longitudinal_reason.as_deref().unwrap_or("")
        );
    }
    if !d.models.axle {
        say!(
            "  axle model not used: {}",
            d.models.axle_reason.as_deref().unwrap_or("")
        );
    }
    for (sig, floor) in &dg.noise_floor {
        let n = dg.mismatch.iter().filter(|m| &m.signal == sig).count();
        say!("  {sig}: noise floor {floor:.4e}, {n} mismatch stretch(es)");
    }
    for f in &dg.findings {
        say!("  finding {}: {}", f.effect, f.sentence);
        if !f.ambiguous_with.is_empty() {
            say!("    not isolable from: {}", f.ambiguous_with.join(", "));
        }
    }
    say!(
        "wrote     {} (+ parquet tables, report.md, plots)",
        w.json.display()
    );
    Ok(())
}
