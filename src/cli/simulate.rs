//! `fleetdyn bode`, `fleetdyn simulate shuffle|axle` and `fleetdyn estimate axle`.

use super::common::{load_vehicle, SlopeInputArg};
use crate::commands::failure::{setting, usage, Failure};
use crate::commands::{bode, estimate, simulate};
use clap::{Args, Subcommand, ValueEnum};
use fleetdyn::pipeline::axle_stage::LongitudinalSource;
use fleetdyn::pipeline::ingest_stage::IngestConfig;
use fleetdyn::schema::Stage;
use fleetdyn::sim::axle_recorded::{AccelSource, AxleRecordConfig};
use fleetdyn::sim::axle_validate::AxleValidationConfig;
use fleetdyn::sim::validate::ValidationConfig;
use std::path::PathBuf;

/// Linear driveline analysis per gear (Myklebust & Eriksson 2012, §3): resonance peaks of
/// F_dr -> v and M_e -> v, open and closed loop; prints the table, writes bode.parquet and
/// bode.svg.
#[derive(Args, Debug)]
pub struct BodeCmd {
    /// Vehicle file with a [driveline] section.
    #[arg(long)]
    vehicle: PathBuf,
    /// Output folder.
    #[arg(short, long)]
    output: PathBuf,
}

impl BodeCmd {
    /// The job: the vehicle file and the output folder.
    pub fn resolve(self) -> Result<bode::Job, Failure> {
        let vehicle = load_vehicle(&self.vehicle)?;
        vehicle
            .driveline(&self.vehicle.display().to_string())
            .map_err(usage)?;
        Ok(bode::Job {
            vehicle,
            vehicle_file: self.vehicle.display().to_string(),
            output: self.output,
        })
    }
}

/// Simulate a recorded drive with a physics model and validate it against the recording.
#[derive(Subcommand, Debug)]
pub enum SimulateCmd {
    /// Driveline shuffle model (docs/models/driveline.md) on the drive's recorded engine
    /// torque, gear, clutch and slope; writes shuffle_sim.parquet and validation.parquet (RMSE,
    /// MAE, fit % of vehicle and engine speed, overall and per gear). Every window starts from
    /// the measured state.
    Shuffle(ShuffleCmd),
    /// Axle-load model (docs/models/axle.md, half truck of a 6x2): either a scripted scenario
    /// (--scenario: writes axle_sim.parquet and SVG plots of normal forces and bellow
    /// pressures), or a recorded drive (--drive: simulates it and validates the bellow
    /// pressures, and travel where recorded: MAE, RMSE, fit % per axle and segment; writes
    /// axle_sim.parquet and axle_validation.parquet).
    Axle(AxleCmd),
}

/// `simulate shuffle`.
#[derive(Args, Debug)]
pub struct ShuffleCmd {
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
    /// Road slope input: the sensor as recorded (raw), or after the zero-phase spatial filter
    /// (filtered, default), which removes the quantisation steps that excite spurious shuffle.
    #[arg(long, value_enum, default_value = "filtered")]
    slope: SlopeInputArg,
}

/// `simulate axle`.
#[derive(Args, Debug)]
pub struct AxleCmd {
    /// Recorded drive (MCAP or Parquet).
    #[arg(
        long,
        required_unless_present = "scenario",
        conflicts_with = "scenario"
    )]
    drive: Option<PathBuf>,
    /// Scripted scenario of the axle-load thesis (docs/models/axle.md).
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
    /// Longitudinal inputs: the recording's, or the driveline simulation of it (end to end;
    /// needs a [driveline] section).
    #[arg(long, value_enum, default_value = "recorded")]
    longitudinal: LongitudinalArg,
    /// Acceleration separating the acceleration / steady / braking segments, m/s².
    #[arg(long, default_value_t = 0.3)]
    accel_threshold_mps2: f64,
}

/// A scripted axle-load scenario.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum AxleScenarioArg {
    /// Full acceleration from standstill.
    FullAcceleration,
    /// Braking with the auxiliary brake.
    AuxBraking,
}

/// Where the axle model's acceleration comes from.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum AccelArg {
    /// The IMU column when present, else d(speed)/dt.
    Auto,
    /// The IMU column.
    Imu,
    /// d(speed)/dt.
    Speed,
}

/// Where the axle model's longitudinal inputs come from.
#[derive(Clone, Copy, Debug, ValueEnum)]
enum LongitudinalArg {
    /// The recording's torques and acceleration.
    Recorded,
    /// The driveline simulation of the recording.
    Driveline,
}

impl SimulateCmd {
    /// The job of either model.
    pub fn resolve(self) -> Result<simulate::Job, Failure> {
        match self {
            SimulateCmd::Shuffle(c) => c.resolve().map(simulate::Job::Shuffle),
            SimulateCmd::Axle(c) => c.resolve(),
        }
    }
}

impl ShuffleCmd {
    fn resolve(self) -> Result<simulate::ShuffleJob, Failure> {
        let vehicle = load_vehicle(&self.vehicle)?;
        let vehicle_file = self.vehicle.display().to_string();
        vehicle.driveline(&vehicle_file).map_err(usage)?;
        let validation = ValidationConfig {
            window_s: self.window_s,
            dt_s: self.dt_s,
            ..Default::default()
        };
        validation.validate().map_err(setting)?;
        let cfg = IngestConfig {
            mapping: self.mapping,
            ..Default::default()
        };
        let opts = cfg
            .options(&[Stage::Driveline], Some(&vehicle))
            .map_err(usage)?;
        Ok(simulate::ShuffleJob {
            drive: self.drive,
            vehicle,
            vehicle_file,
            output: self.output,
            cfg,
            opts,
            validation,
            filtered_slope: matches!(self.slope, SlopeInputArg::Filtered),
        })
    }
}

impl AxleCmd {
    fn resolve(self) -> Result<simulate::Job, Failure> {
        let vehicle = load_vehicle(&self.vehicle)?;
        let vehicle_file = self.vehicle.display().to_string();
        vehicle.axles(&vehicle_file).map_err(usage)?;
        if let Some(sc) = self.scenario {
            return Ok(simulate::Job::AxleScenario {
                name: match sc {
                    AxleScenarioArg::FullAcceleration => "full-acceleration",
                    AxleScenarioArg::AuxBraking => "aux-braking",
                },
                vehicle,
                vehicle_file,
                output: self.output,
            });
        }
        let Some(drive) = self.drive else {
            return Err(crate::commands::failure::usage_msg(
                "give --drive or --scenario",
            ));
        };
        let validation = AxleValidationConfig {
            record: AxleRecordConfig {
                accel: match self.accel {
                    AccelArg::Auto => AccelSource::Auto,
                    AccelArg::Imu => AccelSource::Imu,
                    AccelArg::Speed => AccelSource::Speed,
                },
                ..Default::default()
            },
            accel_threshold_mps2: self.accel_threshold_mps2,
        };
        validation.validate().map_err(setting)?;
        let cfg = IngestConfig {
            mapping: self.mapping,
            ..Default::default()
        };
        let opts = cfg.options(&[], Some(&vehicle)).map_err(usage)?;
        Ok(simulate::Job::Axle(simulate::AxleJob {
            drive,
            vehicle,
            vehicle_file,
            output: self.output,
            cfg,
            opts,
            validation,
            longitudinal: match self.longitudinal {
                LongitudinalArg::Recorded => LongitudinalSource::Recorded,
                LongitudinalArg::Driveline => LongitudinalSource::Driveline,
            },
            filtered_slope: matches!(self.slope, SlopeInputArg::Filtered),
        }))
    }
}

/// Estimate model parameters from measurements and compare them with a vehicle file.
#[derive(Subcommand, Debug)]
pub enum EstimateCmd {
    /// Axle-model parameters (the axle-load thesis, docs/models/axle.md) from scale weights,
    /// static bellow pressures, bellow force-displacement tests and damper datasheets, with the
    /// vehicle file's axle positions, arm levers and axle masses: total mass and CG, chassis
    /// mass and CG, static bellow forces, effective bellow areas, bellow stiffness, damper
    /// coefficients. Prints each estimate beside the vehicle file's value.
    Axle(EstimateAxleCmd),
}

/// `estimate axle`.
#[derive(Args, Debug)]
pub struct EstimateAxleCmd {
    /// Measurement file (TOML: [scale], [static_pressure], [[bellow_test]],
    /// [[damper_datasheet]]; example fixtures/measurements/seed002-static.toml).
    measurements: PathBuf,
    /// Vehicle file with an [axles] section.
    #[arg(long)]
    vehicle: PathBuf,
    /// Write the estimates as a TOML snippet of [axles] keys, to replace those in the vehicle
    /// file (checked against it first; written atomically).
    #[arg(short, long)]
    output: Option<PathBuf>,
}

impl EstimateCmd {
    /// The job: measurement and vehicle files, the snippet's path.
    pub fn resolve(self) -> Result<estimate::Job, Failure> {
        let EstimateCmd::Axle(c) = self;
        Ok(estimate::Job {
            measurements: c.measurements,
            vehicle: c.vehicle,
            output: c.output,
        })
    }
}
