//! `fleetdyn spectrum`: the Welch PSD of one column, in distance or time.

use super::failure::{input, io, usage, Failure};
use fleetdyn::ingest::IngestOptions;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::pipeline::resample_stage;
use fleetdyn::report::spectrum;
use fleetdyn::road::profile_table::read_profile_column;
use fleetdyn::signal::distance::{resample_to_distance, ResampleConfig};
use std::path::PathBuf;

/// Where the analysed column comes from.
// One value per process: the size of its largest variant costs nothing.
#[allow(clippy::large_enum_variant)]
pub enum Source {
    /// A road-profile table, on its own distance grid.
    Profile {
        /// Column.
        column: String,
    },
    /// A recording, ingested (and resampled when `distance`).
    Recording {
        /// Column.
        column: String,
        /// Ingest settings.
        cfg: IngestConfig,
        /// The options they give.
        opts: IngestOptions,
        /// The distance grid.
        resample: ResampleConfig,
        /// On the distance grid (1/m), else in time (Hz).
        distance: bool,
    },
}

/// A resolved `spectrum`.
pub struct Job {
    /// Input file.
    pub input: PathBuf,
    /// Output Parquet file.
    pub output: PathBuf,
    /// Where the column comes from.
    pub source: Source,
    /// Welch segment length, samples.
    pub nperseg: Option<usize>,
    /// Confidence level of the PSD bounds.
    pub confidence: f64,
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    let (nperseg, confidence, output) = (job.nperseg, job.confidence, &job.output);
    match job.source {
        Source::Profile { column } => {
            let pc = read_profile_column(&job.input, &column).map_err(usage)?;
            let sp = spectrum::of_grid(
                &pc.meta.source_file,
                &column,
                &pc.unit,
                &pc.values,
                pc.step_m,
                nperseg,
                confidence,
            )
            .map_err(input)?;
            let fp = spectrum::fingerprint(Some(pc.step_m), &column, nperseg, confidence);
            spectrum::write(output, &pc.meta, &sp, &fp).map_err(io)?;
            say!(
                "{}: {} PSD on the profile's {} m grid, {} segments of {} samples (equivalent dof {:.1}); 90 % of power below {:.3e} {}, 99 % below {:.3e} {} -> {}",
                pc.meta.drive_id, column, pc.step_m, sp.psd.n_segments, sp.psd.nperseg, sp.psd.dof,
                sp.knee_90, sp.freq_unit, sp.knee_99, sp.freq_unit, output.display()
            );
        }
        Source::Recording {
            column,
            cfg,
            opts,
            resample,
            distance,
        } => {
            let ing = ingest_stage::run(&job.input, &opts).map_err(input)?;
            let sp = if distance {
                let d = resample_to_distance(&ing.log, &resample).map_err(input)?;
                spectrum::of_distance_log(&d, &column, nperseg, confidence)
            } else {
                spectrum::of_drive_log(&ing.log, &column, nperseg, confidence)
            }
            .map_err(input)?;
            let fp = format!(
                "{}\n{}\n{}",
                cfg.fingerprint(&opts),
                resample_stage::fingerprint(&resample),
                spectrum::fingerprint(None, &column, nperseg, confidence)
            );
            spectrum::write(output, &ing.log.meta, &sp, &fp).map_err(io)?;
            say!(
                "{}: {} PSD, {} segments of {} samples (equivalent dof {:.1}); 90 % of power below {:.3e} {}, 99 % below {:.3e} {} -> {}",
                ing.log.meta.drive_id, column, sp.psd.n_segments, sp.psd.nperseg, sp.psd.dof,
                sp.knee_90, sp.freq_unit, sp.knee_99, sp.freq_unit, output.display()
            );
        }
    }
    Ok(())
}
