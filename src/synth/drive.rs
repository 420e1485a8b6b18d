//! Closed-loop synthetic drives (issue 5 point 4): a [`Driver`] and an [`Amt`] co-simulated
//! with the fast driveline model ([`FastDriveline`]) over a synthetic road, the axle model run
//! on the result, and the truth written as a CAN log ([`write_can_drive`]).
//!
//! # Loop
//! Control steps of [`DriveConfig::control_dt_s`] (0.1 s): at each step start the driver reads
//! time, travelled distance, speed, slope and engine speed and commands a torque fraction and a
//! brake force; the AMT turns them into gear, clutch position and engine torque; a one-step
//! [`Scenario`] with these inputs held (and the road slope at the step's start position, looked
//! up by the travelled distance) is simulated with [`FastDriveline::simulate_span`] at
//! [`DriveConfig::sample_dt_s`] (0.01 s), carrying the state and the clutch mode. Rolling
//! resistance is unsmoothed and the vehicle's stops are events (`standstill_events`). At a
//! gear change the synchroniser sets the clutch-disc speed to the new input-shaft speed
//! (`ω_c = i_t ω_p`, clutch-spring torsion 0).
//!
//! The distance is the trapezoidal integral of the wheel speed `r_w ω_w`. The drive ends when
//! the truck has stood at the road end for the driver's dwell time, or fails with [`DriveError::Timeout`] after
//! [`DriveConfig::max_duration_s`].
//!
//! # Axles
//! The axle model ([`HalfTruck`], static start) runs on the 100 Hz samples with
//! [`axle_inputs_from_samples`] (acceleration differentiated over ±0.05 s).

use super::amt::{Amt, AmtConfig, AmtState, ShiftPhase};
use super::can::{
    write_can_drive, CanBus, CanChannel, CanMessage, Dropouts, SynthError as CanError,
    SynthOptions, TorqueReference, Truth,
};
use super::driver::{Driver, DriverConfig};
use crate::model::driveline::DrivelineParams;
use crate::model::vehicle::{VehicleError, VehicleFile};
use crate::road::rules::{RoadRules, RulesError};
use crate::road::synth::{generate, SynthError as RoadError};
use crate::sim::axle::{AxleTrajectory, HalfTruck, Start};
use crate::sim::axle_coupling::axle_inputs_from_samples;
use crate::sim::fast::FastDriveline;
use crate::sim::hybrid::{ClutchMode, EngineInput, Scenario, SimError, N_STATES};
use crate::sim::inputs::{Piecewise, PiecewiseError};
use std::path::{Path, PathBuf};
use thiserror::Error;

/// Why a synthetic drive could not be made.
#[derive(Debug, Error)]
pub enum DriveError {
    /// The vehicle file could not be read or lacks a part.
    #[error(transparent)]
    Vehicle(#[from] VehicleError),
    /// The road rules could not be resolved.
    #[error(transparent)]
    Rules(#[from] RulesError),
    /// The road could not be generated.
    #[error(transparent)]
    Road(#[from] RoadError),
    /// The driveline simulation failed.
    #[error("driveline: {0}")]
    Sim(#[from] SimError),
    /// Axle-model inputs could not be built.
    #[error("axle inputs: {0}")]
    Piecewise(#[from] PiecewiseError),
    /// The CAN log could not be written.
    #[error(transparent)]
    Can(#[from] CanError),
    /// A configuration value out of its domain.
    #[error("{parameter} = {value} must be {requirement}")]
    BadConfig {
        /// Parameter name with unit.
        parameter: &'static str,
        /// The value given.
        value: f64,
        /// What it must be.
        requirement: &'static str,
    },
    /// The truck did not reach the road end in time.
    #[error("the truck did not finish within {max_s} s (at {x_m:.0} m of {length_m:.0} m)")]
    Timeout {
        /// Time limit, s.
        max_s: f64,
        /// Distance reached, m.
        x_m: f64,
        /// Road length, m.
        length_m: f64,
    },
    /// File I/O.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
}

/// Settings of a closed-loop drive.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveConfig {
    /// Driver settings.
    pub driver: DriverConfig,
    /// Transmission settings.
    pub amt: AmtConfig,
    /// Control step, s (inputs held over it).
    pub control_dt_s: f64,
    /// Output and integration step, s (a whole fraction of the control step).
    pub sample_dt_s: f64,
    /// Longest drive before giving up, s.
    pub max_duration_s: f64,
}

impl Default for DriveConfig {
    /// Default driver and AMT, 0.1 s control step, 0.01 s samples, at most 4 h.
    fn default() -> Self {
        Self {
            driver: DriverConfig::default(),
            amt: AmtConfig::default(),
            control_dt_s: 0.1,
            sample_dt_s: 0.01,
            max_duration_s: 4.0 * 3600.0,
        }
    }
}

/// Road slope on a distance grid, linear in between and held beyond the ends.
#[derive(Debug, Clone, PartialEq)]
pub struct RoadSlope {
    /// Distances, m, strictly increasing.
    pub distance_m: Vec<f64>,
    /// Slope tan α at each distance.
    pub slope: Vec<f64>,
}

impl RoadSlope {
    /// The slope at distance `x_m`.
    pub fn at(&self, x_m: f64) -> f64 {
        let d = &self.distance_m;
        let k = d.partition_point(|&v| v <= x_m);
        if k == 0 {
            return self.slope[0];
        }
        if k == d.len() {
            return self.slope[d.len() - 1];
        }
        let f = (x_m - d[k - 1]) / (d[k] - d[k - 1]);
        self.slope[k - 1] + f * (self.slope[k] - self.slope[k - 1])
    }
}

/// One gear shift of the AMT while driving (torque ramp-down to ramp-up).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShiftRecord {
    /// Gear before.
    pub from: usize,
    /// Gear after.
    pub to: usize,
    /// Start of the torque ramp-down, s.
    pub t_start_s: f64,
    /// Time the gear input changed, s.
    pub t_change_s: f64,
    /// End of the torque ramp-up, s.
    pub t_end_s: f64,
}

/// A simulated drive on the output grid.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DriveTrajectory {
    /// Times, s from the start.
    pub t_s: Vec<f64>,
    /// Travelled distance, m.
    pub distance_m: Vec<f64>,
    /// Vehicle speed r_w ω_w, m/s.
    pub speed_mps: Vec<f64>,
    /// Engine speed, rad/s.
    pub engine_speed_rad_s: Vec<f64>,
    /// Engine torque, N·m.
    pub engine_torque_nm: Vec<f64>,
    /// Drive-shaft torque M_d, N·m.
    pub drive_torque_nm: Vec<f64>,
    /// Gear input.
    pub gear: Vec<f64>,
    /// Clutch position, 0 = engaged … x_max = open.
    pub clutch_x: Vec<f64>,
    /// Road slope, tan α.
    pub slope: Vec<f64>,
    /// Service-brake force, N.
    pub brake_n: Vec<f64>,
    /// Target speed of the driver, m/s.
    pub target_mps: Vec<f64>,
    /// Shifts while driving.
    pub shifts: Vec<ShiftRecord>,
    /// Launch intervals (launch start, clutch locked), s.
    pub launches: Vec<(f64, f64)>,
    /// Planned stop positions, m (the last is the road end).
    pub planned_stops_m: Vec<f64>,
}

fn check(parameter: &'static str, value: f64, ok: bool) -> Result<(), DriveError> {
    if ok {
        Ok(())
    } else {
        Err(DriveError::BadConfig {
            parameter,
            value,
            requirement: "finite and > 0 (sample step a whole fraction of the control step)",
        })
    }
}

/// Co-simulates driver, AMT and driveline on `road` (length `length_m`) at cruise speed
/// `cruise_mps`, deterministic per `seed`. See the module documentation.
///
/// # Errors
/// [`DriveError::BadConfig`] for bad steps, speeds or lengths; [`DriveError::Sim`];
/// [`DriveError::Timeout`].
pub fn simulate_drive(
    p: &DrivelineParams,
    ratios: &[f64],
    road: &RoadSlope,
    length_m: f64,
    cruise_mps: f64,
    cfg: &DriveConfig,
    seed: u64,
) -> Result<DriveTrajectory, DriveError> {
    let (dt, ds) = (cfg.control_dt_s, cfg.sample_dt_s);
    let sub = (dt / ds).round();
    check("control_dt_s", dt, dt.is_finite() && dt > 0.0)?;
    check(
        "sample_dt_s",
        ds,
        ds.is_finite() && ds > 0.0 && sub >= 1.0 && (sub * ds - dt).abs() < 1e-9,
    )?;
    check("length_m", length_m, length_m.is_finite() && length_m > 0.0)?;
    check(
        "cruise_mps",
        cruise_mps,
        cruise_mps.is_finite() && cruise_mps > 0.0,
    )?;
    check(
        "max_duration_s",
        cfg.max_duration_s,
        cfg.max_duration_s.is_finite() && cfg.max_duration_s > 0.0,
    )?;
    let c = &cfg.driver;
    for (name, v) in [
        ("accel_mps2", c.accel_mps2),
        ("decel_mps2", c.decel_mps2),
        ("speed_gain_per_s", c.speed_gain_per_s),
    ] {
        check(name, v, v.is_finite() && v > 0.0)?;
    }
    let sub = sub as usize;
    let mut fast = FastDriveline::new(p, ratios, ds);
    let mut driver = Driver::new(cfg.driver.clone(), cruise_mps, length_m, seed);
    let mut amt = Amt::new(cfg.amt.clone(), dt);
    let idle = cfg.amt.idle_rpm * std::f64::consts::PI / 30.0;
    let mut y = [0.0; N_STATES];
    y[0] = idle;
    let mut mode = ClutchMode::Slipping(1.0);
    let mut out = DriveTrajectory {
        planned_stops_m: driver.stops_m().to_vec(),
        ..Default::default()
    };
    let mut x = 0.0;
    let mut k = 0usize;
    let mut finished_at: Option<f64> = None;
    let mut shift_start: Option<(f64, f64)> = None;
    let mut launch_start: Option<f64> = None;
    loop {
        let t = k as f64 * dt;
        if let Some(tf) = finished_at {
            if t >= tf + cfg.driver.stop_dwell_s - 1e-9 {
                break;
            }
        }
        if t > cfg.max_duration_s {
            return Err(DriveError::Timeout {
                max_s: cfg.max_duration_s,
                x_m: x,
                length_m,
            });
        }
        let v = p.wheel_radius_m * y[7];
        let slope = road.at(x);
        let gear_now = amt.gear();
        let overall = ratios[gear_now - 1] * p.final_drive_ratio;
        let cmd = driver.command(p, t, x, v, slope, y[0], overall);
        if driver.finished() && finished_at.is_none() {
            finished_at = Some(t);
        }
        let before = amt.state;
        let o = amt.step(
            p,
            ratios,
            cmd.torque_fraction,
            y[0],
            y[7],
            mode == ClutchMode::Locked,
        );
        // bookkeeping of shifts and launches
        match (before, amt.state) {
            (
                AmtState::Driving { .. },
                AmtState::Shift {
                    phase: ShiftPhase::RampDown,
                    ..
                },
            ) => shift_start = Some((t, f64::NAN)),
            (_, AmtState::Shift { .. }) if o.synchronise => {
                if let Some((s, _)) = shift_start {
                    shift_start = Some((s, t));
                }
            }
            (AmtState::Shift { from, to, .. }, AmtState::Driving { .. }) => {
                if let Some((s, ch)) = shift_start.take() {
                    out.shifts.push(ShiftRecord {
                        from,
                        to,
                        t_start_s: s,
                        t_change_s: ch,
                        t_end_s: t,
                    });
                }
            }
            (AmtState::Launch { .. }, AmtState::Launch { .. }) => {}
            (_, AmtState::Launch { .. }) => launch_start = Some(t),
            (AmtState::Launch { .. }, AmtState::Driving { .. }) => {
                if let Some(s) = launch_start.take() {
                    out.launches.push((s, t));
                }
            }
            _ => {}
        }
        if o.synchronise {
            y[1] = ratios[o.gear - 1] * y[3];
            y[2] = 0.0;
            if mode == ClutchMode::Locked {
                mode = ClutchMode::Slipping(if y[0] >= y[1] { 1.0 } else { -1.0 });
            }
        }
        let t1 = t + dt;
        let sc = Scenario {
            t_end_s: t1,
            gear: Piecewise::constant(t1, o.gear as f64),
            clutch_x: Piecewise::constant(t1, o.clutch_x),
            slope: Piecewise::constant(t1, slope),
            brake_n: Piecewise::constant(t1, cmd.brake_n),
            engine: EngineInput::Torque(Piecewise::constant(t1, o.engine_torque_nm)),
            smoothing: false,
            standstill_events: true,
        };
        let tr = fast.simulate_span(&sc, t, t1, y, mode)?;
        for j in 0..sub {
            let yj = &tr.y[j];
            if j > 0 {
                let va = p.wheel_radius_m * tr.y[j - 1][7];
                x += 0.5 * (va + p.wheel_radius_m * yj[7]) * ds;
            }
            out.t_s.push(t + j as f64 * ds);
            out.distance_m.push(x);
            out.speed_mps.push(p.wheel_radius_m * yj[7]);
            out.engine_speed_rad_s.push(yj[0]);
            out.engine_torque_nm.push(tr.torques[j][0]);
            out.drive_torque_nm.push(tr.torques[j][3]);
            out.gear.push(o.gear as f64);
            out.clutch_x.push(o.clutch_x);
            out.slope.push(slope);
            // the drive log's brake_force is the force at the ground: the brakes' capacity
            // while rolling, but at standstill only what holds the truck (drive force and grade),
            // never more than the capacity
            let ground_brake = if yj[7] == 0.0 {
                let hold = tr.torques[j][3] / p.wheel_radius_m
                    - p.mass_kg * p.gravity_m_per_s2 * slope.atan().sin();
                hold.clamp(-cmd.brake_n, cmd.brake_n)
            } else {
                cmd.brake_n
            };
            out.brake_n.push(ground_brake);
            out.target_mps.push(cmd.target_mps);
        }
        let last = sub.min(tr.y.len() - 1);
        x += 0.5 * p.wheel_radius_m * (tr.y[last - 1][7] + tr.y[last][7]) * ds;
        y = tr.y[last];
        mode = tr.mode[last];
        k += 1;
    }
    Ok(out)
}

/// Runs the axle model on a drive's 100 Hz samples (static start).
///
/// # Errors
/// [`DriveError::Piecewise`] for fewer than two samples.
pub fn simulate_axles(
    p: &crate::model::axle::AxleParams,
    tr: &DriveTrajectory,
) -> Result<AxleTrajectory, DriveError> {
    let held = |v: &[f64]| {
        Piecewise::new(
            tr.t_s
                .windows(2)
                .zip(v.iter())
                .map(|(t, &a)| (t[0], t[1], a, a))
                .collect(),
        )
    };
    let (u, _) = axle_inputs_from_samples(
        &tr.t_s,
        &tr.speed_mps,
        &tr.drive_torque_nm,
        held(&tr.slope)?,
        held(&tr.brake_n)?,
        0.05,
    )?;
    Ok(HalfTruck::new(p).simulate(&u, &tr.t_s, Start::Steady))
}

/// The CAN truth of a drive: vehicle_speed, engine_speed, engine_torque, gear, road_slope,
/// brake_force, clutch_position and the three bellow gauge pressures (SI, on the drive's
/// samples).
///
/// `brake_force` is the magnitude of the ground force (the CAN signal is ≥ 0): at standstill the
/// trajectory's holding force is signed (negative = the ground pushes the truck uphill), and a
/// recording's reader recovers that sign from the grade (`sim::axle_recorded`).
/// `clutch_position` is the AMT's actuator position normalised by `clutch_x_max` (0 = engaged,
/// 1 = open): the recorded-input simulation needs every input the truth used (physics.md §1,
/// diagnosis.md step 1).
pub fn drive_truth(tr: &DriveTrajectory, axles: &AxleTrajectory, clutch_x_max: f64) -> Truth {
    let [pf, pr, pt] = axles.pressure_pa.clone();
    Truth {
        t_s: tr.t_s.clone(),
        columns: vec![
            ("vehicle_speed".into(), tr.speed_mps.clone()),
            ("engine_speed".into(), tr.engine_speed_rad_s.clone()),
            ("engine_torque".into(), tr.engine_torque_nm.clone()),
            ("gear".into(), tr.gear.clone()),
            ("road_slope".into(), tr.slope.clone()),
            (
                "brake_force".into(),
                tr.brake_n.iter().map(|b| b.abs()).collect(),
            ),
            (
                "clutch_position".into(),
                tr.clutch_x.iter().map(|x| x / clutch_x_max).collect(),
            ),
            ("bellow_pressure_front".into(), pf),
            ("bellow_pressure_rear".into(), pr),
            ("bellow_pressure_tag".into(), pt),
        ],
    }
}

/// `bus` with the AMT's clutch actuator position added when it carries none: a 50 Hz
/// transmission-controller message `/can/clutch`, field `ClutchActuatorPosition` in % of full
/// travel (0.4 %/bit, the J1939 1-byte percent), no noise (an actuator position sensor), as the
/// bundled `j1939-json-mcap` mapping reads it. A bus that already has a `clutch_position`
/// channel is returned unchanged.
pub fn with_clutch_channel(mut bus: CanBus) -> CanBus {
    if bus.channels().any(|(_, c)| c.column == "clutch_position") {
        return bus;
    }
    bus.messages.push(CanMessage {
        name: "CLUTCH".into(),
        topic: "/can/clutch".into(),
        rate_hz: 50.0,
        phase_s: 0.014,
        dropouts: Dropouts::NONE,
        channels: vec![CanChannel {
            column: "clutch_position".into(),
            field: "ClutchActuatorPosition".into(),
            wire_unit: "%".into(),
            torque_reference: TorqueReference::None,
            resolution: 0.4,
            noise_sigma: 0.0,
            delay_s: 0.0,
            wire_min: 0.0,
            wire_max: 100.0,
        }],
    });
    bus
}

/// A finished synthetic drive: the trajectories and the files written.
#[derive(Debug)]
pub struct SynthDrive {
    /// The driveline-side trajectory.
    pub drive: DriveTrajectory,
    /// The axle-model trajectory on the same samples.
    pub axles: AxleTrajectory,
    /// The ingested drive log of the written MCAP.
    pub log: crate::table::DriveLog,
    /// Written MCAP file.
    pub mcap: PathBuf,
    /// Written canonical Parquet file.
    pub parquet: PathBuf,
    /// Copy of the nominal vehicle file.
    pub vehicle: PathBuf,
}

/// Epoch time of truth time 0 of every synthetic drive: 2024-01-01T00:00:00Z, ns.
pub const DRIVE_START_NS: i64 = 1_704_067_200_000_000_000;

/// Generates a road of `length_km` from `rules` (bundled name or file) with `seed`, drives the
/// vehicle of `vehicle_path` over it (cruise speed: the driver's limit or the rules' design
/// speed) and writes `drive.mcap`, `drive.parquet` and `vehicle.toml` (a byte copy of the
/// vehicle file) into `out_dir` (created if needed). Road grid 1 m. The CAN bus is
/// [`CanBus::j1939_truck`] with the engine's largest full-load torque as reference, plus the clutch
/// actuator position ([`with_clutch_channel`]).
///
/// # Errors
/// [`DriveError`] from every stage; a rule set without design speed and no speed limit is
/// [`DriveError::BadConfig`].
pub fn synth_drive(
    vehicle_path: &Path,
    rules: &str,
    length_km: f64,
    seed: u64,
    out_dir: &Path,
    cfg: &DriveConfig,
) -> Result<SynthDrive, DriveError> {
    let v = VehicleFile::load(vehicle_path)?;
    let file = vehicle_path.display().to_string();
    let d = v.driveline(&file)?;
    let a = v.axles(&file)?;
    let r = RoadRules::resolve(rules)?;
    let length_m = length_km * 1000.0;
    check(
        "length_km",
        length_km,
        length_km.is_finite() && length_km > 0.0,
    )?;
    let road = generate(&r, length_m, 1.0, seed)?;
    let cruise = cfg
        .driver
        .speed_limit_mps
        .or(r.design_speed_km_per_h.map(|k| k / 3.6))
        .unwrap_or(f64::NAN);
    let slope = RoadSlope {
        distance_m: road.profile.distance_m.clone(),
        slope: road.profile.slope.clone(),
    };
    let drive = simulate_drive(d, &v.gearbox.ratios, &slope, length_m, cruise, cfg, seed)?;
    let axles = simulate_axles(a, &drive)?;
    let truth = drive_truth(&drive, &axles, d.clutch_x_max);
    std::fs::create_dir_all(out_dir).map_err(|source| DriveError::Io {
        path: out_dir.to_path_buf(),
        source,
    })?;
    let reference = d.engine_max_torque_nm.iter().fold(0.0f64, |m, &x| m.max(x));
    let bus = with_clutch_channel(CanBus::j1939_truck(reference));
    let opts = SynthOptions {
        start_ns: DRIVE_START_NS,
        seed,
        drive_id: format!("synth-{}-{}km-seed{}", r.name, length_km, seed),
        vehicle_id: Some(v.vehicle_id.clone()),
    };
    let mcap = out_dir.join("drive.mcap");
    let parquet = out_dir.join("drive.parquet");
    let log = write_can_drive(&mcap, &parquet, &bus, &truth, &opts)?;
    let vehicle = out_dir.join("vehicle.toml");
    std::fs::copy(vehicle_path, &vehicle).map_err(|source| DriveError::Io {
        path: vehicle.clone(),
        source,
    })?;
    Ok(SynthDrive {
        drive,
        axles,
        log,
        mcap,
        parquet,
        vehicle,
    })
}
