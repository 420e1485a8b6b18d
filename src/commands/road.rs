//! `fleetdyn road …`: synthetic roads, their spectra, and road profiles from real tracks.

use super::failure::{input, io, model, usage, usage_msg, Failure};
use super::progress::Progress;
use fleetdyn::io::AtomicFile;
use fleetdyn::model::vehicle::VehicleFile;
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::report::road_compare::write_comparison;
use fleetdyn::report::road_spectra::{write_road_spectrum, write_study};
use fleetdyn::road::compare::{compare, CompareConfig, Comparison, ProfileInput, RulesInput};
use fleetdyn::road::fit::{fit, rule_file, FitConfig, FitError};
use fleetdyn::road::gnss_profile::gnss_profile_of;
use fleetdyn::road::profile::{GnssProfileConfig, ProfileError};
use fleetdyn::road::profile_input::{read_profile_input, ProfileInputError};
use fleetdyn::road::profile_table::write_profile;
use fleetdyn::road::road_table::{read_distance_column, write_road};
use fleetdyn::road::rules::RoadRules;
use fleetdyn::road::study::{
    run_study, slope_spectrum, SpectrumSettings, StudyConfig, StudyError, StudyRoads,
};
use fleetdyn::road::synth;
use fleetdyn::road::vdri::{cycle_profile, detect_input, read_vdri, ProfileInput as ProfileKind};
use std::path::PathBuf;

/// A measured profile named on the command line.
pub struct ProfileSpec {
    /// Road class label.
    pub class: String,
    /// VECTO cycle or road Parquet.
    pub file: PathBuf,
    /// Part kept, km from the start.
    pub window_km: Option<(f64, f64)>,
}

/// The synthetic roads of a comparison or fit with their Welch settings, and the worker threads.
pub struct Roads {
    /// Roads, grid and Welch settings.
    pub study: StudyRoads,
    /// Worker threads.
    pub jobs: usize,
}

/// Runs `f` on a pool of `jobs` threads.
fn on_pool<T: Send>(jobs: usize, f: impl FnOnce() -> T + Send) -> Result<T, Failure> {
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .map_err(|e| model(anyhow::anyhow!("thread pool: {e}")))?
        .install(f))
}

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
    /// Rule sets, profiles and resonances side by side.
    Compare {
        /// Rule sets with their classes.
        rules: Vec<RulesInput>,
        /// Profiles.
        profiles: Vec<ProfileSpec>,
        /// Vehicle file with a driveline, and its path.
        vehicle: Option<Box<(VehicleFile, String)>>,
        /// Synthetic roads and Welch settings.
        roads: Roads,
        /// Output folder.
        output: PathBuf,
    },
    /// A rule set's segment lengths fitted to measured roads.
    Fit {
        /// Base rules.
        base: RoadRules,
        /// Name of the fitted set.
        name: String,
        /// Targets.
        targets: Vec<ProfileSpec>,
        /// Scale factors.
        scales: Vec<f64>,
        /// Synthetic roads and Welch settings.
        roads: Roads,
        /// Output TOML file.
        output: PathBuf,
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

/// The profiles on a `step_m` grid: a window or grid that does not fit is a usage error, a file
/// that holds no usable profile an input error.
fn load_profiles(specs: &[ProfileSpec], step_m: f64) -> Result<Vec<ProfileInput>, Failure> {
    specs
        .iter()
        .map(|p| {
            read_profile_input(&p.file, &p.class, p.window_km, step_m).map_err(|e| match e {
                ProfileInputError::Profile(e) => profile_failure(e),
                e @ ProfileInputError::RoadFile(_) => input(e),
                e @ (ProfileInputError::Step { .. } | ProfileInputError::Window { .. }) => usage(e),
            })
        })
        .collect()
}

fn print_comparison(c: &Comparison) {
    say!(
        "{:<28} {:<8} {:<9} {:>8} {:>28} {:>28} {:>8} {:>8} {:>8} {:>7}",
        "item",
        "kind",
        "class",
        "km",
        "50 % knee [1/m] (range)",
        "90 % knee [1/m] (range)",
        "<3e-4",
        "<1e-3",
        "removed",
        "margin"
    );
    for it in &c.items {
        let k = |q: &fleetdyn::road::compare::Knee| {
            format!("{:.2e} ({:.2e}-{:.2e})", q.value, q.lo, q.hi)
        };
        say!(
            "{:<28} {:<8} {:<9} {:>8.1} {:>28} {:>28} {:>7.1}% {:>7.1}% {:>7.2}% {:>6.1}x",
            it.name,
            it.kind.as_str(),
            if it.class.is_empty() { "-" } else { &it.class },
            it.length_m / 1000.0,
            k(&it.knees[0]),
            k(&it.knees[1]),
            100.0 * it.share_below_paper[0],
            100.0 * it.share_below_paper[1],
            100.0 * it.removed_zero_phase,
            it.cutoff_margin(&c.filter)
        );
    }
    say!(
        "  ranges: rule sets 5-95 % across roads, profiles 90 % bootstrap; removed: slope power the zero-phase filter takes; margin: f_co {} 1/m over the 99 % knee",
        c.filter.config.cutoff_per_m
    );
    for r in &c.resonances {
        match (r.peak_hz, r.peak_per_m, r.zero_phase_db, r.causal_db) {
            (Some(hz), Some(pm), Some(zp), Some(ca)) => say!(
                "  gear {:>2}: resonance {:.2} Hz at {:.1} m/s = {:.3} 1/m ({:.1} x f_lo); filter {:.1} dB zero-phase, {:.1} dB causal",
                r.gear, hz, r.v_top_mps, pm, pm / c.filter.config.stop_per_m, zp, ca
            ),
            _ => say!("  gear {:>2}: no resonance peak (open loop)", r.gear),
        }
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
            let study = on_pool(jobs, || run_study(&cfg))?.map_err(study_failure)?;
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
        Job::Compare {
            rules,
            profiles,
            vehicle,
            roads,
            output,
        } => {
            let cfg = CompareConfig {
                rules,
                profiles: load_profiles(&profiles, roads.study.step_m)?,
                roads: roads.study,
            };
            let driveline = match vehicle.as_deref() {
                Some((v, file)) => Some((v.driveline(file).map_err(usage)?, &v.gearbox.ratios[..])),
                None => None,
            };
            let spinner = Progress::spinner("road comparison");
            let cmp = on_pool(roads.jobs, || compare(&cfg, driveline))?.map_err(study_failure)?;
            drop(spinner);
            let files = write_comparison(&output, &cmp).map_err(io)?;
            print_comparison(&cmp);
            for f in files {
                say!("  wrote {}", f.display());
            }
            Ok(())
        }
        Job::Fit {
            base,
            name,
            targets,
            scales,
            roads,
            output,
        } => {
            let cfg = FitConfig {
                base,
                targets: load_profiles(&targets, roads.study.step_m)?,
                scales,
                roads: roads.study,
            };
            let spinner = Progress::spinner(&format!("{} studies", cfg.scales.len()));
            let f = on_pool(roads.jobs, || fit(&cfg, &name))?.map_err(|e| match e {
                FitError::Study(s) => study_failure(s),
                e @ FitError::Setup { .. } => usage(e),
                e @ FitError::FlatTarget { .. } => input(e),
            })?;
            drop(spinner);
            let command = std::env::args().skip(1).collect::<Vec<_>>().join(" ");
            let text = rule_file(&cfg, &f, &command);
            AtomicFile::write_all(&output, text.as_bytes()).map_err(io)?;
            for t in &f.targets {
                say!(
                    "target {}: 50 % knee {:.3e} 1/m, 90 % knee {:.3e} 1/m",
                    t.name,
                    t.knee_50,
                    t.knee_90
                );
            }
            say!(
                "{:>6} {:>12} {:>12} {:>10} {:>12}",
                "k",
                "50 % knee",
                "90 % knee",
                "J",
                "lengthened"
            );
            for (i, p) in f.points.iter().enumerate() {
                say!(
                    "{:>6} {:>12.3e} {:>12.3e} {:>10.4} {:>6} / {:<6}{}",
                    p.scale,
                    p.knee_50,
                    p.knee_90,
                    p.objective,
                    p.lengthened,
                    p.segments,
                    if i == f.best { "  <- best" } else { "" }
                );
            }
            say!("  wrote {} ({})", output.display(), f.rules.name);
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
                ProfileKind::VectoCycle => {
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
                ProfileKind::Recording => {
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
