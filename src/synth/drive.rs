//! Closed-loop synthetic drives: a [`Driver`] and an [`Amt`] co-simulated with the fast driveline
//! model ([`FastDriveline`]) over a synthetic road, the axle model run on the result, and the truth
//! written as a CAN log ([`super::log_writer::write_drive_log`]).
//!
//! # Loop
//! Control steps of [`DriveConfig::control_dt_s`] (0.1 s): at each step start the driver reads
//! time, travelled distance, speed, slope, engine speed and whether the engine is coupled
//! (AMT driving in a gear), and commands a torque fraction (negative: engine brake), a
//! retarder torque and a service-brake force ([`super::driver`], brake blending); the AMT turns
//! the fraction into gear, clutch position and engine torque; a one-step
//! [`Scenario`] with these inputs held (and the road slope at the step's start position, looked
//! up by the travelled distance) is simulated with [`FastDriveline::simulate_span`] at
//! [`DriveConfig::sample_dt_s`] (0.01 s), carrying the state and the clutch mode. The
//! retarder's wheel-equivalent force `T_r i_f / r_w` is added to the service-brake force input
//! of the step ([`super::retarder`]: the driveline model has no retarder of its own). Rolling
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
//! [`axle_inputs_from_samples`] (acceleration differentiated over ±0.05 s), the retarder torque
//! `T_r i_f` as auxiliary brake torque at the driven wheels.
//!
//! The axle model runs only for vehicles with an `[axles]` section; a vehicle with only a
//! driveline (e.g. a tractor-semitrailer, for which the half-truck axle model does not apply)
//! gets no axle trajectory and no bellow-pressure channels.
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

use super::amt::{Amt, AmtConfig, AmtState, ShiftPhase};
use super::can::{CanBus, SynthError as CanError, SynthOptions, Truth};
use super::driver::{Driver, DriverConfig, SpeedLimits};
use super::effects::{
    fault_bus, fault_truth, resolve, Answer, EffectChoice, EffectError, Injection, OutOfCatalogue,
    ResistanceStretch, TruthModel, LOCAL_ROLLING_RESISTANCE,
};
use super::export::{fuel_rate_lph, ExportError, Series};
use super::log_writer::{apply_dropouts, write_drive_log, LogOptions};
use super::road_source::{read_road_file, DriveRoad, RoadSource, RoadSourceError};
use super::track::{gnss_message, gnss_track, GnssConfig, TrackError};
pub use super::trajectory::{DriveTrajectory, ShiftRecord};
use super::truth_file::{truth_columns, write_truth, TruthMeta};
use crate::model::driveline::DrivelineParams;
use crate::model::vehicle::{VehicleError, VehicleFile};
use crate::road::rules::{RoadRules, RulesError};
use crate::road::synth::{generate, SynthError as RoadError};
use crate::sim::axle::{AxleExtensions, AxleTrajectory, HalfTruck, Start};
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
    /// The hidden effect could not be injected or its answer written.
    #[error(transparent)]
    Effect(#[from] EffectError),
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
    /// A road file could not be used.
    #[error(transparent)]
    RoadFile(#[from] RoadSourceError),
    /// A GNSS setting out of its domain.
    #[error(transparent)]
    Track(#[from] TrackError),
    /// The log or the truth table could not be written.
    #[error(transparent)]
    Export(#[from] ExportError),
    /// Speed limits along the road were asked for, but the road has none.
    #[error("road {road}: no speed limits along the road (only a VECTO cycle's <v> gives them)")]
    NoSpeedLimits {
        /// The road's label.
        road: String,
    },
    /// No cruise speed: no speed limit given and the road has no design speed.
    #[error("road {road}: no cruise speed — give a speed limit (the road has no design speed)")]
    NoCruiseSpeed {
        /// The road's label.
        road: String,
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
    /// GNSS track and receiver; `None`: no GNSS in the log.
    pub gnss: Option<GnssConfig>,
    /// Resolution of the road-slope sensor, tan α per step (0.01: the whole percent production
    /// sensors send; a finer one makes `slope_quantization` a hideable effect).
    pub slope_resolution: f64,
    /// Dropouts of every CAN message (`None`: none), [`super::can::Dropouts`].
    pub dropouts: Option<super::can::Dropouts>,
    /// Follow the road's own speed limits (a VECTO cycle's `<v>`, [`DriveRoad::speed_limit_mps`])
    /// below the cruise speed; the road must have them.
    pub road_speed_limits: bool,
}

impl Default for DriveConfig {
    /// Default driver and AMT, 0.1 s control step, 0.01 s samples, at most 4 h, default GNSS,
    /// no speed limits from the road.
    fn default() -> Self {
        Self {
            driver: DriverConfig::default(),
            amt: AmtConfig::default(),
            control_dt_s: 0.1,
            sample_dt_s: 0.01,
            max_duration_s: 4.0 * 3600.0,
            gnss: Some(GnssConfig::default()),
            slope_resolution: 0.01,
            dropouts: None,
            road_speed_limits: false,
        }
    }
}

impl DriveConfig {
    /// Checks the driver's settings a user sets: a finite, non-negative stop dwell and a
    /// retarder, when there is one, with a finite, positive torque.
    pub fn validate(&self) -> Result<(), crate::settings::InvalidSetting> {
        use crate::settings::require;
        let dwell = self.driver.stop_dwell_s;
        require(
            dwell.is_finite() && dwell >= 0.0,
            "stop_dwell_s",
            dwell,
            "must be finite and >= 0",
        )?;
        if let Some(r) = &self.driver.retarder {
            let t = r.max_torque_nm;
            require(
                t.is_finite() && t > 0.0,
                "retarder_max_torque_nm",
                t,
                "must be finite and >= 0",
            )?;
        }
        Ok(())
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
    simulate_drive_with(
        p,
        p,
        &PlantExtras::default(),
        ratios,
        road,
        length_m,
        cruise_mps,
        cfg,
        seed,
    )
}

/// What the plant has beyond its parameters (hidden effects, [`super::effects`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PlantExtras {
    /// Total drive-shaft play, rad ([`FastDriveline::with_lash`]).
    pub lash_rad: f64,
    /// Extra rolling resistance on a stretch of road (added to the step's brake-force input,
    /// as a force against the motion; not logged).
    pub stretch: Option<super::effects::ResistanceStretch>,
}

/// [`simulate_drive`] with a plant that differs from what the controllers believe: the driver
/// and the AMT act on the nominal parameters `p`, the driveline simulated is `plant` with
/// `extras` (drive-shaft play, [`FastDriveline::with_lash`]; a stretch of extra resistance). Used to hide an effect
/// ([`super::effects`]). With lash the driveline integrates at a tenth of the sample step
/// (shaft impacts then overshoot the contact by at most `|ω_d − ω_w|·dt/10`) and keeps every
/// tenth state.
///
/// # Errors
/// As [`simulate_drive`].
#[allow(clippy::too_many_arguments)]
pub fn simulate_drive_with(
    p: &DrivelineParams,
    plant: &DrivelineParams,
    extras: &PlantExtras,
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
    if let Some(l) = &c.speed_limits {
        check(
            "speed_limits.step_m",
            l.step_m,
            l.step_m.is_finite() && l.step_m > 0.0,
        )?;
        check(
            "speed_limits.limit_mps (count)",
            l.limit_mps.len() as f64,
            !l.limit_mps.is_empty(),
        )?;
        for &v in &l.limit_mps {
            check("speed_limits.limit_mps", v, v.is_finite() && v > 0.0)?;
        }
    }
    let sub = sub as usize;
    // with lash, integrate at ds/10 and keep every tenth state
    let lash_rad = extras.lash_rad;
    let fine = if lash_rad > 0.0 { 10 } else { 1 };
    let mut fast = FastDriveline::new(plant, ratios, ds / fine as f64).with_lash(lash_rad);
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
        let coupled = matches!(amt.state, AmtState::Driving { .. });
        let cmd = driver.command(p, t, x, v, slope, y[0], overall, coupled);
        let retarder_n = cmd.retarder_nm * p.final_drive_ratio / p.wheel_radius_m;
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
            brake_n: Piecewise::constant(
                t1,
                cmd.brake_n
                    + retarder_n
                    + extras.stretch.map_or(0.0, |st| {
                        st.force_n(x, plant.mass_kg, plant.gravity_m_per_s2, slope)
                    }),
            ),
            engine: EngineInput::Torque(Piecewise::constant(t1, o.engine_torque_nm)),
            smoothing: false,
            standstill_events: true,
        };
        let tr = fast.simulate_span(&sc, t, t1, y, mode)?;
        let tr = if fine > 1 { decimate(tr, fine) } else { tr };
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
            out.clutch_position.push(o.clutch_x / p.clutch_x_max);
            out.slope.push(slope);
            // the drive log's brake_force is the force at the ground: the brakes' capacity
            // while rolling, but at standstill only what holds the truck (drive force and grade),
            // never more than the capacity
            let ground_brake = if yj[7] == 0.0 {
                let hold = tr.torques[j][3] / p.wheel_radius_m
                    - plant.mass_kg * p.gravity_m_per_s2 * slope.atan().sin();
                hold.clamp(-cmd.brake_n, cmd.brake_n)
            } else {
                cmd.brake_n
            };
            out.brake_n.push(ground_brake);
            out.retarder_torque_nm.push(cmd.retarder_nm);
            out.aux_brake_wheel_nm
                .push(cmd.retarder_nm * p.final_drive_ratio);
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

/// Every `k`-th sample of a span trajectory (the first kept).
fn decimate(tr: crate::sim::hybrid::Trajectory, k: usize) -> crate::sim::hybrid::Trajectory {
    fn pick<T>(v: Vec<T>, k: usize) -> Vec<T> {
        v.into_iter().step_by(k).collect()
    }
    crate::sim::hybrid::Trajectory {
        t: pick(tr.t, k),
        y: pick(tr.y, k),
        mode: pick(tr.mode, k),
        torques: pick(tr.torques, k),
        gear: pick(tr.gear, k),
        events: tr.events,
        stats: tr.stats,
    }
}

/// Runs the axle model on a drive's 100 Hz samples (static start), with the retarder's
/// [`DriveTrajectory::aux_brake_wheel_nm`] (when not empty) as auxiliary brake torque at the
/// driven wheels.
///
/// # Errors
/// [`DriveError::Piecewise`] for fewer than two samples, or auxiliary brake samples that do
/// not match the times.
pub fn simulate_axles(
    p: &crate::model::axle::AxleParams,
    tr: &DriveTrajectory,
) -> Result<AxleTrajectory, DriveError> {
    simulate_axles_with(p, AxleExtensions::default(), tr)
}

/// [`simulate_axles`] with model extensions (a hidden axle effect).
///
/// # Errors
/// [`DriveError::Piecewise`] for fewer than two samples.
pub fn simulate_axles_with(
    p: &crate::model::axle::AxleParams,
    ext: AxleExtensions,
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
    let (mut u, _) = axle_inputs_from_samples(
        &tr.t_s,
        &tr.speed_mps,
        &tr.drive_torque_nm,
        held(&tr.slope)?,
        held(&tr.brake_n)?,
        0.05,
    )?;
    let aux = &tr.aux_brake_wheel_nm;
    if !aux.is_empty() {
        if aux.len() != tr.t_s.len() {
            return Err(PiecewiseError(format!(
                "{} auxiliary brake samples for {} times",
                aux.len(),
                tr.t_s.len()
            ))
            .into());
        }
        u.aux_brake_torque_wheel_nm = Some(Piecewise::new(
            tr.t_s
                .windows(2)
                .zip(aux.windows(2))
                .map(|(t, a)| (t[0], t[1], a[0], a[1]))
                .collect(),
        )?);
    }
    Ok(HalfTruck::new(p)
        .with_extensions(ext)
        .simulate(&u, &tr.t_s, Start::Steady))
}

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
