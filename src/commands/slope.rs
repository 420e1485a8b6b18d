//! `fleetdyn slope`: the road slope filtered without phase lag, on the distance grid and in
//! time.

use super::failure::{input, io, Failure};
use fleetdyn::ingest::IngestOptions;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::pipeline::{resample_stage, slope_stage};
use fleetdyn::road::slope_filter::{filter_slope, SlopeFilterConfig};
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use std::path::PathBuf;

/// A resolved `slope`.
pub struct Job {
    /// Recording.
    pub input: PathBuf,
    /// Output folder.
    pub output: PathBuf,
    /// Ingest settings.
    pub cfg: IngestConfig,
    /// The options they give.
    pub opts: IngestOptions,
    /// The distance grid.
    pub resample: ResampleConfig,
    /// The slope filter.
    pub filter: SlopeFilterConfig,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let scfg = &job.filter;
    let ing = ingest_stage::run(&job.input, &job.opts).map_err(input)?;
    let d = resample_to_distance(&ing.log, &job.resample).map_err(input)?;
    let f = filter_slope(&d, scfg).map_err(input)?;
    let fp = format!(
        "{}\n{}\n{}",
        job.cfg.fingerprint(&job.opts),
        resample_stage::fingerprint(&job.resample),
        slope_stage::fingerprint(scfg)
    );
    let (a, b) = (
        job.output.join("slope_distance.parquet"),
        job.output.join("slope_time.parquet"),
    );
    slope_stage::write(&a, &b, &ing.log, &d, &f, scfg, &fp).map_err(io)?;
    say!(
        "{}: {:.3} km, slope filter cut-off {} 1/m",
        d.meta.drive_id,
        d.map.total_m() / 1000.0,
        scfg.cutoff_per_m
    );
    say!(
        "  gain at {} 1/m: design (order {}) {:.1} dB, zero-phase {:.1} dB, causal (order {}) {:.1} dB (required <= -{} dB)",
        scfg.stop_per_m, scfg.order, f.design_gain_at_stop_db, f.zero_phase_gain_at_stop_db,
        f.causal_order, f.causal_gain_at_stop_db, scfg.required_attenuation_db
    );
    match f.quantization {
        Some(q) => say!(
            "  slope sensor quantisation step {:.6} ({:.4} %)",
            q.step,
            q.step * 100.0
        ),
        None => say!("  slope sensor not quantised"),
    }
    say!("  wrote {} and {}", a.display(), b.display());
    Ok(())
}
