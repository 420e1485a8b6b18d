//! `fleetdyn slope` and `fleetdyn spectrum`.

use super::common::{RecordingArgs, ResampleArgs};
use crate::commands::failure::{usage_msg, Failure};
use crate::commands::{slope, spectrum};
use clap::{Args, ValueEnum};
use fleetdyn::road::slope_filter::{SlopeEdge, SlopeFilterConfig};
use fleetdyn::schema::Stage;
use std::path::PathBuf;

/// Ingest, resample to distance and filter the road slope (Myklebust & Eriksson 2012, §5):
/// zero-phase and causal Butterworth low-pass, on the distance grid and mapped back to time.
#[derive(Args, Debug)]
pub struct SlopeCmd {
    /// Input file (MCAP or Parquet).
    input: PathBuf,
    /// Output folder: slope_distance.parquet and slope_time.parquet are written there.
    #[arg(short, long)]
    output: PathBuf,
    #[command(flatten)]
    recording: RecordingArgs,
    #[command(flatten)]
    resample: ResampleArgs,
    /// Cut-off spatial frequency, 1/m.
    #[arg(long, default_value_t = 4e-3)]
    cutoff_per_m: f64,
    /// Order of the zero-phase filter.
    #[arg(long, default_value_t = 3)]
    order: usize,
    /// Zero-phase edge treatment: matched (fleetdyn default) or scipy (sosfiltfilt defaults).
    #[arg(long, value_enum, default_value = "matched")]
    edge: EdgeArg,
}

/// Edge treatment of the zero-phase filter.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum EdgeArg {
    /// Initial conditions matched to the edges (fleetdyn's default).
    Matched,
    /// scipy's `sosfiltfilt` defaults (odd padding).
    Scipy,
}

impl SlopeCmd {
    /// The job: input, ingest, resampling and filter settings.
    pub fn resolve(self) -> Result<slope::Job, Failure> {
        let (cfg, opts) = self.recording.resolve(&[Stage::Resample, Stage::Slope])?;
        Ok(slope::Job {
            input: self.input,
            output: self.output,
            cfg,
            opts,
            resample: self.resample.config(),
            filter: SlopeFilterConfig {
                cutoff_per_m: self.cutoff_per_m,
                order: self.order,
                edge: match self.edge {
                    EdgeArg::Matched => SlopeEdge::Matched,
                    EdgeArg::Scipy => SlopeEdge::Scipy,
                },
                ..Default::default()
            },
        })
    }
}

/// Welch power spectral density of one column, in distance (1/m) or time (Hz).
#[derive(Args, Debug)]
pub struct SpectrumCmd {
    /// Input file (MCAP or Parquet).
    input: PathBuf,
    /// Output Parquet file (spectrum table).
    #[arg(short, long)]
    output: PathBuf,
    /// Column to analyse (default road_slope; slope with --from-profile).
    #[arg(long)]
    column: Option<String>,
    /// INPUT is a road-profile table written by `fleetdyn road profile`: analyse its column on
    /// the profile's own distance grid (no ingest, no resampling; --domain must be distance).
    #[arg(long)]
    from_profile: bool,
    /// Domain: distance (resampled on the grid of --step-m, frequency in 1/m) or time (Hz).
    #[arg(long, value_enum, default_value = "distance")]
    domain: DomainArg,
    /// Welch segment length, samples (scipy default 256).
    #[arg(long)]
    nperseg: Option<usize>,
    /// Confidence level of the PSD bounds.
    #[arg(long, default_value_t = 0.95)]
    confidence: f64,
    #[command(flatten)]
    recording: RecordingArgs,
    #[command(flatten)]
    resample: ResampleArgs,
}

/// Domain of a spectrum.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum DomainArg {
    /// On the distance grid: frequency in 1/m.
    Distance,
    /// On the time axis: frequency in Hz.
    Time,
}

impl SpectrumCmd {
    /// The job: input, where it is read from, the column and the Welch settings.
    pub fn resolve(self) -> Result<spectrum::Job, Failure> {
        let source = if self.from_profile {
            if matches!(self.domain, DomainArg::Time) {
                return Err(usage_msg(
                    "--from-profile: a road profile is on a distance grid; use --domain distance",
                ));
            }
            spectrum::Source::Profile {
                column: self.column.unwrap_or_else(|| "slope".into()),
            }
        } else {
            let (cfg, opts) = self.recording.resolve(&[Stage::Resample])?;
            spectrum::Source::Recording {
                column: self.column.unwrap_or_else(|| "road_slope".into()),
                cfg,
                opts,
                resample: self.resample.config(),
                distance: matches!(self.domain, DomainArg::Distance),
            }
        };
        Ok(spectrum::Job {
            input: self.input,
            output: self.output,
            source,
            nperseg: self.nperseg,
            confidence: self.confidence,
        })
    }
}
