//! Argument groups and value enums shared by several commands, and their resolution into
//! library settings.

use crate::commands::failure::{usage, usage_msg, Failure};
use clap::{Args, ValueEnum};
use fleetdyn::ingest::{
    BadSamples, IngestOptions, OnGap, TimeRepair, DEFAULT_MIN_SEGMENT_M, DEFAULT_MIN_SEGMENT_S,
};
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::ingest_stage::IngestConfig;
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{DistanceSource, ResampleConfig, ReversePolicy};
use std::path::{Path, PathBuf};

/// How a recording is read into the canonical drive log.
#[derive(Args, Debug)]
pub struct IngestArgs {
    /// Mapping file (schemas/mappings/*.toml); chosen automatically when absent.
    #[arg(long)]
    pub mapping: Option<PathBuf>,
    /// Stages the drive must be usable for (their required columns are checked), comma
    /// separated: ingest, resample, slope, driveline, axle.
    #[arg(long, value_delimiter = ',', default_value = "ingest")]
    pub stages: Vec<String>,
    /// Time base for multi-rate sources, Hz (default: the fastest channel's rate).
    #[arg(long)]
    pub time_base_hz: Option<f64>,
    /// Longest accepted run of missing values in a required column, s; a longer one splits the
    /// recording (or fails it with --on-gap error).
    #[arg(long, default_value_t = 2.0)]
    pub max_nan_run_s: f64,
    /// What to do when time goes backwards.
    #[arg(long, value_enum, default_value = "error")]
    pub time_repair: TimeRepairArg,
    /// What to do with an isolated bad sample (not finite, outside the physical range, a speed
    /// spike) or a timestamp repeated with another value: mask it (the later sample wins) and
    /// count it, or fail the drive.
    #[arg(long, value_enum, default_value = "mask")]
    pub bad_samples: BadSamplesArg,
    /// What to do when a required signal stops for longer than --max-nan-run-s (a logger
    /// pause): split the recording there into drives of their own (`<drive_id>-s<k>`), or
    /// fail it.
    #[arg(long, value_enum, default_value = "split")]
    pub on_gap: OnGapArg,
    /// Segments of a split recording shorter than this are skipped, s.
    #[arg(long, default_value_t = DEFAULT_MIN_SEGMENT_S)]
    pub min_segment_s: f64,
    /// Segments of a split recording in which the vehicle travels less are skipped, m.
    #[arg(long, default_value_t = DEFAULT_MIN_SEGMENT_M)]
    pub min_segment_m: f64,
}

impl IngestArgs {
    /// The ingest settings and the options they give for `extra_stages` beside `--stages`,
    /// with the vehicle file (when given) bounding the gear column.
    pub fn resolve(
        &self,
        extra_stages: &[Stage],
        vehicle: Option<&VehicleFile>,
    ) -> Result<(IngestConfig, IngestOptions), Failure> {
        let mut stages = Vec::new();
        for s in &self.stages {
            stages.push(Stage::parse(s).ok_or_else(|| {
                usage_msg(format_args!(
                    "unknown stage `{s}` (ingest, resample, slope, driveline, axle)"
                ))
            })?);
        }
        stages.extend_from_slice(extra_stages);
        let cfg = IngestConfig {
            mapping: self.mapping.clone(),
            time_base_hz: self.time_base_hz,
            max_nan_run_s: self.max_nan_run_s,
            time_repair: match self.time_repair {
                TimeRepairArg::Error => TimeRepair::Error,
                TimeRepairArg::Sort => TimeRepair::Sort,
            },
            bad_samples: match self.bad_samples {
                BadSamplesArg::Mask => BadSamples::Mask,
                BadSamplesArg::Error => BadSamples::Error,
            },
            on_gap: match self.on_gap {
                OnGapArg::Split => OnGap::Split,
                OnGapArg::Error => OnGap::Error,
            },
            min_segment_s: self.min_segment_s,
            min_segment_m: self.min_segment_m,
        };
        let opts = cfg.options(&stages, vehicle).map_err(usage)?;
        Ok((cfg, opts))
    }
}

/// A recording read on its own: the ingest settings and an optional vehicle file.
#[derive(Args, Debug)]
pub struct RecordingArgs {
    /// Vehicle file (its gearbox bounds the gear column; its id is recorded).
    #[arg(long)]
    pub vehicle: Option<PathBuf>,
    #[command(flatten)]
    pub ingest: IngestArgs,
}

impl RecordingArgs {
    /// The ingest settings and their options for `extra_stages`, with the vehicle file loaded
    /// when one is given.
    pub fn resolve(
        &self,
        extra_stages: &[Stage],
    ) -> Result<(IngestConfig, IngestOptions), Failure> {
        let vehicle = self.vehicle.as_deref().map(load_vehicle).transpose()?;
        self.ingest.resolve(extra_stages, vehicle.as_ref())
    }
}

/// What to do when time goes backwards.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum TimeRepairArg {
    /// Fail the drive.
    Error,
    /// Sort the samples by time.
    Sort,
}

/// What to do with bad samples.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum BadSamplesArg {
    /// Make them missing and count them.
    Mask,
    /// Fail the drive.
    Error,
}

/// What to do at a logger pause.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum OnGapArg {
    /// Split the recording into drives of their own.
    Split,
    /// Fail the recording.
    Error,
}

/// The distance grid.
#[derive(Args, Debug)]
pub struct ResampleArgs {
    /// Distance grid step, m.
    #[arg(long, default_value_t = 1.0)]
    pub step_m: f64,
    /// Distance source: auto (odometer if fine enough, else the speed integral), odometer,
    /// speed.
    #[arg(long, value_enum, default_value = "auto")]
    pub distance_source: DistanceSourceArg,
    /// Reverse motion: error (fail the drive) or exclude (no distance, collapsed).
    #[arg(long, value_enum, default_value = "error")]
    pub reverse: ReverseArg,
}

impl ResampleArgs {
    /// The resampling settings.
    pub fn config(&self) -> ResampleConfig {
        ResampleConfig {
            step_m: self.step_m,
            distance_source: match self.distance_source {
                DistanceSourceArg::Auto => DistanceSource::Auto,
                DistanceSourceArg::Odometer => DistanceSource::Odometer,
                DistanceSourceArg::Speed => DistanceSource::Speed,
            },
            reverse: match self.reverse {
                ReverseArg::Error => ReversePolicy::Error,
                ReverseArg::Exclude => ReversePolicy::Exclude,
            },
            ..Default::default()
        }
    }
}

/// Where the travelled distance comes from.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum DistanceSourceArg {
    /// The odometer when it is fine enough, else the speed integral.
    Auto,
    /// The odometer.
    Odometer,
    /// The integral of the vehicle speed.
    Speed,
}

/// What to do with reverse motion.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ReverseArg {
    /// Fail the drive.
    Error,
    /// Exclude it: no distance, the samples collapsed.
    Exclude,
}

/// The road-slope input of a simulation.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SlopeInputArg {
    /// The sensor as recorded.
    Raw,
    /// Zero-phase filtered in distance (Myklebust & Eriksson 2012, §5).
    Filtered,
}

/// Loads a vehicle file; a file that cannot be read or parsed is a configuration error.
pub fn load_vehicle(path: &Path) -> Result<VehicleFile, Failure> {
    VehicleFile::load(path).map_err(usage)
}

/// Worker threads: `--jobs N` (at least 1), or all cores.
pub fn jobs(jobs: Option<usize>) -> Result<usize, Failure> {
    match jobs {
        Some(0) => Err(usage_msg("--jobs must be at least 1")),
        Some(n) => Ok(n),
        None => Ok(std::thread::available_parallelism().map_or(1, |n| n.get())),
    }
}
