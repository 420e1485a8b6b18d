//! `fleetdyn road synth|study|spectrum|profile`.

use super::common::jobs;
use crate::commands::failure::{setting, usage, Failure};
use crate::commands::road;
use clap::{Args, Subcommand};
use fleetdyn::road::profile::GnssProfileConfig;
use fleetdyn::road::rules::RoadRules;
use fleetdyn::road::study::{SpectrumSettings, StudyConfig};
use std::path::PathBuf;

/// Roads (docs/models/road.md): synthetic roads from road-design rules, studies of their slope
/// spectra, the spectrum of one road file, and road profiles from real tracks (GNSS fixes or
/// VECTO driving cycles).
#[derive(Subcommand, Debug)]
pub enum RoadCmd {
    /// Generate one synthetic road (constant grades joined by parabolic vertical curves
    /// z = x²/(2R), Myklebust & Eriksson 2012, eqs. (34)-(36)) and write distance, elevation and
    /// slope on a uniform grid as Parquet.
    Synth(SynthRoadCmd),
    /// Slope spectra of N random roads (seeds seed..seed+N-1) in parallel: PSD percentile bands
    /// (5/50/95 %) per frequency, the 90 % and 99 % knees of every road, and the slope filter's
    /// response. Writes road_study_psd.parquet, road_study_knees.parquet and road_study.svg.
    Study(StudyCmd),
    /// Slope spectrum of one road file: any Parquet with a uniform `distance` grid (m) and a
    /// slope column (a `road synth` output, or slope_distance.parquet of `fleetdyn slope`).
    /// Writes road_spectrum.parquet and road_spectrum.svg.
    Spectrum(RoadSpectrumCmd),
    /// Road profile on a uniform distance grid: distance, elevation, smoothed elevation, slope
    /// (tan α), latitude and longitude. INPUT is a GNSS track (MCAP or Parquet, read by ingest:
    /// latitude, longitude, altitude; vehicle_speed gates standstill) or a VECTO distance-based
    /// driving cycle (.vdri CSV: elevation integrated from <grad> %), recognised by content.
    /// Bad input (no GNSS columns, fewer than 3 fixes, a malformed .vdri) exits 1, a setting out
    /// of range exits 2; no output either way.
    Profile(ProfileCmd),
}

/// `road synth`.
#[derive(Args, Debug)]
pub struct SynthRoadCmd {
    /// Rule set: a bundled name (highway-se, highway-se-fitted, city-se, freeway-us,
    /// urban-us) or a TOML file of the same keys (schemas/roads/*.toml).
    #[arg(long)]
    rules: String,
    /// Road length, km.
    #[arg(long, allow_negative_numbers = true)]
    length_km: f64,
    /// Seed of the road's random generator (same seed, same road, byte for byte).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Distance grid step, m.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    step_m: f64,
    /// Output Parquet file.
    #[arg(short, long)]
    output: PathBuf,
}

/// `road study`.
#[derive(Args, Debug)]
pub struct StudyCmd {
    /// Rule set: a bundled name or a TOML file.
    #[arg(long)]
    rules: String,
    /// Number of roads.
    #[arg(long, default_value_t = 64)]
    roads: usize,
    /// Length of each road, km.
    #[arg(long, default_value_t = 50.0, allow_negative_numbers = true)]
    length_km: f64,
    /// Seed of the first road.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Distance grid step, m.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    step_m: f64,
    /// Welch segment length, m (frequency resolution = 1/segment).
    #[arg(long, default_value_t = 16384.0, allow_negative_numbers = true)]
    segment_length_m: f64,
    /// Worker threads (default: all cores); the output is the same for any number.
    #[arg(long, alias = "threads")]
    jobs: Option<usize>,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
}

/// `road spectrum`.
#[derive(Args, Debug)]
pub struct RoadSpectrumCmd {
    /// Road Parquet file.
    input: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
    /// Slope column (tan α) to analyse.
    #[arg(long, default_value = "slope")]
    column: String,
    /// Welch segment length, m.
    #[arg(long, default_value_t = 16384.0, allow_negative_numbers = true)]
    segment_length_m: f64,
    /// Confidence level of the PSD band.
    #[arg(long, default_value_t = 0.95)]
    confidence: f64,
}

/// `road profile`.
#[derive(Args, Debug)]
pub struct ProfileCmd {
    /// Input: MCAP, Parquet or .vdri.
    input: PathBuf,
    /// Output Parquet file (road_profile table).
    #[arg(short, long)]
    output: PathBuf,
    /// Distance grid step, m.
    #[arg(long, default_value_t = 1.0)]
    step_m: f64,
    /// Cut-off wavelength of the zero-phase elevation low-pass, m (GNSS tracks only; default
    /// 300 m, see docs/models/road.md).
    #[arg(long)]
    smooth_m: Option<f64>,
    /// Mapping file for a recording (chosen automatically when absent).
    #[arg(long)]
    mapping: Option<PathBuf>,
    /// Elevation column, m: the canonical altitude, or e.g. a barometric pass-through column.
    #[arg(long, default_value = "altitude")]
    elevation_column: String,
    /// IMU pitch column (deg or rad): its slope tan(pitch − mean) is written beside the GNSS
    /// slope and their Pearson r printed.
    #[arg(long)]
    pitch_column: Option<String>,
    /// Drop elevation fixes whose reported accuracy (column altitude_accuracy_m, when the input
    /// has it) is worse than this, m.
    #[arg(long, default_value_t = 5.0)]
    max_elevation_accuracy_m: f64,
}

impl RoadCmd {
    /// The job of the subcommand.
    pub fn resolve(self) -> Result<road::Job, Failure> {
        Ok(match self {
            RoadCmd::Synth(c) => road::Job::Synth {
                rules: RoadRules::resolve(&c.rules).map_err(usage)?,
                rules_name: c.rules,
                length_m: c.length_km * 1000.0,
                seed: c.seed,
                step_m: c.step_m,
                output: c.output,
            },
            RoadCmd::Study(c) => road::Job::Study {
                cfg: StudyConfig {
                    rules: RoadRules::resolve(&c.rules).map_err(usage)?,
                    n_roads: c.roads,
                    length_m: c.length_km * 1000.0,
                    step_m: c.step_m,
                    seed: c.seed,
                    spectrum: SpectrumSettings {
                        segment_length_m: c.segment_length_m,
                        ..Default::default()
                    },
                },
                rules_name: c.rules,
                jobs: jobs(c.jobs)?,
                output: c.output,
            },
            RoadCmd::Spectrum(c) => {
                let settings = SpectrumSettings {
                    segment_length_m: c.segment_length_m,
                    confidence: c.confidence,
                };
                settings.validate().map_err(setting)?;
                road::Job::Spectrum {
                    input: c.input,
                    output: c.output,
                    column: c.column,
                    settings,
                }
            }
            RoadCmd::Profile(c) => road::Job::Profile {
                input: c.input,
                output: c.output,
                smooth_given: c.smooth_m.is_some(),
                gnss: GnssProfileConfig {
                    step_m: c.step_m,
                    smooth_m: c.smooth_m.unwrap_or(GnssProfileConfig::default().smooth_m),
                    elevation_column: c.elevation_column,
                    pitch_column: c.pitch_column,
                    max_elevation_accuracy_m: c.max_elevation_accuracy_m,
                    ..Default::default()
                },
                mapping: c.mapping,
            },
        })
    }
}
