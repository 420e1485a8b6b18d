//! Scripted inputs for the half-truck axle-load model (`sim::axle`): the two main scenarios of the
//! axle-load thesis (docs/models/axle.md), §4.3 — full acceleration from standstill, and hard
//! auxiliary braking with the electric motor from constant speed — and a deterministic stop-and-go
//! drive for benchmarks.
//!
//! The axle model takes the longitudinal acceleration and the wheel torques as inputs; here they
//! come from a point-mass vehicle with an electric drive (the vehicle equation of
//! docs/models/driveline.md with the rotating inertias left out, `c_r2 = 0` and no standstill
//! smoothing):
//!
//! `m·v̇ = F_d − F_aux − F_b − c_r·m·g·cos α − ½·ρ·c_wA·v² − m·g·sin α`   (1)
//!
//! with `m` the axle model's mass (`StaticState::mass_kg`), the drive force limited by the
//! wheel torque and the motor power, `F_d ≤ min(T_max/r_w, P_max/v)`, the auxiliary (regenerative)
//! brake force likewise, `F_aux ≤ min(T_aux/r_w, P_regen/v)`. The drive and auxiliary brake
//! torques handed to the axle model are `F·r_w` (torques at the driven wheels, N·m), and its
//! acceleration input is `v̇` of (1) — so the forces the axle model sees at the contact patches
//! and the vehicle's longitudinal balance agree, and the remainder it puts at
//! `resistance_height_m` is rolling resistance plus drag at every sample (docs/models/axle.md).
//!
//! Torques change over ramps (`torque_ramp_s`, 0.3 s by default), never in steps. Equation (1) is
//! integrated with classical RK4 on the output grid (`sample_rate_hz`); every input is the
//! piecewise-linear interpolation of its samples on that grid, as a recording would give it.
//!
//! Standstill (`v = 0`): the vehicle moves off only when the forward push
//! `F_d − F_aux − m g sin α` exceeds rolling resistance plus the commanded service-brake force;
//! otherwise it stays, rolling resistance holding up to `c_r m g cos α` and the service brake up
//! to its command (the reported service-brake force is the part it holds, either sign).
//! Rolling backwards is not modelled (a = 0). Regenerative braking fades out linearly below
//! `regen_fade_speed_mps` (an electric machine cannot brake a vehicle at rest).
//!
//! Units: SI inside (m, s, kg, N, N·m, W); slope as tan α, + uphill.

use super::axle::{AxleInputs, Start};
use super::inputs::{Piecewise, PiecewiseError};
use crate::model::axle::AxleParams;
use std::fmt;
use std::str::FromStr;
use thiserror::Error;

/// The scripted scenarios of the axle-load thesis, §4.3.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxleScenario {
    /// Full acceleration from standstill to the speed limiter (thesis figs. 4.2–4.4).
    FullAcceleration,
    /// Hard auxiliary braking with the electric motor from constant speed (thesis figs. 4.5–4.7).
    AuxBraking,
}

impl AxleScenario {
    /// Every scenario.
    pub const ALL: [AxleScenario; 2] = [AxleScenario::FullAcceleration, AxleScenario::AuxBraking];

    /// The name used on the command line (`full-acceleration`, `aux-braking`).
    pub fn name(self) -> &'static str {
        match self {
            AxleScenario::FullAcceleration => "full-acceleration",
            AxleScenario::AuxBraking => "aux-braking",
        }
    }
}

impl fmt::Display for AxleScenario {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for AxleScenario {
    type Err = ScenarioError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        AxleScenario::ALL
            .into_iter()
            .find(|a| a.name() == s)
            .ok_or_else(|| ScenarioError::Unknown(s.to_string()))
    }
}

/// Why scenario inputs could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ScenarioError {
    /// A scenario name that is not one of [`AxleScenario::ALL`].
    #[error("unknown axle scenario `{0}` (known: full-acceleration, aux-braking)")]
    Unknown(String),
    /// A configuration value out of its range.
    #[error("axle scenario config: {field} = {value}: {rule}")]
    Config {
        /// Field name (with its unit).
        field: &'static str,
        /// The value given.
        value: f64,
        /// What it must satisfy.
        rule: &'static str,
    },
    /// The inputs could not be assembled (not expected for a checked configuration).
    #[error(transparent)]
    Input(#[from] PiecewiseError),
}

/// Vehicle and driver figures of the scenarios. The axle-load thesis publishes none of them (it
/// lumps air and rolling resistance as 10 % of the longitudinal force and gives no motor data), so
/// the defaults are typical values for its 18.7 t electrified rigid truck, each stated below.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AxleScenarioConfig {
    /// Output and input sample rate, Hz. Default 100 Hz (10 ms, five times finer than the
    /// 2 Hz body modes' half period, and the rate recorded CAN signals are resampled to).
    pub sample_rate_hz: f64,
    /// Rolling-resistance coefficient c_r. Default 0.006, typical of modern truck tyres on
    /// dry asphalt (EU tyre-label classes B–C for C3 tyres span 0.005–0.007).
    pub rolling_resistance_coefficient: f64,
    /// Drag area c_w·A, m². Default 5.5 m²: a box-body rigid truck, c_w ≈ 0.6 on A ≈ 9 m².
    pub drag_area_m2: f64,
    /// Air density ρ, kg/m³. Default 1.2 (sea level, 20 °C).
    pub air_density_kg_per_m3: f64,
    /// Largest drive torque at the driven wheels, N·m. Default 12 000 N·m (24 kN at a 0.5 m
    /// wheel: 1.3 m/s² for 18.7 t, about 13 % gradeability — usual for an electric rigid truck).
    pub max_drive_torque_wheel_nm: f64,
    /// Largest drive power at the wheels, W. Default 300 kW (a typical electric heavy
    /// rigid-truck motor; the torque limit hands over to it at 12.5 m/s with the defaults).
    pub max_drive_power_w: f64,
    /// Largest auxiliary (regenerative) brake torque at the driven wheels, N·m. Default 12 000
    /// N·m, the motor's torque limit in generator mode.
    pub max_aux_brake_torque_wheel_nm: f64,
    /// Largest regenerative brake power, W. Default 300 kW (the motor's power limit); at 80 km/h
    /// it, not the torque, limits the brake force (13.5 kN).
    pub max_regen_power_w: f64,
    /// Regenerative braking fades out linearly below this speed, m/s. Default 2 m/s.
    pub regen_fade_speed_mps: f64,
    /// Duration of every torque ramp, s. Default 0.3 s (an electric drive's torque rate
    /// limiter against driveline shuffle).
    pub torque_ramp_s: f64,
    /// Speed limiter set speed, m/s. Default 25 m/s = 90 km/h, the EU ceiling for N3 trucks
    /// (Council Directive 92/6/EEC).
    pub max_speed_mps: f64,
    /// Speed-limiter gain k, 1/s: near the set speed the drive force is at most
    /// `F_resistance(v) + m·k·(v_max − v)`, so the speed approaches v_max with time constant 1/k
    /// and the torque leaves the power limit continuously. Default 1 /s.
    pub speed_limiter_gain_per_s: f64,
    /// Full acceleration: the drive torque ramp starts at this time, s. Default 2 s.
    pub acceleration_start_s: f64,
    /// Full acceleration: end of the scenario, s. Default 35 s (the span of thesis fig. 4.4).
    pub acceleration_end_s: f64,
    /// Auxiliary braking: the constant speed before braking, m/s. Default 80 km/h.
    pub braking_speed_mps: f64,
    /// Auxiliary braking: the brake torque ramp starts at this time, s. Default 5 s (axle-load
    /// thesis, §5.1: "in the fifth second, we applied braking torque").
    pub braking_start_s: f64,
    /// Auxiliary braking: how long full brake torque is held after its ramp, s. Default 10 s.
    pub braking_hold_s: f64,
    /// Auxiliary braking: end of the scenario, s (after the release ramp the driver holds the
    /// new speed). Default 20 s.
    pub braking_end_s: f64,
}

impl Default for AxleScenarioConfig {
    fn default() -> Self {
        Self {
            sample_rate_hz: 100.0,
            rolling_resistance_coefficient: 0.006,
            drag_area_m2: 5.5,
            air_density_kg_per_m3: 1.2,
            max_drive_torque_wheel_nm: 12_000.0,
            max_drive_power_w: 300e3,
            max_aux_brake_torque_wheel_nm: 12_000.0,
            max_regen_power_w: 300e3,
            regen_fade_speed_mps: 2.0,
            torque_ramp_s: 0.3,
            max_speed_mps: 25.0,
            speed_limiter_gain_per_s: 1.0,
            acceleration_start_s: 2.0,
            acceleration_end_s: 35.0,
            braking_speed_mps: 80.0 / 3.6,
            braking_start_s: 5.0,
            braking_hold_s: 10.0,
            braking_end_s: 20.0,
        }
    }
}

impl AxleScenarioConfig {
    /// Every field as `(name, value)`, names with their units (for file metadata).
    pub fn entries(&self) -> Vec<(&'static str, f64)> {
        vec![
            ("sample_rate_hz", self.sample_rate_hz),
            (
                "rolling_resistance_coefficient",
                self.rolling_resistance_coefficient,
            ),
            ("drag_area_m2", self.drag_area_m2),
            ("air_density_kg_per_m3", self.air_density_kg_per_m3),
            ("max_drive_torque_wheel_nm", self.max_drive_torque_wheel_nm),
            ("max_drive_power_w", self.max_drive_power_w),
            (
                "max_aux_brake_torque_wheel_nm",
                self.max_aux_brake_torque_wheel_nm,
            ),
            ("max_regen_power_w", self.max_regen_power_w),
            ("regen_fade_speed_mps", self.regen_fade_speed_mps),
            ("torque_ramp_s", self.torque_ramp_s),
            ("max_speed_mps", self.max_speed_mps),
            ("speed_limiter_gain_per_s", self.speed_limiter_gain_per_s),
            ("acceleration_start_s", self.acceleration_start_s),
            ("acceleration_end_s", self.acceleration_end_s),
            ("braking_speed_mps", self.braking_speed_mps),
            ("braking_start_s", self.braking_start_s),
            ("braking_hold_s", self.braking_hold_s),
            ("braking_end_s", self.braking_end_s),
        ]
    }

    /// Checks every value.
    ///
    /// # Errors
    /// [`ScenarioError::Config`] for the first non-finite or out-of-range value: rates, torques,
    /// powers, speeds, gains and ramps must be > 0 (the sample rate at most 10 kHz), resistance
    /// coefficients and the hold ≥ 0, start times ≥ 0, and each scenario's end must leave room
    /// for its ramps (`acceleration_end_s > acceleration_start_s + torque_ramp_s`,
    /// `braking_end_s > braking_start_s + 2·torque_ramp_s + braking_hold_s`).
    pub fn check(&self) -> Result<(), ScenarioError> {
        let bad = |field, value, rule| Err(ScenarioError::Config { field, value, rule });
        for (field, value) in self.entries() {
            if !value.is_finite() {
                return bad(field, value, "must be finite");
            }
        }
        // fields that may be zero; every other one must be positive
        const NON_NEGATIVE: [&str; 6] = [
            "rolling_resistance_coefficient",
            "drag_area_m2",
            "air_density_kg_per_m3",
            "acceleration_start_s",
            "braking_start_s",
            "braking_hold_s",
        ];
        const ORDERING_ONLY: [&str; 2] = ["acceleration_end_s", "braking_end_s"];
        for (field, value) in self.entries() {
            if NON_NEGATIVE.contains(&field) {
                if value < 0.0 {
                    return bad(field, value, "must be >= 0");
                }
            } else if !ORDERING_ONLY.contains(&field) && value <= 0.0 {
                return bad(field, value, "must be > 0");
            }
        }
        if self.sample_rate_hz > 10e3 {
            return bad("sample_rate_hz", self.sample_rate_hz, "must be <= 10 kHz");
        }
        if self.acceleration_end_s <= self.acceleration_start_s + self.torque_ramp_s {
            return bad(
                "acceleration_end_s",
                self.acceleration_end_s,
                "must be after acceleration_start_s + torque_ramp_s",
            );
        }
        if self.braking_end_s
            <= self.braking_start_s + 2.0 * self.torque_ramp_s + self.braking_hold_s
        {
            return bad(
                "braking_end_s",
                self.braking_end_s,
                "must be after braking_start_s + braking_hold_s + two torque ramps",
            );
        }
        Ok(())
    }
}

/// A scenario's inputs for [`HalfTruck::simulate`](super::axle::HalfTruck::simulate).
#[derive(Debug, Clone)]
pub struct ScenarioInputs {
    /// Scenario name (`full-acceleration`, `aux-braking`, `stop-and-go`).
    pub name: &'static str,
    /// The axle model's inputs (torques at the driven wheels, service brake, level road or the
    /// scenario's grade).
    pub inputs: AxleInputs,
    /// Output time grid, s, from 0 at the configured sample rate.
    pub t_s: Vec<f64>,
    /// The point-mass vehicle speed at every `t_s`, m/s.
    pub speed_mps: Vec<f64>,
    /// Where the axle simulation starts (the steady state of the first inputs).
    pub start: Start,
}

/// Ground forces the driver and the drive command at `(t, v)`, N, all ≥ 0.
#[derive(Debug, Clone, Copy, Default)]
struct Command {
    drive_n: f64,
    aux_n: f64,
    service_n: f64,
}

/// The point-mass vehicle of equation (1).
struct PointMass<'a> {
    mass_kg: f64,
    g: f64,
    r_w: f64,
    cfg: &'a AxleScenarioConfig,
    slope: Piecewise,
}

/// `0` before `t0`, `1` after `t0 + dur`, linear between.
fn ramp(t: f64, t0: f64, dur: f64) -> f64 {
    ((t - t0) / dur).clamp(0.0, 1.0)
}

impl PointMass<'_> {
    fn new<'a>(p: &AxleParams, cfg: &'a AxleScenarioConfig, slope: Piecewise) -> PointMass<'a> {
        PointMass {
            mass_kg: p.static_state().mass_kg,
            g: p.gravity_m_per_s2,
            r_w: p.wheel_radius_m,
            cfg,
            slope,
        }
    }

    /// Rolling resistance, grade force and drag at `(t, v)`, N (+ against forward motion).
    fn resistances(&self, t: f64, v: f64) -> (f64, f64, f64) {
        let alpha = self.slope.eval(t).atan();
        let mg = self.mass_kg * self.g;
        (
            self.cfg.rolling_resistance_coefficient * mg * alpha.cos(),
            mg * alpha.sin(),
            0.5 * self.cfg.air_density_kg_per_m3 * self.cfg.drag_area_m2 * v * v,
        )
    }

    /// Rolling resistance + grade + drag, N: the drive force that holds speed `v`.
    fn road_load(&self, t: f64, v: f64) -> f64 {
        let (r, g, a) = self.resistances(t, v);
        r + g + a
    }

    /// Drive force limited by wheel torque (times `demand` ∈ [0, 1]), motor power, and the speed
    /// limiter aiming at `v_set`; never negative.
    fn drive_limited(&self, t: f64, v: f64, demand: f64, v_set: f64) -> f64 {
        let torque = demand * self.cfg.max_drive_torque_wheel_nm / self.r_w;
        let power = if v > 0.0 {
            self.cfg.max_drive_power_w / v
        } else {
            f64::INFINITY
        };
        let limiter =
            self.road_load(t, v) + self.mass_kg * self.cfg.speed_limiter_gain_per_s * (v_set - v);
        torque.min(power).min(limiter).max(0.0)
    }

    /// Regenerative brake force at full command, limited by torque and power, N.
    fn regen_limited(&self, v: f64) -> f64 {
        let torque = self.cfg.max_aux_brake_torque_wheel_nm / self.r_w;
        if v > 0.0 {
            torque.min(self.cfg.max_regen_power_w / v)
        } else {
            torque
        }
    }

    /// Acceleration and the forces actually acting, for command `c` at `(t, v)`.
    fn state(&self, t: f64, v: f64, c: Command) -> (f64, Command) {
        let (roll, grade, drag) = self.resistances(t, v);
        let fade = (v / self.cfg.regen_fade_speed_mps).clamp(0.0, 1.0);
        let act = Command {
            aux_n: c.aux_n * fade,
            ..c
        };
        if v > 0.0 {
            let net = act.drive_n - act.aux_n - act.service_n - roll - drag - grade;
            return (net / self.mass_kg, act);
        }
        let push = act.drive_n - act.aux_n - grade;
        if push > roll + act.service_n {
            return ((push - roll - act.service_n) / self.mass_kg, act);
        }
        let held_by_rolling = push.clamp(-roll, roll);
        let service = (push - held_by_rolling).clamp(-act.service_n, act.service_n);
        (
            0.0,
            Command {
                service_n: service,
                ..act
            },
        )
    }

    /// Integrates (1) with RK4 on `t` from `v0` under the command law and returns the inputs.
    fn run(
        &self,
        name: &'static str,
        t: Vec<f64>,
        v0: f64,
        command: impl Fn(f64, f64) -> Command,
    ) -> Result<ScenarioInputs, ScenarioError> {
        let accel = |tt: f64, v: f64| self.state(tt, v, command(tt, v)).0;
        let n = t.len();
        let (mut speed, mut a, mut drive, mut aux, mut service) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let mut v = v0;
        for (k, &tk) in t.iter().enumerate() {
            if k > 0 {
                let (t0, h) = (t[k - 1], tk - t[k - 1]);
                let k1 = accel(t0, v);
                let k2 = accel(t0 + 0.5 * h, v + 0.5 * h * k1);
                let k3 = accel(t0 + 0.5 * h, v + 0.5 * h * k2);
                let k4 = accel(tk, v + h * k3);
                v = (v + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)).max(0.0);
            }
            let (ak, f) = self.state(tk, v, command(tk, v));
            speed.push(v);
            a.push(ak);
            drive.push(f.drive_n * self.r_w);
            aux.push(f.aux_n * self.r_w);
            service.push(f.service_n);
        }
        let sampled = |y: &[f64]| -> Result<Piecewise, PiecewiseError> {
            Piecewise::new(
                t.windows(2)
                    .zip(y.windows(2))
                    .map(|(tw, yw)| (tw[0], tw[1], yw[0], yw[1]))
                    .collect(),
            )
        };
        let inputs = AxleInputs {
            accel_mps2: sampled(&a)?,
            slope: self.slope.clone(),
            drive_torque_wheel_nm: Some(sampled(&drive)?),
            aux_brake_torque_wheel_nm: Some(sampled(&aux)?),
            service_brake_n: Some(sampled(&service)?),
        };
        Ok(ScenarioInputs {
            name,
            inputs,
            t_s: t,
            speed_mps: speed,
            start: Start::Steady,
        })
    }
}

/// The time grid `k / fs`, `k = 0 … round(t_end·fs)`.
fn grid(t_end_s: f64, fs_hz: f64) -> Vec<f64> {
    let n = (t_end_s * fs_hz).round().max(1.0) as usize;
    (0..=n).map(|k| k as f64 / fs_hz).collect()
}

/// Full acceleration from standstill on a level road (axle-load thesis, §4.3.2): at
/// `acceleration_start_s` the drive torque demand ramps to 100 % over `torque_ramp_s`; the drive
/// force is `min(T_max/r_w, P_max/v)`, and near `max_speed_mps` the speed limiter takes over;
/// the scenario runs to `acceleration_end_s`. No brakes.
///
/// # Errors
/// [`ScenarioError::Config`] from [`AxleScenarioConfig::check`].
pub fn full_acceleration(
    p: &AxleParams,
    cfg: &AxleScenarioConfig,
) -> Result<ScenarioInputs, ScenarioError> {
    cfg.check()?;
    let t_end = cfg.acceleration_end_s;
    let pm = PointMass::new(p, cfg, Piecewise::constant(t_end, 0.0));
    let t = grid(t_end, cfg.sample_rate_hz);
    pm.run(AxleScenario::FullAcceleration.name(), t, 0.0, |t, v| {
        let demand = ramp(t, cfg.acceleration_start_s, cfg.torque_ramp_s);
        Command {
            drive_n: pm.drive_limited(t, v, demand, cfg.max_speed_mps),
            ..Command::default()
        }
    })
}

/// Hard auxiliary braking from constant speed on a level road (axle-load thesis, §4.3.3, §5.1): the
/// truck holds `braking_speed_mps` with the drive force balancing the road load; at
/// `braking_start_s` the drive torque ramps to zero while the motor's full brake torque
/// (`min(T_aux/r_w, P_regen/v)`) ramps in over `torque_ramp_s`; it is held `braking_hold_s`, then
/// ramped out while the drive torque returns to hold the new speed, to `braking_end_s`. No service
/// brake.
///
/// # Errors
/// [`ScenarioError::Config`] from [`AxleScenarioConfig::check`].
pub fn hard_aux_braking(
    p: &AxleParams,
    cfg: &AxleScenarioConfig,
) -> Result<ScenarioInputs, ScenarioError> {
    cfg.check()?;
    let t_end = cfg.braking_end_s;
    let pm = PointMass::new(p, cfg, Piecewise::constant(t_end, 0.0));
    let t = grid(t_end, cfg.sample_rate_hz);
    let (t_on, dur) = (cfg.braking_start_s, cfg.torque_ramp_s);
    let t_off = t_on + dur + cfg.braking_hold_s;
    pm.run(
        AxleScenario::AuxBraking.name(),
        t,
        cfg.braking_speed_mps,
        |t, v| {
            let brake = ramp(t, t_on, dur) - ramp(t, t_off, dur);
            Command {
                drive_n: (1.0 - brake) * pm.road_load(t, v).max(0.0),
                aux_n: brake * pm.regen_limited(v),
                service_n: 0.0,
            }
        },
    )
}

/// The inputs of a named scenario.
///
/// # Errors
/// [`ScenarioError::Config`] from [`AxleScenarioConfig::check`].
pub fn scenario_inputs(
    which: AxleScenario,
    p: &AxleParams,
    cfg: &AxleScenarioConfig,
) -> Result<ScenarioInputs, ScenarioError> {
    match which {
        AxleScenario::FullAcceleration => full_acceleration(p, cfg),
        AxleScenario::AuxBraking => hard_aux_braking(p, cfg),
    }
}

/// Fractional part of `k·φ + offset` (a low-discrepancy sequence: deterministic, well spread).
fn spread(k: usize, phi: f64, offset: f64) -> f64 {
    (k as f64 * phi + offset).fract()
}

/// A deterministic stop-and-go drive of `t_end_s` with inputs sampled at `sample_rate_hz`, as a
/// recording would give them (for benchmarks and long-run tests). Cycles of 100 s: held by the
/// service brake (30 kN) until 8 s; drive torque demand 50–100 % to a set speed of 10–22 m/s
/// until 60 s; auxiliary braking at 30–100 % of full torque until 75 s; service braking at
/// 20–45 kN to a stop, held to the cycle's end. The road grade varies within ±3 %, knots every
/// 50 s. Per-cycle figures follow golden-ratio sequences, so every cycle differs and every run
/// is the same. Vehicle figures from `cfg` (its scenario times are not used).
///
/// # Errors
/// [`ScenarioError::Config`] from [`AxleScenarioConfig::check`], or for `t_end_s` or
/// `sample_rate_hz` not finite and > 0.
pub fn stop_and_go(
    p: &AxleParams,
    cfg: &AxleScenarioConfig,
    t_end_s: f64,
    sample_rate_hz: f64,
) -> Result<ScenarioInputs, ScenarioError> {
    cfg.check()?;
    for (field, value) in [("t_end_s", t_end_s), ("sample_rate_hz", sample_rate_hz)] {
        if !(value.is_finite() && value > 0.0) {
            return Err(ScenarioError::Config {
                field,
                value,
                rule: "must be finite and > 0",
            });
        }
    }
    const CYCLE_S: f64 = 100.0;
    const KNOT_S: f64 = 50.0;
    let knots = (t_end_s / KNOT_S).ceil() as usize;
    let grade = |k: usize| 0.03 * (0.37 * k as f64).sin() * (0.11 * k as f64).cos();
    let slope = Piecewise::new(
        (0..knots)
            .map(|k| {
                let (a, b) = (k as f64 * KNOT_S, ((k + 1) as f64 * KNOT_S).min(t_end_s));
                (a, b, grade(k), grade(k + 1))
            })
            .filter(|q| q.1 > q.0)
            .collect(),
    )?;
    let pm = PointMass::new(p, cfg, slope);
    let dur = cfg.torque_ramp_s;
    let t = grid(t_end_s, sample_rate_hz);
    pm.run("stop-and-go", t, 0.0, |t, v| {
        let c = (t / CYCLE_S).floor().max(0.0) as usize;
        let tau = t - c as f64 * CYCLE_S;
        let v_set = 10.0 + 12.0 * spread(c, 0.618_033_988_7, 0.3);
        let demand = 0.5 + 0.5 * spread(c, 0.381_966_011_3, 0.1);
        let aux = 0.3 + 0.7 * spread(c, 0.754_877_666_2, 0.5);
        let stop = 20e3 + 25e3 * spread(c, 0.569_840_290_9, 0.7);
        let driving = ramp(tau, 8.0, dur) - ramp(tau, 60.0, dur);
        let braking = ramp(tau, 60.0, dur) - ramp(tau, 75.0, dur);
        let service = 30e3 * (1.0 - ramp(tau, 7.5, 0.5)) + stop * ramp(tau, 75.0, 0.5);
        Command {
            drive_n: driving * pm.drive_limited(t, v, demand, v_set),
            aux_n: braking * aux * pm.regen_limited(v),
            service_n: service,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_unknown_names_are_errors() {
        for s in AxleScenario::ALL {
            assert_eq!(s.name().parse::<AxleScenario>().unwrap(), s);
        }
        assert_eq!(
            "braking".parse::<AxleScenario>(),
            Err(ScenarioError::Unknown("braking".into()))
        );
    }

    #[test]
    fn config_check_names_the_bad_field() {
        AxleScenarioConfig::default().check().unwrap();
        let cfg = AxleScenarioConfig {
            torque_ramp_s: f64::NAN,
            ..Default::default()
        };
        assert!(matches!(
            cfg.check(),
            Err(ScenarioError::Config {
                field: "torque_ramp_s",
                ..
            })
        ));
        let cfg = AxleScenarioConfig {
            braking_end_s: 15.0,
            ..Default::default()
        };
        assert!(matches!(
            cfg.check(),
            Err(ScenarioError::Config {
                field: "braking_end_s",
                ..
            })
        ));
    }

    #[test]
    fn ramp_is_continuous_and_bounded() {
        assert_eq!(ramp(1.0, 2.0, 0.3), 0.0);
        assert!((ramp(2.15, 2.0, 0.3) - 0.5).abs() < 1e-12);
        assert_eq!(ramp(3.0, 2.0, 0.3), 1.0);
    }
}
