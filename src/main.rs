//! `fleetdyn`: the command-line shell over the library. Exit codes: 0 ok, 1 some drive failed,
//! 2 usage or configuration error.

use clap::{Args, Parser, Subcommand};
use fleetdyn::ingest::TimeRepair;
use fleetdyn::io::AtomicFile;
use fleetdyn::model::axle_measurement::{estimate, Measurements};
use fleetdyn::model::vehicle::{VehicleError, VehicleFile};
use fleetdyn::pipeline::axle_stage::{self, AxleStageConfig, LongitudinalSource};
use fleetdyn::pipeline::ingest_stage::{self, IngestConfig};
use fleetdyn::pipeline::resample_stage;
use fleetdyn::pipeline::run::run_plan;
use fleetdyn::pipeline::slope_stage;
use fleetdyn::pipeline::spec::PipelineSpec;
use fleetdyn::report::axle_scenario::run_scenario;
use fleetdyn::report::axle_validation::axle_summary;
use fleetdyn::report::bode::{plot_svg, BodeTable};
use fleetdyn::report::road_spectra::{write_road_spectrum, write_study};
use fleetdyn::report::spectrum;
use fleetdyn::report::validation;
use fleetdyn::report::IngestSummary;
use fleetdyn::road::profile::{
    detect_input, gnss_profile_of, read_profile_column, write_profile, GnssProfileConfig,
    ProfileInput,
};
use fleetdyn::road::road_table::{read_distance_column, write_road};
use fleetdyn::road::rules::RoadRules;
use fleetdyn::road::slope_filter::{filter_slope, SlopeEdge, SlopeFilterConfig};
use fleetdyn::road::study::{run_study, slope_spectrum, SpectrumSettings, StudyConfig, StudyError};
use fleetdyn::road::synth;
use fleetdyn::road::vdri::{cycle_profile, read_vdri};
use fleetdyn::schema::Stage;
use fleetdyn::signal::distance::{
    resample_to_distance, DistanceSource, ResampleConfig, ReversePolicy,
};
use fleetdyn::sim::axle_recorded::{AccelSource, AxleRecordConfig};
use fleetdyn::sim::axle_validate::AxleValidationConfig;
use fleetdyn::sim::validate::{validate_shuffle, ValidationConfig};
use std::path::PathBuf;
use std::process::ExitCode;

/// Prints a line to stdout; a closed pipe (`fleetdyn ... | head`) ends output quietly instead of
/// panicking.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// Like [`say!`] without the newline.
macro_rules! say_raw {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

#[derive(Parser)]
#[command(
    name = "fleetdyn",
    version,
    about = "Heavy-truck fleet logs to physics: ingest MCAP/Parquet, resample to distance, filter the road slope without phase lag, write Parquet with units."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Read one MCAP or Parquet file (or, with --dbc, the MDF4 files of one raw CAN logging
    /// session) into the canonical drive log and print a summary.
    Ingest {
        /// Input file (MCAP or Parquet; format detected from its magic bytes); with --dbc, the
        /// session's MDF4 files, concatenated in time.
        #[arg(required = true, num_args = 1..)]
        inputs: Vec<PathBuf>,
        /// DBC file(s) decoding raw CAN frames (repeat for several buses / databases).
        #[arg(long)]
        dbc: Vec<PathBuf>,
        /// Output Parquet file (canonical drive log). Without it only the summary is printed.
        #[arg(short, long)]
        output: Option<PathBuf>,
        #[command(flatten)]
        ingest: IngestArgs,
    },
    /// Ingest, then resample the drive to a uniform distance grid.
    Resample {
        /// Input file (MCAP or Parquet).
        input: PathBuf,
        /// Output Parquet file (distance log).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        ingest: IngestArgs,
        #[command(flatten)]
        resample: ResampleArgs,
    },
    /// Ingest, resample to distance and filter the road slope (seed 000 §5): zero-phase and causal
    /// Butterworth low-pass, on the distance grid and mapped back to time.
    Slope {
        /// Input file (MCAP or Parquet).
        input: PathBuf,
        /// Output folder: slope_distance.parquet and slope_time.parquet are written there.
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        ingest: IngestArgs,
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
    },
    /// Welch power spectral density of one column, in distance (1/m) or time (Hz).
    Spectrum {
        /// Input file (MCAP or Parquet).
        input: PathBuf,
        /// Output Parquet file (spectrum table).
        #[arg(short, long)]
        output: PathBuf,
        /// Column to analyse (default road_slope; slope with --from-profile).
        #[arg(long)]
        column: Option<String>,
        /// IN is a road-profile table written by `fleetdyn road profile`: analyse its column on
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
        ingest: IngestArgs,
        #[command(flatten)]
        resample: ResampleArgs,
    },
    /// Linear driveline analysis per gear (seed 000 §3): resonance peaks of F_dr -> v and
    /// M_e -> v, open and closed loop; prints the table, writes bode.parquet and bode.svg.
    Bode {
        /// Vehicle file with a [driveline] section.
        #[arg(long)]
        vehicle: PathBuf,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Simulate a recorded drive with a physics model and validate it against the recording.
    #[command(subcommand)]
    Simulate(SimulateCommand),
    /// Estimate model parameters from measurements and compare them with a vehicle file.
    #[command(subcommand)]
    Estimate(EstimateCommand),
    /// Roads (physics.md §2, seed 000 §4): synthetic roads from road-design rules, studies of
    /// their slope spectra, the spectrum of one road file, and road profiles from real tracks
    /// (GNSS fixes or VECTO driving cycles).
    #[command(subcommand)]
    Road(RoadCommand),
    /// Synthetic drives (issue 5 point 4): a driver and an AMT co-simulated with the driveline
    /// and axle models over a synthetic road, written as a CAN log (MCAP + canonical Parquet).
    #[command(subcommand)]
    Synth(SynthCommand),
    /// Diagnose where a recording and the nominal model disagree (diagnosis.md): compare, locate
    /// against the noise floor, explain with the effect catalogue (fit, held-out test, fixed
    /// acceptance rule), show. Writes diagnosis.json, mismatch.parquet, findings.parquet,
    /// report.md with residual plots, and detail.json into the output folder.
    Diagnose {
        /// Drive file (MCAP or Parquet).
        #[arg(long)]
        drive: PathBuf,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
        /// Most findings accepted (greedy rounds).
        #[arg(long, default_value_t = 3)]
        max_findings: usize,
        #[command(flatten)]
        ingest: IngestArgs,
    },
    /// The diagnosis proof: synthetic drives each hiding one catalogue effect, nothing, or an
    /// effect outside the catalogue; diagnosed blind and scored. Writes proof.md, proof.json,
    /// proof_cases.parquet and every case's drive, answer and diagnosis.
    Prove {
        /// Where the drives come from: `independent`, the independent truth plant (the proof);
        /// `model`, the diagnosis's own extended model (an inversion check).
        #[arg(long, value_enum, default_value = "independent")]
        truth: TruthArg,
        /// Number of drives (a cycle covers every effect once, four clean drives and the
        /// out-of-catalogue ones: 17 on the independent truth, 22 on the model).
        #[arg(long, default_value_t = 66)]
        drives: usize,
        /// Seed of the plan; drive i uses seed + i.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Shortest drive, km.
        #[arg(long, default_value_t = 3.0)]
        min_km: f64,
        /// Longest drive, km.
        #[arg(long, default_value_t = 6.0)]
        max_km: f64,
        /// Nominal vehicle file (default: fixtures/vehicles/truck-40t.toml on the independent
        /// truth, fixtures/vehicles/seed002-6x2-diesel.toml, which has [axles], on the model).
        #[arg(long)]
        vehicle: Option<PathBuf>,
        /// Output folder.
        #[arg(short, long, default_value = "out/proof")]
        output: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Run only these plan indices (comma separated, e.g. 49,60), each drive exactly as in
        /// the whole plan of --drives and --seed.
        #[arg(long, value_delimiter = ',')]
        cases: Vec<usize>,
        /// The drives' driving on the model truth: `drawn`, a driver drawn per drive
        /// (acceleration, braking, speed holding, torque tips, lift-offs, stop time); `fixed`,
        /// the generator's one default driver for every drive. The independent truth has its
        /// own driver and ignores it.
        #[arg(long, value_enum, default_value = "drawn")]
        driving: DrivingArg,
    },
    /// Run a pipeline file (pipelines/*.toml) over its inputs, in parallel, into a
    /// hive-partitioned dataset with a run report; drives already done with the same input and
    /// configuration are reused. Exit 1 if any drive failed.
    Run {
        /// Pipeline file.
        pipeline: PathBuf,
        /// Inputs instead of the pipeline's: files, folders (recursive), `*` globs, manifest
        /// files (`path,vehicle_id` per line). Repeatable.
        #[arg(long)]
        input: Vec<PathBuf>,
        /// Output root instead of the pipeline's output_dir.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Worker threads (default: all cores); outputs are the same bytes for any number.
        #[arg(long)]
        jobs: Option<usize>,
        /// Process only shard I of N (0-based, e.g. 2/8): inputs split by a hash of their path.
        #[arg(long)]
        shard: Option<String>,
        /// Recompute drives whose outputs are up to date.
        #[arg(long)]
        force: bool,
    },
}

#[derive(Subcommand)]
enum SimulateCommand {
    /// Driveline shuffle model (physics.md §1) on the drive's recorded engine torque, gear,
    /// clutch and slope; writes shuffle_sim.parquet and validation.parquet (RMSE, MAE, fit % of
    /// vehicle and engine speed, overall and per gear). Drift: every window starts from the
    /// measured state.
    Shuffle {
        /// Recorded drive (MCAP or Parquet).
        #[arg(long)]
        drive: PathBuf,
        /// Vehicle file with a [driveline] section.
        #[arg(long)]
        vehicle: PathBuf,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
        /// Re-initialisation window, s.
        #[arg(long, default_value_t = 30.0)]
        window_s: f64,
        /// Fast-path step, s.
        #[arg(long, default_value_t = 0.01)]
        dt_s: f64,
        /// Mapping file for the drive (chosen automatically when absent).
        #[arg(long)]
        mapping: Option<PathBuf>,
        /// Road slope input: the sensor as recorded (raw), or after the seed 000 §5 zero-phase
        /// spatial filter (filtered, default), which removes the quantisation steps that excite
        /// spurious shuffle.
        #[arg(long, value_enum, default_value = "filtered")]
        slope: SlopeInputArg,
    },
    /// Axle-load model (physics.md §3, half truck of a 6x2): either a scripted seed 002 scenario
    /// (--scenario: writes axle_sim.parquet and SVG plots of normal forces and bellow
    /// pressures), or a recorded drive (--drive: simulates it and validates the bellow
    /// pressures, and travel where recorded — MAE, RMSE, fit % per axle and segment; writes
    /// axle_sim.parquet and axle_validation.parquet).
    Axle {
        /// Recorded drive (MCAP or Parquet).
        #[arg(
            long,
            required_unless_present = "scenario",
            conflicts_with = "scenario"
        )]
        drive: Option<PathBuf>,
        /// Scripted scenario of seed 002 §4.3.
        #[arg(long, value_enum)]
        scenario: Option<AxleScenarioArg>,
        /// Vehicle file with an [axles] section.
        #[arg(long)]
        vehicle: PathBuf,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
        /// Mapping file for the drive (chosen automatically when absent).
        #[arg(long)]
        mapping: Option<PathBuf>,
        /// Road slope input: as recorded (raw) or zero-phase filtered (default).
        #[arg(long, value_enum, default_value = "filtered")]
        slope: SlopeInputArg,
        /// Acceleration input: the IMU column when present (auto), the IMU, or d(speed)/dt.
        #[arg(long, value_enum, default_value = "auto")]
        accel: AccelArg,
        /// Longitudinal inputs: the recording's, or the driveline simulation of it (end to
        /// end; needs a [driveline] section).
        #[arg(long, value_enum, default_value = "recorded")]
        longitudinal: LongitudinalArg,
        /// Acceleration separating the acceleration / steady / braking segments, m/s².
        #[arg(long, default_value_t = 0.3)]
        accel_threshold_mps2: f64,
    },
}

#[derive(Subcommand)]
enum SynthCommand {
    /// Drive a vehicle over a synthetic road (--rules) or a road file (--road-file): launches,
    /// stops (every --stop-every-km and at the road end), AMT shifts, engine brake and retarder
    /// before the service brake; writes the log (drive.mcap with CAN topics and a 1 Hz GNSS fix,
    /// or a portal export, --log-format), drive.parquet, vehicle.toml and optionally
    /// truth.parquet (--truth-rate-hz) into the output folder.
    Drive {
        /// Vehicle file with a [driveline] section; with [axles] the axle model runs and the log
        /// carries bellow pressures.
        #[arg(long)]
        vehicle: PathBuf,
        /// Rule set: a bundled name (highway-se, city-se, freeway-us, urban-us) or a TOML file.
        #[arg(
            long,
            required_unless_present = "road_file",
            conflicts_with = "road_file"
        )]
        rules: Option<String>,
        /// Road file instead of rules: a Parquet table with distance (m) and slope (tan α)
        /// columns, optionally elevation (m) — e.g. a `road synth` or `road profile` output —
        /// or a VECTO distance-based cycle (.vdri; its <grad> is used, not its <v> or <stop>).
        /// Needs --speed-limit-km-per-h.
        #[arg(long)]
        road_file: Option<PathBuf>,
        /// Start of the driven window in the road file, m from its first row.
        #[arg(long, allow_negative_numbers = true)]
        road_start_m: Option<f64>,
        /// Road length, km (with --road-file: the window's length, default to the file's end).
        #[arg(long, allow_negative_numbers = true)]
        length_km: Option<f64>,
        /// Seed of the road, the driver's variations, the GNSS track and the CAN noise.
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Speed limit, km/h (default: the rule set's design speed; needed with --road-file).
        #[arg(long)]
        speed_limit_km_per_h: Option<f64>,
        /// Follow the road file's speed limits below --speed-limit-km-per-h (a VECTO cycle's
        /// <v>, held from its row; its stops are not used).
        #[arg(long)]
        road_speed_limits: bool,
        /// Distance between planned stops, km (0: only the stop at the road end).
        #[arg(long, default_value_t = 1.0)]
        stop_every_km: f64,
        /// Standstill time at the start, at each planned stop and at the road end, s.
        #[arg(long, default_value_t = 8.0, allow_negative_numbers = true)]
        stop_dwell_s: f64,
        /// Longest drive before giving up, s (default 4 h; raise it for long-drive tests).
        #[arg(long, default_value_t = 4.0 * 3600.0, allow_negative_numbers = true)]
        max_duration_s: f64,
        /// Hide an effect of the diagnosis catalogue in the truth: `ID` (magnitude drawn from
        /// the seed), `ID=VALUE` (the parameter's truth value in its SI unit), `random` (one of
        /// the catalogue or none, by the seed) or `none`. The vehicle file written stays the
        /// nominal one; the answer goes to --answer only.
        #[arg(long)]
        effect: Option<String>,
        /// Answer file of --effect (JSON; default OUTPUT/answer.json).
        #[arg(long)]
        answer: Option<PathBuf>,
        /// Resolution of the road-slope sensor, % (1: whole percent, as production sensors send).
        #[arg(long, default_value_t = 1.0)]
        slope_resolution_percent: f64,
        /// Largest retarder torque at the propeller shaft, N·m (0: no retarder).
        #[arg(long, default_value_t = 3500.0)]
        retarder_max_torque_nm: f64,
        /// Latitude of the road's start for the GNSS track, WGS84 deg.
        #[arg(long, default_value_t = 57.7, allow_negative_numbers = true)]
        gnss_origin_lat_deg: f64,
        /// Longitude of the road's start for the GNSS track, WGS84 deg.
        #[arg(long, default_value_t = 11.9, allow_negative_numbers = true)]
        gnss_origin_lon_deg: f64,
        /// Log format: mcap (drive.mcap, multi-rate JSON topics), portal-export
        /// (drive-export.parquet: wide 20 Hz fleet-portal export, mapping fleet-portal-export)
        /// or long-export (drive-long.parquet: ts, signal, value; mapping j1939-long-export).
        #[arg(long, value_enum, default_value = "mcap")]
        log_format: LogFormatArg,
        /// Chunk compression of an MCAP log.
        #[arg(long, value_enum, default_value = "zstd")]
        mcap_compression: McapCompressionArg,
        /// Compression level of an MCAP log's chunks (0: the encoder's default; zstd 1-22,
        /// lz4 1-12, from 3 its high-compression mode).
        #[arg(long, default_value_t = 0)]
        mcap_compression_level: u32,
        /// Drive id in the log's metadata (default synth-ROAD-LENGTHkm-seedSEED).
        #[arg(long)]
        drive_id: Option<String>,
        /// Vehicle id in the log's metadata (default: the vehicle file's).
        #[arg(long)]
        vehicle_id: Option<String>,
        /// Start of the drive, RFC 3339 UTC (default 2024-01-01T00:00:00Z).
        #[arg(long)]
        start_utc: Option<String>,
        /// Logger timestamp jitter, s: each frame's log time is its sample time plus a uniform
        /// delay in ±this, in whole µs (0: none).
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        timestamp_jitter_s: f64,
        /// Canonical columns whose CAN messages get dropouts (comma separated, e.g.
        /// vehicle_speed,road_slope).
        #[arg(long, value_delimiter = ',')]
        dropout_columns: Vec<String>,
        /// Probability that a dropout starts at a scheduled message of --dropout-columns.
        #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
        dropout_start_probability: f64,
        /// Mean dropout length, s (exponentially distributed).
        #[arg(long, default_value_t = 0.3, allow_negative_numbers = true)]
        dropout_mean_length_s: f64,
        /// Write truth.parquet, the drive's pre-sensor signals (SI, canonical names, plus
        /// distance) at this rate, Hz (a whole divisor of 100 Hz).
        #[arg(long, allow_negative_numbers = true)]
        truth_rate_hz: Option<f64>,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LogFormatArg {
    Mcap,
    PortalExport,
    LongExport,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum McapCompressionArg {
    Zstd,
    Lz4,
}

#[derive(Subcommand)]
enum RoadCommand {
    /// Generate one synthetic road (constant grades joined by parabolic vertical curves
    /// z = x²/(2R), seed 000 eqs. (34)-(36)) and write distance, elevation and slope on a
    /// uniform grid as Parquet.
    Synth {
        /// Rule set: a bundled name (highway-se, city-se, freeway-us, urban-us) or a TOML file
        /// of the same keys (schemas/roads/*.toml).
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
    },
    /// Slope spectra of N random roads (seeds seed..seed+N-1) in parallel: PSD percentile bands
    /// (5/50/95 %) per frequency, the 90 % and 99 % knees of every road, and the slope filter's
    /// response. Writes road_study_psd.parquet, road_study_knees.parquet and road_study.svg.
    Study {
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
        #[arg(long)]
        threads: Option<usize>,
        /// Output folder.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Slope spectrum of one road file: any Parquet with a uniform `distance` grid (m) and a
    /// slope column (a `road synth` output, or slope_distance.parquet of `fleetdyn slope`).
    /// Writes road_spectrum.parquet and road_spectrum.svg.
    Spectrum {
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
    },
    /// Road profile on a uniform distance grid: distance, elevation, smoothed elevation, slope
    /// (tan α), latitude and longitude. IN is a GNSS track (MCAP or Parquet, read by ingest:
    /// latitude, longitude, altitude; vehicle_speed gates standstill) or a VECTO distance-based
    /// driving cycle (.vdri CSV: elevation integrated from <grad> %), recognised by content.
    /// Bad input (no GNSS columns, fewer than 3 fixes, a malformed .vdri) exits 2, no output.
    Profile {
        /// Input: MCAP, Parquet or .vdri.
        input: PathBuf,
        /// Output Parquet file (road_profile table).
        #[arg(short, long)]
        output: PathBuf,
        /// Distance grid step, m.
        #[arg(long, default_value_t = 1.0)]
        step_m: f64,
        /// Cut-off wavelength of the zero-phase elevation low-pass, m (GNSS tracks only;
        /// default 300 m, chosen on the measured car drive: see src/road/profile.rs).
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
        /// Drop elevation fixes whose reported accuracy (column altitude_accuracy_m, when the
        /// input has it) is worse than this, m.
        #[arg(long, default_value_t = 5.0)]
        max_elevation_accuracy_m: f64,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum TruthArg {
    Independent,
    Model,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum DrivingArg {
    Drawn,
    Fixed,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum AxleScenarioArg {
    FullAcceleration,
    AuxBraking,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum AccelArg {
    Auto,
    Imu,
    Speed,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LongitudinalArg {
    Recorded,
    Driveline,
}

#[derive(Subcommand)]
enum EstimateCommand {
    /// Axle-model parameters (seed 002 §3.3, physics.md §3) from scale weights, static bellow
    /// pressures, bellow force-displacement tests and damper datasheets, with the vehicle file's
    /// axle positions, arm levers and axle masses: total mass and CG, chassis mass and CG, static
    /// bellow forces, effective bellow areas, bellow stiffness, damper coefficients. Prints each
    /// estimate beside the vehicle file's value.
    Axle {
        /// Measurement file (TOML: [scale], [static_pressure], [[bellow_test]],
        /// [[damper_datasheet]]; example fixtures/measurements/seed002-static.toml).
        measurements: PathBuf,
        /// Vehicle file with an [axles] section.
        #[arg(long)]
        vehicle: PathBuf,
        /// Write the estimates as a TOML snippet of [axles] keys, to replace those in the
        /// vehicle file (checked against it first; written atomically).
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum SlopeInputArg {
    Raw,
    Filtered,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum EdgeArg {
    Matched,
    Scipy,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum DomainArg {
    Distance,
    Time,
}

#[derive(Args)]
struct IngestArgs {
    /// Mapping file (schemas/mappings/*.toml); chosen automatically when absent.
    #[arg(long)]
    mapping: Option<PathBuf>,
    /// Stages the drive must be usable for (their required columns are checked), comma separated:
    /// ingest, resample, slope, driveline, axle.
    #[arg(long, value_delimiter = ',', default_value = "ingest")]
    stages: Vec<String>,
    /// Time base for multi-rate sources, Hz (default: the fastest channel's rate).
    #[arg(long)]
    time_base_hz: Option<f64>,
    /// Longest accepted run of missing values in a required column, s.
    #[arg(long, default_value_t = 2.0)]
    max_nan_run_s: f64,
    /// What to do when time goes backwards.
    #[arg(long, value_enum, default_value = "error")]
    time_repair: TimeRepairArg,
    /// Vehicle file (its gearbox bounds the gear column; its id is recorded).
    #[arg(long)]
    vehicle: Option<PathBuf>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum TimeRepairArg {
    Error,
    Sort,
}

#[derive(Args)]
struct ResampleArgs {
    /// Distance grid step, m.
    #[arg(long, default_value_t = 1.0)]
    step_m: f64,
    /// Distance source: auto (odometer if fine enough, else the speed integral), odometer, speed.
    #[arg(long, value_enum, default_value = "auto")]
    distance_source: DistanceSourceArg,
    /// Reverse motion: error (fail the drive) or exclude (no distance, collapsed).
    #[arg(long, value_enum, default_value = "error")]
    reverse: ReverseArg,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum DistanceSourceArg {
    Auto,
    Odometer,
    Speed,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum ReverseArg {
    Error,
    Exclude,
}

/// A failure and the exit code it maps to.
struct Failure {
    code: u8,
    error: anyhow::Error,
}

/// The slope column a simulation uses: `None` for the raw sensor (or a log without one), else
/// the seed 000 §5 zero-phase filtered slope, added to the log as `road_slope_filtered`.
fn slope_input(
    log: &mut fleetdyn::table::DriveLog,
    slope: SlopeInputArg,
) -> anyhow::Result<Option<String>> {
    if matches!(slope, SlopeInputArg::Raw) || log.signal("road_slope").is_none() {
        return Ok(None);
    }
    let d = resample_to_distance(log, &ResampleConfig::default())?;
    let f = filter_slope(&d, &SlopeFilterConfig::default())?;
    log.signals.push(fleetdyn::table::Signal {
        name: "road_slope_filtered".into(),
        unit: "1".into(),
        values: f.zero_phase_time,
    });
    Ok(Some("road_slope_filtered".to_string()))
}

fn usage(e: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 2,
        error: e.into(),
    }
}

fn drive(e: impl Into<anyhow::Error>) -> Failure {
    Failure {
        code: 1,
        error: e.into(),
    }
}

impl IngestArgs {
    fn resolve(
        &self,
        extra_stages: &[Stage],
    ) -> Result<(IngestConfig, fleetdyn::ingest::IngestOptions), Failure> {
        let mut stages = Vec::new();
        for s in &self.stages {
            stages.push(Stage::parse(s).ok_or_else(|| {
                usage(anyhow::anyhow!(
                    "unknown stage {s:?} (ingest, resample, slope, driveline, axle)"
                ))
            })?);
        }
        stages.extend_from_slice(extra_stages);
        let vehicle = match &self.vehicle {
            Some(p) => Some(VehicleFile::load(p).map_err(usage)?),
            None => None,
        };
        let cfg = IngestConfig {
            mapping: self.mapping.clone(),
            time_base_hz: self.time_base_hz,
            max_nan_run_s: self.max_nan_run_s,
            time_repair: match self.time_repair {
                TimeRepairArg::Error => TimeRepair::Error,
                TimeRepairArg::Sort => TimeRepair::Sort,
            },
        };
        let opts = cfg.options(&stages, vehicle.as_ref()).map_err(usage)?;
        Ok((cfg, opts))
    }
}

impl ResampleArgs {
    fn config(&self) -> ResampleConfig {
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

fn run_diagnose(
    drive_path: PathBuf,
    output: PathBuf,
    max_findings: usize,
    ingest: IngestArgs,
) -> Result<(), Failure> {
    use fleetdyn::diagnose::run::{diagnose, write_outputs, DiagnoseConfig};
    let Some(vehicle_path) = ingest.vehicle.clone() else {
        return Err(usage(anyhow::anyhow!(
            "diagnose needs --vehicle FILE: the nominal model the recording is compared with"
        )));
    };
    let vehicle = VehicleFile::load(&vehicle_path).map_err(usage)?;
    let (cfg, opts) = ingest.resolve(&[])?;
    let ing = ingest_stage::run(&drive_path, &opts).map_err(drive)?;
    let dcfg = DiagnoseConfig {
        max_findings,
        ..DiagnoseConfig::default()
    };
    let t0 = std::time::Instant::now();
    let d = diagnose(&ing.log, &vehicle, &dcfg).map_err(drive)?;
    let fp = format!(
        "{}\nvehicle {}\nmax_findings {max_findings}",
        cfg.fingerprint(&opts),
        vehicle_path.display()
    );
    let w = write_outputs(&output, &d, &ing.log, &fp).map_err(drive)?;
    let dg = &d.diagnosis;
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

#[allow(clippy::too_many_arguments)]
fn run_prove(
    truth: TruthArg,
    drives: usize,
    seed: u64,
    min_km: f64,
    max_km: f64,
    vehicle: Option<PathBuf>,
    output: PathBuf,
    jobs: Option<usize>,
    cases: Vec<usize>,
    driving: DrivingArg,
) -> Result<(), Failure> {
    use fleetdyn::proof::{run_proof, Driving, ProofConfig};
    let base = match truth {
        TruthArg::Independent => ProofConfig::independent(),
        TruthArg::Model => ProofConfig::model(),
    };
    let vehicle = vehicle.unwrap_or_else(|| {
        PathBuf::from(match truth {
            TruthArg::Independent => "fixtures/vehicles/truck-40t.toml",
            TruthArg::Model => "fixtures/vehicles/seed002-6x2-diesel.toml",
        })
    });
    if !(min_km.is_finite() && max_km.is_finite() && 0.5 <= min_km && min_km <= max_km) {
        return Err(usage(anyhow::anyhow!(
            "--min-km {min_km} and --max-km {max_km} must be finite with 0.5 <= min <= max"
        )));
    }
    if drives == 0 {
        return Err(usage(anyhow::anyhow!("--drives must be at least 1")));
    }
    if let Some(c) = cases.iter().find(|&&c| c >= drives) {
        return Err(usage(anyhow::anyhow!(
            "--cases {c} is not in the plan of --drives {drives} (indices 0 to {})",
            drives - 1
        )));
    }
    let cfg = ProofConfig {
        drives,
        seed,
        length_km: (min_km, max_km),
        only: cases,
        driving: match driving {
            DrivingArg::Drawn => Driving::Drawn,
            DrivingArg::Fixed => Driving::Fixed,
        },
        ..base
    };
    let jobs = jobs.unwrap_or_else(|| {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    });
    let t0 = std::time::Instant::now();
    let progress = |done: usize, total: usize| {
        eprintln!(
            "prove: {done}/{total} drives ({:.0} s)",
            t0.elapsed().as_secs_f64()
        )
    };
    let run = run_proof(&cfg, &vehicle, &output, jobs, &progress).map_err(usage)?;
    say!("{}", run.summary.to_markdown());
    for f in &run.failed {
        say!(
            "case {} ({}) failed at {}: {}",
            f.index,
            f.hidden,
            f.stage,
            f.error
        );
    }
    say!(
        "wrote     {} ({} drives, {} jobs, {:.0} s)",
        output.join("proof.md").display(),
        run.summary.drives,
        jobs,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

fn run(cli: Cli) -> Result<(), Failure> {
    match cli.command {
        Command::Diagnose {
            drive: d,
            output,
            max_findings,
            ingest,
        } => run_diagnose(d, output, max_findings, ingest),
        Command::Prove {
            truth,
            drives,
            seed,
            min_km,
            max_km,
            vehicle,
            output,
            jobs,
            cases,
            driving,
        } => run_prove(
            truth, drives, seed, min_km, max_km, vehicle, output, jobs, cases, driving,
        ),
        Command::Ingest {
            inputs,
            dbc,
            output,
            ingest,
        } => {
            let (cfg, opts) = ingest.resolve(&[])?;
            let mut fingerprint = cfg.fingerprint(&opts);
            let ing = if dbc.is_empty() {
                let [input] = inputs.as_slice() else {
                    return Err(usage(anyhow::anyhow!(
                        "{} inputs: several files are one raw CAN session and need --dbc",
                        inputs.len()
                    )));
                };
                ingest_stage::run(input, &opts).map_err(drive)?
            } else {
                let texts = dbc
                    .iter()
                    .map(std::fs::read)
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(usage)?;
                let parts: Vec<&[u8]> = texts.iter().map(Vec::as_slice).collect();
                fingerprint.push_str(&format!("\ndbc {}", fleetdyn::io::config_hash(&parts)));
                fleetdyn::ingest::can::ingest_session(&inputs, &dbc, &opts).map_err(drive)?
            };
            say_raw!("{}", IngestSummary::new(&ing));
            if let Some(out) = output {
                ingest_stage::write(&out, &ing.log, &fingerprint).map_err(drive)?;
                say!("wrote     {}", out.display());
            }
            Ok(())
        }
        Command::Resample {
            input,
            output,
            ingest,
            resample,
        } => {
            let (cfg, opts) = ingest.resolve(&[Stage::Resample])?;
            let rcfg = resample.config();
            let ing = ingest_stage::run(&input, &opts).map_err(drive)?;
            let d = resample_to_distance(&ing.log, &rcfg).map_err(drive)?;
            let fp = format!(
                "{}\n{}",
                cfg.fingerprint(&opts),
                resample_stage::fingerprint(&rcfg)
            );
            resample_stage::write(&output, &d, &fp).map_err(drive)?;
            say!(
                "{}: {:.3} km on a {} m grid ({} points, distance from {:?}, {} samples collapsed) -> {}",
                d.meta.drive_id,
                d.map.total_m() / 1000.0,
                d.step_m,
                d.distance_m.len(),
                d.map.source,
                d.collapsed_samples,
                output.display()
            );
            Ok(())
        }
        Command::Slope {
            input,
            output,
            ingest,
            resample,
            cutoff_per_m,
            order,
            edge,
        } => {
            let (cfg, opts) = ingest.resolve(&[Stage::Resample, Stage::Slope])?;
            let rcfg = resample.config();
            let scfg = SlopeFilterConfig {
                cutoff_per_m,
                order,
                edge: match edge {
                    EdgeArg::Matched => SlopeEdge::Matched,
                    EdgeArg::Scipy => SlopeEdge::Scipy,
                },
                ..Default::default()
            };
            let ing = ingest_stage::run(&input, &opts).map_err(drive)?;
            let d = resample_to_distance(&ing.log, &rcfg).map_err(drive)?;
            let f = filter_slope(&d, &scfg).map_err(drive)?;
            let fp = format!(
                "{}\n{}\n{}",
                cfg.fingerprint(&opts),
                resample_stage::fingerprint(&rcfg),
                slope_stage::fingerprint(&scfg)
            );
            let (a, b) = (
                output.join("slope_distance.parquet"),
                output.join("slope_time.parquet"),
            );
            slope_stage::write(&a, &b, &ing.log, &d, &f, &scfg, &fp).map_err(drive)?;
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
        Command::Spectrum {
            input,
            output,
            column,
            from_profile,
            domain,
            nperseg,
            confidence,
            ingest,
            resample,
        } => {
            if from_profile {
                if matches!(domain, DomainArg::Time) {
                    return Err(usage(anyhow::anyhow!(
                        "--from-profile: a road profile is on a distance grid; use --domain distance"
                    )));
                }
                let column = column.unwrap_or_else(|| "slope".into());
                let pc = read_profile_column(&input, &column).map_err(usage)?;
                let sp = spectrum::of_grid(
                    &pc.meta.source_file,
                    &column,
                    &pc.unit,
                    &pc.values,
                    pc.step_m,
                    nperseg,
                    confidence,
                )
                .map_err(drive)?;
                let fp = format!(
                    "spectrum:v1 from_profile step_m={} {column} {nperseg:?} {confidence}",
                    pc.step_m
                );
                spectrum::write(&output, &pc.meta, &sp, &fp).map_err(drive)?;
                say!(
                    "{}: {} PSD on the profile's {} m grid, {} segments of {} samples (equivalent dof {:.1}); 90 % of power below {:.3e} {}, 99 % below {:.3e} {} -> {}",
                    pc.meta.drive_id, column, pc.step_m, sp.psd.n_segments, sp.psd.nperseg, sp.psd.dof,
                    sp.knee_90, sp.freq_unit, sp.knee_99, sp.freq_unit, output.display()
                );
                return Ok(());
            }
            let column = column.unwrap_or_else(|| "road_slope".into());
            let (cfg, opts) = ingest.resolve(&[Stage::Resample])?;
            let rcfg = resample.config();
            let ing = ingest_stage::run(&input, &opts).map_err(drive)?;
            let sp = match domain {
                DomainArg::Distance => {
                    let d = resample_to_distance(&ing.log, &rcfg).map_err(drive)?;
                    spectrum::of_distance_log(&d, &column, nperseg, confidence)
                }
                DomainArg::Time => spectrum::of_drive_log(&ing.log, &column, nperseg, confidence),
            }
            .map_err(drive)?;
            let fp = format!(
                "{}\n{}\nspectrum:v1 {column} {nperseg:?} {confidence}",
                cfg.fingerprint(&opts),
                resample_stage::fingerprint(&rcfg)
            );
            spectrum::write(&output, &ing.log.meta, &sp, &fp).map_err(drive)?;
            say!(
                "{}: {} PSD, {} segments of {} samples (equivalent dof {:.1}); 90 % of power below {:.3e} {}, 99 % below {:.3e} {} -> {}",
                ing.log.meta.drive_id, column, sp.psd.n_segments, sp.psd.nperseg, sp.psd.dof,
                sp.knee_90, sp.freq_unit, sp.knee_99, sp.freq_unit, output.display()
            );
            Ok(())
        }
        Command::Bode { vehicle, output } => {
            let v = VehicleFile::load(&vehicle).map_err(usage)?;
            let p = v.driveline(&vehicle.display().to_string()).map_err(usage)?;
            let table = BodeTable::new(&v.vehicle_id, p, &v.gearbox.ratios);
            say_raw!("{table}");
            match table.open_loop_peak_gone_from() {
                Some(g) => say!("open-loop F_dr -> v resonance: no peak from gear {g} on"),
                None => say!("open-loop F_dr -> v resonance: a peak in every gear"),
            }
            let fp = format!("bode:v1 {:?} {:?}", p, v.gearbox.ratios);
            let (pq, svg) = (output.join("bode.parquet"), output.join("bode.svg"));
            table.write(&pq, &fp).map_err(drive)?;
            plot_svg(&svg, p, &v.gearbox.ratios, &table).map_err(|e| drive(anyhow::anyhow!(e)))?;
            say!("wrote {} and {}", pq.display(), svg.display());
            Ok(())
        }
        Command::Simulate(SimulateCommand::Shuffle {
            drive: input,
            vehicle,
            output,
            window_s,
            dt_s,
            mapping,
            slope,
        }) => {
            let v = VehicleFile::load(&vehicle).map_err(usage)?;
            let p = v.driveline(&vehicle.display().to_string()).map_err(usage)?;
            if !(window_s > 0.0 && dt_s > 0.0 && dt_s < window_s) {
                return Err(usage(anyhow::anyhow!(
                    "--window-s and --dt-s must be positive with dt_s < window_s"
                )));
            }
            let cfg = IngestConfig {
                mapping,
                ..Default::default()
            };
            let opts = cfg.options(&[Stage::Driveline], Some(&v)).map_err(usage)?;
            let mut ing = ingest_stage::run(&input, &opts).map_err(drive)?;
            let slope_column = slope_input(&mut ing.log, slope).map_err(drive)?;
            let slope_column = slope_column.as_deref();
            let vcfg = ValidationConfig {
                window_s,
                dt_s,
                ..Default::default()
            };
            let val = validate_shuffle(&ing.log, p, &v.gearbox.ratios, slope_column, &vcfg)
                .map_err(drive)?;
            let fp = format!(
                "{}\nshuffle:v1 {:?} {:?} {:?} slope={:?}",
                cfg.fingerprint(&opts),
                p,
                v.gearbox.ratios,
                vcfg,
                slope_column
            );
            validation::write(&output, &ing.log, &val, &fp).map_err(drive)?;
            say!("{}: driveline simulation vs recording (windows of {window_s} s re-initialised from the measured state; slope from {})", ing.log.meta.drive_id, val.slope_column.as_deref().unwrap_or("none: flat road"));
            say_raw!("{}", validation::summary(&val));
            say!(
                "wrote {} and {}",
                output.join("shuffle_sim.parquet").display(),
                output.join("validation.parquet").display()
            );
            Ok(())
        }
        Command::Simulate(SimulateCommand::Axle {
            drive: drive_path,
            scenario,
            vehicle,
            output,
            mapping,
            slope,
            accel,
            longitudinal,
            accel_threshold_mps2,
        }) => {
            let v = VehicleFile::load(&vehicle).map_err(usage)?;
            let vname = vehicle.display().to_string();
            let p = v.axles(&vname).map_err(usage)?;
            if let Some(sc) = scenario {
                let name = match sc {
                    AxleScenarioArg::FullAcceleration => "full-acceleration",
                    AxleScenarioArg::AuxBraking => "aux-braking",
                };
                let rep = run_scenario(name, p, &v.vehicle_id, &output).map_err(drive)?;
                say_raw!("{rep}");
                return Ok(());
            }
            let input = drive_path.expect("clap requires --drive without --scenario");
            if !(accel_threshold_mps2.is_finite() && accel_threshold_mps2 > 0.0) {
                return Err(usage(anyhow::anyhow!(
                    "--accel-threshold-mps2 must be positive"
                )));
            }
            let cfg = IngestConfig {
                mapping,
                ..Default::default()
            };
            let opts = cfg.options(&[], Some(&v)).map_err(usage)?;
            let mut ing = ingest_stage::run(&input, &opts).map_err(drive)?;
            let slope_column = slope_input(&mut ing.log, slope).map_err(drive)?;
            let scfg = AxleStageConfig {
                validation: AxleValidationConfig {
                    record: AxleRecordConfig {
                        accel: match accel {
                            AccelArg::Auto => AccelSource::Auto,
                            AccelArg::Imu => AccelSource::Imu,
                            AccelArg::Speed => AccelSource::Speed,
                        },
                        ..Default::default()
                    },
                    accel_threshold_mps2,
                },
                longitudinal: match longitudinal {
                    LongitudinalArg::Recorded => LongitudinalSource::Recorded,
                    LongitudinalArg::Driveline => LongitudinalSource::Driveline,
                },
                slope_column,
            };
            let val = axle_stage::run(&ing.log, &v, &vname, &scfg).map_err(|e| match e {
                // a vehicle file without the section the mode needs is a configuration error
                axle_stage::AxleStageError::Vehicle(_) => usage(e),
                _ => drive(e),
            })?;
            let fp = format!("{}\naxle:v1 {:?} {:?}", cfg.fingerprint(&opts), p, scfg);
            axle_stage::write(&output, &ing.log, &val, p.gravity_m_per_s2, &fp).map_err(drive)?;
            say!(
                "{}: axle-load model vs recording (acceleration from {}; slope from {}; {})",
                ing.log.meta.drive_id,
                val.recorded.accel_source,
                val.recorded
                    .slope_column
                    .as_deref()
                    .unwrap_or("none: flat road"),
                if val.recorded.torque_inputs {
                    "torque inputs"
                } else {
                    "acceleration only"
                }
            );
            say_raw!("{}", axle_summary(&val));
            say!(
                "wrote {} and {}",
                output.join("axle_sim.parquet").display(),
                output.join("axle_validation.parquet").display()
            );
            Ok(())
        }
        Command::Estimate(EstimateCommand::Axle {
            measurements,
            vehicle,
            output,
        }) => {
            let vehicle_file = vehicle.display().to_string();
            let vehicle_text = std::fs::read_to_string(&vehicle).map_err(|source| {
                usage(VehicleError::Io {
                    file: vehicle_file.clone(),
                    source,
                })
            })?;
            let v = VehicleFile::parse(&vehicle_text, &vehicle_file).map_err(usage)?;
            let p = v.axles(&vehicle_file).map_err(usage)?;
            let m = Measurements::load(&measurements).map_err(usage)?;
            let est = estimate(&m, p, &vehicle_file).map_err(usage)?;
            say!(
                "{}: axle-model parameters from {} (seed 002 §3.3) beside {}",
                v.vehicle_id,
                m.file,
                vehicle_file
            );
            say_raw!("{}", est.comparison(p));
            if let Some(out) = output {
                // never write a snippet that would break the vehicle file
                est.merged_vehicle(&vehicle_text, &vehicle_file)
                    .map_err(usage)?;
                let write = || -> std::io::Result<()> {
                    use std::io::Write as _;
                    let mut f = AtomicFile::create(&out)?;
                    f.file().write_all(est.snippet().as_bytes())?;
                    f.commit()
                };
                write().map_err(|e| drive(anyhow::anyhow!("{}: {e}", out.display())))?;
                say!("wrote {}", out.display());
            }
            Ok(())
        }
        Command::Road(cmd) => run_road(cmd),
        Command::Synth(SynthCommand::Drive {
            vehicle,
            rules,
            road_file,
            road_start_m,
            length_km,
            seed,
            speed_limit_km_per_h,
            road_speed_limits,
            stop_every_km,
            stop_dwell_s,
            max_duration_s,
            effect,
            answer,
            slope_resolution_percent,
            retarder_max_torque_nm,
            gnss_origin_lat_deg,
            gnss_origin_lon_deg,
            log_format,
            mcap_compression,
            mcap_compression_level,
            drive_id,
            vehicle_id,
            start_utc,
            timestamp_jitter_s,
            dropout_columns,
            dropout_start_probability,
            dropout_mean_length_s,
            truth_rate_hz,
            output,
        }) => {
            use fleetdyn::synth::drive::{
                synth_drive_logged, DriveConfig, DriveError, HiddenEffect,
            };
            use fleetdyn::synth::effects::{EffectChoice, EffectError};
            use fleetdyn::synth::export::ExportError;
            use fleetdyn::synth::log_writer::{DropoutSpec, LogFormat, LogOptions};
            use fleetdyn::synth::retarder::RetarderConfig;
            use fleetdyn::synth::road_source::{RoadSource, RoadSourceError};
            use fleetdyn::synth::{Dropouts, McapCompression, SynthError};
            let mut cfg = DriveConfig::default();
            cfg.driver.speed_limit_mps = speed_limit_km_per_h.map(|k| k / 3.6);
            cfg.driver.stop_every_m = (stop_every_km > 0.0).then_some(stop_every_km * 1000.0);
            cfg.slope_resolution = slope_resolution_percent / 100.0;
            if !(stop_dwell_s.is_finite() && stop_dwell_s >= 0.0) {
                return Err(usage(anyhow::anyhow!(
                    "--stop-dwell-s {stop_dwell_s} must be finite and >= 0"
                )));
            }
            cfg.driver.stop_dwell_s = stop_dwell_s;
            cfg.max_duration_s = max_duration_s;
            cfg.road_speed_limits = road_speed_limits;
            let p = dropout_start_probability;
            if !(0.0..=1.0).contains(&p) {
                return Err(usage(anyhow::anyhow!(
                    "--dropout-start-probability {p} must be in [0, 1]"
                )));
            }
            if !(dropout_mean_length_s.is_finite() && dropout_mean_length_s >= 0.0) {
                return Err(usage(anyhow::anyhow!(
                    "--dropout-mean-length-s {dropout_mean_length_s} must be finite and >= 0"
                )));
            }
            if p > 0.0 && dropout_columns.is_empty() {
                return Err(usage(anyhow::anyhow!(
                    "--dropout-start-probability needs --dropout-columns"
                )));
            }
            let log = LogOptions {
                format: match log_format {
                    LogFormatArg::Mcap => LogFormat::Mcap(match mcap_compression {
                        McapCompressionArg::Zstd => McapCompression::Zstd,
                        McapCompressionArg::Lz4 => McapCompression::Lz4,
                    }),
                    LogFormatArg::PortalExport => LogFormat::PortalExport,
                    LogFormatArg::LongExport => LogFormat::LongExport,
                },
                mcap_compression_level,
                drive_id,
                vehicle_id,
                start_ns: start_utc
                    .as_deref()
                    .map(fleetdyn::time_fmt::parse_rfc3339_utc_ns)
                    .transpose()
                    .map_err(usage)?,
                timestamp_jitter_s,
                dropouts: (!dropout_columns.is_empty()).then_some(DropoutSpec {
                    columns: dropout_columns,
                    dropouts: Dropouts {
                        start_probability: p,
                        mean_length_s: dropout_mean_length_s,
                    },
                }),
                truth_rate_hz,
            };
            if !(retarder_max_torque_nm.is_finite() && retarder_max_torque_nm >= 0.0) {
                return Err(usage(anyhow::anyhow!(
                    "--retarder-max-torque-nm {retarder_max_torque_nm} must be finite and >= 0"
                )));
            }
            cfg.driver.retarder = (retarder_max_torque_nm > 0.0).then(|| RetarderConfig {
                max_torque_nm: retarder_max_torque_nm,
                ..RetarderConfig::default()
            });
            if let Some(g) = cfg.gnss.as_mut() {
                g.origin_lat_deg = gnss_origin_lat_deg;
                g.origin_lon_deg = gnss_origin_lon_deg;
            }
            let road = match (rules, road_file) {
                (Some(_), None) if road_start_m.is_some() => {
                    return Err(usage(anyhow::anyhow!(
                        "--road-start-m applies to --road-file, not to --rules"
                    )))
                }
                (Some(rules), None) => RoadSource::Rules {
                    rules,
                    length_km: length_km
                        .ok_or_else(|| usage(anyhow::anyhow!("--rules needs --length-km")))?,
                },
                (None, Some(path)) => RoadSource::File {
                    path,
                    start_m: road_start_m.unwrap_or(0.0),
                    length_km,
                },
                _ => {
                    return Err(usage(anyhow::anyhow!(
                        "give exactly one of --rules and --road-file"
                    )))
                }
            };
            let hidden = match &effect {
                None => None,
                Some(e) => Some(HiddenEffect {
                    choice: EffectChoice::parse(e).map_err(usage)?,
                    answer_path: answer.unwrap_or_else(|| output.join("answer.json")),
                }),
            };
            let r = synth_drive_logged(&vehicle, &road, seed, &output, &cfg, hidden.as_ref(), &log)
                .map_err(|e| match e {
                    DriveError::Io { .. }
                    | DriveError::Can(_)
                    | DriveError::Effect(EffectError::Io { .. })
                    | DriveError::RoadFile(RoadSourceError::Io { .. }) => drive(e),
                    DriveError::Export(
                        ExportError::BadInput { .. }
                        | ExportError::Mismatch { .. }
                        | ExportError::Mapping { .. }
                        | ExportError::Can(SynthError::BadCompressionLevel { .. }),
                    ) => usage(e),
                    DriveError::Export(_) => drive(e),
                    _ => usage(e),
                })?;
            if let Some(h) = &hidden {
                say!("answer (hidden effect) -> {}", h.answer_path.display());
            }
            let d = &r.drive;
            let vmax = d.speed_mps.iter().fold(0.0f64, |m, &v| m.max(v));
            let ret_max = d.retarder_torque_nm.iter().fold(0.0f64, |m, &v| m.max(v));
            let me_min = d.engine_torque_nm.iter().fold(0.0f64, |m, &v| m.min(v));
            say!(
                "{:.3} km drive over {}, seed {}: {:.1} s, {} launches, {} shifts, max {:.1} km/h, {:.0} m travelled, engine torque down to {:.0} N·m, retarder up to {:.0} N·m -> {}, {}, {}{}",
                r.road.length_m / 1000.0, r.road.label, seed, d.t_s.last().copied().unwrap_or(0.0),
                d.launches.len(), d.shifts.len(), vmax * 3.6,
                d.distance_m.last().copied().unwrap_or(0.0), me_min, ret_max,
                r.log_file.display(), r.parquet.display(), r.vehicle.display(),
                r.truth_file.as_ref().map(|p| format!(", {}", p.display())).unwrap_or_default()
            );
            Ok(())
        }
        Command::Run {
            pipeline,
            input,
            out,
            jobs,
            shard,
            force,
        } => run_pipeline(pipeline, input, out, jobs, shard, force),
    }
}

/// `fleetdyn run`: plan errors exit 2 (every problem listed), a failed drive exits 1.
fn run_pipeline(
    pipeline: PathBuf,
    input: Vec<PathBuf>,
    out: Option<PathBuf>,
    jobs: Option<usize>,
    shard: Option<String>,
    force: bool,
) -> Result<(), Failure> {
    use fleetdyn::pipeline::run::{DriveOutcome, DriveStatus, RunOptions, Shard};
    use std::io::IsTerminal as _;
    let shard = shard
        .map(|s| Shard::parse(&s))
        .transpose()
        .map_err(|e| usage(anyhow::anyhow!(e)))?;
    let jobs = match jobs {
        Some(0) => return Err(usage(anyhow::anyhow!("--jobs must be at least 1"))),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let spec = PipelineSpec::load(&pipeline).map_err(usage)?;
    let inputs = (!input.is_empty()).then_some(input.as_slice());
    let plan = spec
        .plan(&pipeline.display().to_string(), inputs)
        .map_err(usage)?;
    let out_root = out.unwrap_or_else(|| plan.spec.output_dir.clone());
    let mine = plan
        .inputs
        .iter()
        .filter(|it| shard.is_none_or(|s| s.owns(&it.path)))
        .count();
    let tty = std::io::stderr().is_terminal();
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
        out_root.display(),
        jobs
    );
    let bar = tty.then(|| {
        let b = indicatif::ProgressBar::new(mine as u64);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} drives {msg} [{elapsed_precise}, eta {eta}]",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let counts = std::sync::Mutex::new((0usize, 0usize, 0u64, std::time::Instant::now()));
    let on_drive = |o: &DriveOutcome| {
        let mut c = counts.lock().unwrap_or_else(|p| p.into_inner());
        if o.status == DriveStatus::Failed {
            c.1 += 1;
        } else {
            c.0 += 1;
        }
        if o.status == DriveStatus::Ok {
            c.2 += o.record.as_ref().map_or(0, |r| r.metrics.rows);
        }
        let rate = c.2 as f64 / c.3.elapsed().as_secs_f64().max(1e-9);
        match &bar {
            Some(b) => {
                b.set_message(format!("({} failed, {:.0} rows/s)", c.1, rate));
                if let Some(e) = &o.error {
                    b.println(format!(
                        "FAILED {} at {}: {e}",
                        o.drive_id,
                        o.failed_stage.unwrap_or("?")
                    ));
                }
                b.inc(1);
            }
            None => match &o.error {
                None => tracing::info!(
                    "{:?} {} {:.3} s ({}/{} done, {} failed, {:.0} rows/s) {}",
                    o.status,
                    o.drive_id,
                    o.elapsed_s,
                    c.0 + c.1,
                    mine,
                    c.1,
                    rate,
                    o.input
                ),
                Some(e) => tracing::warn!(
                    "FAILED {} at {}: {e} ({}/{} done)",
                    o.drive_id,
                    o.failed_stage.unwrap_or("?"),
                    c.0 + c.1,
                    mine
                ),
            },
        }
    };
    let opts = RunOptions {
        out_root: out_root.clone(),
        jobs,
        shard,
        force,
    };
    let report = run_plan(&plan, &opts, &on_drive).map_err(|e| match e {
        // the environment, not a drive: a configuration error like a bad output path
        e @ fleetdyn::pipeline::run::RunError::OutputFolder { .. } => usage(e),
        e => drive(e),
    })?;
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
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
        return Err(drive(anyhow::anyhow!(
            "{} of {} drives failed",
            report.failed,
            report.drives.len()
        )));
    }
    Ok(())
}

/// `fleetdyn road …`: configuration errors (rules, lengths, seeds, Welch settings) exit 2;
/// an unreadable road file or a failed write exits 1.
fn run_road(cmd: RoadCommand) -> Result<(), Failure> {
    match cmd {
        RoadCommand::Profile {
            input,
            output,
            step_m,
            smooth_m,
            mapping,
            elevation_column,
            pitch_column,
            max_elevation_accuracy_m,
        } => {
            let kind = detect_input(&input).map_err(usage)?;
            let (profile, fp) = match kind {
                ProfileInput::VectoCycle => {
                    if smooth_m.is_some() {
                        return Err(usage(anyhow::anyhow!(
                            "{}: --smooth-m applies to GNSS tracks; a VECTO cycle's grade is used as given",
                            input.display()
                        )));
                    }
                    let c = read_vdri(&input).map_err(usage)?;
                    let p = cycle_profile(&c, step_m).map_err(usage)?;
                    (p, format!("road_profile:vdri:v1 step_m={step_m}"))
                }
                ProfileInput::Recording => {
                    let gcfg = GnssProfileConfig {
                        step_m,
                        smooth_m: smooth_m.unwrap_or(GnssProfileConfig::default().smooth_m),
                        elevation_column,
                        pitch_column,
                        max_elevation_accuracy_m,
                        ..Default::default()
                    };
                    // GNSS fixes may be missing for long (no satellite lock): the profile
                    // interpolates over them in distance, so ingest takes any missing-value run
                    // and requires no column; the profile names what is missing.
                    let icfg = IngestConfig {
                        mapping,
                        max_nan_run_s: f64::INFINITY,
                        ..Default::default()
                    };
                    let opts = icfg.options(&[], None).map_err(usage)?;
                    let ing = ingest_stage::run(&input, &opts).map_err(usage)?;
                    let p = gnss_profile_of(&ing, &gcfg).map_err(usage)?;
                    let fp = format!("{}\n{}", icfg.fingerprint(&opts), gcfg.fingerprint());
                    (p, fp)
                }
            };
            write_profile(&output, &profile, &fp).map_err(drive)?;
            say_raw!("{}", profile.summary());
            say!(
                "  {} grid points of {} m -> {}",
                profile.distance_m.len(),
                profile.step_m,
                output.display()
            );
            Ok(())
        }
        RoadCommand::Synth {
            rules,
            length_km,
            seed,
            step_m,
            output,
        } => {
            let r = RoadRules::resolve(&rules).map_err(usage)?;
            let road = synth::generate(&r, length_km * 1000.0, step_m, seed).map_err(usage)?;
            write_road(&output, &road, &rules).map_err(drive)?;
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
                r.name, seed, road.length_m / 1000.0, step_m, p.slope.len(),
                road.alignment.grades.len(), road.alignment.radii_m.len(),
                road.lengthened_segments, max_abs, zmin, zmax, output.display()
            );
            Ok(())
        }
        RoadCommand::Study {
            rules,
            roads,
            length_km,
            seed,
            step_m,
            segment_length_m,
            threads,
            output,
        } => {
            let r = RoadRules::resolve(&rules).map_err(usage)?;
            let cfg = StudyConfig {
                rules: r,
                n_roads: roads,
                length_m: length_km * 1000.0,
                step_m,
                seed,
                spectrum: SpectrumSettings {
                    segment_length_m,
                    ..Default::default()
                },
            };
            let result = match threads {
                Some(0) => return Err(usage(anyhow::anyhow!("--threads must be at least 1"))),
                Some(n) => rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map_err(|e| drive(anyhow::anyhow!("thread pool: {e}")))?
                    .install(|| run_study(&cfg)),
                None => run_study(&cfg),
            };
            let study = result.map_err(|e| match e {
                StudyError::Signal { .. } => drive(e),
                _ => usage(e),
            })?;
            let files = write_study(&output, &study, &rules).map_err(drive)?;
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
        RoadCommand::Spectrum {
            input,
            output,
            column,
            segment_length_m,
            confidence,
        } => {
            let settings = SpectrumSettings {
                segment_length_m,
                confidence,
            };
            if !(confidence > 0.0 && confidence < 1.0) {
                return Err(usage(anyhow::anyhow!(
                    "--confidence {confidence} must lie strictly between 0 and 1"
                )));
            }
            let col = read_distance_column(&input, &column).map_err(drive)?;
            let sp = slope_spectrum(&col.values, col.step_m, &settings).map_err(|e| match e {
                StudyError::Signal { .. } => drive(e),
                _ => usage(e),
            })?;
            let files = write_road_spectrum(&output, &col, &sp, &settings).map_err(drive)?;
            say!(
                "{}: {column} on a {} m grid, {} Welch segments of {} samples ({:.1} dof); half the power below {:.3e} 1/m, 90 % below {:.3e} 1/m, 99 % below {:.3e} 1/m",
                input.display(), col.step_m, sp.psd.n_segments, sp.psd.nperseg, sp.psd.dof,
                sp.knee_50, sp.knee_90, sp.knee_99
            );
            for f in files {
                say!("  wrote {}", f.display());
            }
            Ok(())
        }
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.error);
            ExitCode::from(f.code)
        }
    }
}
