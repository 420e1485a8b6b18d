//! `fleetdyn synth drive`.

use crate::commands::failure::{setting, usage, usage_msg, Failure};
use crate::commands::synth;
use clap::{Args, Subcommand, ValueEnum};
use fleetdyn::synth::drive::{DriveConfig, HiddenEffect};
use fleetdyn::synth::effects::EffectChoice;
use fleetdyn::synth::log_writer::{DropoutSpec, LogFormat, LogOptions};
use fleetdyn::synth::retarder::RetarderConfig;
use fleetdyn::synth::road_source::RoadSource;
use fleetdyn::synth::{Dropouts, McapCompression};
use std::path::PathBuf;

/// Synthetic drives: a driver and an AMT co-simulated with the driveline and axle models over a
/// synthetic road, written as a CAN log (MCAP + canonical Parquet).
#[derive(Subcommand, Debug)]
pub enum SynthCmd {
    /// Drive a vehicle over a synthetic road (--rules) or a road file (--road-file): launches,
    /// stops (every --stop-every-km and at the road end), AMT shifts, engine brake and retarder
    /// before the service brake; writes the log (drive.mcap with CAN topics and a 1 Hz GNSS
    /// fix, or a portal export, --log-format), drive.parquet, vehicle.toml and optionally
    /// truth.parquet (--truth-rate-hz) into the output folder.
    Drive(DriveCmd),
}

/// `synth drive`.
#[derive(Args, Debug)]
pub struct DriveCmd {
    /// Vehicle file with a [driveline] section; with [axles] the axle model runs and the log
    /// carries bellow pressures.
    #[arg(long)]
    vehicle: PathBuf,
    /// Rule set: a bundled name (highway-se, city-se, freeway-us, urban-us, each also as
    /// NAME-fitted: segment lengths fitted to measured roads) or a TOML file.
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
}

/// Log format of a synthetic drive.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum LogFormatArg {
    /// drive.mcap: multi-rate JSON topics.
    Mcap,
    /// drive-export.parquet: a wide 20 Hz fleet-portal export.
    PortalExport,
    /// drive-long.parquet: ts, signal, value.
    LongExport,
}

/// Chunk compression of an MCAP log.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum McapCompressionArg {
    /// zstd.
    Zstd,
    /// LZ4.
    Lz4,
}

impl SynthCmd {
    /// The job: vehicle, road, drive and log settings, the hidden effect.
    pub fn resolve(self) -> Result<synth::Job, Failure> {
        let SynthCmd::Drive(c) = self;
        let mut cfg = DriveConfig::default();
        cfg.driver.speed_limit_mps = c.speed_limit_km_per_h.map(|k| k / 3.6);
        cfg.driver.stop_every_m = (c.stop_every_km > 0.0).then_some(c.stop_every_km * 1000.0);
        cfg.driver.stop_dwell_s = c.stop_dwell_s;
        cfg.slope_resolution = c.slope_resolution_percent / 100.0;
        cfg.max_duration_s = c.max_duration_s;
        cfg.road_speed_limits = c.road_speed_limits;
        cfg.driver.retarder = (c.retarder_max_torque_nm != 0.0).then(|| RetarderConfig {
            max_torque_nm: c.retarder_max_torque_nm,
            ..RetarderConfig::default()
        });
        if let Some(g) = cfg.gnss.as_mut() {
            g.origin_lat_deg = c.gnss_origin_lat_deg;
            g.origin_lon_deg = c.gnss_origin_lon_deg;
        }
        cfg.validate().map_err(setting)?;
        let p = c.dropout_start_probability;
        if p != 0.0 && c.dropout_columns.is_empty() {
            return Err(usage_msg(
                "--dropout-start-probability needs --dropout-columns",
            ));
        }
        let log = LogOptions {
            format: match c.log_format {
                LogFormatArg::Mcap => LogFormat::Mcap(match c.mcap_compression {
                    McapCompressionArg::Zstd => McapCompression::Zstd,
                    McapCompressionArg::Lz4 => McapCompression::Lz4,
                }),
                LogFormatArg::PortalExport => LogFormat::PortalExport,
                LogFormatArg::LongExport => LogFormat::LongExport,
            },
            mcap_compression_level: c.mcap_compression_level,
            drive_id: c.drive_id,
            vehicle_id: c.vehicle_id,
            start_ns: c
                .start_utc
                .as_deref()
                .map(fleetdyn::time_fmt::parse_rfc3339_utc_ns)
                .transpose()
                .map_err(usage)?,
            timestamp_jitter_s: c.timestamp_jitter_s,
            dropouts: (!c.dropout_columns.is_empty()).then_some(DropoutSpec {
                columns: c.dropout_columns,
                dropouts: Dropouts {
                    start_probability: p,
                    mean_length_s: c.dropout_mean_length_s,
                },
            }),
            truth_rate_hz: c.truth_rate_hz,
        };
        log.validate().map_err(setting)?;
        let road = match (c.rules, c.road_file) {
            (Some(_), None) if c.road_start_m.is_some() => {
                return Err(usage_msg(
                    "--road-start-m applies to --road-file, not to --rules",
                ))
            }
            (Some(rules), None) => RoadSource::Rules {
                rules,
                length_km: c
                    .length_km
                    .ok_or_else(|| usage_msg("--rules needs --length-km"))?,
            },
            (None, Some(path)) => RoadSource::File {
                path,
                start_m: c.road_start_m.unwrap_or(0.0),
                length_km: c.length_km,
            },
            _ => return Err(usage_msg("give exactly one of --rules and --road-file")),
        };
        let hidden = match &c.effect {
            None => None,
            Some(e) => Some(HiddenEffect {
                choice: EffectChoice::parse(e).map_err(usage)?,
                answer_path: c.answer.unwrap_or_else(|| c.output.join("answer.json")),
            }),
        };
        Ok(synth::Job {
            vehicle: c.vehicle,
            road,
            seed: c.seed,
            output: c.output,
            cfg,
            hidden,
            log,
        })
    }
}
