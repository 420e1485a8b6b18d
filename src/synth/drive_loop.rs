//! The closed loop of a synthetic drive: a [`Driver`] and an [`Amt`] co-simulated with the fast
//! driveline model ([`FastDriveline`]) over a road slope given by distance ([`RoadSlope`]),
//! into a [`DriveTrajectory`] on the output grid (SI units, s from the start).
//!
//! # Loop
//! Control steps of [`DriveConfig::control_dt_s`] (0.1 s): at each step start the driver reads
//! time, travelled distance, speed, slope, engine speed and whether the engine is coupled
//! (AMT driving in a gear), and commands a torque fraction (negative: engine brake), a
//! retarder torque and a service-brake force ([`super::driver`], brake blending); the AMT turns
//! the fraction into gear, clutch position and engine torque (the ECU's figure, which the log
//! records; the plant is driven by the torque the engine produces, that figure through the
//! vehicle file's first-order engine lag `engine_torque_lag_s`); a one-step [`Scenario`] with
//! these inputs held (the produced torque following its lag; the road slope at the step's
//! start position, looked up by the travelled distance) is simulated with
//! [`FastDriveline::simulate_span`] at
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

use super::amt::{Amt, AmtConfig, AmtState, ShiftPhase};
use super::drive_error::{check, DriveError};
use super::driver::{Driver, DriverConfig};
use super::track::GnssConfig;
use super::trajectory::{DriveTrajectory, ShiftRecord};
use crate::model::driveline::DrivelineParams;
use crate::sim::fast::FastDriveline;
use crate::sim::hybrid::{ClutchMode, EngineInput, Scenario, N_STATES};
use crate::sim::inputs::Piecewise;

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

    /// Follow the road's own speed limits (a VECTO cycle's `<v>`, [`DriveRoad::speed_limit_mps`](super::road_source::DriveRoad::speed_limit_mps))
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
                "must be finite and > 0 (0: no retarder)",
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
    let mut produced = ProducedTorque::new(plant.engine_torque_lag_s);
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
            engine: EngineInput::Torque(produced.over_step(o.engine_torque_nm, t, t1, ds)),
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
            // the ECU's figure: the command, which the produced torque follows
            out.engine_torque_nm.push(o.engine_torque_nm);
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

/// The torque the engine produces: the AMT's command (the ECU's figure, which the log
/// records) through the engine's first-order lag `τ_e Ṁ_e = M_cmd − M_e`
/// ([`DrivelineParams::engine_torque_lag_s`]), starting at the first command.
#[derive(Debug, Clone, Copy)]
struct ProducedTorque {
    lag_s: f64,
    state: Option<f64>,
}

impl ProducedTorque {
    fn new(lag_s: f64) -> Self {
        Self { lag_s, state: None }
    }

    /// The produced torque over one control step `[t, t1]` with `command` held: the lag's
    /// exact response at every sample `t + j·ds`, linear between them; the command itself,
    /// held, without a lag.
    fn over_step(&mut self, command: f64, t: f64, t1: f64, ds: f64) -> Piecewise {
        if self.lag_s <= 0.0 {
            return Piecewise::constant(t1, command);
        }
        let mut m = *self.state.get_or_insert(command);
        let steps = ((t1 - t) / ds).round().max(1.0) as usize;
        let times: Vec<f64> = (0..=steps)
            .map(|j| if j == steps { t1 } else { t + j as f64 * ds })
            .collect();
        let mut values = Vec::with_capacity(times.len());
        values.push(m);
        for w in times.windows(2) {
            m = command + (m - command) * (-(w[1] - w[0]) / self.lag_s).exp();
            values.push(m);
        }
        self.state = Some(m);
        let times: std::sync::Arc<[f64]> = times.into();
        Piecewise::through_samples(&times, &values, crate::sim::inputs::Between::Linear)
            .expect("increasing times and finite torques")
    }
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
