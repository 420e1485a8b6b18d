//! `fleetdyn road …`: synthetic roads, their spectra, and road profiles from real tracks.

use super::failure::{input, io, model, usage, usage_msg, Failure};
use super::progress::Progress;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::report::road_spectra::{write_road_spectrum, write_study};
use fleetdyn::road::gnss_profile::gnss_profile_of;
use fleetdyn::road::profile::{GnssProfileConfig, ProfileError};
use fleetdyn::road::profile_table::write_profile;
use fleetdyn::road::road_table::{read_distance_column, write_road};
use fleetdyn::road::rules::RoadRules;
use fleetdyn::road::study::{run_study, slope_spectrum, SpectrumSettings, StudyConfig, StudyError};
use fleetdyn::road::synth;
use fleetdyn::road::vdri::{cycle_profile, detect_input, read_vdri, ProfileInput};
use std::path::PathBuf;

/// A resolved `road` subcommand.
pub enum Job {
    /// One synthetic road.
    Synth {
        /// Rule set.
        rules: RoadRules,
        /// As given (bundled name or file), recorded in the output.
        rules_name: String,
        /// Length, m.
        length_m: f64,
        /// Seed.
        seed: u64,
        /// Grid step, m.
        step_m: f64,
        /// Output Parquet file.
        output: PathBuf,
    },
    /// Spectra of many roads.
    Study {
        /// The study.
        cfg: StudyConfig,
        /// The rule set as given.
        rules_name: String,
        /// Worker threads.
        jobs: usize,
        /// Output folder.
        output: PathBuf,
    },
    /// Spectrum of one road file.
    Spectrum {
        /// Road Parquet file.
        input: PathBuf,
        /// Output folder.
        output: PathBuf,
        /// Slope column.
        column: String,
        /// Welch settings.
        settings: SpectrumSettings,
    },
    /// Road profile from a GNSS track or a VECTO cycle.
    Profile {
        /// Input file.
        input: PathBuf,
        /// Output Parquet file.
        output: PathBuf,
        /// `--smooth-m` was given (it applies to GNSS tracks only).
        smooth_given: bool,
        /// GNSS profile settings.
        gnss: GnssProfileConfig,
        /// Mapping file for a recording.
        mapping: Option<PathBuf>,
    },
}

/// Configuration errors (settings of the study or spectrum) are usage errors; a signal that
/// cannot be analysed is an input error.
fn study_failure(e: StudyError) -> Failure {
    match e {
        StudyError::Signal { .. } => input(e),
        _ => usage(e),
    }
}

/// A profile setting out of range is a usage error; an input that holds no usable track or
/// cycle is an input error.
fn profile_failure(e: ProfileError) -> Failure {
    match e {
        ProfileError::Setting { .. } => usage(e),
        _ => input(e),
    }
}

/// Runs it.
pub fn run(job: Job) -> Result<(), Failure> {
    match job {
        Job::Synth {
            rules,
            rules_name,
            length_m,
            seed,
            step_m,
            output,
        } => {
            let road = synth::generate(&rules, length_m, step_m, seed).map_err(usage)?;
            write_road(&output, &road, &rules_name).map_err(io)?;
            let p = &road.profile;
            let max_abs = p.slope.iter().fold(0.0f64, |m, s| m.max(s.abs()));
            let (zmin, zmax) = p
                .elevation_m
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &z| {
                    (a.min(z), b.max(z))
                });
            say!(
                "road {} seed {}: {:.3} km on a {} m grid ({} samples), {} grade segments, {} vertical curves ({} segments lengthened to fit their curves), max |slope| {:.4}, elevation {:.1} .. {:.1} m -> {}",
                rules.name, seed, road.length_m / 1000.0, step_m, p.slope.len(),
                road.alignment.grades.len(), road.alignment.radii_m.len(),
                road.lengthened_segments, max_abs, zmin, zmax, output.display()
            );
            Ok(())
        }
        Job::Study {
            cfg,
            rules_name,
            jobs,
            output,
        } => {
            let spinner = Progress::spinner(&format!("{} roads", cfg.n_roads));
            let study = rayon::ThreadPoolBuilder::new()
                .num_threads(jobs)
                .build()
                .map_err(|e| model(anyhow::anyhow!("thread pool: {e}")))?
                .install(|| run_study(&cfg))
                .map_err(study_failure)?;
            drop(spinner);
            let files = write_study(&output, &study, &rules_name).map_err(io)?;
            let c = &study.config;
            say!(
                "study {}: {} roads x {:.3} km (seeds {}..{}), Welch segments of {} m ({} per road, {:.1} dof), resolution {:.3e} 1/m",
                c.rules.name, c.n_roads, c.length_m / 1000.0, c.seed, c.seed + c.n_roads as u64 - 1,
                study.nperseg as f64 * c.step_m, study.n_segments, study.dof,
                study.freq_per_m.get(1).copied().unwrap_or(f64::NAN)
            );
            for (name, k, m) in [
                ("50 %", &study.knee_50, study.knee_50_of_mean),
                ("90 %", &study.knee_90, study.knee_90_of_mean),
                ("99 %", &study.knee_99, study.knee_99_of_mean),
            ] {
                say!(
                    "  {name} knee across roads: median {:.3e} 1/m (5 %: {:.3e}, 95 %: {:.3e}); of the mean PSD: {:.3e} 1/m",
                    k.p50, k.p05, k.p95, m
                );
            }
            say!(
                "  mean PSD's power below 3e-4 1/m: {:.1} %, below 1e-3 1/m: {:.1} % (the paper: most of a highway's below 3e-4, most of a city road's below 1e-3)",
                100.0 * study.share_below_paper[0],
                100.0 * study.share_below_paper[1]
            );
            say!(
                "  slope filter (f_co {} 1/m) removes {:.2} % of the mean PSD's power zero-phase, {:.2} % causal",
                study.filter.config.cutoff_per_m,
                100.0 * study.removed_by_zero_phase,
                100.0 * study.removed_by_causal
            );
            let lengthened: usize = study.roads.iter().map(|k| k.lengthened_segments).sum();
            let segments: usize = study.roads.iter().map(|k| k.grade_segments).sum();
            say!("  {segments} grade segments in all, {lengthened} lengthened to fit their curves");
            for f in files {
                say!("  wrote {}", f.display());
            }
            Ok(())
        }
        Job::Spectrum {
            input: path,
            output,
            column,
            settings,
        } => {
            let col = read_distance_column(&path, &column).map_err(input)?;
            let sp = slope_spectrum(&col.values, col.step_m, &settings).map_err(study_failure)?;
            let files = write_road_spectrum(&output, &col, &sp, &settings).map_err(io)?;
            say!(
                "{}: {column} on a {} m grid, {} Welch segments of {} samples ({:.1} dof); half the power below {:.3e} 1/m, 90 % below {:.3e} 1/m, 99 % below {:.3e} 1/m",
                path.display(), col.step_m, sp.psd.n_segments, sp.psd.nperseg, sp.psd.dof,
                sp.knee_50, sp.knee_90, sp.knee_99
            );
            say!(
                "  power below 3e-4 1/m: {:.1} %, below 1e-3 1/m: {:.1} %",
                100.0 * sp.share_below_paper[0],
                100.0 * sp.share_below_paper[1]
            );
            for f in files {
                say!("  wrote {}", f.display());
            }
            Ok(())
        }
        Job::Profile {
            input: path,
            output,
            smooth_given,
            gnss,
            mapping,
        } => {
            let (profile, fp) = match detect_input(&path).map_err(profile_failure)? {
                ProfileInput::VectoCycle => {
                    if smooth_given {
                        return Err(usage_msg(format_args!(
                            "{}: --smooth-m applies to GNSS tracks; a VECTO cycle's grade is used as given",
                            path.display()
                        )));
                    }
                    let c = read_vdri(&path).map_err(profile_failure)?;
                    let p = cycle_profile(&c, gnss.step_m).map_err(profile_failure)?;
                    (p, format!("road_profile:vdri:v1 step_m={}", gnss.step_m))
                }
                ProfileInput::Recording => {
                    // GNSS fixes may be missing for long (no satellite lock): the profile
                    // interpolates over them in distance, so ingest takes any missing-value run
                    // and requires no column; the profile names what is missing.
                    let icfg = IngestConfig {
                        mapping,
                        max_nan_run_s: f64::INFINITY,
                        ..Default::default()
                    };
                    let opts = icfg.options(&[], None).map_err(usage)?;
                    let ing = ingest_stage::run(&path, &opts).map_err(input)?;
                    let p = gnss_profile_of(&ing, &gnss).map_err(profile_failure)?;
                    let fp = format!("{}\n{}", icfg.fingerprint(&opts), gnss.fingerprint());
                    (p, fp)
                }
            };
            write_profile(&output, &profile, &fp).map_err(io)?;
            say_raw!("{}", profile.summary());
            say!(
                "  {} grid points of {} m -> {}",
                profile.distance_m.len(),
                profile.step_m,
                output.display()
            );
            Ok(())
        }
    }
}
