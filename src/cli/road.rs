//! `fleetdyn road synth|study|spectrum|profile|compare|fit`.

use super::common::{jobs, load_vehicle};
use crate::commands::failure::{setting, usage, usage_msg, Failure};
use crate::commands::road;
use clap::{Args, Subcommand};
use fleetdyn::road::compare::RulesInput;
use fleetdyn::road::profile::GnssProfileConfig;
use fleetdyn::road::rules::RoadRules;
use fleetdyn::road::study::{SpectrumSettings, StudyRoads};
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
    /// Rule sets, measured road profiles and a vehicle's driveline resonances side by side
    /// (Myklebust & Eriksson 2012, §4-§5): per item the 50/90/99 % knees with their ranges, the
    /// share of slope power below 3e-4 and 1e-3 1/m, what the slope filter removes and its
    /// cut-off margin; per gear the resonance in 1/m and the filter's attenuation there. Writes
    /// road_compare.parquet, road_compare_psd.parquet, road_compare_resonances.parquet and
    /// road_compare.svg.
    Compare(CompareCmd),
    /// Calibrate a rule set's segment lengths to measured roads: for each scale factor k the
    /// lengths are multiplied by k (every regulation value kept), a study is run, and the k whose
    /// median 50 % and 90 % knees lie closest (in squared log ratio) to the targets' wins. Prints
    /// the grid; writes the fitted rule set as TOML with the fit recorded in its comments.
    Fit(FitCmd),
}

/// `road synth`.
#[derive(Args, Debug)]
pub struct SynthRoadCmd {
    /// Rule set: a bundled name (highway-se, city-se, freeway-us, urban-us, each also as
    /// NAME-fitted: segment lengths fitted to measured roads) or a TOML file of the same keys
    /// (schemas/roads/*.toml).
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

/// The synthetic roads of a study and the Welch settings (`road study`, `compare`, `fit`).
#[derive(Args, Debug)]
pub struct StudyArgs {
    /// Roads per study (per rule set).
    #[arg(long, default_value_t = 64)]
    roads: usize,
    /// Length of each synthetic road, km (in a comparison or a fit, about the measured
    /// profiles' length keeps their spectra comparable).
    #[arg(long, default_value_t = 50.0, allow_negative_numbers = true)]
    length_km: f64,
    /// Seed of a study's first road.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Distance grid step of roads and profiles, m.
    #[arg(long, default_value_t = 1.0, allow_negative_numbers = true)]
    step_m: f64,
    /// Welch segment length, m (frequency resolution = 1/segment), the same for every road and
    /// profile (at most the shortest profile).
    #[arg(long, default_value_t = 16384.0, allow_negative_numbers = true)]
    segment_length_m: f64,
    /// Worker threads (default: all cores); the output is the same for any number.
    #[arg(long, alias = "threads")]
    jobs: Option<usize>,
}

impl StudyArgs {
    /// The roads and Welch settings (the segment length is checked against the grid when the
    /// study runs), and the worker threads.
    fn resolve(&self) -> Result<road::Roads, Failure> {
        let spectrum = SpectrumSettings {
            segment_length_m: self.segment_length_m,
            ..Default::default()
        };
        Ok(road::Roads {
            study: StudyRoads {
                n_roads: self.roads,
                length_m: self.length_km * 1000.0,
                seed: self.seed,
                step_m: self.step_m,
                spectrum,
            },
            jobs: jobs(self.jobs)?,
        })
    }
}

/// `road study`.
#[derive(Args, Debug)]
pub struct StudyCmd {
    /// Rule set: a bundled name or a TOML file.
    #[arg(long)]
    rules: String,
    #[command(flatten)]
    study: StudyArgs,
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

/// `road compare`.
#[derive(Args, Debug)]
pub struct CompareCmd {
    /// A rule set, `[CLASS=]NAME` (a bundled name or a TOML file; CLASS labels the road class,
    /// e.g. `highway=highway-se-fitted`). Repeatable.
    #[arg(long = "rules")]
    rules: Vec<String>,
    /// A measured profile, `[CLASS=]FILE[@FROM_KM..TO_KM]`: a VECTO cycle (.vdri) or a road
    /// Parquet with `distance` and `slope` (a `road profile` or `road synth` output); the window
    /// keeps part of it. Repeatable.
    #[arg(long = "profile")]
    profiles: Vec<String>,
    /// Vehicle file with a [driveline]: its per-gear resonances are set against the filter.
    #[arg(long)]
    vehicle: Option<PathBuf>,
    #[command(flatten)]
    study: StudyArgs,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
}

/// `road fit`.
#[derive(Args, Debug)]
pub struct FitCmd {
    /// Rule set whose segment lengths are scaled (bundled name or TOML file).
    #[arg(long)]
    rules: String,
    /// A measured target, `[CLASS=]FILE[@FROM_KM..TO_KM]` as in `road compare`. Repeatable.
    #[arg(long = "profile", required = true)]
    profiles: Vec<String>,
    /// Scale factors tried, comma separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "0.5,0.75,1,1.25,1.5,2,2.5,3,3.5,4,5"
    )]
    scales: Vec<f64>,
    /// Name of the fitted rule set (default: the base name with `-fitted`).
    #[arg(long)]
    name: Option<String>,
    #[command(flatten)]
    study: StudyArgs,
    /// Output rule file (TOML).
    #[arg(short, long)]
    output: PathBuf,
}

fn profile_specs(specs: &[String]) -> Result<Vec<road::ProfileSpec>, Failure> {
    specs
        .iter()
        .map(|spec| {
            let (class, rest) = class_prefix(spec);
            let (file, window_km) = window(rest)?;
            Ok(road::ProfileSpec {
                class,
                file,
                window_km,
            })
        })
        .collect()
}

/// Splits `CLASS=REST` (CLASS without `/`, `.` or `@`) from `REST`.
fn class_prefix(spec: &str) -> (String, &str) {
    match spec.split_once('=') {
        Some((c, rest)) if !c.is_empty() && !c.contains(['/', '.', '@', '\\']) => {
            (c.to_string(), rest)
        }
        _ => (String::new(), spec),
    }
}

/// Parses `FILE[@FROM_KM..TO_KM]` (an `@` not followed by a `..` range is part of the file name).
fn window(spec: &str) -> Result<(PathBuf, Option<(f64, f64)>), Failure> {
    let Some((file, w)) = spec.rsplit_once('@').filter(|(_, w)| w.contains("..")) else {
        return Ok((PathBuf::from(spec), None));
    };
    let bad = || {
        usage_msg(format_args!(
            "--profile {spec}: the window must be @FROM_KM..TO_KM with 0 <= FROM_KM < TO_KM"
        ))
    };
    let (a, b) = w.split_once("..").ok_or_else(bad)?;
    let (a, b): (f64, f64) = (
        a.trim().parse().map_err(|_| bad())?,
        b.trim().parse().map_err(|_| bad())?,
    );
    if !(a >= 0.0 && b > a && b.is_finite()) {
        return Err(bad());
    }
    Ok((PathBuf::from(file), Some((a, b))))
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
            RoadCmd::Study(c) => {
                let rules = RoadRules::resolve(&c.rules).map_err(usage)?;
                let roads = c.study.resolve()?;
                road::Job::Study {
                    cfg: roads.study.with_rules(rules),
                    rules_name: c.rules,
                    jobs: roads.jobs,
                    output: c.output,
                }
            }
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
            RoadCmd::Compare(c) => {
                let rules = c
                    .rules
                    .iter()
                    .map(|spec| {
                        let (class, name) = class_prefix(spec);
                        Ok(RulesInput {
                            class,
                            rules: RoadRules::resolve(name).map_err(usage)?,
                        })
                    })
                    .collect::<Result<Vec<_>, Failure>>()?;
                let profiles = profile_specs(&c.profiles)?;
                if rules.is_empty() && profiles.is_empty() {
                    return Err(usage_msg(
                        "road compare: give at least one --rules or --profile",
                    ));
                }
                let vehicle = match &c.vehicle {
                    Some(p) => {
                        let v = load_vehicle(p)?;
                        v.driveline(&p.display().to_string()).map_err(usage)?;
                        Some(Box::new((v, p.display().to_string())))
                    }
                    None => None,
                };
                road::Job::Compare {
                    rules,
                    profiles,
                    vehicle,
                    roads: c.study.resolve()?,
                    output: c.output,
                }
            }
            RoadCmd::Fit(c) => {
                let base = RoadRules::resolve(&c.rules).map_err(usage)?;
                let roads = c.study.resolve()?;
                if c.scales.is_empty() || c.scales.iter().any(|k| !(k.is_finite() && *k > 0.0)) {
                    return Err(usage_msg(format_args!(
                        "--scales must be numbers > 0, got {:?}",
                        c.scales
                    )));
                }
                road::Job::Fit {
                    name: c.name.unwrap_or_else(|| format!("{}-fitted", base.name)),
                    base,
                    targets: profile_specs(&c.profiles)?,
                    scales: c.scales,
                    roads,
                    output: c.output,
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
