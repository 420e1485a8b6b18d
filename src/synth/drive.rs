//! Closed-loop synthetic drives: a driver and an AMT co-simulated with the fast driveline model
//! over a synthetic road ([`super::drive_loop`]), the axle model run on the result
//! ([`super::drive_axles`]), and the truth written as a CAN log
//! ([`super::log_writer::write_drive_log`]). Every stage's error is a [`DriveError`]
//! ([`super::drive_error`]); the items of these modules are re-exported here.
//!
//! # Roads and GNSS
//! [`synth_drive_on`] drives over a [`RoadSource`]: a road generated from rules, or a window of
//! a road file ([`super::road_source`]). With [`DriveConfig::gnss`] the log gets a GNSS track
//! along the road ([`super::track`]) on `/gnss/fix`. With [`DriveConfig::road_speed_limits`]
//! the driver follows the road file's speed limits (a VECTO cycle's `<v>`).
//!
//! # Logs
//! [`synth_drive_logged`] writes the log as [`LogOptions`] say ([`super::log_writer`]): MCAP
//! with zstd or LZ4 chunks or one of the portal exports ([`super::export`]), with the drive's
//! own ids, start time, logger jitter and dropouts, and optionally the truth table
//! ([`super::truth_file`]).

use super::can::{CanBus, SynthOptions, Truth};
pub use super::drive_axles::{simulate_axles, simulate_axles_with};
use super::drive_error::check;
pub use super::drive_error::DriveError;
pub use super::drive_loop::{
    simulate_drive, simulate_drive_with, DriveConfig, PlantExtras, RoadSlope,
};
use super::driver::SpeedLimits;
use super::effects::{
    fault_bus, fault_truth, resolve, Answer, EffectChoice, Injection, OutOfCatalogue,
    ResistanceStretch, TruthModel, LOCAL_ROLLING_RESISTANCE,
};
use super::export::{fuel_rate_lph, ExportError, Series};
use super::log_writer::{apply_dropouts, write_drive_log, LogOptions};
use super::road_source::{read_road_file, DriveRoad, RoadSource};
use super::track::{gnss_message, gnss_track};
pub use super::trajectory::{DriveTrajectory, ShiftRecord};
use super::truth_file::{truth_columns, write_truth, TruthMeta};
use crate::model::vehicle::VehicleFile;
use crate::road::rules::RoadRules;
use crate::road::synth::generate;
use crate::sim::axle::AxleTrajectory;
use std::path::{Path, PathBuf};

/// The CAN truth of a drive: vehicle_speed, engine_speed, engine_torque, gear, road_slope,
/// brake_force, retarder_torque, clutch_position and, with `axles`, the three bellow gauge
/// pressures (SI, on the drive's samples).
pub fn drive_truth(tr: &DriveTrajectory, axles: Option<&AxleTrajectory>) -> Truth {
    let mut columns: Vec<(String, Vec<f64>)> = vec![
        ("vehicle_speed".into(), tr.speed_mps.clone()),
        ("engine_speed".into(), tr.engine_speed_rad_s.clone()),
        ("engine_torque".into(), tr.engine_torque_nm.clone()),
        ("gear".into(), tr.gear.clone()),
        ("road_slope".into(), tr.slope.clone()),
        // the magnitude of the ground force (the CAN signal is >= 0): at standstill the
        // trajectory's holding force is signed (negative = the ground pushes the truck uphill),
        // and a recording's reader recovers that sign from the grade (`sim::axle_recorded`)
        (
            "brake_force".into(),
            tr.brake_n.iter().map(|b| b.abs()).collect(),
        ),
        ("retarder_torque".into(), tr.retarder_torque_nm.clone()),
        ("clutch_position".into(), tr.clutch_position.clone()),
    ];
    if let Some(a) = axles {
        let [pf, pr, pt] = a.pressure_pa.clone();
        columns.push(("bellow_pressure_front".into(), pf));
        columns.push(("bellow_pressure_rear".into(), pr));
        columns.push(("bellow_pressure_tag".into(), pt));
    }
    Truth {
        t_s: tr.t_s.clone(),
        columns,
    }
}

/// A finished synthetic drive: the trajectories and the files written.
#[derive(Debug)]
pub struct SynthDrive {
    /// The driveline-side trajectory.
    pub drive: DriveTrajectory,
    /// The axle-model trajectory on the same samples (vehicles with `[axles]` only).
    pub axles: Option<AxleTrajectory>,
    /// The road driven (grid from 0 m at the start of the drive).
    pub road: DriveRoad,
    /// The GNSS track and receiver readings on the drive's samples, if configured.
    pub gnss: Option<super::track::GnssTrack>,
    /// The ingested drive log of the written log file.
    pub log: crate::table::DriveLog,
    /// Written log file (MCAP or an export, [`LogOptions::format`]).
    pub log_file: PathBuf,
    /// Written canonical Parquet file.
    pub parquet: PathBuf,
    /// Written truth table, if asked for ([`LogOptions::truth_rate_hz`]).
    pub truth_file: Option<PathBuf>,
    /// Copy of the nominal vehicle file.
    pub vehicle: PathBuf,
    /// The hidden effect, if any.
    pub injection: Option<Injection>,
    /// The truth model the drive was made with.
    pub truth: TruthModel,
}

/// Epoch time of truth time 0 of every synthetic drive: 2024-01-01T00:00:00Z, ns.
pub const DRIVE_START_NS: i64 = 1_704_067_200_000_000_000;

/// An effect to hide in a synthetic drive, and where its answer goes.
#[derive(Debug, Clone)]
pub struct HiddenEffect {
    /// Which effect.
    pub choice: EffectChoice,
    /// The answer file (JSON), written apart from the drive's own files.
    pub answer_path: PathBuf,
}

/// Generates a road of `length_km` from `rules` (bundled name or file) with `seed` and drives
/// over it: [`synth_drive_on`] with [`RoadSource::Rules`].
///
/// With `hidden`, the truth carries that effect ([`super::effects`]): the vehicle file copied
/// stays the nominal one, the drive's id and metadata do not mention the effect, and the answer
/// (effect, parameter, nominal and truth values) is written to `hidden.answer_path` only.
///
/// # Errors
/// As [`synth_drive_on`].
pub fn synth_drive(
    vehicle_path: &Path,
    rules: &str,
    length_km: f64,
    seed: u64,
    out_dir: &Path,
    cfg: &DriveConfig,
    hidden: Option<&HiddenEffect>,
) -> Result<SynthDrive, DriveError> {
    let road = RoadSource::Rules {
        rules: rules.into(),
        length_km,
    };
    synth_drive_on(vehicle_path, &road, seed, out_dir, cfg, hidden)
}

/// Drives the vehicle of `vehicle_path` over `road` — generated from rules with `seed` on a
/// 1 m grid, or a window of a road file ([`read_road_file`]) — with seed `seed` for the
/// driver's variations, the GNSS track and the CAN noise, and writes `drive.mcap`,
/// `drive.parquet` and `vehicle.toml` (a byte copy of the vehicle file) into `out_dir`
/// (created if needed): [`synth_drive_logged`] with the default [`LogOptions`].
///
/// # Errors
/// As [`synth_drive_logged`].
pub fn synth_drive_on(
    vehicle_path: &Path,
    road: &RoadSource,
    seed: u64,
    out_dir: &Path,
    cfg: &DriveConfig,
    hidden: Option<&HiddenEffect>,
) -> Result<SynthDrive, DriveError> {
    synth_drive_logged(
        vehicle_path,
        road,
        seed,
        out_dir,
        cfg,
        hidden,
        &LogOptions::default(),
    )
}

/// Drives the vehicle of `vehicle_path` over `road` — generated from rules with `seed` on a
/// 1 m grid, or a window of a road file ([`read_road_file`]) — with seed `seed` for the
/// driver's variations, the GNSS track and the CAN noise, and writes into `out_dir` (created if
/// needed) the log as `log` says ([`LogFormat::file_name`](super::log_writer::LogFormat::file_name)),
/// `drive.parquet` (what ingest makes of it), `vehicle.toml` (a byte copy of the vehicle file)
/// and, with [`LogOptions::truth_rate_hz`], `truth.parquet` ([`super::truth_file`]).
/// Cruise speed: the driver's speed limit, else the rules' design speed; with
/// [`DriveConfig::road_speed_limits`] the road's limits below it. The CAN bus is
/// [`CanBus::j1939_truck`] with the engine's largest full-load torque as reference (its bellow
/// channels stay silent for a vehicle without `[axles]`, and without a retarder
/// ([`DriverConfig::retarder`](super::driver::DriverConfig::retarder) `None`) it has no ERC1
/// message), plus [`gnss_message`] when
/// [`DriveConfig::gnss`] is set; the GNSS track's smallest radius follows the cruise speed
/// unless configured.
///
/// # Errors
/// [`DriveError`] from every stage; no speed limit on a road without design speed is
/// [`DriveError::NoCruiseSpeed`]; road speed limits on a road without them
/// [`DriveError::NoSpeedLimits`]; a bad road file [`DriveError::RoadFile`]; a truth rate that
/// does not divide the sample rate [`DriveError::BadConfig`]; bad jitter, dropout columns or a
/// failed log [`DriveError::Export`].
pub fn synth_drive_logged(
    vehicle_path: &Path,
    road: &RoadSource,
    seed: u64,
    out_dir: &Path,
    cfg: &DriveConfig,
    hidden: Option<&HiddenEffect>,
    log: &LogOptions,
) -> Result<SynthDrive, DriveError> {
    let v = VehicleFile::load(vehicle_path)?;
    let file = vehicle_path.display().to_string();
    let d = v.driveline(&file)?;
    let a = v.axles.as_ref();
    let truth_every = match log.truth_rate_hz {
        None => None,
        Some(r) => {
            let k = 1.0 / (r * cfg.sample_dt_s);
            let ok = r.is_finite() && r > 0.0 && k >= 1.0 && (k - k.round()).abs() < 1e-9;
            if !ok {
                return Err(DriveError::BadConfig {
                    parameter: "truth_rate_hz",
                    value: r,
                    requirement: "finite, > 0 and a whole divisor of the sample rate",
                });
            }
            Some(k.round() as usize)
        }
    };
    if let Some(g) = &cfg.gnss {
        g.validate()?;
    }
    let (road, length_label) = match road {
        RoadSource::Rules { rules, length_km } => {
            let r = RoadRules::resolve(rules)?;
            check(
                "length_km",
                *length_km,
                length_km.is_finite() && *length_km > 0.0,
            )?;
            let synthetic = generate(&r, length_km * 1000.0, 1.0, seed)?;
            (DriveRoad::from_synthetic(&synthetic), *length_km)
        }
        RoadSource::File {
            path,
            start_m,
            length_km,
        } => {
            if let Some(l) = length_km {
                check("length_km", *l, l.is_finite() && *l > 0.0)?;
            }
            let r = read_road_file(path, *start_m, length_km.map(|l| l * 1000.0))?;
            let l = r.length_m / 1000.0;
            (r, l)
        }
    };
    let length_m = road.length_m;
    let reference = d.engine_max_torque_nm.iter().fold(0.0f64, |m, &x| m.max(x));
    let mut bus = CanBus::j1939_truck(reference);
    check(
        "slope_resolution",
        cfg.slope_resolution,
        cfg.slope_resolution.is_finite() && cfg.slope_resolution > 0.0,
    )?;
    for c in bus.messages.iter_mut().flat_map(|m| m.channels.iter_mut()) {
        if c.column == "road_slope" {
            c.resolution = if c.wire_unit == "%" {
                100.0 * cfg.slope_resolution
            } else {
                cfg.slope_resolution
            };
        }
    }
    let slope_resolution = bus
        .channels()
        .find(|(_, c)| c.column == "road_slope")
        .map_or(0.01, |(_, c)| {
            if c.wire_unit == "%" {
                c.resolution / 100.0
            } else {
                c.resolution
            }
        });
    let nominal = TruthModel::nominal(d, a);
    let (injection, mut truth_model) = match hidden {
        None => (None, nominal),
        Some(h) => resolve(h.choice, &nominal, slope_resolution, seed)?,
    };
    if let Some(EffectChoice::LocalRollingResistance) = hidden.map(|h| h.choice) {
        truth_model.stretch = Some(ResistanceStretch::draw(length_m, d.c_r1, seed));
    }
    let cruise = cfg
        .driver
        .speed_limit_mps
        .or(road.design_speed_mps)
        .ok_or_else(|| DriveError::NoCruiseSpeed {
            road: road.label.clone(),
        })?;
    let slope = RoadSlope {
        distance_m: road.distance_m.clone(),
        slope: road.slope.clone(),
    };
    let mut cfg_run;
    let cfg = if cfg.road_speed_limits {
        let limits = road
            .speed_limit_mps
            .clone()
            .ok_or_else(|| DriveError::NoSpeedLimits {
                road: road.label.clone(),
            })?;
        cfg_run = cfg.clone();
        cfg_run.driver.speed_limits = Some(SpeedLimits {
            step_m: road.step_m,
            limit_mps: limits,
        });
        &cfg_run
    } else {
        cfg
    };
    let drive = simulate_drive_with(
        d,
        &truth_model.vehicle.driveline,
        &PlantExtras {
            lash_rad: truth_model.vehicle.lash_rad,
            stretch: truth_model.stretch,
        },
        &v.gearbox.ratios,
        &slope,
        length_m,
        cruise,
        cfg,
        seed,
    )?;
    let axles = match truth_model.vehicle.axles.as_ref() {
        Some(pa) => Some(simulate_axles_with(
            pa,
            truth_model.vehicle.axle_ext,
            &drive,
        )?),
        None => None,
    };
    let mut truth = drive_truth(&drive, axles.as_ref());
    if cfg.driver.retarder.is_none() {
        // no retarder fitted: no ERC1 on the bus
        truth.columns.retain(|(c, _)| c != "retarder_torque");
        bus.messages
            .retain(|m| !m.channels.iter().any(|c| c.column == "retarder_torque"));
    }
    fault_truth(&truth_model.vehicle.sensors, &mut truth);
    fault_bus(&truth_model.vehicle.sensors, &mut bus);
    if let Some(dr) = cfg.dropouts {
        bus = bus.with_dropouts(dr);
    }
    let gnss = match &cfg.gnss {
        Some(g) => {
            let track = gnss_track(
                g,
                road.step_m,
                &road.elevation_m,
                &drive.t_s,
                &drive.distance_m,
                cruise,
                seed,
            )?;
            truth.columns.extend(track.receiver_columns());
            bus.messages.push(gnss_message(g));
            Some(track)
        }
        None => None,
    };
    std::fs::create_dir_all(out_dir).map_err(|source| DriveError::Io {
        path: out_dir.to_path_buf(),
        source,
    })?;
    let opts = SynthOptions {
        start_ns: log.start_ns.unwrap_or(DRIVE_START_NS),
        seed,
        drive_id: log
            .drive_id
            .clone()
            .unwrap_or_else(|| format!("synth-{}-{}km-seed{}", road.label, length_label, seed)),
        vehicle_id: Some(log.vehicle_id.clone().unwrap_or(v.vehicle_id.clone())),
    };
    if let Some(spec) = &log.dropouts {
        apply_dropouts(&mut bus, spec)?;
    }
    let fuel: Vec<f64> = drive
        .engine_speed_rad_s
        .iter()
        .zip(&drive.engine_torque_nm)
        .map(|(&w, &m)| fuel_rate_lph(w, m))
        .collect();
    let log_file = out_dir.join(log.format.file_name());
    let parquet = out_dir.join("drive.parquet");
    let drive_log = write_drive_log(
        &log_file,
        &parquet,
        &bus,
        &truth,
        Some(Series {
            t_s: &drive.t_s,
            values: &fuel,
        }),
        &opts,
        log,
    )?;
    let truth_file = match truth_every {
        None => None,
        Some(every) => {
            let path = out_dir.join("truth.parquet");
            let cols = truth_columns(&drive, axles.as_ref(), gnss.as_ref(), opts.start_ns, every);
            let meta = TruthMeta {
                drive_id: opts.drive_id.clone(),
                vehicle_id: opts.vehicle_id.clone(),
                seed,
                road: format!("{} ({:.3} km)", road.label, road.length_m / 1000.0),
                rate_hz: log.truth_rate_hz.unwrap_or_default(),
            };
            write_truth(&path, &cols, &meta).map_err(ExportError::from)?;
            Some(path)
        }
    };
    let vehicle = out_dir.join("vehicle.toml");
    std::fs::copy(vehicle_path, &vehicle).map_err(|source| DriveError::Io {
        path: vehicle.clone(),
        source,
    })?;
    if let Some(h) = hidden {
        let mut answer = Answer::new(&opts.drive_id, seed, injection.as_ref());
        answer.out_of_catalogue = truth_model.stretch.map(|stretch| OutOfCatalogue {
            kind: LOCAL_ROLLING_RESISTANCE,
            description: "rolling resistance that rises on one stretch of road only",
            stretch,
        });
        answer.write(&h.answer_path)?;
    }
    Ok(SynthDrive {
        drive,
        axles,
        road,
        gnss,
        log: drive_log,
        log_file,
        parquet,
        truth_file,
        vehicle,
        injection,
        truth: truth_model,
    })
}
